"""Strokes as a layered SVG drawing: one Inkscape layer per line kind and visibility, optionally on a page.

Layers are top-level `<g inkscape:groupmode="layer" inkscape:label="contour">` groups (hidden lines in
"contour hidden" and so on), in the order of `values.LINE_KINDS`, visible before hidden, so Inkscape shows
them as layers and vpype reads them as its layers. Without a page the file's unit is the pixel (width and
height as the canvas, stroke widths in pixels); with a page (`A4`, `A3`, `letter`, or `WxHmm`, portrait or
landscape as the drawing is) the file is that size in millimetres, the drawing scaled to fit inside a margin
and centred, and stroke widths are in millimetres (pixels times the same scale). y is flipped (strokes have y
up) so the file looks like the image.

An SVG path has one width and one opacity: each stroke is one path with its vertices' mean width and tone (taper
and pressure along a stroke show in the GPU drawing, `draw_strokes`, not in the file). Points that coincide once
rounded to the file's digits are written once.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from ..errors import SketchgraphError
from ..values import LINE_KINDS, Strokes

SVG_NS = "http://www.w3.org/2000/svg"
INKSCAPE_NS = "http://www.inkscape.org/namespaces/inkscape"
PAGES_MM = {"a4": (210.0, 297.0), "a3": (297.0, 420.0), "letter": (215.9, 279.4)}


@dataclass(frozen=True)
class Page:
    """A physical page in millimetres (portrait as given; `fit` turns it to the drawing's orientation)."""

    width_mm: float
    height_mm: float
    margin_mm: float = 10.0


def parse_page(text: str | None, margin_mm: float = 10.0) -> Page | None:
    """`A4`, `A3`, `letter` or `WxHmm` (e.g. `150x100mm`); None for None."""
    if text is None:
        return None
    key = text.strip().lower()
    if key in PAGES_MM:
        w, h = PAGES_MM[key]
    else:
        m = re.fullmatch(r"(\d+(?:\.\d+)?)\s*x\s*(\d+(?:\.\d+)?)\s*mm", key)
        if not m:
            raise SketchgraphError(f"--page: expected A4, A3, letter or WxHmm (e.g. 150x100mm), found '{text[:40]}'")
        w, h = float(m.group(1)), float(m.group(2))
    if min(w, h) <= 2.0 * margin_mm:
        raise SketchgraphError(f"--page {text}: {w:g}x{h:g} mm leaves nothing inside a {margin_mm:g} mm margin")
    return Page(w, h, margin_mm)


def layer_name(kind: int, visible: bool) -> str:
    return LINE_KINDS[kind] + ("" if visible else " hidden")


def _hex(color: tuple[float, ...]) -> str:
    r, g, b = (int(round(255 * max(0.0, min(1.0, c)))) for c in color[:3])
    return f"#{r:02x}{g:02x}{b:02x}"


def layered_svg(strokes: Strokes, page: Page | None = None, digits: int = 2) -> str:
    """The SVG document (text) of `strokes`: one layer per (line kind, visibility) present."""
    w, h = strokes.size
    if page is None:
        scale, off_x, off_y = 1.0, 0.0, 0.0
        doc_w, doc_h, unit = float(w), float(h), ""
    else:
        pw, ph = page.width_mm, page.height_mm
        if (w > h) != (pw > ph) and w != h:  # the page turned to the drawing's orientation
            pw, ph = ph, pw
        scale = min((pw - 2 * page.margin_mm) / max(w, 1), (ph - 2 * page.margin_mm) / max(h, 1))
        off_x, off_y = 0.5 * (pw - scale * w), 0.5 * (ph - scale * h)
        doc_w, doc_h, unit = pw, ph, "mm"
    ET.register_namespace("", SVG_NS)
    ET.register_namespace("inkscape", INKSCAPE_NS)
    root = ET.Element(f"{{{SVG_NS}}}svg", {"width": f"{doc_w:g}{unit}", "height": f"{doc_h:g}{unit}",
                                           "viewBox": f"0 0 {doc_w:g} {doc_h:g}", "version": "1.1"})
    kinds = strokes.stroke_attr("kind")
    vis = strokes.stroke_attr("visible")
    widths = np.where(np.isnan(strokes.attrs["width"]), strokes.width, strokes.attrs["width"])
    tones = strokes.attrs["tone"]
    colour = _hex(strokes.color)
    base_w = strokes.width * scale
    lens = np.diff(strokes.starts)
    mean_w, mean_tone = per_stroke_mean(widths, strokes.starts), per_stroke_mean(tones, strokes.starts)
    xs = off_x + scale * strokes.xy[:, 0].astype(np.float64)
    ys = off_y + scale * (h - strokes.xy[:, 1].astype(np.float64))
    layer_no = 0
    for visible in (True, False):
        for k in range(len(LINE_KINDS)):
            idx = np.flatnonzero((kinds == k) & (vis == visible) & (lens >= 2))
            if not len(idx):
                continue
            layer_no += 1
            g = ET.SubElement(root, f"{{{SVG_NS}}}g", {
                "id": f"layer{layer_no}", f"{{{INKSCAPE_NS}}}groupmode": "layer",
                f"{{{INKSCAPE_NS}}}label": layer_name(k, visible), "fill": "none",
                "stroke": colour if visible else "#9a9a9a", "stroke-width": f"{base_w:.{digits + 2}g}",
                "stroke-linecap": "round", "stroke-linejoin": "round"})
            if not visible:
                g.set("stroke-dasharray", f"{4 * base_w:.3g} {3 * base_w:.3g}")
            for i in idx:
                a, b = strokes.starts[i], strokes.starts[i + 1]
                d = path_data(xs[a:b], ys[a:b], digits)
                if d is None:
                    continue
                attrs = {"d": d}
                sw = float(mean_w[i]) * scale
                if abs(sw - base_w) > 1e-6 * max(base_w, 1e-9):
                    attrs["stroke-width"] = f"{sw:.{digits + 2}g}"
                tone = float(mean_tone[i])
                if tone < 1.0:
                    attrs["stroke-opacity"] = f"{max(tone, 0.0):.3g}"
                ET.SubElement(g, f"{{{SVG_NS}}}path", attrs)
    ET.indent(root, space="", level=0)
    return ET.tostring(root, encoding="unicode", xml_declaration=False) + "\n"


def per_stroke_mean(values: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """The mean of per-vertex `values` over each stroke (float64; NaN for an empty stroke), in one pass."""
    lens = np.diff(starts)
    out = np.full(len(lens), np.nan)
    some = np.flatnonzero(lens > 0)
    if len(some):
        out[some] = np.add.reduceat(values.astype(np.float64), starts[some]) / lens[some]
    return out


def path_data(x: np.ndarray, y: np.ndarray, digits: int) -> str | None:
    """An SVG path's `d` for one polyline, points rounded to `digits` decimals and a point equal to the one
    before it once rounded left out; None when fewer than two distinct points remain."""
    n = len(x)
    if n < 2:
        return None
    flat = np.empty(2 * n)
    flat[0::2], flat[1::2] = x, y
    pts = ((f"%.{digits}f,%.{digits}f\n" * n) % tuple(flat.tolist()))[:-1].split("\n")  # one format call
    kept = [q for q, before in zip(pts, [None, *pts[:-1]], strict=True) if q != before]
    return "M" + " L".join(kept) if len(kept) >= 2 else None


def read_layers(text: str) -> dict[str, list[np.ndarray]]:
    """An SVG written by `layered_svg` read back: layer label -> polylines in the file's units (tests, benches)."""
    root = ET.fromstring(text)
    out: dict[str, list[np.ndarray]] = {}
    for g in root.findall(f"{{{SVG_NS}}}g"):
        if g.get(f"{{{INKSCAPE_NS}}}groupmode") != "layer":
            continue
        polys = out.setdefault(g.get(f"{{{INKSCAPE_NS}}}label", ""), [])
        for path in g.findall(f"{{{SVG_NS}}}path"):
            nums = re.findall(r"-?\d+(?:\.\d+)?", path.get("d", ""))
            polys.append(np.array(nums, dtype=np.float64).reshape(-1, 2))
    return out
