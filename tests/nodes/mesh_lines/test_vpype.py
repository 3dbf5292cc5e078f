"""plotter_lines' SVG read back by vpype (the plotter community's tool): its Inkscape layers become vpype's
layers with their names, the page is A4 and every path lies where the strokes' pixels map onto the page by hand
(10 mm margin, centred, y down); the bench's pen-up travel in file order equals the sum of the gaps between
consecutive strokes of a layer, and linesort shortens it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from nodegraph_nodes.mesh_lines.bench import pen_up

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.output.svg import layered_svg, parse_page
from nodegraph.values import LINE_KINDS

vp = pytest.importorskip("vpype")

SIZE = 240
PX_MM = 25.4 / 96.0  # vpype's unit is the CSS pixel


@pytest.fixture(scope="module")
def strokes():
    pipe = pl.load("plotter_lines", size=(SIZE, SIZE), scene="builtin:primitives")
    ex = Executor(pipe, None)
    try:
        return ex.run(0).values[("hatch", "combined")]
    finally:
        ex.close()


def on_page(poly: np.ndarray) -> np.ndarray:
    """Pixels (y up) -> A4 millimetres (y down): the square drawing fills the page's width inside 10 mm margins."""
    scale = (210.0 - 20.0) / SIZE
    off_y = (297.0 - scale * SIZE) / 2
    return np.c_[10.0 + scale * poly[:, 0], off_y + scale * (SIZE - poly[:, 1])]


def test_vpype_reads_the_layers_in_millimetres_on_a4(strokes, tmp_path: Path):
    path = tmp_path / "plot.svg"
    path.write_text(layered_svg(strokes, parse_page("A4")))
    doc = vp.read_multilayer_svg(str(path), quantization=0.1)
    assert np.allclose(np.asarray(doc.page_size) * PX_MM, (210.0, 297.0), atol=1e-6)
    names = [doc.layers[i].property("vp_name") for i in sorted(doc.layers)]
    assert names == ["contour", "crease", "boundary", "hatching"]
    kinds = strokes.stroke_attr("kind")
    lens = np.diff(strokes.starts)
    assert strokes.stroke_attr("visible").all()
    for i, name in zip(sorted(doc.layers), names, strict=True):
        want = [on_page(strokes.polylines[j].astype(np.float64))
                for j in np.flatnonzero((kinds == LINE_KINDS.index(name)) & (lens >= 2))]
        got = [np.c_[line.real, line.imag] * PX_MM for line in doc.layers[i]]
        assert len(got) == len(want) > 0
        for g, w in zip(got, want, strict=True):
            # the file has two decimals; vpype drops a point that repeats the one before it there
            keep = np.r_[True, np.abs(np.diff(w.round(2), axis=0)).max(axis=1) > 0]
            np.testing.assert_allclose(g, w[keep], atol=0.006)
        # vpype's pen width: the layer's strokes' width (each stroke's mean, all alike here) in mm on the page
        width = np.where(np.isnan(strokes["width"]), strokes.width, strokes["width"])
        per_stroke = {round(float(width[strokes.starts[j]:strokes.starts[j + 1]].mean()), 4)
                      for j in np.flatnonzero((kinds == LINE_KINDS.index(name)) & (lens >= 2))}
        assert len(per_stroke) == 1
        pen = doc.layers[i].property("vp_pen_width") * PX_MM
        assert pen == pytest.approx(per_stroke.pop() * (210.0 - 20.0) / SIZE, rel=1e-3)


def test_pen_up_travel_in_file_order_and_after_linesort(strokes):
    text = layered_svg(strokes, parse_page("A4"))
    got = pen_up(text)
    kinds = strokes.stroke_attr("kind")
    lens = np.diff(strokes.starts)
    gaps = 0.0
    for k in np.unique(kinds):
        polys = [on_page(strokes.polylines[j].astype(np.float64)) for j in np.flatnonzero((kinds == k) & (lens >= 2))]
        gaps += sum(float(np.hypot(*(b[0] - a[-1]))) for a, b in zip(polys, polys[1:], strict=False))
    assert got["file_order"]["pen_up_mm"] == pytest.approx(gaps, abs=0.1 + 1e-3 * gaps)
    assert got["linesort"]["pen_up_mm"] < got["file_order"]["pen_up_mm"]
    assert got["linesort"]["pen_down_mm"] == pytest.approx(got["file_order"]["pen_down_mm"], abs=0.2)
