"""Meshes, primitives, cameras and scenes (CPU only, fast)."""

from __future__ import annotations

import math
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from nodegraph.errors import MeshError, PipelineError
from nodegraph.scene import scene as scene_module
from nodegraph.scene.meshes import Mesh, MeshWarning, clear_mesh_cache, load_mesh
from nodegraph.scene.scene import (
    Camera,
    Orbit,
    Scene,
    SceneObject,
    frame_camera,
    load_scene,
    primitives,
)

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "meshes"

# (vertices, faces) as listed in shared/meshes/README.md
README_COUNTS = {
    "spot": (2930, 5856),
    "fandisk": (6475, 12946),
    "stanford-bunny": (35947, 69451),
    "ogre": (62194, 124008),
    "teapot": (3644, 6320),
    "suzanne": (507, 968),
    "cow": (2903, 5804),
}


def shared_mesh(name: str) -> Mesh:
    path = SHARED / f"{name}.obj"
    if not path.exists():
        pytest.skip(f"shared test mesh {path} is absent (the shared/meshes folder is not part of the repository)")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)
        return load_mesh(path)


def directed_edges_unique(mesh: Mesh) -> bool:
    """Consistent winding: no directed edge is used twice."""
    f = mesh.faces.astype(np.int64)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = e[:, 0] * mesh.n_vertices + e[:, 1]
    return len(np.unique(key)) == len(key)


def sphere_points(center: np.ndarray, radius: float, n: int = 400) -> np.ndarray:
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    theta = np.pi * (1 + 5**0.5) * i
    d = np.stack([np.cos(theta) * np.sin(phi), np.cos(phi), np.sin(theta) * np.sin(phi)], axis=1)
    return center + radius * d


# --- primitives ---------------------------------------------------------------------------------

CLOSED = {
    "box": (lambda: primitives.box((1.0, 2.0, 3.0)), 6.0, 1e-12),
    "sphere": (lambda: primitives.sphere(1.0, 4), 4.0 / 3.0 * math.pi, 0.005),
    "uv_sphere": (lambda: primitives.uv_sphere(1.0, 64, 32), 4.0 / 3.0 * math.pi, 0.01),
    "cylinder": (lambda: primitives.cylinder(0.5, 2.0, 64), math.pi * 0.25 * 2.0, 0.005),
    "cone": (lambda: primitives.cone(0.5, 1.0, 64), math.pi * 0.25 / 3.0, 0.005),
    "torus": (lambda: primitives.torus(1.0, 0.25, 96, 48), 2.0 * math.pi**2 * 0.25**2, 0.005),
    "ellipsoid": (lambda: primitives.ellipsoid(1.0, 0.75, 0.5, 4), 4.0 / 3.0 * math.pi * 0.375, 0.005),
    "arch": (lambda: primitives.arch(1.0, 0.15, 0.3, 64), math.pi / 2 * (0.65**2 - 0.5**2) * 0.3, 0.005),
    "arch_spandrels": (lambda: primitives.arch(1.0, 0.15, 0.3, 64, spandrels=True),
                       (2 * 0.65 * 0.65 - math.pi / 2 * 0.5**2) * 0.3, 0.005),
}


@pytest.mark.parametrize("name", list(CLOSED))
def test_closed_primitives_are_watertight_and_outward(name: str) -> None:
    make, volume, rtol = CLOSED[name]
    mesh = make()
    topo = mesh.topology()
    assert topo.n_boundary_edges == 0 and topo.n_nonmanifold_edges == 0
    assert topo.n_components == 1 and topo.n_degenerate == 0 and topo.n_unreferenced == 0
    assert topo.n_welded == 0, "primitives share their vertices (no seams)"
    assert directed_edges_unique(mesh)
    assert mesh.signed_volume() > 0
    assert mesh.signed_volume() == pytest.approx(volume, rel=rtol)


@pytest.mark.parametrize("name", ["box", "sphere", "uv_sphere", "cylinder", "cone", "ellipsoid"])
def test_convex_primitives_face_outward(name: str) -> None:
    mesh = CLOSED[name][0]()
    centroids = mesh.vertices[mesh.faces].mean(axis=1)
    assert (np.einsum("ij,ij->i", mesh.face_normals(), centroids) > 0).all()


def test_torus_grid_wraps_without_seam_vertices() -> None:
    t = primitives.torus(2.0, 0.5, 40, 16)
    assert t.n_vertices == 40 * 16 and t.n_faces == 2 * 40 * 16
    radial = t.vertices.copy()
    radial[:, 1] = 0.0
    core = 2.0 * radial / np.linalg.norm(radial, axis=1, keepdims=True)
    centroids = t.vertices[t.faces].mean(axis=1)
    core_c = core[t.faces].mean(axis=1)
    assert (np.einsum("ij,ij->i", t.face_normals(), centroids - core_c) > 0).all()


def test_plane_faces_up_and_is_open() -> None:
    p = primitives.plane(2.0, 4)
    assert p.n_faces == 32
    assert np.allclose(p.face_normals(), [0.0, 1.0, 0.0])
    assert p.topology().n_boundary_edges == 16
    assert p.area() == pytest.approx(4.0)


def test_open_cylinder_has_two_boundary_loops() -> None:
    c = primitives.cylinder(0.5, 1.0, 20, caps=False)
    assert c.topology().n_boundary_edges == 40


def test_revolve_makes_a_closed_outward_body() -> None:
    """A cone-topped drum from its (r, y) profile: poles collapse to one vertex, every edge has two faces, the
    normals point away from the axis, and the volume is the drum's plus the cone's."""
    r, h, n = 0.5, 1.0, 64
    m = primitives.revolve([(0.0, h + 0.5), (r, h), (r, 0.0), (0.0, 0.0)], n, "drum")
    assert m.name == "drum" and m.topology().n_boundary_edges == 0
    centre = m.vertices[m.faces].mean(axis=1) * (1.0, 0.0, 1.0)
    assert (np.einsum("ij,ij->i", m.face_normals(), centre) >= -1e-12).all()
    polygon = 0.5 * n * r * r * math.sin(2 * math.pi / n)  # the n-gon that stands for the circle
    assert m.signed_volume() == pytest.approx(polygon * (h + 0.5 / 3.0), rel=1e-9)


def test_arch_geometry() -> None:
    a = primitives.arch(span=0.8, thickness=0.1, depth=0.2, segments=10)
    lo, hi = a.bounds()
    assert np.allclose(lo, [-0.5, 0.0, -0.1]) and np.allclose(hi, [0.5, 0.5, 0.1])
    r = np.linalg.norm(a.vertices[:, :2], axis=1)
    assert np.all((np.isclose(r, 0.4)) | (np.isclose(r, 0.5)))
    s = primitives.arch(span=0.8, thickness=0.1, depth=0.2, segments=10, spandrels=True)
    lo, hi = s.bounds()
    assert np.allclose(lo, [-0.5, 0.0, -0.1]) and np.allclose(hi, [0.5, 0.5, 0.1])


# --- normals, welding, render arrays ------------------------------------------------------------


def test_box_render_arrays_split_at_creases() -> None:
    ra = primitives.box().render_arrays(40.0)
    assert ra.positions.shape == (24, 3) and ra.normals.shape == (24, 3)
    assert ra.indices.shape == (12, 3) and ra.indices.dtype == np.uint32
    assert ra.positions.dtype == np.float32 and ra.normals.dtype == np.float32
    n = ra.normals
    assert np.allclose(np.abs(n).max(axis=1), 1.0) and np.allclose(np.abs(n).sum(axis=1), 1.0)
    # every triangle's corners carry the triangle's own face normal
    p = ra.positions.astype(np.float64)[ra.indices]
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    assert np.allclose(n[ra.indices], fn[:, None, :], atol=1e-6)
    # smooth normals point along the diagonals, shared by the three copies of a corner
    assert np.allclose(np.abs(ra.smooth_normals), 1 / math.sqrt(3), atol=1e-6)


def test_box_stays_smooth_with_a_wide_crease_angle() -> None:
    assert primitives.box().render_arrays(100.0).n_vertices == 8


def test_sphere_render_arrays_stay_smooth() -> None:
    s = primitives.sphere(2.0, 3)
    ra = s.render_arrays(40.0)
    assert ra.n_vertices == s.n_vertices
    radial = ra.positions / np.linalg.norm(ra.positions, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", ra.normals, radial).min() > 0.999
    assert np.allclose(ra.normals, ra.smooth_normals)
    assert np.all(ra.component == 0)


def test_cylinder_splits_only_the_rims() -> None:
    c = primitives.cylinder(0.5, 1.0, 32)
    ra = c.render_arrays(40.0)
    assert ra.n_vertices == 2 + 4 * 32  # two cap centres, each rim vertex once for its cap, once for the side


def unshared_box() -> Mesh:
    b = primitives.box()
    return Mesh("soup", b.vertices[b.faces].reshape(-1, 3), np.arange(36).reshape(12, 3))


def test_welding_merges_split_vertices() -> None:
    soup = unshared_box()
    welded, n_unique = soup.weld()
    assert n_unique == 8 and welded.shape == (36,)
    reps = np.array([soup.vertices[welded == k][0] for k in range(8)])
    assert np.allclose(soup.vertices, reps[welded])
    assert len(np.unique(reps, axis=0)) == 8
    topo = soup.topology()
    assert topo.n_components == 1 and topo.n_welded == 28
    assert topo.n_boundary_edges == 0 and topo.n_nonmanifold_edges == 0
    vn = soup.vertex_normals()
    for k in range(8):
        assert np.allclose(vn[welded == k], vn[welded == k][0])
    assert soup.render_arrays().n_vertices == 24
    assert (soup.render_arrays().component == 0).all()


def test_weld_tolerance_is_relative() -> None:
    b = primitives.box((1000.0, 1000.0, 1000.0))
    v = b.vertices[b.faces].reshape(-1, 3) + np.random.default_rng(1).normal(0.0, 1e-7, (36, 3))
    assert Mesh("noisy", v, np.arange(36).reshape(12, 3)).weld()[1] == 8
    assert Mesh("noisy", v, np.arange(36).reshape(12, 3)).weld(0.0)[1] == 36


def test_vertex_normals_have_no_nan() -> None:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5], [2, 0, 0], [3, 0, 0]], dtype=float)
    f = np.array([[0, 1, 2], [1, 4, 5]])  # vertex 3 unreferenced; face 1 has zero area
    m = Mesh("odd", v, f)
    n = m.vertex_normals()
    assert n.dtype == np.float32 and np.isfinite(n).all()
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    assert np.allclose(n[0], [0, 0, 1])
    topo = m.topology()
    assert topo.n_unreferenced == 1 and topo.n_degenerate == 1
    ra = m.render_arrays()
    assert np.isfinite(ra.normals).all() and np.isfinite(ra.smooth_normals).all()


def test_two_parts_are_two_components() -> None:
    a = primitives.sphere(1.0, 1)
    t = np.eye(4)
    t[0, 3] = 5.0
    b = a.transformed(t)
    merged = Mesh("two", np.concatenate([a.vertices, b.vertices]), np.concatenate([a.faces, b.faces + a.n_vertices]))
    assert merged.topology().n_components == 2
    assert set(np.unique(merged.render_arrays().component)) == {0.0, 1.0}


def test_mirroring_transform_flips_winding() -> None:
    m = primitives.box().transformed(np.diag([-1.0, 1.0, 1.0, 1.0]))
    assert m.signed_volume() > 0


def test_content_hash_follows_content() -> None:
    a, b = primitives.sphere(1.0, 2), primitives.sphere(1.0, 2)
    assert a.content_hash() == b.content_hash() and len(a.content_hash()) == 64
    assert primitives.sphere(1.01, 2).content_hash() != a.content_hash()
    with pytest.raises(ValueError):
        a.vertices[0, 0] = 1.0  # arrays are read-only: cached data cannot go stale


# --- loading ------------------------------------------------------------------------------------


def one_line_naming(exc: Exception, path: Path) -> str:
    msg = str(exc)
    assert "\n" not in msg
    assert str(path) in msg
    return msg


def test_load_missing_file(tmp_path: Path) -> None:
    p = tmp_path / "nothere.obj"
    with pytest.raises(MeshError) as err:
        load_mesh(p)
    assert "not found" in one_line_naming(err.value, p)


def test_load_bad_extension(tmp_path: Path) -> None:
    p = tmp_path / "model.blend"
    p.write_text("x")
    with pytest.raises(MeshError) as err:
        load_mesh(p)
    msg = one_line_naming(err.value, p)
    assert ".obj" in msg and ".ply" in msg and ".off" in msg and ".stl" in msg


@pytest.mark.parametrize("text", ["", "# nothing\n", "v 0 0 0\nv 1 0 0\n"])
def test_load_empty(tmp_path: Path, text: str) -> None:
    p = tmp_path / "empty.obj"
    p.write_text(text)
    with pytest.raises(MeshError) as err:
        load_mesh(p)
    msg = one_line_naming(err.value, p)
    assert "no faces" in msg or "no vertices" in msg


@pytest.mark.parametrize("ext, text", [
    (".obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nv 1 1 inf\nf 1 2 3\nf 2 4 3\n"),
    (".off", "OFF\n4 2 0\n0 0 0\nnan 0 0\n0 1 0\n1 1 inf\n3 0 1 2\n3 1 3 2\n"),
    (".ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
             "0 0 0\nnan 0 0\n0 1 0\n1 1 inf\n3 0 1 2\n3 1 3 2\n"),
])
def test_load_nan_coordinates(tmp_path: Path, ext: str, text: str) -> None:
    p = tmp_path / f"bad{ext}"
    p.write_text(text)
    with pytest.raises(MeshError) as err:
        load_mesh(p)
    msg = one_line_naming(err.value, p)
    assert "NaN/Inf" in msg and "2 " in msg


def test_load_index_out_of_range(tmp_path: Path) -> None:
    p = tmp_path / "oor.off"
    p.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    with pytest.raises(MeshError) as err:
        load_mesh(p)
    assert "out of range" in one_line_naming(err.value, p)


def test_an_out_of_range_index_is_named_in_the_files_own_numbering(tmp_path: Path) -> None:
    obj = tmp_path / "oor.obj"  # OBJ counts vertices from 1: the 9 the user wrote
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    with pytest.raises(MeshError) as err:
        load_mesh(obj)
    assert "a face uses vertex 9 (counted from 1, as OBJ does), out of range: the file has 3 vertices" in \
        one_line_naming(err.value, obj)
    off = tmp_path / "oor.off"  # OFF counts from 0
    off.write_text("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 7\n")
    with pytest.raises(MeshError) as err:
        load_mesh(off)
    assert "a face uses vertex 7 (counted from 0), out of range: the file has 3 vertices" in \
        one_line_naming(err.value, off)


def test_load_unreadable(tmp_path: Path) -> None:
    p = tmp_path / "broken.obj"
    p.write_text("v 0 0\nf 1 2 3\n")
    with pytest.raises(MeshError) as err:
        load_mesh(p)
    one_line_naming(err.value, p)


def test_load_triangulates_polygons(tmp_path: Path) -> None:
    obj = tmp_path / "poly.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0.5 0\nf 1 2 3 4\nf 2 5 3\n")
    assert load_mesh(obj).n_faces == 3
    ply = tmp_path / "mixed.ply"  # libigl's own PLY reader aborts the process on mixed polygon sizes
    header = (b"ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
              b"property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n")
    verts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0.5, 0]], "<f4").tobytes()
    faces = struct.pack("<B4i", 4, 0, 1, 2, 3) + struct.pack("<B3i", 3, 1, 4, 2)
    ply.write_bytes(header + verts + faces)
    m = load_mesh(ply)
    assert m.n_faces == 3 and np.allclose(m.face_normals(), [0, 0, 1])
    ascii_ply = tmp_path / "quads.ply"
    ascii_ply.write_text("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                         "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
    assert load_mesh(ascii_ply).n_faces == 2


def test_load_repairs_with_one_warning(tmp_path: Path) -> None:
    p = tmp_path / "dups.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 0 0\n"
                 "f 1 2 3\nf 2 3 1\nf 1 1 2\nf 2 4 3\nf 1 2 5\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mesh(p)
    ours = [w for w in caught if issubclass(w.category, MeshWarning)]
    assert len(ours) == 1
    msg = str(ours[0].message)
    assert "dups" in msg and "2 degenerate" in msg and "1 duplicate" in msg
    assert m.n_faces == 2


def test_obj_statements_without_a_surface_load_quietly(tmp_path: Path) -> None:
    """An object name (every Blender OBJ has `o NAME`) or free-form curve data is no problem of the file: no
    warning. A polyline (`l`) is geometry left out: the warning names the statement, not the line's content."""
    quiet = tmp_path / "blender.obj"
    quiet.write_text("# Blender 4.2\nmtllib blender.mtl\no Cube\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n"
                     "s 0\nusemtl Material\nf 1//1 2//1 3//1\nvp 0.5\ncstype bspline\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert load_mesh(quiet).n_faces == 1
    assert [str(w.message) for w in caught if issubclass(w.category, MeshWarning)] == []
    lines = tmp_path / "poly.obj"
    lines.write_text("o Cube\nv 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nf 1 2 3\n")
    with pytest.warns(MeshWarning, match=r"ignored non-comment line 5 \(an 'l' statement\)"):
        assert load_mesh(lines).n_faces == 1


def test_load_is_memoised_by_path_mtime_size(tmp_path: Path) -> None:
    clear_mesh_cache()
    p = tmp_path / "tri.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    a = load_mesh(p)
    assert load_mesh(str(p)) is a
    p.write_text("v 0 0 0\nv 2 0 0\nv 0 2 0\nv 2 2 0\nf 1 2 3\nf 2 4 3\n")
    b = load_mesh(p)
    assert b is not a and b.n_faces == 2


UNUSED_VERTICES = {"stanford-bunny": 1113}  # the scan's file lists vertices no face uses


@pytest.mark.parametrize("name", list(README_COUNTS))
def test_shared_meshes_load(name: str) -> None:
    m = shared_mesh(name)
    n_v, n_f = README_COUNTS[name]
    assert m.n_vertices == n_v - UNUSED_VERTICES.get(name, 0)  # vertices no face uses are dropped at load
    assert n_f - 10 <= m.n_faces <= n_f  # a few degenerate faces may be dropped (ogre has 4)
    ra = m.render_arrays()
    assert np.isfinite(ra.normals).all() and np.isfinite(ra.smooth_normals).all()
    assert ra.indices.max() < ra.n_vertices


def test_shared_topology_matches_readme() -> None:
    assert shared_mesh("suzanne").topology().n_components >= 3
    teapot = shared_mesh("teapot").topology()
    assert teapot.n_boundary_edges > 0 and teapot.n_welded > 0
    assert shared_mesh("stanford-bunny").topology().n_boundary_edges > 0
    spot = shared_mesh("spot").topology()
    assert spot.closed and spot.n_components == 1
    assert shared_mesh("fandisk").topology().closed


def test_shared_crease_splitting() -> None:
    fandisk = shared_mesh("fandisk")
    assert fandisk.render_arrays(40.0).n_vertices > fandisk.n_vertices * 1.05  # sharp CAD edges split
    bunny = shared_mesh("stanford-bunny")
    ra = bunny.render_arrays(40.0)
    referenced = len(np.unique(bunny.faces))
    # a scan stays smooth but for a few folds sharper than the crease angle (about 1% here)
    assert ra.n_vertices <= referenced * 1.03
    same = np.einsum("ij,ij->i", ra.normals, ra.smooth_normals) > 0.9999
    assert same.mean() > 0.97


# --- camera -------------------------------------------------------------------------------------


def test_camera_view_matrix_is_computed_once_and_handed_out_as_copies() -> None:
    cam = Camera(eye=(1.0, 2.0, 5.0), target=(0.5, 0.0, -1.0), up=(0.1, 1, 0), fov_y_deg=40)
    first = cam.view_matrix()
    expected = first.copy()
    first[:] = 0.0  # a caller that writes into its matrix must not change the camera's
    assert np.array_equal(cam.view_matrix(), expected)
    assert cam.view_matrix() is not cam.view_matrix()


@given(st.lists(st.floats(-1e6, 1e6), min_size=6, max_size=6))
def test_camera_cross_product_has_the_bits_of_np_cross(v: list[float]) -> None:
    a, b = np.array(v[:3]), np.array(v[3:])
    assert np.array_equal(scene_module._cross3(a, b), np.cross(a, b))


def test_camera_conventions() -> None:
    cam = Camera(eye=(1.0, 2.0, 5.0), target=(0.5, 0.0, -1.0), up=(0, 1, 0), fov_y_deg=40, near=0.5, far=50)
    v = cam.view_matrix()
    assert np.allclose(v[:3, :3] @ v[:3, :3].T, np.eye(3))
    assert np.allclose(v @ [*cam.eye, 1.0], [0, 0, 0, 1])
    t = v @ [*cam.target, 1.0]
    assert np.allclose(t[:2], 0.0) and t[2] < 0  # looks down -z
    assert np.allclose(cam.project(cam.target)[0, :2], 0.0)
    r, u, f = cam.basis()
    assert np.allclose(cam.project(cam.eye + f * 0.5)[0, 2], -1.0)  # near plane -> -1
    assert np.allclose(cam.project(cam.eye + f * 50.0)[0, 2], 1.0)  # far plane -> +1
    above = cam.project(cam.target + u * 0.1)[0]
    right = cam.project(cam.target + r * 0.1)[0]
    assert above[1] > 0 and right[0] > 0
    p = cam.projection_matrix(2.0)
    assert p[0, 0] == pytest.approx(p[1, 1] / 2.0)


@pytest.mark.parametrize("scale", [0.15, 1.0, 45.0, 3000.0])
@pytest.mark.parametrize("aspect", [1.0, 16 / 9, 9 / 16])
def test_frame_camera_fits_the_bounding_sphere(scale: float, aspect: float) -> None:
    lo = np.array([-0.6, 0.2, -0.4]) * scale + 7.0 * scale
    hi = np.array([0.4, 1.2, 0.4]) * scale + 7.0 * scale
    cam = frame_camera(lo, hi)  # the field of view spans the shorter side: one camera fits every aspect
    center, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    ndc = cam.project(sphere_points(center, radius), aspect)
    assert np.abs(ndc[:, :2]).max() <= 1.0
    assert np.abs(ndc[:, :2]).max() > 0.75  # fitted, not lost in the middle
    assert ndc[:, 2].min() >= -1.0 and ndc[:, 2].max() <= 1.0
    assert np.allclose(cam.project(center, aspect)[0, :2], 0.0, atol=1e-9)
    assert cam.near > 0 and cam.far / cam.near < 100


def test_frame_camera_for_shared_meshes() -> None:
    for name in ("stanford-bunny", "ogre"):
        lo, hi = shared_mesh(name).bounds()
        cam = frame_camera(lo, hi)
        ndc = cam.project(shared_mesh(name).vertices)
        assert np.abs(ndc).max() <= 1.0


def test_frame_camera_straight_down_still_has_an_up() -> None:
    cam = frame_camera((-1, -1, -1), (1, 1, 1), direction=(0, 1, 0))
    assert np.isfinite(cam.view_matrix()).all()


def test_orbit_keeps_the_distance_to_its_center() -> None:
    cam = Camera(eye=(3.0, 2.0, 4.0), target=(0.0, 0.5, 0.0), up=(0, 1, 0), near=0.1, far=20)
    box = SceneObject(primitives.box())
    for orbit in (Orbit(), Orbit(axis=(0.2, 1.0, 0.1), degrees_per_frame=7.5, center=np.array([1.0, 0.0, 1.0]))):
        scene = Scene("s", (box,), cam, orbit=orbit)
        center = cam.target if orbit.center is None else orbit.center
        d0 = np.linalg.norm(cam.eye - center)
        for k in (1, 5, 17, -3):
            ck = scene.camera_at(k)
            assert np.linalg.norm(ck.eye - center) == pytest.approx(d0)
            assert ck.distance == pytest.approx(cam.distance)
        assert not np.allclose(scene.camera_at(1).eye, cam.eye)
    full = Scene("s", (box,), cam, orbit=Orbit(degrees_per_frame=6.0)).camera_at(60)
    assert np.allclose(full.eye, cam.eye)
    assert Scene("s", (box,), cam).camera_at(9) is cam


# --- scenes -------------------------------------------------------------------------------------


def write(tmp_path: Path, text: str, name: str = "scene.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_scene_yaml_loads(tmp_path: Path) -> None:
    p = write(tmp_path, """\
scene: courtyard
objects:
  - name: slab
    primitive: {type: box, size: [3, 0.1, 3]}
    transform: {translate: [0, -0.05, 0]}
    color: [0.6, 0.6, 0.6]
    sketchy: false
  - primitive: {type: torus, R: 0.5, r: 0.1}
    transform: {translate: [0, 0.1, 0], rotate: [90, 0, 0], scale: 2}
    color: [0.8, 0.3, 0.3]
light: {direction: [0, 1, 0], space: world}
orbit: {degrees_per_frame: 3}
background: [0.9, 0.9, 0.85]
""")
    s = load_scene(str(p))
    assert s.name == "courtyard" and len(s.objects) == 2
    assert [o.name for o in s.select("sketchy")] == ["torus1"]
    assert [o.index for o in s.select("non_sketchy")] == [0]
    assert s.light_space == "world" and np.allclose(s.light_direction, [0, 1, 0])
    assert s.orbit is not None and s.orbit.degrees_per_frame == 3
    lo, hi = s.bounds()
    # the torus (R 1, r 0.2 after scaling) stands in the XY plane after turning 90 degrees about X
    assert np.allclose(lo, [-1.5, -1.1, -1.5], atol=1e-9) and np.allclose(hi, [1.5, 1.3, 1.5], atol=1e-9)
    ndc = s.camera.project(sphere_points((lo + hi) / 2, np.linalg.norm(hi - lo) / 2))
    assert np.abs(ndc).max() <= 1.0


def test_scene_yaml_mesh_paths_are_relative_to_the_file(tmp_path: Path) -> None:
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    p = write(tmp_path, "objects:\n  - mesh: m/tri.obj\ncamera: {eye: [0, 0, 3], target: [0, 0, 0]}\n")
    s = load_scene("scene.yaml", base_dir=tmp_path)
    assert s.objects[0].name == "tri" and s.objects[0].mesh.n_faces == 1
    assert 0 < s.camera.near < 3 < s.camera.far
    assert s.source is not None and Path(s.source).name == p.name


@pytest.mark.parametrize("text, where, words", [
    ("objects:\n  - primitive: {type: box}\n    colour: [1, 0, 0]\n", "3:5", ["unknown field", "colour"]),
    ("objects:\n  - primitive: {type: box}\n    color: [1, 0]\n", "3:12", ["color", "3 numbers"]),
    ("objects:\n  - primitive: {type: box}\n    color: [1, 0, 2]\n", "3:12", ["color", "[0, 1]"]),
    ("objects:\n  - primitive: {type: boz}\n", "2:23", ["boz", "did you mean 'box'"]),
    ("objects:\n  - primitive: {type: torus, R: 1, r: 0.3, n_majr: 5}\n", "2:44", ["n_majr"]),
    ("objects:\n  - primitive: {type: box}\ncamera: {eye: [0, 1, 5], target: [0, 0, 0], fov: 200}\n", "3:50",
     ["fov"]),
    ("objects:\n  - primitive: {type: box}\ncamera: {eye: [0, 5, 0], target: [0, 0, 0]}\n", "3:9", ["parallel"]),
    ("objects:\n  - primitive: {type: box}\n    transform: {scale: -1}\n", "3:24", ["scale"]),
    ("objects:\n  - primitive: {type: box}\nlight: {space: screen}\n", "3:16", ["space"]),
    ("objects:\n  - primitive: {type: box}\n    mesh: x.obj\n", "2:5", ["exactly one"]),
    ("scene: x\n", "1:1", ["objects"]),
    ("objects: [\n", "2:1", ["invalid YAML"]),
])
def test_scene_yaml_errors_are_located(tmp_path: Path, text: str, where: str, words: list[str]) -> None:
    p = write(tmp_path, text)
    with pytest.raises(PipelineError) as err:
        load_scene(str(p))
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith(f"{p}:{where}: "), msg
    for w in words:
        assert w in msg, msg


def test_scene_yaml_missing_mesh_names_the_resolved_path(tmp_path: Path) -> None:
    p = write(tmp_path, "scene: x\nobjects:\n  - name: a\n    mesh: meshes/nothere.obj\n")
    with pytest.raises(PipelineError) as err:
        load_scene(str(p))
    msg = str(err.value)
    assert msg.startswith(f"{p}:4:11: ")
    assert str(tmp_path / "meshes" / "nothere.obj") in msg


def test_scene_yaml_bad_mesh_is_located(tmp_path: Path) -> None:
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
    p = write(tmp_path, "objects:\n  - mesh: nan.obj\n")
    with pytest.raises(PipelineError) as err:
        load_scene(str(p))
    assert str(err.value).startswith(f"{p}:2:11: ") and "NaN" in str(err.value)


def test_scene_content_hash() -> None:
    cam = Camera(eye=(0, 1, 4), target=(0, 0, 0), up=(0, 1, 0))
    obj = SceneObject(primitives.box(), color=(0.5, 0.5, 0.5))
    a = Scene("a", (obj,), cam)
    b = Scene("renamed", (SceneObject(primitives.box(), color=(0.5, 0.5, 0.5), name="other"),), cam)
    assert a.content_hash() == b.content_hash()  # names do not change pixels
    assert a.content_hash() == a.content_hash()
    changed = [
        Scene("a", (SceneObject(primitives.box(), color=(0.5, 0.5, 0.6)),), cam),
        Scene("a", (SceneObject(primitives.box(), color=(0.5, 0.5, 0.5), sketchy=False),), cam),
        Scene("a", (SceneObject(primitives.box((1, 1, 2)), color=(0.5, 0.5, 0.5)),), cam),
        Scene("a", (SceneObject(primitives.box(), np.diag([2.0, 2, 2, 1]), (0.5, 0.5, 0.5)),), cam),
        Scene("a", (obj,), Camera(eye=(0, 1, 4), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=30)),
        Scene("a", (obj,), cam, light_direction=np.array([0.0, 1.0, 0.0])),
        Scene("a", (obj,), cam, light_space="world"),
        Scene("a", (obj,), cam, orbit=Orbit()),
        Scene("a", (obj,), cam, background=(0.9, 0.9, 0.9)),
    ]
    hashes = {s.content_hash() for s in changed}
    assert len(hashes) == len(changed) and a.content_hash() not in hashes


def test_bare_mesh_scene(tmp_path: Path) -> None:
    p = tmp_path / "tet.off"
    p.write_text("OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
    s = load_scene(str(p))
    assert len(s.objects) == 1 and s.objects[0].sketchy
    assert s.orbit is not None and s.orbit.degrees_per_frame == 6.0 and np.allclose(s.orbit.axis, [0, 1, 0])
    assert np.allclose(s.camera.project(s.objects[0].mesh.vertices)[:, :2], 0, atol=1.0)


def test_shared_mesh_scene() -> None:
    shared_mesh("stanford-bunny")
    s = load_scene(str(SHARED / "stanford-bunny.obj"))
    assert np.abs(s.camera.project(s.objects[0].mesh.vertices)).max() <= 1.0


def test_load_scene_errors(tmp_path: Path) -> None:
    with pytest.raises(PipelineError, match="did you mean 'builtin:cloister'"):
        load_scene("builtin:clositer")
    with pytest.raises(PipelineError, match="not found"):
        load_scene("nothere.yaml", base_dir=tmp_path)
    with pytest.raises(PipelineError, match=r"\.obj"):
        load_scene("scene.blend")


@pytest.mark.parametrize("name", ["box", "sphere", "torus", "primitives"])
def test_small_builtins(name: str) -> None:
    s = load_scene(f"builtin:{name}")
    assert s.objects and s.camera.near < s.camera.far
    lo, hi = s.bounds()
    ndc = s.camera.project(sphere_points((lo + hi) / 2, np.linalg.norm(hi - lo) / 2))
    assert np.abs(ndc).max() <= 1.0


def test_cloister() -> None:
    s = load_scene("builtin:cloister")
    assert s is load_scene("builtin:cloister")  # built once
    assert len(s.objects) >= 10
    assert s.n_triangles() < 60_000
    assert len({o.color for o in s.objects}) >= 8  # readable color patches in the shade map
    assert len({o.name for o in s.objects}) == len(s.objects)
    for o in s.objects:
        topo = o.mesh.topology()
        assert topo.n_boundary_edges == 0 and topo.n_degenerate == 0, o.name
        assert o.mesh.signed_volume() > 0, o.name
    lo, hi = s.bounds()
    cam = s.camera
    elevation = math.degrees(math.asin(-cam.basis()[2][1]))
    assert 5.0 < elevation < 35.0  # from slightly above
    center, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    depth = sphere_points(center, radius) - cam.eye
    along = depth @ cam.basis()[2]
    assert cam.near <= along.min() + 1e-9 and along.max() <= cam.far + 1e-9  # near/far enclose the scene
    ndc = cam.project(np.concatenate([o.world_vertices() for o in s.objects]))
    inside = (np.abs(ndc[:, :2]) <= 1.0).all(axis=1)
    assert inside.mean() > 0.6  # the camera sees most of it
    assert s.content_hash() == load_scene("builtin:cloister").content_hash()


def test_mesh_files_are_seen_from_their_most_revealing_side():
    """A long box along X is seen from the side (largest projected area), not end-on."""
    from nodegraph.scene import primitives
    from nodegraph.scene.scene import best_view_direction

    long_x = primitives.box((4.0, 1.0, 1.0))
    d = best_view_direction(long_x)
    assert abs(d[0]) < 0.5 * abs(d[2])  # looking along Z, at the long side
    long_z = primitives.box((1.0, 1.0, 4.0))
    d = best_view_direction(long_z)
    assert abs(d[2]) < 0.5 * abs(d[0])


def test_hole_share_bounds_what_holes_can_show():
    from nodegraph.scene import primitives

    assert primitives.box((1.0, 1.0, 1.0)).hole_share() == 0.0
    # a unit square: one loop of length 4 over area 1 -> 16 / (4 pi)
    assert primitives.plane(1.0, 4).hole_share() == pytest.approx(16 / (4 * np.pi), rel=1e-6)
    # a torus with a thin slot cut out: one loop around the cut, small against the surface
    t = primitives.torus(1.0, 0.3, 64, 24)
    keep = np.ones(len(t.faces), bool)
    keep[:4] = False
    from nodegraph.scene.meshes import Mesh

    cut = Mesh("cut", t.vertices, t.faces[keep])
    assert 0 < cut.hole_share() < 0.01


def test_the_field_of_view_spans_the_shorter_side():
    """A framed subject stays inside tall images as well as wide ones."""
    from nodegraph.scene.scene import Camera

    cam = Camera(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=40.0, near=1, far=10)
    edge = np.tan(np.radians(20.0)) * 5  # a point at the edge of the field of view, at the target's depth
    for aspect in (0.4, 1.0, 2.5):
        ndc = cam.project([[edge, 0, 0], [0, edge, 0]], aspect)
        assert max(abs(ndc[0, 0]), abs(ndc[1, 1])) == pytest.approx(1.0)  # the shorter side is exactly filled
        assert abs(ndc[0, 0]) <= 1 + 1e-9 and abs(ndc[1, 1]) <= 1 + 1e-9
