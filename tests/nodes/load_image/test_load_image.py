"""load_image: an image file as a texture, keyed by content; missing files are load errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph import imageio
from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from tests.helpers import RASTER


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


def test_missing_files_are_load_errors(tmp_path: Path):
    text = RASTER.format(scene="builtin:box", extra=f"  i: {{type: load_image, params: {{path: {tmp_path}/no.exr}}}}",
                         g_in="")
    with pytest.raises(PipelineError, match="image file not found"):
        pl.loads(text, "t.yaml")
