"""contour: shaken multiple contours against the float64 reference; overlaps darken; light; grain."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from nodegraph_nodes._shared.pencil import view_light
from nodegraph_nodes.contour import Contour, reference, screen_bounds

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.node import RunContext, derive_seed
from tests.helpers import assert_outputs_as_planned, run_minimal

TEXT = """\
pipeline: t
size: [160, 120]
reference_size: 120  # px_scale 1: widths and grain as written
scene: builtin:torus
seed: 5
nodes:
  gbuf: {type: rasterize}
  edges: {type: edge_detect, in: {normal_depth: gbuf.normal_depth}, params: {normal_threshold: 0.5}}
  dist: {type: distortion_map, params: {layers: 3, amplitude: 0.01}}
  paper: {type: paper, params: {size: 64}}
  contour:
    type: contour
    in: {edges: edges.out, distortion: dist.out, normal_depth: gbuf.normal_depth, paper: paper.out}
outputs:
  image: contour.color
  value: contour.out
"""


def synthetic(gl, offsets: list[tuple[float, float]], normal=(0.0, 0.0, 1.0), **params) -> tuple[np.ndarray, Any]:
    w, h = 48, 32
    node = Contour("c", Contour.Params(**params))
    edges = np.zeros((h, w, 1), np.float32)
    edges[:, 20] = 1.0
    nd = np.zeros((h, w, 4), np.float32)
    nd[...] = [*normal, 2.0]
    dist = np.zeros((len(offsets), h, w, 2), np.float32)
    for k, off in enumerate(offsets):
        dist[k] = off
    inputs = {"edges": gl.upload(edges, "R16F"), "normal_depth": gl.upload(nd, "RGBA16F"),
              "distortion": gl.texture_array((w, h), len(offsets), "RG16F", dist, repeat=False, mipmaps=False)}
    out = node.compute(RunContext(node, gl=gl, size=(w, h), pipeline_seed=1), inputs, frozenset({"out", "color"}))
    expected = reference.contour(edges, dist, nd, np.array([0.0, 0.0, 1.0]), node.pressures(1, len(offsets)),
                                 tone=node.params.tone, light_weight=node.params.light_weight)
    return out["out"].read()[..., 0], expected


def test_overlapping_attempts_darken(gl):
    same, ref_same = synthetic(gl, [(0.0, 0.0), (0.0, 0.0)], pressure_jitter=0.0)
    apart, ref_apart = synthetic(gl, [(0.0, 0.0), (6.0, 0.0)], pressure_jitter=0.0)
    np.testing.assert_allclose(same, ref_same, atol=2e-3)
    np.testing.assert_allclose(apart, ref_apart, atol=2e-3)
    one = apart[:, 20].mean()  # a single attempt over the line
    assert apart[:, 14].mean() == pytest.approx(one, abs=2e-3)  # the second attempt, 6 px to the left
    assert same[:, 20].mean() == pytest.approx(one * one, abs=2e-3)  # both over one line: (1 - d)^2
    assert same[:, 20].mean() < one - 0.1
    assert np.all(same[:, :14] == 1.0) and np.all(same[:, 21:] == 1.0)  # paper elsewhere


def test_light_contribution_lightens_lines(gl):
    lit, ref_lit = synthetic(gl, [(0.0, 0.0)], normal=(0.0, 0.0, 1.0), pressure_jitter=0.0)
    dark, ref_dark = synthetic(gl, [(0.0, 0.0)], normal=(0.0, 0.0, -1.0), pressure_jitter=0.0)
    np.testing.assert_allclose(lit, ref_lit, atol=2e-3)
    np.testing.assert_allclose(dark, ref_dark, atol=2e-3)
    p = Contour.Params(pressure_jitter=0.0)
    # N.L = 1: l = 1; N.L = -1: l = 0 (darkness = tone)
    assert lit[0, 20] == pytest.approx(1.0 - p.tone * (1.0 - p.light_weight), abs=2e-3)
    assert dark[0, 20] == pytest.approx(1.0 - p.tone, abs=2e-3)


def test_light_contribution_reference_values():
    light = np.array([0.0, 0.0, 1.0])
    n = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])
    np.testing.assert_allclose(reference.light_contribution(n, light), np.sqrt([1.0, 0.0, 0.5, 0.9]))


def test_pipeline_matches_reference(gl):
    pipe = pl.loads(TEXT, "t.yaml")
    refs = [("edges", "out"), ("dist", "out"), ("gbuf", "normal_depth"), ("paper", "out"), ("contour", "out")]
    res = Executor(pipe, None, requested=refs, gl=gl).run()
    edges, dist, nd, paper, got = (res.values[r].read() for r in refs)
    node = pipe.nodes["contour"]
    light = view_light(pipe.scene, pipe.scene.camera)
    expected = reference.contour(edges, dist, nd, light, node.pressures(derive_seed(pipe.seed, "contour", 0), 3),
                                 tone=node.params.tone, light_weight=node.params.light_weight,
                                 grain=node.params.grain, paper=paper)
    got = got[..., 0]
    assert got.min() < 0.6  # lines were drawn
    err = np.abs(got - expected)
    # bilinear weights on the GPU have 8 fractional bits: allow that much on steep edge profiles
    assert np.percentile(err, 99.9) < 1e-2 and err.max() < 4e-2


def test_scissor_box_holds_the_objects():
    pipe = pl.loads(TEXT, "t.yaml")
    box = screen_bounds(pipe.scene, pipe.scene.camera, pipe.size, 3)
    assert box is not None
    x, y, w, h = box
    assert x >= 0 and y >= 0 and x + w <= 160 and y + h <= 120 and w > 20 and h > 20


def test_color_is_graphite_on_paper(gl):
    pipe = pl.loads(TEXT, "t.yaml")
    res = Executor(pipe, None, gl=gl).run()
    color, value = res.values[("contour", "color")].read(), res.values[("contour", "out")].read()[..., 0]
    p = pipe.nodes["contour"].params
    assert (value < 0.5).any()
    # colour = mix(graphite, paper x (1 - tint x (1 - tooth height)), value), channel by channel
    g, pc = np.array(p.graphite_color), np.array(p.paper_color)
    v = value[..., None]
    lower = g + (pc * (1 - p.paper_tint) - g) * v
    upper = g + (pc - g) * v
    assert np.all(color[..., :3] >= lower - 2e-3) and np.all(color[..., :3] <= upper + 2e-3)
    assert np.all(color[..., 3] == 1.0)


def test_wrong_connection_is_a_load_error():
    from nodegraph.errors import PortTypeError

    bad = TEXT.replace("distortion: dist.out", "distortion: edges.out")
    with pytest.raises(PortTypeError, match=r"input 'distortion': expected TextureArray\[RG16F\]"):
        pl.loads(bad, "t.yaml")


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  g: {type: rasterize}
  e: {type: edge_detect, in: {normal_depth: g.normal_depth}}
  d: {type: distortion_map}
  c: {type: contour, in: {edges: e.out, distortion: d.out, normal_depth: g.normal_depth}}
"""
    ex, res = run_minimal(gl, nodes, {"out": "c.out", "image": "c.color"})
    assert assert_outputs_as_planned(ex, res, "c") == ["color", "out"]
