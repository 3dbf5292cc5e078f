"""strokes_svg: the SVG written holds one polyline per stroke, the strokes' points with y flipped."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError, PortTypeError
from tests.helpers import assert_one_line_located, assert_outputs_as_planned, run_minimal

SIZE = (64, 48)


def particles(svg: str) -> str:
    return ("  g: {type: rasterize}\n"
            "  e: {type: depth_edges, in: {depth: g.linear_depth}}\n"
            "  f: {type: force_field, in: {gradient: e.gradient}}\n"
            "  p: {type: particle_sketch, in: {edges: e.edges, force: f.out}, params: {strokes: 60}}\n"
            f"  s: {{type: strokes_svg, in: {{strokes: p.strokes}}, params: {{path: '{svg}'}}}}\n")


def svg_polylines(path: Path) -> tuple[ET.Element, list[np.ndarray]]:
    root = ET.parse(path).getroot()
    polys = []
    for el in root.iter("{http://www.w3.org/2000/svg}path"):
        nums = [float(t) for t in re.findall(r"-?\d+(?:\.\d+)?", el.get("d"))]
        polys.append(np.asarray(nums).reshape(-1, 2))
    return root, polys


def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl, tmp_path: Path):
    ex, res = run_minimal(gl, particles(tmp_path / "a.svg"), {"file": "s.file"}, size=SIZE, out_dir=tmp_path)
    assert assert_outputs_as_planned(ex, res, "s") == ["file"]
    assert res.values[("s", "file")] == tmp_path / "a.svg"


def test_svg_polylines_equal_the_strokes(gl, tmp_path: Path):
    ex, res = run_minimal(gl, particles(tmp_path / "a.svg"), {"file": "s.file", "strokes": "p.strokes"}, size=SIZE,
                          out_dir=tmp_path)
    strokes = res.values[("p", "strokes")]
    drawn = [np.asarray(p, np.float64) for p in strokes.polylines if len(p) >= 2]
    assert len(drawn) >= 5
    root, polys = svg_polylines(tmp_path / "a.svg")
    w, h = SIZE
    assert (root.get("width"), root.get("height"), root.get("viewBox")) == (str(w), str(h), f"0 0 {w} {h}")
    assert len(polys) == len(drawn)
    for got, want in zip(polys, drawn, strict=True):
        expected = np.c_[want[:, 0], h - want[:, 1]]  # SVG's y runs down from the top
        np.testing.assert_allclose(got, expected, atol=0.005 + 1e-9)  # two decimals in the file
    g = root.find("{http://www.w3.org/2000/svg}g")
    r, gg, b = (round(255 * c) for c in strokes.color)
    assert g.get("stroke") == f"rgb({r},{gg},{b})" and float(g.get("stroke-width")) == strokes.width


def test_errors_are_located_at_load_time(tmp_path: Path):
    text = "pipeline: t\nscene: builtin:box\nnodes:\n" + particles(tmp_path / "a.png") + "outputs: {f: s.file}\n"
    with pytest.raises(PipelineError) as e:
        pl.loads(text, "t.yaml", out_dir=tmp_path)
    assert_one_line_located(e.value, "t.yaml:8:")
    assert ".svg" in str(e.value)
    text = text.replace("a.png", "a.svg").replace("strokes: p.strokes", "strokes: g.color")
    with pytest.raises(PortTypeError) as e:
        pl.loads(text, "t.yaml", out_dir=tmp_path)
    assert_one_line_located(e.value, "t.yaml:8:")
    assert "Strokes" in str(e.value)
