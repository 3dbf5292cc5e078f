"""rasterize: the G-buffer of builtin:box against a float64 ray cast through the camera matrices."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import maximum_filter, minimum_filter

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError, PortTypeError
from nodegraph.scene.scene import load_scene
from tests.helpers import assert_one_line_located, assert_outputs_as_planned, run_minimal

W, H = 72, 56
PORTS = ("color", "normal", "normal_depth", "depth", "linear_depth", "position", "object_id")


def ray_cast_box(scene, size: tuple[int, int]) -> dict[str, np.ndarray]:
    """float64 per pixel centre: which face of the (axis-aligned, world-space) box the eye ray meets
    first (-1 = none), the hit point and its outward normal, in world space; slab method."""
    w, h = size
    (obj,) = scene.objects
    lo, hi = (np.asarray(b, np.float64) for b in obj.world_bounds())
    cam = scene.camera_at(0)
    inv = np.linalg.inv(cam.projection_matrix(w / h) @ cam.view_matrix())
    xs, ys = np.meshgrid((np.arange(w) + 0.5) / w * 2 - 1, (np.arange(h) + 0.5) / h * 2 - 1)  # row 0 = bottom
    ndc = np.stack([xs, ys, -np.ones_like(xs), np.ones_like(xs)], axis=-1)
    near = ndc @ inv.T
    far = (ndc * [1, 1, -1, 1]) @ inv.T
    p0 = near[..., :3] / near[..., 3:]
    d = far[..., :3] / far[..., 3:] - p0
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - p0) / d, (hi - p0) / d
    tmin, tmax = np.minimum(t1, t2), np.maximum(t1, t2)
    t_in, axis = tmin.max(axis=-1), tmin.argmax(axis=-1)
    hit = (t_in <= tmax.min(axis=-1)) & (t_in > 0)
    point = p0 + t_in[..., None] * d
    normal = np.zeros_like(point)
    side = np.where(np.take_along_axis(d, axis[..., None], -1)[..., 0] > 0, -1.0, 1.0)  # against the ray
    np.put_along_axis(normal, axis[..., None], side[..., None], -1)
    face = np.where(hit, axis * 2 + (side > 0), -1)
    return {"face": face, "point": point, "normal": normal}


def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    ex, res = run_minimal(gl, "  g: {type: rasterize}\n", {p: f"g.{p}" for p in PORTS}, size=(W, H))
    assert assert_outputs_as_planned(ex, res, "g") == sorted(PORTS)


def test_box_matches_a_float64_ray_cast(gl):
    ex, res = run_minimal(gl, "  g: {type: rasterize}\n", {p: f"g.{p}" for p in PORTS}, size=(W, H))
    v = {p: res.values[("g", p)].read() for p in PORTS}
    scene = load_scene("builtin:box")
    ref = ray_cast_box(scene, (W, H))
    face = ref["face"]
    assert len(np.unique(face[face >= 0])) == 3  # a box from a general direction shows three faces
    # compare where the whole 3x3 neighbourhood sees the same face (or background): no edge pixels
    inner = minimum_filter(face, 3, mode="nearest") == maximum_filter(face, 3, mode="nearest")
    on, off = inner & (face >= 0), inner & (face < 0)
    assert on.sum() > 300 and off.sum() > 300
    cam = scene.camera_at(0)
    view = cam.view_matrix()
    proj = cam.projection_matrix(W / H)
    p = np.concatenate([ref["point"], np.ones(face.shape + (1,))], axis=-1)
    p_view = p @ view.T
    clip = p_view @ proj.T
    window_depth = (clip[..., 2] / clip[..., 3]) * 0.5 + 0.5
    n_view = ref["normal"] @ np.linalg.inv(view[:3, :3])  # rows of (V^-T n): normals to view space
    model = np.asarray(scene.objects[0].transform)
    p_obj = (p @ np.linalg.inv(model).T)[..., :3]
    # coverage and background values
    assert np.all(v["normal_depth"][on, 3] > 0) and np.all(v["normal_depth"][off] == 0)
    assert np.all(v["depth"][off] == 1.0) and np.all(v["linear_depth"][off] == 0)
    assert np.all(v["object_id"][on] == 1.0) and np.all(v["object_id"][off] == 0.0)
    for port in ("color", "normal", "position"):
        assert np.all(v[port][on, 3] == 1.0) and np.all(v[port][off] == 0), port
    # geometry against the float64 camera maths
    np.testing.assert_allclose(v["depth"][on, 0], window_depth[on], atol=2e-6)
    np.testing.assert_allclose(v["linear_depth"][on, 0], -p_view[on, 2], rtol=2e-5)
    np.testing.assert_allclose(v["normal_depth"][on, 3], -p_view[on, 2], rtol=2e-5)
    np.testing.assert_allclose(v["normal_depth"][on, :3], n_view[on], atol=1e-4)
    np.testing.assert_allclose(v["normal"][on, :3], n_view[on], atol=2e-3)  # half floats
    np.testing.assert_allclose(v["position"][on, :3], p_obj[on], atol=1e-4)
    # unlit flat colour, 8 bits
    np.testing.assert_allclose(v["color"][on, :3], np.broadcast_to(scene.objects[0].color, (on.sum(), 3)),
                               atol=0.5 / 255 + 1e-6)


def test_errors_are_located_at_load_time():
    text = ("pipeline: t\nscene: builtin:box\nnodes:\n  g: {type: rasterize, params: {enlarge: 2}}\n"
            "outputs: {a: g.color}\n")
    with pytest.raises(PipelineError) as e:
        pl.loads(text, "t.yaml")
    assert_one_line_located(e.value, "t.yaml:4:")
    assert "enlarge" in str(e.value)
    text = ("pipeline: t\nscene: builtin:box\nnodes:\n  m: {type: rasterize}\n"
            "  g: {type: rasterize, in: {scene: m.color}}\noutputs: {a: g.color}\n")
    with pytest.raises(PortTypeError) as e:
        pl.loads(text, "t.yaml")
    assert_one_line_located(e.value, "t.yaml:5:")
    assert "Scene" in str(e.value) and "Texture[RGBA8]" in str(e.value)
