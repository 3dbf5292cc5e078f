"""depth_sprite against a float64 NumPy reference, over paper and over ordinary geometry."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.depth_sprite import DepthSprite
from nodegraph_nodes.depth_sprite.reference import depth_sprite as depth_sprite_ref

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from nodegraph.gpu.sampling import nearest
from tests.helpers import ROOT, assert_one_line_located, assert_outputs_as_planned, run_minimal, run_node


@pytest.mark.parametrize("with_under", [False, True])
def test_depth_sprite_matches_float64_reference(gl, with_under):
    h, w = 48, 64
    ys, xs = np.mgrid[0:h, 0:w]
    depth = np.where((xs - 30) ** 2 + (ys - 24) ** 2 < 14**2, 0.4 + 0.002 * xs, 1.0).astype(np.float32)
    color = np.zeros((h, w, 4), np.float32)
    color[..., 0] = xs / w
    color[..., 1] = ys / h
    color[..., 3] = 1
    # whole-pixel shifts: edge +5 px in x, shade -3 px in y (in texture units)
    offsets = np.zeros((h, w, 4), np.float32)
    offsets[..., 0] = 5 / w
    offsets[..., 3] = -3 / h
    inputs = {"color": gl.upload(color, "RGBA16F"), "offsets": gl.upload(offsets, "RGBA16F"),
              "depth": gl.upload(depth[..., None], "R32F")}
    under_c = under_d = None
    if with_under:
        under_d = np.where(xs > 34, 0.42, 1.0).astype(np.float32)
        under_c = np.zeros((h, w, 4), np.float32)
        under_c[xs > 34] = (0.2, 0.5, 0.3, 1.0)
        inputs.update(under_color=gl.upload(under_c, "RGBA8"), under_depth=gl.upload(under_d[..., None], "R32F"))
        under_c = inputs["under_color"].read()
    got = run_node(gl, DepthSprite("d"), inputs, (w, h), needed=frozenset({"color", "depth"}))
    ref = depth_sprite_ref(inputs["color"].read(), inputs["offsets"].read(), depth, under_c, under_d)
    gz, rz = got["depth"].read()[..., 0], ref["depth"]
    # the depth test runs at depth-buffer precision: allow 1e-6 in the values, no pixel decided differently
    assert np.abs(gz - rz).max() < 1e-5
    assert np.abs(got["color"].read() - ref["color"]).max() < 2e-3
    # the sprite reaches beyond the disc (shifted lookups) and background stays paper at the far plane
    drawn = rz < 1.0
    assert drawn.sum() > (depth < 1).sum()
    assert np.all(gz[~drawn] == 1.0)


# -- composed with ordinary geometry (sketchy_composite.yaml): occlusion both ways -------------
def test_composite_occlusion_both_ways(gl):
    pipe = pl.load(ROOT / "pipelines" / "sketchy_composite.yaml", size=(200, 200))
    refs = [("sprite", "depth"), ("sketchy", "depth"), ("plain", "depth"), ("sketch", "offsets"),
            ("sprite", "color"), ("plain", "color"), ("sketch", "color")]
    res = Executor(pipe, None, requested=refs, gl=gl).run()
    v = {ref: res.values[ref].read() for ref in refs}
    out_z = v[("sprite", "depth")][..., 0]
    sk_z, pl_z = v[("sketchy", "depth")][..., 0], v[("plain", "depth")][..., 0]
    off = v[("sketch", "offsets")]
    h, w = out_z.shape
    u, vv = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    sprite_z = np.minimum(nearest(sk_z, u + off[..., 0], vv + off[..., 1]),
                          nearest(sk_z, u + off[..., 2], vv + off[..., 3]))
    expected = np.minimum(pl_z, sprite_z)
    mismatch = np.abs(out_z - expected) > 1e-5
    assert mismatch.mean() < 0.002
    sketch_in_front = (sprite_z < pl_z) & (pl_z < 1)   # the sketch hides ordinary geometry here
    plain_in_front = (pl_z < sprite_z) & (sprite_z < 1)  # ordinary geometry hides the sketch here
    assert sketch_in_front.sum() > 200 and plain_in_front.sum() > 200, "the scene exercises both directions"
    color = v[("sprite", "color")][..., :3]
    plain = v[("plain", "color")][..., :3]
    sketch = v[("sketch", "color")][..., :3]
    assert np.abs(color[plain_in_front] - plain[plain_in_front]).max() < 1e-2
    assert np.abs(color[sketch_in_front] - sketch[sketch_in_front]).max() < 2e-3


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  g: {type: rasterize}
  e: {type: edge_detect, in: {normal_depth: g.normal_depth}}
  n: {type: perlin_noise}
  s: {type: sketch, in: {edges: e.out, shade: g.color, offset: n.out}}
  d: {type: depth_sprite, in: {color: s.color, offsets: s.offsets, depth: g.depth}}
"""
    ex, res = run_minimal(gl, nodes, {"image": "d.color", "depth": "d.depth"})
    assert assert_outputs_as_planned(ex, res, "d") == ["color", "depth"]


def test_connections_are_checked_at_load_time():
    text = ("pipeline: t\nscene: builtin:box\nnodes:\n  g: {type: rasterize}\n"
            "  d: {type: depth_sprite, in: {color: g.color, sketch_depth: g.depth, under_color: g.color}}\n"
            "outputs: {a: d.color}\n")
    with pytest.raises(PipelineError) as e:
        pl.loads(text, "t.yaml")
    assert_one_line_located(e.value, "t.yaml:5:")
    assert "under_depth" in str(e.value)
    with pytest.raises(PipelineError) as e:  # no depth at all
        pl.loads(text.replace(", sketch_depth: g.depth, under_color: g.color", ""), "t.yaml")
    assert_one_line_located(e.value, "t.yaml:5:")
    assert "sketch_depth" in str(e.value)
