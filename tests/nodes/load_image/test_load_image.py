"""load_image: an image file as a texture, keyed by content; missing files are load errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from nodegraph.output import imageio
from tests.helpers import RASTER, assert_outputs_as_planned, run_minimal


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


# -- roster -----------------------------------------------------------------------------------------
def _png(tmp_path: Path, rng) -> tuple[Path, np.ndarray]:
    """A 30 x 20 RGB PNG written with OIIO directly (row 0 = top); the 8-bit values it holds."""
    import OpenImageIO as oiio

    data = rng.integers(0, 256, (20, 30, 3), dtype=np.uint8)
    f = tmp_path / "in.png"
    out = oiio.ImageOutput.create(str(f))
    assert out.open(str(f), oiio.ImageSpec(30, 20, 3, oiio.UINT8))
    out.write_image(data)
    out.close()
    return f, data


def test_smoke_in_a_minimal_pipeline_png_scaled_and_flipped(gl, tmp_path: Path, rng):
    f, data = _png(tmp_path, rng)
    ex, res = run_minimal(gl, f"  i: {{type: load_image, params: {{path: '{f}'}}}}\n", {"image": "i.out"},
                          size=(48, 40), load_scene=False)
    tex = res.values[("i", "out")]
    assert tex.fmt == ex.plan.formats[("i", "out")] == "RGBA32F"
    assert tex.size == (30, 20)  # the image's own size, not the pipeline's
    got = tex.read()
    assert got.dtype == np.float32 and got.shape == (20, 30, 4)
    np.testing.assert_allclose(got[::-1, :, :3], data / 255.0, atol=1e-7)  # rows bottom-up in OpenGL
    assert np.all(got[..., 3] == 1.0)


def test_declared_output_shape_is_the_images_size(gl, tmp_path: Path, rng):
    f, _ = _png(tmp_path, rng)
    ex, res = run_minimal(gl, f"  i: {{type: load_image, params: {{path: '{f}'}}}}\n", {"image": "i.out"},
                          size=(48, 40), load_scene=False)
    assert_outputs_as_planned(ex, res, "i")
