"""viz's 8-bit conversion and PNG writer, against plain-Python references and the files read back."""

from __future__ import annotations

import numpy as np
import pytest

from nodegraph.output import imageio
from nodegraph.tools import viz


def _reference_uint8(values: np.ndarray) -> np.ndarray:
    """Element by element: x * 255 in float64, Python's round (half to even), clamped to [0, 255]."""
    flat = [min(255, max(0, round(float(x) * 255.0))) for x in np.asarray(values).ravel()]
    return np.array(flat, np.uint8).reshape(np.shape(values))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_to_uint8_rounds_half_to_even_and_clamps_like_the_reference(dtype):
    rng = np.random.default_rng(3)
    img = rng.uniform(-0.2, 1.2, (17, 23, 3)).astype(dtype)
    # values whose x * 255 lies on or next to a half: k + 0.5 rounds to the even neighbour
    halves = (np.arange(0, 255, dtype=np.float64) + 0.5) / 255.0
    img.reshape(-1)[: halves.size] = halves.astype(dtype)
    before = img.copy()
    got = viz.to_uint8(img)
    assert got.dtype == np.uint8 and got.shape == img.shape
    assert np.array_equal(got, _reference_uint8(img))
    assert np.array_equal(viz.to_uint8(img[:, :, 0]), _reference_uint8(img[:, :, 0]))  # 2-D too
    assert np.array_equal(img, before)  # the input is left as it was


def test_write_png_writes_the_8_bit_values_and_other_formats_by_extension(tmp_path):
    rng = np.random.default_rng(5)
    rgb = rng.random((9, 14, 3)).astype(np.float32)
    grey = rng.random((6, 5)).astype(np.float32)
    viz.write_png(tmp_path / "rgb.png", rgb)
    viz.write_png(tmp_path / "grey.png", grey)
    back = viz.read_png(tmp_path / "rgb.png")  # display order, values / 255
    assert np.array_equal(np.rint(back * 255).astype(np.uint8), viz.to_uint8(rgb))
    back_grey = viz.read_png(tmp_path / "grey.png")
    assert back_grey.shape[:2] == (6, 5)
    assert np.array_equal(np.rint(back_grey[:, :, 0] * 255).astype(np.uint8), viz.to_uint8(grey))
    assert (tmp_path / "rgb.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # another extension keeps its own format (`wedge -o sheet.jpg`)
    viz.write_png(tmp_path / "sheet.jpg", rgb)
    assert (tmp_path / "sheet.jpg").read_bytes()[:2] == b"\xff\xd8"
    assert imageio.read(tmp_path / "sheet.jpg").shape[:2] == (9, 14)
