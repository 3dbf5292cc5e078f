"""Strokes (polylines in pixel coordinates, y up) as SVG and as a quick raster preview."""

from __future__ import annotations

import numpy as np

from ..values import Strokes


def to_svg(strokes: Strokes) -> str:
    """An SVG document with one path per stroke; y is flipped so it looks like the image."""
    w, h = strokes.size
    r, g, b = (int(round(255 * max(0.0, min(1.0, c)))) for c in strokes.color)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}">',
           f'<g fill="none" stroke="rgb({r},{g},{b})" stroke-width="{strokes.width:g}" '
           'stroke-linecap="round" stroke-linejoin="round">']
    for poly in strokes.polylines:
        if len(poly) < 2:
            continue
        pts = " L".join(f"{x:.2f},{h - y:.2f}" for x, y in np.asarray(poly, dtype=np.float64))
        out.append(f'<path d="M{pts}"/>')
    out.append("</g></svg>")
    return "\n".join(out) + "\n"


def rasterize_strokes(strokes: Strokes, samples_per_px: float = 2.0) -> np.ndarray:
    """A grey preview (H, W, 1), ink dark on white, by splatting points along each segment."""
    w, h = strokes.size
    ink = np.zeros((h, w), np.float32)
    for poly in strokes.polylines:
        p = np.asarray(poly, dtype=np.float64)
        if len(p) < 2:
            continue
        seg = np.diff(p, axis=0)
        n = np.maximum(1, np.ceil(np.hypot(seg[:, 0], seg[:, 1]) * samples_per_px).astype(int))
        t = np.concatenate([np.arange(k) / k for k in n])
        idx = np.repeat(np.arange(len(seg)), n)
        pts = p[idx] + seg[idx] * t[:, None]
        x = np.clip(pts[:, 0].astype(int), 0, w - 1)
        y = np.clip(pts[:, 1].astype(int), 0, h - 1)
        ink[y, x] = 1.0
    return (1.0 - ink)[..., None]
