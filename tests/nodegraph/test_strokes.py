"""Strokes values as SVG: the project's one SVG writer (strokes_svg, inspect dumps, the particle bench)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from nodegraph.output.strokes import to_svg
from nodegraph.values import Strokes


def test_svg_flips_y_and_writes_a_path_per_stroke():
    polylines = [np.array([[10, 0], [20, 5]], np.float32), np.array([[1, 1]], np.float32),
                 np.array([[0, 100], [50, 50], [60, 40]], np.float32)]
    svg = to_svg(Strokes(polylines, (200, 100), 1.5, (0.2, 0.4, 0.6)))
    root = ET.fromstring(svg)
    ns = {"s": "http://www.w3.org/2000/svg"}
    paths = root.findall(".//s:path", ns)
    assert root.get("width") == "200" and root.get("height") == "100" and len(paths) == 2
    assert paths[0].get("d") == "M10.00,100.00 L20.00,95.00"
    assert paths[1].get("d") == "M0.00,0.00 L50.00,50.00 L60.00,60.00"
    group = root.find("s:g", ns)
    assert group.get("stroke") == "rgb(51,102,153)" and group.get("stroke-width") == "1.5"
