"""sketch reads the shade map's alpha instead of the depth map when only its colour is needed and both come
from one rasterize pass (nodes/_shared/coverage.py): the same pixels, checked against the depth path and
against the float64 reference, on the built-in scene and the shared meshes."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes._shared import coverage
from nodegraph_nodes.sketch import Sketch
from nodegraph_nodes.sketch.reference import sketch as sketch_ref

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from tests.helpers import run_node, shared_mesh

SIZE = (160, 120)


def _gbuffer(gl, scene: str, tone_bands: int = 0) -> dict:
    text = (f"pipeline: t\nsize: [{SIZE[0]}, {SIZE[1]}]\nscene: {scene}\nnodes:\n"
            f"  g: {{type: rasterize, params: {{tone_bands: {tone_bands}}}}}\n"
            "outputs:\n  color: g.color\n  depth: g.depth\n")
    ex = Executor(pl.loads(text, "t.yaml"), None, gl=gl)
    res = ex.run(3)
    return {"color": res.values[("g", "color")], "depth": res.values[("g", "depth")]}


def _scenes():
    return ["builtin:cloister", "spot.obj", "ogre.obj", "teapot.obj"]


def _scene_arg(name: str) -> str:
    return name if name.startswith("builtin:") else str(shared_mesh(name))


@pytest.mark.parametrize("name", _scenes())
def test_rasterize_alpha_marks_exactly_where_depth_is_below_far(gl, name):
    g = _gbuffer(gl, _scene_arg(name))
    alpha, depth = g["color"].read()[..., 3], g["depth"].read()[..., 0]
    assert 0 < (alpha > 0).mean() < 1, "the view should hold surface and background"
    np.testing.assert_array_equal(alpha > 0, depth < 1.0)
    assert coverage.same_coverage(g["depth"], g["color"])


def test_tone_bands_keep_the_coverage(gl):
    g = _gbuffer(gl, "builtin:cloister", tone_bands=3)
    np.testing.assert_array_equal(g["color"].read()[..., 3] > 0, g["depth"].read()[..., 0] < 1.0)
    assert coverage.same_coverage(g["depth"], g["color"])


def _sketch_inputs(gl, g: dict, rng) -> dict:
    h, w = SIZE[1], SIZE[0]
    edges = gl.upload(rng.random((h, w, 1)).astype(np.float32), "R16F")
    offset = gl.upload(rng.random((h, w, 2)).astype(np.float32), "RG16F")
    return {"edges": edges, "shade": g["color"], "offset": offset, "depth": g["depth"]}


@pytest.mark.parametrize("name", _scenes())
def test_colour_from_alpha_equals_colour_from_depth(gl, rng, name):
    g = _gbuffer(gl, _scene_arg(name))
    ins = _sketch_inputs(gl, g, rng)
    # large matrices: many lookups cross the silhouette, so the far test decides many pixels
    node = Sketch("s", Sketch.Params(edge_matrix=((0.05, 0.0), (0.0, 0.05)),
                                     shade_matrix=((-0.06, 0.02), (-0.02, -0.06))))
    via_alpha = run_node(gl, node, ins, SIZE, needed=frozenset({"color"}))["color"].read()
    via_depth = run_node(gl, node, ins, SIZE, needed=frozenset({"color", "depth"}))["color"].read()
    np.testing.assert_array_equal(via_alpha, via_depth)
    # and both agree with the float64 reference, which reads the depth map itself
    ref = sketch_ref(ins["edges"].read()[..., 0], ins["shade"].read(), ins["offset"].read(),
                     np.asarray(node.params.shade_matrix),
                     [(np.asarray(node.params.edge_matrix), node.params.edge_color)],
                     depth=ins["depth"].read()[..., 0])
    far_ref = ref["color"][..., 3] == 0
    far_gpu = via_alpha[..., 3] == 0
    assert far_ref.mean() > 0.05
    assert (far_ref != far_gpu).mean() < 1e-3  # half-float offsets can move a lookup across a texel edge
    err = np.abs(via_alpha - ref["color"])
    assert np.percentile(err, 99) < 2e-2


def test_unrelated_shade_reads_the_depth(gl, rng):
    """A shade map that is not the depth's own G-buffer colour (here: its alpha everywhere 1) must not stand
    in for the depth: the far test still comes from the depth map."""
    g = _gbuffer(gl, "builtin:cloister")
    shade = gl.upload(np.ones((SIZE[1], SIZE[0], 4), np.float32), "RGBA8")
    ins = {**_sketch_inputs(gl, g, rng), "shade": shade}
    assert not coverage.same_coverage(ins["depth"], shade)
    node = Sketch("s", Sketch.Params())
    got = run_node(gl, node, ins, SIZE, needed=frozenset({"color"}))["color"].read()
    far = got[..., 3] == 0  # with the all-ones alpha standing in for the depth there would be none
    ref = sketch_ref(ins["edges"].read()[..., 0], shade.read(), ins["offset"].read(),
                     np.asarray(node.params.shade_matrix),
                     [(np.asarray(node.params.edge_matrix), node.params.edge_color)],
                     depth=ins["depth"].read()[..., 0])
    far_ref = ref["color"][..., 3] == 0
    assert far_ref.mean() > 0.05
    assert (far != far_ref).mean() < 1e-3
