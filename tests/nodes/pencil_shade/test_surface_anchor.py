"""pencil_shade `anchor: surface`: the hatching coordinates of every corner frame are a function of the object-space
surface point (checked against a float64 computation from rasterize's position buffer), and a surface point keeps
them when the object moves rigidly."""

from __future__ import annotations

import math

import numpy as np
import pytest
from nodegraph_nodes.curvature import object_field
from nodegraph_nodes.hatching_synthesis.tam import synthesize_tam
from nodegraph_nodes.pencil_shade import PencilShade, reference, surface_coordinates
from nodegraph_nodes.rasterize import NODE as Rasterize

from nodegraph.node import RunContext
from nodegraph.scene.scene import Scene, load_scene
from tests import gltf_files
from tests.nodes.pencil_shade.test_pencil_shade import H, W, curvature_for, quad_barycentrics, top_down_plane

TAM_SIZE = 64
TEXEL_SCALE = 0.7


@pytest.fixture(scope="module")
def tam() -> np.ndarray:
    return synthesize_tam(size=TAM_SIZE, tones=8, max_darkness=0.7, seed=4)


def shade(gl, scene: Scene, curv, tam: np.ndarray, **params) -> tuple[np.ndarray, np.ndarray]:
    """(h, w, 3, 2) corner coordinates in corner order (`blend` asked for) and the `blend` output."""
    params.setdefault("planes", False)  # the directions given here, not a flat mesh's plane's
    node = PencilShade("shade", PencilShade.Params(anchor="surface", texel_scale=TEXEL_SCALE, **params))
    inputs = {"tam": gl.texture_array((tam.shape[2], tam.shape[1]), tam.shape[0], "R8", tam), "curvature": curv}
    out = node.compute(RunContext(node, gl=gl, size=(W, H), pipeline_seed=1, scene=scene), inputs,
                       frozenset({"shade", "blend"}))
    coords, _lod = surface_coordinates(gl)
    return coords.astype(np.float64), out["blend"].read()


def positions(gl, scene: Scene) -> np.ndarray:
    """rasterize's object-space position buffer (h, w, 4), bottom row first like the other reads."""
    node = Rasterize("gbuf", Rasterize.Params())
    out = node.compute(RunContext(node, gl=gl, size=(W, H), pipeline_seed=1, scene=scene), {}, frozenset({"position"}))
    return out["position"].read().astype(np.float64)


def tiles_per_unit(scene: Scene) -> float:
    """By hand for the top-down camera (3 units above the plane, no model scale): TAM texels per pixel
    (texel_scale) over the tile size, times pixels per unit at depth 3: (H / 2) / (3 tan(fov / 2))."""
    cam = scene.camera
    return TEXEL_SCALE / TAM_SIZE * (H / 2) / (3.0 * math.tan(math.radians(cam.fov_y_deg) / 2))


def frame_of(d: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = d - n * (d @ n)
    d = d / np.linalg.norm(d)
    return d, np.cross(n, d)


def test_coordinates_are_the_surface_point_in_each_corner_frame(gl, tam):
    scene = top_down_plane()
    mesh = scene.objects[0].mesh
    angles = [10.0, 75.0, -40.0, 130.0][: mesh.n_vertices]
    curv = curvature_for(mesh, angles)
    coords, blend = shade(gl, scene, curv, tam)
    pos = positions(gl, scene)
    tri, _bary, corners = quad_barycentrics(scene)
    lo, hi = (np.asarray(b, dtype=np.float64) for b in mesh.bounds())
    centre = (lo + hi) / 2
    k = tiles_per_unit(scene)
    dmin = curv.data[object_field(0, "dmin")].astype(np.float64)
    normals = np.asarray(mesh.render_arrays(40.0).normals, dtype=np.float64)
    ys, xs = np.nonzero(tri >= 0)
    assert len(ys) > 1000
    want = np.zeros((len(ys), 3, 2))
    for j in range(3):
        for i, (y, x) in enumerate(zip(ys, xs, strict=True)):
            v = corners[y, x, j]
            d, e = frame_of(dmin[v], normals[v] / np.linalg.norm(normals[v]))
            p = pos[y, x, :3] - centre
            want[i, j] = k * (p @ d), k * (p @ e)
    got = coords[ys, xs]
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-4)
    # the weights are in the same (corner) order: they blend these three frames
    assert np.all(blend[ys, xs, 3] >= 0)


def film(tmp_path) -> Scene:
    """A glTF film: a quad (half a unit each way, in z = 0) under tests/gltf_files.py's front camera, turning 25
    degrees about x and moving by (0.15, 0.1, 0.2) (towards the camera) over 1 s: a rigid motion."""
    b = gltf_files.Builder()
    quad = b.node(mesh=b.mesh(0.5 * gltf_files.QUAD_V, gltf_files.QUAD_F), name="quad")
    gltf_files._quad_camera(b)
    b.animate(quad, "rotation", [0.0, 1.0], np.array([gltf_files.quat_axis((1, 0, 0), 0.0),
                                                      gltf_files.quat_axis((1, 0, 0), 25.0)]))
    b.animate(quad, "translation", [0.0, 1.0], np.array([[0.0, 0.0, 0.0], [0.15, 0.1, 0.2]]))
    return load_scene(str(b.save(tmp_path / "film.gltf")))


def test_a_surface_point_keeps_its_coordinates_under_a_rigid_turn(gl, tam, tmp_path):
    """Frames 0 and 24 of the film: every interior pixel of frame 24, traced to its object point and to where that
    point was in frame 0, finds there (interpolated bilinearly between frame 0's pixel centres: the coordinates
    are linear over this quad) the coordinates it has in frame 24; the scale is frame 0's in both, though the
    quad comes nearer. A corner whose weight is below 0.05 is left out: its direction is (b d) / b of interpolated
    values, imprecise where b is nearly 0 (and so is its share)."""
    scene = film(tmp_path)
    a_scene, b_scene = scene.at(0), scene.at(24)
    mesh = a_scene.objects[0].mesh
    curv = curvature_for(mesh, [30.0] * mesh.n_vertices)  # one direction: one linear field over the quad
    ca, wa = shade(gl, a_scene, curv, tam)
    cb, wb = shade(gl, b_scene, curv, tam)
    pb = positions(gl, b_scene)
    covered_a = positions(gl, a_scene)[..., 3] > 0
    cam = a_scene.camera
    view, proj = cam.view_matrix(), cam.projection_matrix(W / H)
    model_a = np.asarray(a_scene.objects[0].transform, dtype=np.float64)
    assert not np.allclose(b_scene.objects[0].transform, model_a)  # it moved
    covered = pb[..., 3] > 0
    ys, xs = np.nonzero(covered)
    checked = 0
    for y, x in zip(ys, xs, strict=True):
        world = (model_a @ np.append(pb[y, x, :3], 1.0))[:3]
        qx, qy = reference.project_to_pixels(world, view, proj, (W, H))
        ix, iy = int(math.floor(qx - 0.5)), int(math.floor(qy - 0.5))  # the pixel centres around q
        if not (2 <= ix < W - 3 and 2 <= iy < H - 3):
            continue
        if not (covered_a[iy - 2:iy + 4, ix - 2:ix + 4].all() and covered[y - 2:y + 3, x - 2:x + 3].all()):
            continue
        fx, fy = qx - 0.5 - ix, qy - 0.5 - iy
        at_a = ((1 - fx) * (1 - fy) * ca[iy, ix] + fx * (1 - fy) * ca[iy, ix + 1] + (1 - fx) * fy * ca[iy + 1, ix]
                + fx * fy * ca[iy + 1, ix + 1])
        heavy = (wb[y, x, :3] > 0.05) & np.all(wa[iy:iy + 2, ix:ix + 2, :3] > 0.05, axis=(0, 1))
        np.testing.assert_allclose(cb[y, x][heavy], at_a[heavy], rtol=0, atol=3e-4)
        checked += int(heavy.sum())
    assert checked > 1000
