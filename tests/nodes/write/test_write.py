"""write: the file written holds the input texture's pixels, top row first as image files are."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import NodeError, PipelineError
from nodegraph.executor import Executor
from tests.helpers import assert_one_line_located, assert_outputs_as_planned, run_minimal


def read_with_oiio(path: Path) -> np.ndarray:
    """The file's pixels as stored (row 0 = top), without the project's reader."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    arr = np.asarray(inp.read_image(oiio.FLOAT), np.float32).reshape(spec.height, spec.width, spec.nchannels)
    inp.close()
    return arr


def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl, tmp_path: Path):
    nodes = ("  g: {type: rasterize}\n"
             f"  w: {{type: write, in: {{image: g.color}}, params: {{path: '{tmp_path}/a.png'}}}}\n")
    ex, res = run_minimal(gl, nodes, {"file": "w.file"}, out_dir=tmp_path)
    assert assert_outputs_as_planned(ex, res, "w") == ["file"]
    assert res.values[("w", "file")] == tmp_path / "a.png" and (tmp_path / "a.png").is_file()


@pytest.mark.parametrize("ext", ["exr", "png"])
def test_written_pixels_equal_the_input_flipped_top_down(gl, tmp_path: Path, ext: str):
    nodes = ("  g: {type: rasterize}\n"
             f"  w: {{type: write, in: {{image: g.normal}}, params: {{path: '{tmp_path}/a.{ext}'}}}}\n")
    ex, res = run_minimal(gl, nodes, {"file": "w.file", "normal": "g.normal"}, size=(40, 32), out_dir=tmp_path)
    tex = res.values[("g", "normal")].read()  # RGBA16F, row 0 = bottom (OpenGL)
    got = read_with_oiio(tmp_path / f"a.{ext}")
    want = tex[::-1]
    assert tex[..., 3].min() == 0 and tex[..., 3].max() == 1  # the image has content and background
    if ext == "exr":  # values kept, 32-bit float, all four channels
        assert got.shape == (32, 40, 4)
        assert np.array_equal(got, want)
    else:  # 8 bits, clipped to [0, 1], alpha dropped
        assert got.shape == (32, 40, 3)
        np.testing.assert_allclose(got, np.round(np.clip(want[..., :3], 0, 1) * 255) / 255, atol=1e-6)


TEXT = ("pipeline: t\nsize: [32, 24]\nscene: builtin:box\nnodes:\n  g: {type: rasterize}\n"
        "  w: {type: write, in: {image: g.color}}\n")


def test_missing_path_is_a_located_load_error():
    with pytest.raises(PipelineError) as e:
        pl.loads(TEXT + "outputs: {f: w.file}\n", "t.yaml")
    assert_one_line_located(e.value, "t.yaml:6:")
    assert "path" in str(e.value)


def test_unwritable_extension_is_a_load_error_or_a_node_error(gl, tmp_path: Path):
    bad = TEXT.replace("g.color}}", f"g.color}}, params: {{path: '{tmp_path}/a.xyz'}}}}") + "outputs: {f: w.file}\n"
    try:
        pipe = pl.loads(bad, "t.yaml", out_dir=tmp_path)
    except PipelineError as e:
        assert_one_line_located(e, "t.yaml:6:")
        assert "xyz" in str(e)
        return
    with pytest.raises(NodeError, match=r"node 'w' \(write\).*xyz") as e:
        Executor(pipe, None, gl=gl).run()
    assert "\n" not in str(e.value)
