"""depth_sprite refuses a paper colour that is not finite or not in [0, 1] when the pipeline loads."""

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
  s: {{type: sketch, in: {{edges: e.out, shade: g.color, offset: n.out, depth: g.depth}}}}
  d: {{type: depth_sprite, in: {{color: s.color, sketch_depth: s.depth}}, params: {{paper: {paper}}}}}
outputs: {{image: d.color}}
"""


@pytest.mark.parametrize(("paper", "expected"), [
    ("[.nan, 1, 1]", "field 'paper.0': expected a finite number, found nan"),
    ("[1, .inf, 1]", "field 'paper.1': expected a finite number, found inf"),
    ("[1, 1, 1.01]", "field 'paper.2': expected less than or equal to 1, found 1.01"),
    ("[1, 1]", "missing required field 'paper.2'"),
])
def test_bad_paper_is_a_located_load_error(paper, expected):
    with pytest.raises(PipelineError) as info:
        pl.loads(PIPE.format(paper=paper), "t.yaml", load_scene=False)
    assert str(info.value).startswith("t.yaml:9:") and expected in str(info.value)


def test_paper_in_range_loads():
    assert pl.loads(PIPE.format(paper="[0, 0.5, 1]"), "t.yaml", load_scene=False).nodes["d"].params.paper == (0, 0.5, 1)
