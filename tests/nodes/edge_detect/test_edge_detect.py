"""edge_detect against analytic geometry (the edges of a box) and a float64 NumPy reference."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.edge_detect import EdgeDetect
from nodegraph_nodes.edge_detect.reference import edge_detect as edge_detect_ref
from nodegraph_nodes.rasterize import Rasterize

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError, PortTypeError
from nodegraph.scene.scene import load_scene
from tests.helpers import assert_one_line_located, assert_outputs_as_planned, run_minimal, run_node


# -- edge detection on a box: edges where faces meet, none inside faces ------------------------
def _box_edges_px(scene, size):
    """Visible edges of the (convex) box, projected to pixel coordinates (x right, y up)."""
    obj = scene.objects[0]
    lo, hi = obj.world_bounds()
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    cam = scene.camera_at(0)
    faces = []  # (normal, corner indices of the face)
    for axis in range(3):
        for side, val in ((-1, lo[axis]), (1, hi[axis])):
            idx = [i for i, c in enumerate(corners) if np.isclose(c[axis], val)]
            n = np.zeros(3)
            n[axis] = side
            faces.append((n, idx))
    front = [np.dot(n, cam.eye - corners[idx].mean(axis=0)) > 0 for n, idx in faces]
    edges = set()
    for i in range(8):
        for j in range(i + 1, 8):
            if np.count_nonzero(~np.isclose(corners[i], corners[j])) != 1:
                continue
            adjacent = [k for k, (_, idx) in enumerate(faces) if i in idx and j in idx]
            if any(front[k] for k in adjacent):
                edges.add((i, j))
    w, h = size
    ndc = cam.project(corners, w / h)
    px = np.c_[(ndc[:, 0] * 0.5 + 0.5) * w, (ndc[:, 1] * 0.5 + 0.5) * h]
    return [(px[i], px[j]) for i, j in edges]


def _distance_to_segments(points, segments):
    d = np.full(len(points), np.inf)
    for a, b in segments:
        ab = b - a
        t = np.clip(((points - a) @ ab) / (ab @ ab), 0, 1)
        d = np.minimum(d, np.linalg.norm(points - (a + t[:, None] * ab), axis=1))
    return d


@pytest.mark.parametrize("operator", ["four_neighbour", "sobel"])
def test_box_edges_where_faces_meet_and_none_inside(gl, operator):
    size = (256, 256)
    scene = load_scene("builtin:box")
    g = run_node(gl, Rasterize("g"), {}, size, scene=scene, needed=frozenset({"normal_depth"}))
    node = EdgeDetect("e", EdgeDetect.Params(operator=operator))
    e = run_node(gl, node, {"normal_depth": g["normal_depth"]}, size)["out"].read()[..., 0]
    segments = _box_edges_px(scene, size)
    assert len(segments) == 9  # a box seen from a general direction shows 3 faces bounded by 9 edges
    ys, xs = np.mgrid[0:size[1], 0:size[0]]
    centres = np.c_[xs.ravel() + 0.5, ys.ravel() + 0.5]
    dist = _distance_to_segments(centres, segments).reshape(size[1], size[0])
    on = e > 0.5
    tol = 2.5 if operator == "sobel" else 1.5
    assert on.sum() > 0
    assert dist[on].max() <= tol, f"edge pixels {dist[on].max():.2f} px away from any box edge"
    assert e[dist > tol + 1].max() == 0.0, "no edges inside faces or in the background"
    # recall: points along every visible edge have an edge pixel within 1.5 px
    for a, b in segments:
        ts = np.linspace(0.05, 0.95, 40)
        pts = a + ts[:, None] * (b - a)
        hit = [on[max(0, int(y) - 1):int(y) + 2, max(0, int(x) - 1):int(x) + 2].any() for x, y in pts]
        assert np.mean(hit) >= 0.95


def test_edge_detect_matches_float64_reference(gl, rng):
    size = (96, 80)
    scene = load_scene("builtin:cloister")
    g = run_node(gl, Rasterize("g"), {}, size, scene=scene, needed=frozenset({"normal_depth"}))
    nd = g["normal_depth"]
    arr = nd.read()
    for operator in ("four_neighbour", "sobel"):
        for mode in ("normal_depth", "normal", "depth"):
            params = dict(operator=operator, mode=mode, normal_threshold=0.3, depth_threshold=0.02, width=1)
            out = run_node(gl, EdgeDetect("e", EdgeDetect.Params(**params)), {"normal_depth": nd}, size)
            ref = edge_detect_ref(arr, **params)
            for port in ("out", "profile", "inner"):
                got = out[port].read()[..., 0]
                # R16F output; smoothstep ramps make a few pixels sensitive to float32 vs float64 rounding
                bad = np.abs(got - ref[port]) > 2e-3
                assert bad.mean() < 0.002, (operator, mode, port, bad.sum())


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  g: {type: rasterize}
  e: {type: edge_detect, in: {normal_depth: g.normal_depth}}
"""
    ex, res = run_minimal(gl, nodes, {"out": "e.out", "profile": "e.profile", "inner": "e.inner"})
    assert assert_outputs_as_planned(ex, res, "e") == ["inner", "out", "profile"]


def test_errors_are_located_at_load_time():
    text = ("pipeline: t\nscene: builtin:box\nnodes:\n  g: {type: rasterize}\n"
            "  e: {type: edge_detect, in: {normal_depth: g.normal_depth}, params: {normal_threshold: 0}}\n"
            "outputs: {a: e.out}\n")
    with pytest.raises(PipelineError) as e:
        pl.loads(text, "t.yaml")
    assert_one_line_located(e.value, "t.yaml:5:")
    assert "normal_threshold" in str(e.value)
    with pytest.raises(PortTypeError) as e:
        pl.loads(text.replace("g.normal_depth}, params: {normal_threshold: 0}", "g.color}"), "t.yaml")
    assert_one_line_located(e.value, "t.yaml:5:")
    assert "Texture[RGBA32F]" in str(e.value) and "Texture[RGBA8]" in str(e.value)


# -- widths at the reference size (docs/sizes.md) ----------------------------------------------------------
def _box_nd(gl, size=(128, 128)):
    g = run_node(gl, Rasterize("g"), {}, size, scene=load_scene("builtin:box"), needed=frozenset({"normal_depth"}))
    return g["normal_depth"]


@pytest.mark.parametrize("operator", ["four_neighbour", "sobel"])
@pytest.mark.parametrize("width", [0.5, 1.5, 2.25])
def test_fractional_width_matches_the_float64_reference(gl, operator, width):
    nd = _box_nd(gl)
    node = EdgeDetect("e", EdgeDetect.Params(operator=operator, width=width))
    got = run_node(gl, node, {"normal_depth": nd}, nd.size)
    ref = edge_detect_ref(nd.read(), operator=operator, width=width)
    for port in ("out", "profile", "inner"):
        np.testing.assert_allclose(got[port].read()[..., 0], ref[port], atol=2e-3, err_msg=port)


def test_width_follows_the_reference_size_and_fades_below_a_pixel(gl):
    """width 2 at reference 800: radius 1 at 400, 0.5 at 200 (one pixel at half intensity), and the ink
    (sum of intensities across a line) falls with the radius smoothly instead of vanishing."""
    nd = _box_nd(gl)
    ref = edge_detect_ref(nd.read())  # radius 1 of this image, by hand
    inks = []
    for px_scale in (1.0, 0.5, 0.25, 0.125):
        node = EdgeDetect("e", EdgeDetect.Params(width=2))
        out = run_node(gl, node, {"normal_depth": nd}, nd.size, reference_size=round(128 * 2 / (2 * px_scale)))
        inks.append(out["out"].read()[..., 0].astype(np.float64))
    # reference 128 x 2 / 2: px_scale 0.5 of width 2 -> radius 1, bit for bit the whole-radius stencil
    np.testing.assert_allclose(inks[1], ref["out"], atol=1e-3)
    # radius 0.5 and 0.25: the radius-1 lines at half and a quarter intensity (the radius-0 stencil is empty)
    np.testing.assert_allclose(inks[2], 0.5 * ref["out"], atol=1e-3)
    np.testing.assert_allclose(inks[3], 0.25 * ref["out"], atol=1e-3)
    totals = [a.sum() for a in inks]
    assert totals[0] > totals[1] > totals[2] > totals[3] > 0


def test_width_key_covers_the_scale_only_away_from_the_reference():
    from nodegraph.node import HashContext

    node = EdgeDetect("e", EdgeDetect.Params(width=2))
    at_ref = node.key_parts(HashContext((800, 600), 0, 1, None, 600), {})["context"]
    assert at_ref == {"size": [800, 600]}  # px_scale 1 is left out: the key is what it was before
    half = node.key_parts(HashContext((800, 600), 0, 1, None, 1200), {})["context"]
    assert half == {"size": [800, 600], "px_scale": 0.5}
    keys = {node.key(HashContext((800, 600), 0, 1, None, ref), {}) for ref in (600, 1200)}
    assert len(keys) == 2
