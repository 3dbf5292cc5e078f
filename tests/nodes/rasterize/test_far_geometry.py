"""Geometry far from the origin renders like the same geometry at the origin (nodegraph/scene/origin.py).

An icosphere of radius 1, moved along the diagonal (1, 1, 1)/sqrt(3) by 1e3 .. 1e9 with the camera moved
with it, either by its transform (the mesh stays at its origin) or in its vertices (a mesh file far from
its origin), against the same sphere and camera at the origin: coverage, view-space normals, linear and
window depth and object-space positions agree. Measured at 128x128 on llvmpipe, both placements, every
offset: IoU 1.0, normals within 0.024 degrees, linear depth within 6.2e-6, window depth within 1.9e-6,
positions within 5.8e-6 (the same at 1e3 as at 1e9: the far scene is drawn relative to the eye, the one
at the origin in world space, and these are the float32 differences of those two paths).
Drawn in world space as before: at 1e5 normals off by 2.7 (transform) / 5.3 (vertices) degrees, at 1e6
IoU 0.94 / 0.93 and 17 degrees, at 1e7 IoU 0.77 / 0.62, from 1e8 on nothing drawn (IoU 0).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from nodegraph_nodes.rasterize import Rasterize

from nodegraph.scene import origin, primitives
from nodegraph.scene.scene import Camera, Scene, SceneObject, frame_camera, translation
from tests.helpers import run_node

SIZE = (128, 128)
DIAGONAL = np.ones(3) / np.sqrt(3.0)
OFFSETS = [1e3, 1e5, 1e6, 1e7, 1e8, 1e9]
PORTS = frozenset({"normal", "linear_depth", "depth", "position"})


def _scene(offset: float, placement: str) -> Scene:
    sphere = primitives.sphere(1.0, 4)
    shift = DIAGONAL * offset
    lo, hi = sphere.bounds()
    cam0 = frame_camera(lo, hi)
    camera = Camera(eye=cam0.eye + shift, target=cam0.target + shift, up=cam0.up, fov_y_deg=cam0.fov_y_deg,
                    near=cam0.near, far=cam0.far)
    if placement == "transform":
        obj = SceneObject(sphere, translation(shift), (0.5, 0.6, 0.7), True, "sphere")
    else:
        obj = SceneObject(sphere.transformed(translation(shift)), np.eye(4), (0.5, 0.6, 0.7), True, "sphere")
    return Scene(name=f"sphere@{offset:g}", objects=(obj,), camera=camera)


def _render(gl, scene: Scene) -> dict[str, np.ndarray]:
    out = run_node(gl, Rasterize("r"), {}, SIZE, scene=scene, needed=PORTS)
    return {port: out[port].read() for port in PORTS}


def measure(gl, offset: float, placement: str) -> dict[str, float]:
    """IoU of coverage, largest normal angle (degrees), largest linear and window depth differences and
    largest object-space position difference over pixels both cover."""
    ref, far = _render(gl, _scene(0.0, placement)), _render(gl, _scene(offset, placement))
    a, b = ref["normal"][..., 3] > 0.5, far["normal"][..., 3] > 0.5
    both = a & b
    iou = float(both.sum() / max((a | b).sum(), 1))
    if not both.any():
        return {"iou": iou, "normal_deg": 180.0, "linear_depth": np.inf, "depth": np.inf, "position": np.inf}
    n0, n1 = ref["normal"][both][:, :3].astype(np.float64), far["normal"][both][:, :3].astype(np.float64)
    cos = np.sum(n0 * n1, axis=1) / (np.linalg.norm(n0, axis=1) * np.linalg.norm(n1, axis=1))
    return {
        "iou": iou,
        "normal_deg": float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).max()),
        "linear_depth": float(np.abs(ref["linear_depth"][both] - far["linear_depth"][both]).max()),
        "depth": float(np.abs(ref["depth"][both] - far["depth"][both]).max()),
        "position": float(np.abs(ref["position"][both][:, :3] - far["position"][both][:, :3]).max()),
    }


@pytest.mark.parametrize("placement", ["transform", "vertices"])
@pytest.mark.parametrize("offset", OFFSETS)
def test_far_sphere_matches_sphere_at_origin(gl, offset, placement):
    with warnings.catch_warnings():
        warnings.simplefilter("error", origin.PrecisionWarning)  # representable: no warning
        m = measure(gl, offset, placement)
    assert m["iou"] >= 0.99, m
    assert m["normal_deg"] <= 0.5, m
    assert m["linear_depth"] <= 1e-4, m
    assert m["depth"] <= 1e-4, m
    # object-space positions about the mesh's own origin: identical placements give identical positions
    assert m["position"] <= 5e-5, m


def test_near_origin_scene_draws_exactly_as_before():
    """Origins are exactly 0 (so the uploads are the arrays and matrices used before) within 64 radii."""
    scene = _scene(0.0, "transform")
    assert not origin.world_origin(scene, scene.camera).any()
    assert not origin.mesh_origin(scene.objects[0].mesh).any()
    view, model = scene.camera.view_matrix(), np.asarray(scene.objects[0].transform)
    v, m = origin.relative_matrices(view, model, np.zeros(3), np.zeros(3))
    assert v is view and m is model
    assert origin.hash_extra(scene, 0) is None
    assert origin.hash_extra(_scene(1e3, "transform"), 0) == {"origin": "relative"}


def test_relative_matrices_compose_to_the_world_transform():
    scene = _scene(1e6, "vertices")
    cam = scene.camera
    world = origin.world_origin(scene, cam)
    local = origin.mesh_origin(scene.objects[0].mesh)
    np.testing.assert_array_equal(world, cam.eye)
    v, m = origin.relative_matrices(cam.view_matrix(), np.eye(4), world, local)
    assert np.abs(v[:3, 3]).max() < 1e-6 and np.abs(m[:3, 3]).max() < 10.0  # small numbers reach float32
    np.testing.assert_allclose(v @ m @ translation(-local), cam.view_matrix(), atol=1e-6)


@pytest.mark.parametrize("case", ["float32", "float64"])
def test_unrepresentable_scene_warns_once(gl, case):
    if case == "float32":  # 1e39 apart: beyond float32 even relative to the eye
        mesh = primitives.sphere(1.0, 1)
        objs = (SceneObject(mesh, np.eye(4), name="a"), SceneObject(mesh, translation((1e39, 0, 0)), name="b"))
    else:  # a 1e-6 sphere at 1e9 in its own vertices: float64 has lost its shape
        objs = (SceneObject(primitives.sphere(1e-6, 1).transformed(translation((1e9, 0, 0))), np.eye(4), name="a"),)
    scene = Scene(name=f"bad-{case}", objects=objs, camera=frame_camera((-1, -1, -1), (1, 1, 1)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(2):
            run_node(gl, Rasterize("r"), {}, (16, 16), scene=scene, needed=frozenset({"depth"}))
    msgs = [str(w.message) for w in caught if issubclass(w.category, origin.PrecisionWarning)]
    assert len(msgs) == 1, msgs
    assert "cannot be represented" in msgs[0]
