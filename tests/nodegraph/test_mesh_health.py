"""Mesh health when a file is read (nodegraph/scene/meshes.py: `orient_consistently`, `health_notes`): faces wound
against their neighbours are turned, with one line; a noisy surface and holes in a mostly closed one are told in
one line each; none of it for clean meshes (spheres, a cube, the shared test meshes), and not again when a later
run reads the parsed mesh from the mesh store."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from nodegraph.cache import Cache
from nodegraph.scene import meshes, meshstore
from nodegraph.scene.meshes import Mesh, MeshHealthWarning, MeshWarning, health_notes, load_mesh
from nodegraph.scene.primitives import box, plane, sphere
from tests.helpers import shared_mesh

CAMERA_SIDE = np.array([0.4, 0.5, 0.8]) / np.linalg.norm([0.4, 0.5, 0.8])


def write_obj(path: Path, v: np.ndarray, f: np.ndarray) -> Path:
    path.write_text("".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in v)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))
    return path


def noisy_sphere(subdiv: int, share: float, seed: int = 5) -> Mesh:
    """A unit icosphere with every vertex moved `share` of the radius in a random direction."""
    m = sphere(1.0, subdiv)
    d = np.random.default_rng(seed).normal(size=m.vertices.shape)
    return Mesh("noisy", m.vertices + share * d / np.linalg.norm(d, axis=1, keepdims=True), m.faces)


def load(path: Path) -> tuple[Mesh, list[str], list[str]]:
    """(mesh, MeshHealthWarning lines, other MeshWarning lines) of a load in a fresh process, as far as the
    in-memory memo goes."""
    meshes.clear_mesh_cache()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = load_mesh(path)
    health = [str(w.message) for w in caught if issubclass(w.category, MeshHealthWarning)]
    other = [str(w.message) for w in caught if issubclass(w.category, MeshWarning)
             and not issubclass(w.category, MeshHealthWarning)]
    return mesh, health, other


@pytest.fixture
def no_store():
    """Parse every file (no mesh store), whatever an earlier test configured."""
    old = meshstore.root()
    meshstore.configure(None)
    meshes.clear_mesh_cache()
    yield
    meshstore.configure(old)
    meshes.clear_mesh_cache()


def flipped_patch(m: Mesh, side: np.ndarray, cos: float) -> tuple[np.ndarray, np.ndarray]:
    centre = m.vertices[m.faces].mean(axis=1)
    patch = centre @ side / np.linalg.norm(centre, axis=1) > cos
    f = np.array(m.faces)
    f[patch] = f[patch][:, ::-1]
    return f, patch


def same_triangles(a: np.ndarray, b: np.ndarray) -> bool:
    """The same triangles in the same order and winding (each row possibly rotated)."""
    return bool(np.any([(a == np.roll(b, k, axis=1)).all(axis=1) for k in range(3)], axis=0).all())


# -- winding ---------------------------------------------------------------------------------------------------------
def test_a_flipped_patch_is_turned_back_with_one_line(no_store, tmp_path):
    clean = sphere(1.0, 3)
    f, patch = flipped_patch(clean, CAMERA_SIDE, 0.75)
    assert 20 < patch.sum() < len(f) // 4
    mesh, health, other = load(write_obj(tmp_path / "patched.obj", clean.vertices, f))
    assert other == [] and len(health) == 1, health
    assert f"{int(patch.sum())} faces flipped to match their neighbours" in health[0]
    assert "patched.obj" in health[0]
    assert same_triangles(mesh.faces, clean.faces) and mesh.winding_conflicts() == 0
    assert mesh.signed_volume() > 0


def test_the_winding_most_of_the_surface_has_is_kept(no_store, tmp_path):
    """Flipping 80% of a sphere turns the other 20%: the file is inside out, consistently (pencil_shade culls by
    the signed volume); a closed mesh wound one way throughout is left alone."""
    clean = sphere(1.0, 3)
    f, patch = flipped_patch(clean, CAMERA_SIDE, -0.6)
    assert patch.mean() > 0.7
    mesh, health, _ = load(write_obj(tmp_path / "mostly.obj", clean.vertices, f))
    assert f"{int((~patch).sum())} faces flipped" in health[0]
    assert same_triangles(mesh.faces, clean.faces[:, ::-1]) and mesh.signed_volume() < 0
    inside_out, health, _ = load(write_obj(tmp_path / "inside_out.obj", clean.vertices, clean.faces[:, ::-1]))
    assert health == [] and inside_out.signed_volume() < 0


def test_two_patches_joined_at_a_seam_of_split_vertices_are_turned_as_one(no_store, tmp_path):
    """Orientation follows welded edges: an OBJ whose faces do not share vertex ids (STL-like) is still fixed."""
    clean = sphere(1.0, 2)
    f, patch = flipped_patch(clean, CAMERA_SIDE, 0.7)
    v = clean.vertices[f].reshape(-1, 3)  # every face its own three vertices
    mesh, health, _ = load(write_obj(tmp_path / "soup.obj", v, np.arange(len(v)).reshape(-1, 3)))
    assert len(health) == 1 and f"{int(patch.sum())} faces flipped" in health[0]
    assert mesh.winding_conflicts() == 0


def test_a_flipped_patch_renders_like_the_sphere(gl, no_store, tmp_path):
    """Before, a closed mesh's back faces are culled, so the patch drew as a hole with a zigzag rim; now
    rasterize's coverage and normals are the clean sphere's."""
    from nodegraph_nodes.rasterize import Rasterize

    from nodegraph.scene.scene import mesh_scene
    from tests.helpers import run_node

    clean = sphere(1.0, 3)
    f, _ = flipped_patch(clean, CAMERA_SIDE, 0.75)
    ports = frozenset({"normal"})

    def draw(path: Path) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MeshWarning)
            scene = mesh_scene(path)
        return run_node(gl, Rasterize("r"), {}, (96, 96), scene=scene, needed=ports)["normal"].read()

    want = draw(write_obj(tmp_path / "clean.obj", clean.vertices, clean.faces))
    got = draw(write_obj(tmp_path / "patched.obj", clean.vertices, f))
    a, b = want[..., 3] > 0.5, got[..., 3] > 0.5
    assert a.sum() > 2000 and (a == b).all()
    np.testing.assert_allclose(got[..., :3][a], want[..., :3][a], atol=1e-3)
    # as it drew without the fix: the same faces put straight into a scene (no file, nothing turned)
    from nodegraph.scene.scene import scene_for_mesh

    raw = scene_for_mesh(Mesh("patched", clean.vertices, f))
    holed = run_node(gl, Rasterize("r"), {}, (96, 96), scene=raw, needed=ports)["normal"].read()[..., 3] > 0.5
    assert (a & ~holed).sum() > 200


# -- noise -----------------------------------------------------------------------------------------------------------
@pytest.mark.slow  # an 82k-face OBJ written and read: about 2 s
def test_a_sphere_with_half_a_percent_of_noise_warns_a_clean_one_does_not(no_store, tmp_path):
    noisy = noisy_sphere(6, 0.005)  # 82k faces, every vertex moved 0.5% of the radius
    mesh, health, _ = load(write_obj(tmp_path / "noisy.obj", noisy.vertices, noisy.faces))
    assert len(health) == 1, health
    assert "noisy surface" in health[0] and "edges will fire everywhere; smooth it first or raise " \
        "edges.normal_threshold" in health[0]
    noise = mesh.surface_noise()
    assert noise.noisy and noise.rough_deg > 6.0 and noise.n_measured == mesh.n_vertices
    clean = sphere(1.0, 6)
    assert health_notes(clean) == [] and clean.surface_noise().rough_deg < 0.1


def test_noise_is_told_in_one_line_and_only_where_there_is_noise(no_store, tmp_path):
    noisy = noisy_sphere(5, 0.01)  # 20k faces, every vertex moved 1% of the radius
    _, health, other = load(write_obj(tmp_path / "noisy.obj", noisy.vertices, noisy.faces))
    assert other == [] and len(health) == 1 and "noisy surface" in health[0], health
    assert "noisy.obj" in health[0] and "edges will fire everywhere" in health[0]
    for clean in (sphere(1.0, 4), sphere(1.0, 5), box(1.0), plane(2.0, 40)):
        assert health_notes(clean) == [], clean
    for smooth in (sphere(1.0, 5), plane(2.0, 40)):
        assert smooth.surface_noise().rough_deg < 0.1 and smooth.surface_noise().n_measured > 1000
    # coarser: 0.5% moves a 20k-face sphere's normals less than edges notice
    assert not noisy_sphere(5, 0.005).surface_noise().noisy
    # heavy noise (most edges creases) is still measured
    heavy = noisy_sphere(5, 0.04).surface_noise()
    assert heavy.noisy and heavy.n_measured == 10242


@pytest.mark.slow  # two 82k-face G-buffers and edge maps: about 3 s
def test_the_noisy_sphere_really_fires_edges_everywhere(gl, tmp_path):
    """What the warning says: pencil.yaml's edge map (normal_threshold 0.5) marks inner edges all over the noisy
    sphere (specks over about 2% of it, in every quadrant of its picture), and none on the clean one."""
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor

    root = Path(__file__).resolve().parents[2]
    cover = {}
    for name, m in (("clean", sphere(1.0, 6)), ("noisy", noisy_sphere(6, 0.005))):
        path = write_obj(tmp_path / f"{name}.obj", m.vertices, m.faces)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MeshWarning)
            # px_scale 1: the edge stencil 2 px wide, as at pencil.yaml's own 800 x 800
            pipe = pl.load(root / "pipelines" / "pencil.yaml", size=(240, 240), scene=str(path), reference_size=240)
        res = Executor(pipe, None, requested=[("edges", "inner"), ("gbuf", "normal_depth")]).run()
        inner = res.values[("edges", "inner")].read()[..., 0]
        covered = res.values[("gbuf", "normal_depth")].read()[..., 3] > 0
        fired = (inner > 0.5) & covered
        rows, cols = np.nonzero(covered)
        mid_r, mid_c = int(np.median(rows)), int(np.median(cols))
        # in each quadrant of the sphere's picture, not only along one part of it
        quads = [fired[:mid_r, :mid_c], fired[:mid_r, mid_c:], fired[mid_r:, :mid_c], fired[mid_r:, mid_c:]]
        cover[name] = (fired.sum() / covered.sum(), min(q.sum() for q in quads))
    assert cover["clean"][0] < 0.002, cover
    assert cover["noisy"][0] > 0.01 and cover["noisy"][1] > 20, cover  # measured: 1.8%, 47 px


# -- holes -----------------------------------------------------------------------------------------------------------
def test_holes_in_a_closed_surface_are_told_an_open_surface_is_not(no_store, tmp_path):
    m = sphere(1.0, 4)
    centre = m.vertices[m.faces].mean(axis=1)
    keep = np.ones(len(m.faces), bool)
    keep[np.argsort(centre @ CAMERA_SIDE)[-3:]] = False  # three faces around one vertex: one hole
    keep[np.argsort(centre @ -CAMERA_SIDE)[-1:]] = False  # one face on the other side: another
    _, health, _ = load(write_obj(tmp_path / "holed.obj", m.vertices, m.faces[keep]))
    assert len(health) == 1 and "2 holes in an otherwise closed surface" in health[0], health
    flat = plane(2.0, 8)
    _, health, _ = load(write_obj(tmp_path / "plane.obj", flat.vertices, flat.faces))
    assert health == []
    loops, edges, share = flat.holes()
    assert (loops, edges) == (1, 32) and share > 1.0


# -- the shared meshes -----------------------------------------------------------------------------------------------
# what each shared mesh is told (all of it true: ogre and the bunny scan have holes); none is noisy or flipped
SHARED_HEALTH = {"spot": [], "fandisk": [], "teapot": [], "suzanne": [], "cow": [],
                 "ogre": ["9 holes in an otherwise closed surface"],
                 "stanford-bunny": ["5 holes in an otherwise closed surface"]}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "ogre" else n  # ogre: 1.1 s
                                  for n in sorted(SHARED_HEALTH)])
def test_shared_meshes_get_no_false_warning(no_store, name):
    mesh, health, _ = load(shared_mesh(f"{name}.obj"))
    assert len(health) == len(SHARED_HEALTH[name]), health
    for line, want in zip(health, SHARED_HEALTH[name], strict=True):
        assert want in line
    assert mesh.winding_conflicts() == 0 and not mesh.surface_noise().noisy


# -- once, not on every cached run ----------------------------------------------------------------------------------
def test_told_when_parsed_not_again_from_the_mesh_store(tmp_path):
    old = meshstore.root()
    meshstore.use_cache(Cache(tmp_path / "cache"))
    try:
        clean = sphere(1.0, 3)
        f, patch = flipped_patch(clean, CAMERA_SIDE, 0.75)
        f = np.vstack([f, [[0, 0, 1]]])  # and a degenerate face: the repair's MeshWarning
        path = write_obj(tmp_path / "patched.obj", clean.vertices, f)
        first, health, other = load(path)
        assert len(health) == 1 and len(other) == 1 and "degenerate" in other[0]
        again, health_again, other_again = load(path)  # a new process: read from the store, not parsed
        assert health_again == []  # health: told once
        assert other_again == other  # the repair's line is given again by the store, as before
        assert again.faces.tobytes() == first.faces.tobytes() and again.winding_conflicts() == 0
    finally:
        meshstore.configure(old)
        meshes.clear_mesh_cache()
