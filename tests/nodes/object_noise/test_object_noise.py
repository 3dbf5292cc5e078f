"""Geometry-controlled uncertainty (Nienhaus & Döllner §4): enlargement, g(s,t), 3D noise at g(s,t)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import nodegraph_nodes.rasterize as rasterize_mod
import numpy as np
import pytest
from nodegraph_nodes._shared.noise import noise3_at
from nodegraph_nodes.object_noise import ObjectNoise
from nodegraph_nodes.rasterize import Rasterize
from scipy import ndimage
from scipy.spatial import Delaunay

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.node import derive_seed
from nodegraph.scene.meshes import Mesh, MeshWarning
from nodegraph.scene.scene import Scene, SceneObject, frame_camera, load_scene
from tests.helpers import assert_outputs_as_planned, run_minimal, run_node, shared_mesh

ROOT = Path(__file__).resolve().parents[3]


def _position(gl, scene, size, enlarge=0.0, frame=0, cull=False):
    node = Rasterize("g", Rasterize.Params(enlarge=enlarge, backfaces="cull" if cull else "draw"))
    return run_node(gl, node, {}, size, scene=scene, frame=frame, needed=frozenset({"position"}))["position"].read()


def _forget_vertex_buffers(gl):
    gl.release_meshes()


# -- the band around the silhouette ---------------------------------------------------------------
def test_position_band_has_the_analytic_width_for_a_sphere(gl):
    """A sphere of radius r seen from distance D has a silhouette of angular radius asin(r/D), i.e.
    tan(asin(r/D)) / tan(fov/2) * H/2 pixels; enlarged by d it is that of a sphere of radius r + d."""
    size = (256, 256)
    scene = load_scene("builtin:sphere")
    mesh = scene.objects[0].mesh
    cam = scene.camera
    assert np.allclose(cam.target, 0.0)  # the camera looks at the sphere's centre
    r = float(np.linalg.norm(mesh.vertices, axis=1).mean())
    assert np.allclose(np.linalg.norm(mesh.vertices, axis=1), r)
    enlarge = 0.025
    d = enlarge * mesh.diagonal()  # `enlarge` is a fraction of the bounding-box diagonal

    def radius_px(rr: float) -> float:
        return math.tan(math.asin(rr / cam.distance)) / math.tan(math.radians(cam.fov_y_deg) / 2) * size[1] / 2

    plain = _position(gl, scene, size)
    big = _position(gl, scene, size, enlarge)
    inside, covered = plain[..., 3] > 0, big[..., 3] > 0
    assert not (inside & ~covered).any()
    measured = math.sqrt(covered.sum() / math.pi) - math.sqrt(inside.sum() / math.pi)  # area-equivalent radii
    expected = radius_px(r + d) - radius_px(r)
    assert expected > 5
    assert abs(measured - expected) < 0.15, (measured, expected)  # measured 5.894 vs 5.899 px
    # the band holds the enlarged geometry's object-space positions, g(s,t): |p| = r + d
    band = covered & ~inside
    assert band.sum() > 2 * math.pi * radius_px(r) * 5
    assert np.abs(np.linalg.norm(big[band][:, :3], axis=1) - (r + d)).max() < 2e-3
    # and inside, points on the enlarged sphere too (coverage alpha = 1)
    assert np.abs(np.linalg.norm(big[inside][:, :3], axis=1) - (r + d)).max() < 2e-3
    assert np.all(big[covered][:, 3] == 1.0)


def test_enlarge_unit_scene_is_a_world_distance(gl):
    """With enlarge_unit: scene, every object moves by the same fraction of the scene's diagonal."""
    size = (128, 128)
    small = replace_transform(load_scene("builtin:sphere"), 0.5)
    lo, hi = small.bounds()
    scene_diag = float(np.linalg.norm(hi - lo))  # world units
    node = Rasterize("g", Rasterize.Params(enlarge=0.02, enlarge_unit="scene"))
    pos = run_node(gl, node, {}, size, scene=small, needed=frozenset({"position"}))["position"].read()
    cov = pos[..., 3] > 0
    # object space is scaled by 0.5: the world distance 0.02 * diag is twice that in object units
    r = np.linalg.norm(pos[cov][:, :3], axis=1)
    assert np.abs(r - (1.0 + 0.02 * scene_diag / 0.5)).max() < 3e-3


def replace_transform(scene: Scene, scale: float) -> Scene:
    obj = scene.objects[0]
    t = np.diag([scale, scale, scale, 1.0])
    return Scene("scaled", (SceneObject(obj.mesh, t, obj.color, True, obj.name),), scene.camera)


# -- no cracks --------------------------------------------------------------------------------
def _split_normal_cube() -> Mesh:
    """A cube whose six faces have their own four vertices (split normals, 16 coincident vertices)."""
    verts: list[np.ndarray] = []
    faces: list[list[int]] = []
    for axis in range(3):
        for side in (-1.0, 1.0):
            u, w = (a for a in range(3) if a != axis)
            quad = []
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = np.zeros(3)
                p[axis], p[u], p[w] = side, a, b
                quad.append(p)
            q = np.array(quad)
            if np.dot(np.cross(q[1] - q[0], q[2] - q[0]), np.eye(3)[axis] * side) < 0:
                q = q[::-1]
            k = len(verts)
            verts.extend(q)
            faces += [[k, k + 1, k + 2], [k, k + 2, k + 3]]
    return Mesh("split-cube", np.array(verts), np.array(faces))


def _background_inside_hull(covered: np.ndarray) -> int:
    ys, xs = np.nonzero(covered)
    hull = Delaunay(np.c_[xs, ys])
    by, bx = np.nonzero(~covered)
    return int((hull.find_simplex(np.c_[bx, by]) >= 0).sum())


def test_split_normals_are_welded_so_the_enlarged_cube_has_no_cracks(gl, monkeypatch):
    """Back faces culled, so a crack would show background; a convex object's enlarged silhouette has
    none inside its convex hull. Enlarging along the split (per-face) normals instead opens cracks along
    every edge, which the same check sees."""
    mesh = _split_normal_cube()
    assert mesh.topology().n_welded == 16
    scene = Scene("cube", (SceneObject(mesh),), frame_camera(*mesh.bounds()))
    size = (200, 200)
    _forget_vertex_buffers(gl)
    welded = _position(gl, scene, size, enlarge=0.05, cull=True)[..., 3] > 0
    assert welded.sum() > (_position(gl, scene, size, cull=True)[..., 3] > 0).sum()
    assert _background_inside_hull(welded) == 0
    monkeypatch.setattr(rasterize_mod, "enlarge_normals", lambda m, crease=40.0: m.render_arrays(crease).normals)
    _forget_vertex_buffers(gl)
    try:
        split = _position(gl, scene, size, enlarge=0.05, cull=True)[..., 3] > 0
    finally:
        _forget_vertex_buffers(gl)
    assert _background_inside_hull(split) > 1000  # measured 4073: the check can fail


def test_closed_mesh_enlarged_has_no_holes(gl):
    scene = load_scene(str(shared_mesh("spot.obj")))
    for frame in (0, 20, 40):
        cov = _position(gl, scene, (192, 192), enlarge=0.03, frame=frame, cull=True)[..., 3] > 0
        assert not (ndimage.binary_fill_holes(cov) & ~cov).any()


@pytest.mark.parametrize("name", ["suzanne.obj", "teapot.obj"])
def test_meshes_with_split_normals_and_components_warn_once_and_have_no_gaps(gl, monkeypatch, name):
    """suzanne (4 components, 2 coincident vertices) and teapot (4 components, 403 coincident vertices,
    open): one warning naming the mesh and what was done; the enlarged render covers everything the
    plain one covers, and background enclosed by the enlarged silhouette only where the plain render
    has a genuine hole too (the teapot's handle)."""
    scene = load_scene(str(shared_mesh(name)))
    monkeypatch.setattr(rasterize_mod, "_WARNED", set())
    size = (192, 192)
    with pytest.warns(MeshWarning) as record:
        _position(gl, scene, size, enlarge=0.02)
    messages = [str(w.message) for w in record if issubclass(w.category, MeshWarning)]
    assert len(messages) == 1
    assert name.removesuffix(".obj") in messages[0] and "welded" in messages[0] and "components" in messages[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error", MeshWarning)  # once per mesh: the next renders are silent
        for frame in (0, 15, 30, 45):
            plain = _position(gl, scene, size, frame=frame)[..., 3] > 0
            big = _position(gl, scene, size, enlarge=0.02, frame=frame)[..., 3] > 0
            assert not (plain & ~big).any()
            holes = ndimage.binary_fill_holes(big) & ~big
            assert not (holes & plain).any()
            assert not (holes & ~(ndimage.binary_fill_holes(plain) & ~plain)).any()


def test_clean_mesh_does_not_warn(gl, monkeypatch):
    scene = load_scene(str(shared_mesh("spot.obj")))
    monkeypatch.setattr(rasterize_mod, "_WARNED", set())
    with warnings.catch_warnings():
        warnings.simplefilter("error", MeshWarning)
        _position(gl, scene, (32, 32), enlarge=0.02)


# -- 3D noise at g(s,t) ---------------------------------------------------------------------------
@pytest.mark.parametrize("mode", ["turbulence", "fbm"])
def test_object_noise_matches_float64_cpu_at_object_space_positions(gl, mode):
    scene = load_scene(str(shared_mesh("spot.obj")))
    size = (160, 160)
    pos_tex = run_node(gl, Rasterize("g", Rasterize.Params(enlarge=0.02)), {}, size, scene=scene,
                       needed=frozenset({"position"}))["position"]
    node = ObjectNoise("noise", ObjectNoise.Params(scale=7.0, octaves=4, mode=mode, background=(0.25, -1.0)))
    got = run_node(gl, node, {"position": pos_tex}, size, scene=scene, seed=5)["out"].read()
    pos = pos_tex.read()
    covered = pos[..., 3] > 0
    assert 0.1 < covered.mean() < 0.9
    seed = derive_seed(5, "noise", 0)
    lo, hi = scene.bounds()
    k = float(np.float32(7.0 / np.linalg.norm(hi - lo)))  # unit: scene -> cycles per scene diagonal
    ref = noise3_at(pos[covered][:, :3].astype(np.float64), 4, seed, mode, k)
    err = np.abs(got[covered] - ref)
    assert err.max() < 1e-5, err.max()  # measured ~1.9e-6 (spot, cloister, ogre)
    assert np.array_equal(got[~covered], np.broadcast_to(np.float32([0.25, -1.0]), got[~covered].shape))
    assert np.abs(node.reference(pos, seed, scene) - got).max() < 1e-5
    # not constant: the noise varies over the surface, with the value range of its mode
    assert got[covered].std(axis=0).min() > 0.05
    if mode == "turbulence":
        assert got[covered].min() >= 0


def test_object_noise_seed_comes_from_pipeline_and_node_not_frame(gl):
    """Object-space uncertainty must not change with the frame: only g(s,t) (the camera) may."""
    pipe = pl.load(ROOT / "pipelines" / "object_space_uncertainty.yaml", size=(48, 48))
    assert "frame" not in pipe.nodes["noise"].context_keys
    assert "seed" in pipe.nodes["noise"].context_keys
    a = Executor(pipe, None, requested=[("noise", "out")], gl=gl).run(3).values[("noise", "out")].read()
    b = Executor(pipe, None, requested=[("noise", "out")], gl=gl).run(3).values[("noise", "out")].read()
    assert np.array_equal(a, b)
    other = pl.load(ROOT / "pipelines" / "object_space_uncertainty.yaml", size=(48, 48), overrides=[])
    other.seed = pipe.seed + 1
    c = Executor(other, None, requested=[("noise", "out")], gl=gl).run(3).values[("noise", "out")].read()
    assert not np.array_equal(a, c)


def test_object_noise_shape_format_and_port_type_error(gl):
    pipe = pl.load(ROOT / "pipelines" / "object_space_uncertainty.yaml", size=(40, 24))
    out = Executor(pipe, None, requested=[("noise", "out")], gl=gl).run().values[("noise", "out")]
    assert out.fmt == "RG32F" and out.size == (40, 24) and out.read().shape == (24, 40, 2)
    from nodegraph.errors import PipelineError

    text = (ROOT / "pipelines" / "object_space_uncertainty.yaml").read_text()
    bad = text.replace("in: {position: enlarged.position}", "in: {position: enlarged.color}")
    assert bad != text
    with pytest.raises(PipelineError, match="position"):
        pl.loads(bad, file="bad.yaml", load_scene=False)


def test_a_huge_depth_range_warns_once(gl):
    from nodegraph_nodes import rasterize as rmod

    from nodegraph.scene.scene import Camera

    scene = load_scene("builtin:box")
    cam = scene.camera_at(0)
    wide = Camera(eye=cam.eye, target=cam.target, up=cam.up, fov_y_deg=cam.fov_y_deg, near=1e-5, far=cam.far)
    rmod._WARNED.discard(f"depth-range:{wide.far / wide.near:.3g}:True")
    with pytest.warns(RuntimeWarning, match="far/near = .*window depth"):
        rmod._warn_depth_range_once(wide, True)
    import warnings as w

    with w.catch_warnings():
        w.simplefilter("error")
        rmod._warn_depth_range_once(wide, True)  # once only
        rmod._warn_depth_range_once(cam, True)  # an ordinary range is silent


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  g: {type: rasterize}
  o: {type: object_noise, in: {position: g.position}}
"""
    ex, res = run_minimal(gl, nodes, {"out": "o.out"})
    assert assert_outputs_as_planned(ex, res, "o") == ["out"]
