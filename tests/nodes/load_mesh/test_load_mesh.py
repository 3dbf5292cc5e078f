"""load_mesh: a mesh file as a value, framed like a mesh scene; missing files are load errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from tests.helpers import RASTER, render_normal_depth, shared_mesh


def test_a_loaded_mesh_is_framed_like_a_mesh_scene(gl):
    mesh = shared_mesh("spot.obj")
    direct = render_normal_depth(gl, RASTER.format(scene=str(mesh), extra="", g_in=""))
    extra = f"  m: {{type: load_mesh, params: {{path: '{mesh}'}}}}\n  s: {{type: scene, in: {{mesh: m.out}}}}"
    via_nodes = render_normal_depth(gl, RASTER.format(scene="builtin:box", extra=extra, g_in=", in: {scene: s.out}"))
    assert np.array_equal(direct, via_nodes)


def test_missing_files_are_load_errors(tmp_path: Path):
    text = RASTER.format(scene="builtin:box", extra=f"  m: {{type: load_mesh, params: {{path: {tmp_path}/no.obj}}}}",
                         g_in="")
    with pytest.raises(PipelineError, match=r"t.yaml:5:39: node 'm' \(load_mesh\) field 'path': .*no.obj"):
        pl.loads(text, "t.yaml")
