"""composite against a float64 computation of over and multiply, with and without a mask."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.composite import Composite
from pydantic import ValidationError

from nodegraph.errors import NodeError
from tests.helpers import assert_outputs_as_planned, run_minimal, run_node

W, H = 37, 23


def _expected(mode: str, base: np.ndarray, layer: np.ndarray, a: np.ndarray) -> np.ndarray:
    a = a[..., None]
    if mode == "over":
        return np.concatenate([base[..., :3] * (1 - a) + layer * a, a + base[..., 3:] * (1 - a)], axis=-1)
    return np.concatenate([base[..., :3] * (1 - a + layer * a), base[..., 3:]], axis=-1)


@pytest.mark.parametrize("mode", ["over", "multiply"])
@pytest.mark.parametrize("inputs", ["top", "mask", "top+mask"])
def test_matches_float64(gl, rng, mode, inputs):
    q = lambda a: np.round(a * 255) / 255  # noqa: E731 - the RGBA8 / R8 quantisation of the uploads
    base, top, mask = q(rng.random((H, W, 4))), q(rng.random((H, W, 4))), q(rng.random((H, W)))
    ins = {"base": gl.upload(base, "RGBA8")}
    if "top" in inputs:
        ins["top"] = gl.upload(top, "RGBA8")
    if "mask" in inputs:
        ins["mask"] = gl.upload(mask, "R8")
    params = Composite.Params(mode=mode, color=(0.2, 0.4, 0.6), opacity=0.75)
    out = run_node(gl, Composite("c", params), ins, (W, H))["color"]
    assert out.fmt == "RGBA8"
    layer = top[..., :3] if "top" in inputs else np.broadcast_to(np.array([0.2, 0.4, 0.6]), (H, W, 3))
    alpha = (mask if "mask" in inputs else top[..., 3] if "top" in inputs else 1.0) * 0.75
    np.testing.assert_allclose(out.read(), _expected(mode, base, layer, alpha), atol=1.01 / 255)


def test_errors(gl):
    assert Composite.check_connections({"base"}) is not None
    assert Composite.check_connections({"base", "mask"}) is None
    small = gl.upload(np.zeros((5, 5)), "R8")
    with pytest.raises(NodeError, match="composite needs equal sizes"):
        run_node(gl, Composite("c"), {"base": gl.upload(np.zeros((H, W, 4)), "RGBA8"), "mask": small}, (W, H))
    with pytest.raises(ValidationError):
        Composite.Params(opacity=2.0)
    with pytest.raises(ValidationError):
        Composite.Params(mode="screen")


_PIPE = """pipeline: t
size: [64, 48]
scene: builtin:sphere
nodes:
  g: {{type: rasterize}}
  p: {{type: paper, params: {{size: 32}}}}
  q: {{type: paper, params: {{size: {q}}}}}
  c: {{type: composite, in: {{{ins}}}, params: {{{params}}}}}
outputs: {{image: c.color}}
"""


@pytest.mark.parametrize(("params", "expected"), [
    ("color: [.nan, 0, 0]", "field 'color.0': expected a finite number, found nan"),
    ("color: [0, -.inf, 0]", "field 'color.1': expected a finite number, found -inf"),
    ("color: [0, 0, 1.5]", "field 'color.2': expected less than or equal to 1, found 1.5"),
    ("opacity: .nan", "field 'opacity'"),
])
def test_bad_params_are_located_load_errors(params, expected):
    from nodegraph import pipeline as pl
    from nodegraph.errors import PipelineError

    with pytest.raises(PipelineError) as info:
        pl.loads(_PIPE.format(q=32, ins="base: g.color, top: g.color", params=params), "t.yaml", load_scene=False)
    assert str(info.value).startswith("t.yaml:8:") and expected in str(info.value)


@pytest.mark.parametrize(("ins", "q", "bad"), [
    ("base: p.out, top: q.out", 64, True),     # both sizes declared (paper tiles): a load error
    ("base: p.out, top: q.out", 16, True),
    ("base: p.out, top: q.out", 32, False),    # equal
    ("base: g.color, top: q.out", 64, False),  # base follows the image: checked in compute
])
def test_declared_sizes_that_differ_are_load_errors(ins, q, bad):
    from nodegraph import pipeline as pl
    from nodegraph.errors import PipelineError

    text = _PIPE.format(q=q, ins=ins, params="")
    if not bad:
        pl.loads(text, "t.yaml", load_scene=False)
        return
    with pytest.raises(PipelineError, match=rf"t.yaml:8:3: node 'c' \(composite\): input '(top|mask)' is {q}x{q}, "
                                            r"'base' is 32x32; composite needs equal sizes"):
        pl.loads(text, "t.yaml", load_scene=False)


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  g: {type: rasterize}
  c: {type: composite, in: {base: g.color, top: g.color}}
"""
    ex, res = run_minimal(gl, nodes, {"image": "c.color"})
    assert assert_outputs_as_planned(ex, res, "c") == ["color"]
