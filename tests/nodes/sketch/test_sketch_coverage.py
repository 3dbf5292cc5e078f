"""sketch reads the shade map's alpha instead of the depth map when only its colour is needed and both come
from one rasterize node (Sketch.unread_inputs): the plan then neither reads nor makes the depth, and the
pixels are the same, checked against the depth path and the float64 reference on the built-in scene and the
shared meshes."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.sketch import Sketch
from nodegraph_nodes.sketch.reference import sketch as sketch_ref

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.plan import plan
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


def test_tone_bands_keep_the_coverage(gl):
    g = _gbuffer(gl, "builtin:cloister", tone_bands=3)
    np.testing.assert_array_equal(g["color"].read()[..., 3] > 0, g["depth"].read()[..., 0] < 1.0)


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
    # the executor gives an input the plan left unread as None
    via_alpha = run_node(gl, node, {**ins, "depth": None}, SIZE, needed=frozenset({"color"}))["color"].read()
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


def _plan(sketch_in: str, outputs: str):
    text = ("pipeline: t\nsize: [64, 48]\nscene: builtin:box\nnodes:\n"
            "  g: {type: rasterize}\n  h: {type: rasterize, params: {lit: true}}\n"
            "  edges: {type: edge_detect, in: {normal_depth: g.normal_depth}}\n"
            "  noise: {type: perlin_noise}\n"
            f"  sketch: {{type: sketch, in: {{{sketch_in}}}}}\n"
            "  sprite: {type: depth_sprite, in: {color: sketch.color, sketch_depth: sketch.depth}}\n"
            f"outputs:\n{outputs}")
    return plan(pl.loads(text, "t.yaml"))


def test_plan_leaves_the_depth_unmade_only_when_the_alpha_stands_in():
    common = "edges: edges.out, offset: noise.out, "
    p = _plan(common + "shade: g.color, depth: g.depth", "  image: sprite.color\n")
    assert p.unread == {"sketch": frozenset({"depth"})}
    assert "depth" not in p.needed["g"] and {"color", "normal_depth"} <= p.needed["g"]
    # the perturbed depth asked for: read
    p = _plan(common + "shade: g.color, depth: g.depth", "  image: sprite.color\n  z: sprite.depth\n")
    assert not p.unread and "depth" in p.needed["g"]
    # shade and depth of different G-buffers: the alpha says nothing about that depth
    p = _plan(common + "shade: h.color, depth: g.depth", "  image: sprite.color\n")
    assert not p.unread and "depth" in p.needed["g"]


def test_pipeline_without_the_depth_pass_matches_the_depth_path(gl):
    """The whole default pipeline run as planned (no depth made) against the same pipeline asked also for the
    perturbed depth (which makes the sketch read the depth map): identical colour."""
    from nodegraph import shipped

    pipe = pl.load(str(shipped.paths()["nienhaus_sketchy"]), size=(200, 160))
    lean = Executor(pipe, None, gl=gl)
    assert lean.plan.unread == {"sketch": frozenset({"depth"})}
    a = lean.run(2).values[("sprite", "color")].read()
    full = Executor(pipe, None, gl=gl, requested=[("sprite", "color"), ("sprite", "depth")])
    assert not full.plan.unread and "depth" in full.plan.needed["gbuf"]
    b = full.run(2).values[("sprite", "color")].read()
    np.testing.assert_array_equal(a, b)
    assert (a[..., 3] == 0).mean() > 0.05  # the far test matters somewhere
