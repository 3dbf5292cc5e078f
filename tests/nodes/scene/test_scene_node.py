"""scene, load_mesh and load_image: values from files, keyed by content, errors at load time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph import imageio
from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from tests.helpers import shared_mesh

RASTER = """\
pipeline: t
size: [96, 80]
scene: {scene}
nodes:
{extra}
  g: {{type: rasterize{g_in}}}
outputs:
  image: g.normal_depth
"""


def _render(gl, text: str) -> np.ndarray:
    pipe = pl.loads(text, "t.yaml")
    return Executor(pipe, None, gl=gl).run().values[("g", "normal_depth")].read()


def test_scene_node_draws_what_the_pipeline_scene_draws(gl):
    direct = _render(gl, RASTER.format(scene="builtin:box", extra="", g_in=""))
    via_node = _render(gl, RASTER.format(scene="builtin:torus", extra="  s: {type: scene, params: {path: builtin:box}}",
                                         g_in=", in: {scene: s.out}"))
    assert np.array_equal(direct, via_node)
    assert (direct[..., 3] > 0).sum() > 500


def test_a_loaded_mesh_is_framed_like_a_mesh_scene(gl):
    mesh = shared_mesh("spot.obj")
    direct = _render(gl, RASTER.format(scene=str(mesh), extra="", g_in=""))
    extra = f"  m: {{type: load_mesh, params: {{path: '{mesh}'}}}}\n  s: {{type: scene, in: {{mesh: m.out}}}}"
    via_nodes = _render(gl, RASTER.format(scene="builtin:box", extra=extra, g_in=", in: {scene: s.out}"))
    assert np.array_equal(direct, via_nodes)


def test_scene_node_needs_exactly_one_source():
    text = RASTER.format(scene="builtin:box", extra="  s: {type: scene}", g_in=", in: {scene: s.out}")
    with pytest.raises(PipelineError, match=r"t.yaml:5:3: node 's' \(scene\): give either params.path"):
        pl.loads(text, "t.yaml")


def test_missing_files_are_load_errors(tmp_path: Path):
    text = RASTER.format(scene="builtin:box", extra=f"  m: {{type: load_mesh, params: {{path: {tmp_path}/no.obj}}}}",
                         g_in="")
    with pytest.raises(PipelineError, match=r"t.yaml:5:39: node 'm' \(load_mesh\) field 'path': .*no.obj"):
        pl.loads(text, "t.yaml")
    text = RASTER.format(scene="builtin:box", extra=f"  i: {{type: load_image, params: {{path: {tmp_path}/no.exr}}}}",
                         g_in="")
    with pytest.raises(PipelineError, match="image file not found"):
        pl.loads(text, "t.yaml")


def test_load_image_round_trips_and_follows_the_file(gl, tmp_path: Path, rng):
    f = tmp_path / "in.exr"
    arr = rng.random((30, 40, 3)).astype(np.float32) * 4 - 1  # values outside [0, 1] survive an EXR
    imageio.write(f, arr, half=False)
    text = f"pipeline: t\nnodes:\n  i: {{type: load_image, params: {{path: '{f}'}}}}\noutputs: {{image: i.out}}\n"
    pipe = pl.loads(text, "t.yaml", load_scene=False)
    ex = Executor(pipe, None, gl=gl)
    got = ex.run().values[("i", "out")].read()
    assert got.shape == (30, 40, 4)
    assert np.array_equal(got[..., :3], arr) and np.all(got[..., 3] == 1)
    key = ex.keys()["i"]
    imageio.write(f, arr * 0.5, half=False)
    assert Executor(pl.loads(text, "t.yaml", load_scene=False), None, gl=gl).keys()["i"] != key
