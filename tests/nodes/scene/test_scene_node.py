"""scene: a scene from a path or a connected mesh, errors at load time."""

from __future__ import annotations

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from tests.helpers import RASTER, assert_outputs_as_planned, render_normal_depth, run_minimal


def test_scene_node_draws_what_the_pipeline_scene_draws(gl):
    direct = render_normal_depth(gl, RASTER.format(scene="builtin:box", extra="", g_in=""))
    extra = "  s: {type: scene, params: {path: builtin:box}}"
    via_node = render_normal_depth(gl, RASTER.format(scene="builtin:torus", extra=extra, g_in=", in: {scene: s.out}"))
    assert np.array_equal(direct, via_node)
    assert (direct[..., 3] > 0).sum() > 500


def test_scene_node_needs_exactly_one_source():
    text = RASTER.format(scene="builtin:box", extra="  s: {type: scene}", g_in=", in: {scene: s.out}")
    with pytest.raises(PipelineError, match=r"t.yaml:5:3: node 's' \(scene\): give either params.path"):
        pl.loads(text, "t.yaml")


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  s: {type: scene, params: {path: builtin:torus}}
  g: {type: rasterize, in: {scene: s.out}}
"""
    ex, res = run_minimal(gl, nodes, {"scene": "s.out", "image": "g.color"})
    assert assert_outputs_as_planned(ex, res, "s") == ["out"]
