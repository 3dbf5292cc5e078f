"""sketch refuses NaN, infinity and out-of-range colours in its matrices and colours when the pipeline loads."""

from __future__ import annotations

import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError

PIPE = """pipeline: t
size: [32, 32]
scene: builtin:sphere
nodes:
  g: {{type: rasterize}}
  e: {{type: edge_detect, in: {{normal_depth: g.normal_depth}}}}
  n: {{type: perlin_noise}}
  s: {{type: sketch, in: {{edges: e.out, shade: g.color, offset: n.out}}, params: {{{params}}}}}
outputs: {{image: s.color}}
"""


@pytest.mark.parametrize(("params", "field", "expected"), [
    ("edge_matrix: [[.nan, 0], [0, 0.01]]", "edge_matrix.0.0", "finite number, found nan"),
    ("edge_matrix: [[0.01, 0], [0, .inf]]", "edge_matrix.1.1", "finite number, found inf"),
    ("shade_matrix: [[0.01, -.inf], [0, 0.01]]", "shade_matrix.0.1", "finite number, found -inf"),
    ("shade_matrix: [[0.01, 0], [0]]", "shade_matrix.1.1", "missing required field"),
    ("edge_color: [0.1, .nan, 0.1]", "edge_color.1", "finite number, found nan"),
    ("edge_color: [0.1, 0.1, 1.5]", "edge_color.2", "less than or equal to 1, found 1.5"),
    ("paper: [-0.1, 1, 1]", "paper.0", "greater than or equal to 0, found -0.1"),
    ("edge_layers: [{matrix: [[0, 0], [.nan, 0]]}]", "edge_layers.0.matrix.1.0", "finite number, found nan"),
    ("edge_layers: [{matrix: [[0, 0], [0, 0]], color: [2, 0, 0]}]", "edge_layers.0.color.0",
     "less than or equal to 1, found 2"),
])
def test_bad_values_are_located_load_errors(params, field, expected):
    with pytest.raises(PipelineError) as info:
        pl.loads(PIPE.format(params=params), "t.yaml", load_scene=False)
    msg = str(info.value)
    assert msg.startswith("t.yaml:8:") and "\n" not in msg
    assert "node 's' (sketch) " in msg and f"field '{field}'" in msg and expected in msg


@pytest.mark.parametrize("override", ["s.edge_matrix=[[.nan, 0], [0, 0]]", "s.paper=[1, 1, .inf]"])
def test_bad_overrides_are_load_errors(override):
    with pytest.raises(PipelineError, match=r"--set .*finite number"):
        pl.loads(PIPE.format(params=""), "t.yaml", load_scene=False, overrides=[override])


def test_good_values_load():
    pipe = pl.loads(PIPE.format(params="edge_matrix: [[1e3, 0], [0, -1e3]], edge_color: [0, 1, 0.5]"), "t.yaml",
                    load_scene=False)
    assert pipe.nodes["s"].params.edge_matrix == ((1e3, 0.0), (0.0, -1e3))
