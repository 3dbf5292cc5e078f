"""Looking at buffers: a visualisation per value type, per-channel statistics, area resizing, a tiny
bitmap font for labels, and contact sheets.

Every image here is float32 (H, W, 3) in [0, 1] in *display* order (row 0 = top); `write_png` flips
it back for `imageio.write`, which takes GL order (row 0 = bottom). Everything is plain NumPy with a
fixed order of operations, so the same buffer gives the same bytes on every machine.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

VERSION = "2"  # bump when a visualisation changes: gallery entries built with another version are rebuilt

BACKGROUND = np.array([0.05, 0.07, 0.18], np.float32)  # depth background (no surface)
NONFINITE = np.array([1.0, 0.0, 1.0], np.float32)  # NaN / Inf pixels in every visualisation
SHEET_BG = np.array([0.13, 0.13, 0.14], np.float32)
LABEL = np.array([0.92, 0.92, 0.90], np.float32)
LABEL_DIM = np.array([0.62, 0.62, 0.60], np.float32)


@dataclass
class Panel:
    """What one value looks like: an image (or None), how it was drawn and a one-line note."""

    image: np.ndarray | None
    kind: str
    note: str = ""


@dataclass
class ChannelStats:
    name: str
    min: float
    max: float
    mean: float
    nan: int
    inf: int = 0

    def as_dict(self) -> dict[str, Any]:
        return {"channel": self.name, "min": self.min, "max": self.max, "mean": self.mean, "nan": self.nan,
                "inf": self.inf}


# -- statistics ------------------------------------------------------------------------------------------
def channel_stats(arr: np.ndarray, names: str | list[str] | None = None) -> list[ChannelStats]:
    """Per-channel min/max/mean over finite values, and NaN/Inf counts, of an (..., C) array."""
    a = np.asarray(arr)
    if a.ndim == 1:
        a = a[:, None]
    c = a.shape[-1]
    flat = a.reshape(-1, c).astype(np.float64)
    labels = list(names) if names is not None else list("RGBA"[:c] if c <= 4 else [str(i) for i in range(c)])
    out = []
    for i in range(c):
        ch = flat[:, i]
        finite = np.isfinite(ch)
        vals = ch[finite]
        if vals.size:
            lo, hi, mean = float(vals.min()), float(vals.max()), float(vals.mean())
        else:
            lo = hi = mean = float("nan")
        out.append(ChannelStats(labels[i] if i < len(labels) else str(i), lo, hi, mean,
                                int(np.isnan(ch).sum()), int(np.isinf(ch).sum())))
    return out


# -- visualisations --------------------------------------------------------------------------------------
def classify(port: str, channels: int, doc: str = "") -> str:
    """Which visualisation fits a texture output, from its port name and channel count; where the name
    says nothing (`out`), from the first clause of the port's documentation."""
    kind = _classify(port.lower(), channels)
    if kind in ("grey", "color") and doc:
        first = re.split(r"[.:;]", doc.lower(), maxsplit=1)[0]
        hint = _classify(first, channels)
        if hint not in ("grey", "color"):
            return hint
    return kind


def _classify(name: str, channels: int) -> str:
    if channels == 1:
        if "depth" in name:
            return "depth"
        if name in ("id", "ids") or name.endswith("_id") or "object id" in name:
            return "ids"
        return "grey"
    if channels == 2:
        return "vector"
    if "normal" in name:
        return "normals"
    if any(w in name for w in ("offset", "force", "flow", "velocity", "gradient", "direction")):
        return "vector2" if channels == 4 else "vector"
    if "position" in name:
        return "position"
    return "color"


def visualize_texture(arr: np.ndarray, port: str, doc: str = "") -> Panel:
    """An (H, W, C) texture in GL order as a display image."""
    a = np.asarray(arr, np.float32)
    kind = classify(port, a.shape[2], doc)
    img, note = _DRAW[kind](a)
    return Panel(np.ascontiguousarray(img[::-1]), kind, note)


def visualize(value: Any, port: str, doc: str = "") -> Panel:
    """Any node value: textures by type, texture arrays as a strip, strokes as a preview, the rest as text."""
    from ..values import Arrays, Strokes, Tex, TexArray

    if isinstance(value, Tex):
        return visualize_texture(value.read(), port, doc)
    if isinstance(value, TexArray):
        return visualize_array(value.read(), port, doc=doc)
    if isinstance(value, np.ndarray) and value.ndim == 3:
        return visualize_texture(value, port, doc)
    if isinstance(value, np.ndarray) and value.ndim == 4:
        return visualize_array(value, port, doc=doc)
    if isinstance(value, Strokes):
        from ..output.strokes import rasterize_strokes

        grey = rasterize_strokes(value)[::-1, :, 0]
        return Panel(np.repeat(grey[:, :, None], 3, axis=2), "strokes", f"{len(value.polylines)} strokes")
    if isinstance(value, Arrays):
        return Panel(None, "arrays", ", ".join(f"{k} {tuple(v.shape)}" for k, v in value.data.items()))
    if isinstance(value, Path):
        return Panel(None, "file", str(value))
    return Panel(None, "none", type(value).__name__)


def visualize_array(arr: np.ndarray, port: str, per_row: int = 16, gap: int = 2, doc: str = "") -> Panel:
    """A texture array (L, H, W, C) as a strip of its layers, left to right (wrapped every `per_row`)."""
    layers = [visualize_texture(layer, port, doc) for layer in arr]
    tiles = [p.image for p in layers]
    rows = [tiles[i:i + per_row] for i in range(0, len(tiles), per_row)]
    h, w = tiles[0].shape[:2]
    width = min(len(tiles), per_row) * (w + gap) - gap
    out = np.empty((len(rows) * (h + gap) - gap, width, 3), np.float32)
    out[:] = SHEET_BG
    for r, row in enumerate(rows):
        for c, tile in enumerate(row):
            out[r * (h + gap):r * (h + gap) + h, c * (w + gap):c * (w + gap) + w] = tile
    return Panel(out, "strip", f"{len(tiles)} layers ({layers[0].kind})")


def _finite_mask(a: np.ndarray) -> np.ndarray:
    return np.all(np.isfinite(a), axis=2)


def _paint_nonfinite(img: np.ndarray, a: np.ndarray) -> np.ndarray:
    bad = ~_finite_mask(a)
    if bad.any():
        img[bad] = NONFINITE
    return img


def _grey(a: np.ndarray) -> tuple[np.ndarray, str]:
    ch = a[:, :, 0]
    finite = np.isfinite(ch)
    vals = ch[finite]
    lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (0.0, 1.0)
    if lo >= -1e-3 and hi <= 1.0 + 1e-3:
        g, note = np.clip(np.where(finite, ch, 0.0), 0.0, 1.0), "grey, 0..1"
    else:
        g, note = _normalize(np.where(finite, ch, lo), lo, hi), f"grey, normalized {lo:.4g}..{hi:.4g}"
    img = np.repeat(g[:, :, None], 3, axis=2).astype(np.float32)
    return _paint_nonfinite(img, a), note


def _depth(a: np.ndarray) -> tuple[np.ndarray, str]:
    """Normalized over the finite range of the surface; exact 0 and 1 (no surface) count as background."""
    d = a[:, :, 0]
    finite = np.isfinite(d)
    surface = finite & (d != 0.0) & (d != 1.0)
    if not surface.any():
        surface = finite
    vals = d[surface]
    lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (0.0, 1.0)
    v = 1.0 - _normalize(np.where(surface, d, lo), lo, hi)  # near is bright
    g = 0.12 + 0.88 * v
    img = np.repeat(g[:, :, None], 3, axis=2).astype(np.float32)
    img[finite & ~surface] = BACKGROUND
    return _paint_nonfinite(img, a), f"depth {lo:.4g}..{hi:.4g}, near bright"


def _normals(a: np.ndarray) -> tuple[np.ndarray, str]:
    n = np.where(np.isfinite(a[:, :, :3]), a[:, :, :3], 0.0)
    img = np.clip(n * 0.5 + 0.5, 0.0, 1.0).astype(np.float32)
    return _paint_nonfinite(img, a), "normal xyz as rgb = n/2 + 1/2"


def _vector(a: np.ndarray) -> tuple[np.ndarray, str]:
    img, peak = wheel(a[:, :, 0], a[:, :, 1])
    return _paint_nonfinite(img, a[:, :, :2]), f"direction as hue, |v| as brightness (max {peak:.4g})"


def _vector2(a: np.ndarray) -> tuple[np.ndarray, str]:
    """Two 2D vectors per pixel (xy, zw): two colour wheels side by side, sharing one scale."""
    peak = max(_peak(a[:, :, 0], a[:, :, 1]), _peak(a[:, :, 2], a[:, :, 3]))
    left, _ = wheel(a[:, :, 0], a[:, :, 1], peak)
    right, _ = wheel(a[:, :, 2], a[:, :, 3], peak)
    _paint_nonfinite(left, a[:, :, :2])
    _paint_nonfinite(right, a[:, :, 2:])
    h, w = a.shape[:2]
    gap = max(1, w // 100)
    out = np.empty((h, 2 * w + gap, 3), np.float32)
    out[:] = SHEET_BG
    out[:, :w], out[:, w + gap:] = left, right
    return out, f"xy | zw: direction as hue, |v| as brightness (max {peak:.4g})"


def _position(a: np.ndarray) -> tuple[np.ndarray, str]:
    img = np.zeros(a.shape[:2] + (3,), np.float32)
    covered = a[:, :, 3] > 0 if a.shape[2] == 4 else np.ones(a.shape[:2], bool)
    for c in range(3):
        ch = a[:, :, c]
        ok = covered & np.isfinite(ch)
        vals = ch[ok]
        lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (0.0, 1.0)
        img[:, :, c] = np.where(ok, _normalize(np.where(ok, ch, lo), lo, hi), 0.0)
    return _paint_nonfinite(img, a), "xyz normalized per channel over covered pixels"


def _color(a: np.ndarray) -> tuple[np.ndarray, str]:
    rgb = a[:, :, :3] if a.shape[2] >= 3 else np.repeat(a[:, :, :1], 3, axis=2)
    rgb = np.where(np.isfinite(rgb), rgb, 0.0)
    lo, hi = float(rgb.min()), float(rgb.max())
    if lo >= -1e-3 and hi <= 1.0 + 1e-3:
        return _paint_nonfinite(np.clip(rgb, 0.0, 1.0).astype(np.float32), a), "rgb"
    return _paint_nonfinite(_normalize(rgb, lo, hi), a), f"rgb normalized {lo:.4g}..{hi:.4g}"


def _ids(a: np.ndarray) -> tuple[np.ndarray, str]:
    ids = np.where(np.isfinite(a[:, :, 0]), np.rint(a[:, :, 0]), 0).astype(np.int64)
    hue = np.mod(ids * 0.6180339887, 1.0)
    img = hsv_to_rgb(hue, np.full(hue.shape, 0.55), np.full(hue.shape, 0.95))
    img[ids == 0] = 0.0
    n = len(np.unique(ids[ids != 0]))
    return _paint_nonfinite(img, a), f"{n} ids as colours, 0 black"


_DRAW = {"grey": _grey, "depth": _depth, "normals": _normals, "vector": _vector, "vector2": _vector2,
         "position": _position, "color": _color, "ids": _ids}


def _normalize(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    span = hi - lo
    if not span > 0:
        return np.zeros_like(x, dtype=np.float32)
    return np.clip((x - lo) / span, 0.0, 1.0).astype(np.float32)


def _peak(x: np.ndarray, y: np.ndarray) -> float:
    mag = np.hypot(x.astype(np.float64), y.astype(np.float64))
    vals = mag[np.isfinite(mag)]
    return float(vals.max()) if vals.size else 0.0


def wheel(x: np.ndarray, y: np.ndarray, peak: float | None = None) -> tuple[np.ndarray, float]:
    """2D vectors as colours: hue = direction (+x red, +y yellow-green, -x cyan, -y violet),
    brightness = magnitude / `peak` (default: the largest finite magnitude)."""
    xf = np.where(np.isfinite(x), x, 0.0).astype(np.float64)
    yf = np.where(np.isfinite(y), y, 0.0).astype(np.float64)
    peak = _peak(xf, yf) if peak is None else peak
    mag = np.hypot(xf, yf)
    val = np.clip(mag / peak, 0.0, 1.0) if peak > 0 else np.zeros_like(mag)
    hue = np.mod(np.arctan2(yf, xf) / (2 * math.pi), 1.0)
    return hsv_to_rgb(hue, np.ones_like(hue), val), peak


def hsv_to_rgb(h: np.ndarray, s: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Hue in turns, saturation and value in [0, 1]. Each channel is v minus the part of v*s that a
    piecewise-linear ramp of the hue (offset per channel by 1/3 turn) takes away."""
    h6 = np.mod(h, 1.0) * 6.0
    vs = v * s
    out = np.empty(h.shape + (3,), np.float32)
    for c, offset in enumerate((5.0, 3.0, 1.0)):  # red, green, blue
        k = np.mod(offset + h6, 6.0)
        ramp = np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0)
        out[..., c] = v - vs * ramp
    return out


def heat(x: np.ndarray, peak: float) -> np.ndarray:
    """Non-negative values as black -> red -> yellow -> white, `peak` mapping to white."""
    t = np.clip(x / peak, 0.0, 1.0) if peak > 0 else np.zeros_like(x)
    r = np.clip(3 * t, 0, 1)
    g = np.clip(3 * t - 1, 0, 1)
    b = np.clip(3 * t - 2, 0, 1)
    return np.stack([r, g, b], axis=-1).astype(np.float32)


# -- resizing and writing --------------------------------------------------------------------------------
def resize_area(img: np.ndarray, width: int, height: int) -> np.ndarray:
    """Area-average resize (box filter over integer pixel spans), exact and order-fixed.

    Shrinking averages every source pixel a target pixel covers; enlarging repeats pixels."""
    h, w = img.shape[:2]
    if (w, h) == (width, height):
        return img.astype(np.float32, copy=True)
    a = img.astype(np.float64)
    if width <= w and height <= h:  # shrinking: spans tile the image, sum them row-wise then column-wise
        ys = np.arange(height) * h // height
        xs = np.arange(width) * w // width
        sums = np.add.reduceat(np.add.reduceat(a, ys, axis=0), xs, axis=1)
        area = np.outer(np.diff(np.append(ys, h)), np.diff(np.append(xs, w))).astype(np.float64)
        return (sums / (area[:, :, None] if sums.ndim == 3 else area)).astype(np.float32)
    ys0 = np.minimum(np.arange(height) * h // height, h - 1)
    xs0 = np.minimum(np.arange(width) * w // width, w - 1)
    ys1 = np.minimum(np.maximum((np.arange(height) + 1) * h // height, ys0 + 1), h)
    xs1 = np.minimum(np.maximum((np.arange(width) + 1) * w // width, xs0 + 1), w)
    sat = np.zeros((h + 1, w + 1) + a.shape[2:], np.float64)
    sat[1:, 1:] = a.cumsum(axis=0).cumsum(axis=1)
    y0, y1 = ys0[:, None], ys1[:, None]
    x0, x1 = xs0[None, :], xs1[None, :]
    total = sat[y1, x1] - sat[y0, x1] - sat[y1, x0] + sat[y0, x0]
    area = ((y1 - y0) * (x1 - x0)).astype(np.float64)
    if total.ndim == 3:
        area = area[:, :, None]
    return (total / area).astype(np.float32)


def fit(img: np.ndarray, box: int) -> np.ndarray:
    """Shrink (never enlarge) so the longer side is at most `box` pixels, keeping the aspect ratio."""
    h, w = img.shape[:2]
    scale = min(1.0, box / max(h, w))
    return resize_area(img, max(1, round(w * scale)), max(1, round(h * scale)))


def to_uint8(img: np.ndarray) -> np.ndarray:
    """x * 255 in float64, rounded half to even, clamped to [0, 255], as uint8; in one float64 array worked in
    place (2-4 times faster than a new array a step at an 800x2404 picture, the same bytes)."""
    a = np.multiply(img, 255.0, dtype=np.float64)
    np.rint(a, out=a)
    np.clip(a, 0, 255, out=a)
    return a.astype(np.uint8)


def write_png(path: str | Path, img: np.ndarray) -> Path:
    """A display-order (row 0 = top) float RGB image in [0, 1] as an 8-bit PNG (`imageio.write_png8` at its fast
    level: the diff images, wedge sheets; quantised here, so the pixels depend on NumPy only). Another extension
    (`wedge -o sheet.jpg`) is written in its own format by `imageio.write`."""
    from ..output import imageio

    a = to_uint8(img)
    if Path(path).suffix.lower() != ".png":
        return imageio.write(path, a[::-1].astype(np.float32) / 255.0, half=False)
    return imageio.write_png8(path, a[:, :, None] if a.ndim == 2 else a)


def read_png(path: str | Path) -> np.ndarray:
    """An image file as display-order float32 (H, W, C)."""
    from ..output import imageio

    return np.ascontiguousarray(imageio.read(path)[::-1])


# -- a 5x7 bitmap font -----------------------------------------------------------------------------------
# Upper case, digits and common punctuation; lower case is drawn as upper case, unknown characters as '?'.
_GLYPHS: dict[str, str] = {
    " ": ".....|.....|.....|.....|.....|.....|.....",
    "A": ".###.|#...#|#...#|#####|#...#|#...#|#...#",
    "B": "####.|#...#|#...#|####.|#...#|#...#|####.",
    "C": ".###.|#...#|#....|#....|#....|#...#|.###.",
    "D": "####.|#...#|#...#|#...#|#...#|#...#|####.",
    "E": "#####|#....|#....|####.|#....|#....|#####",
    "F": "#####|#....|#....|####.|#....|#....|#....",
    "G": ".###.|#...#|#....|#.###|#...#|#...#|.####",
    "H": "#...#|#...#|#...#|#####|#...#|#...#|#...#",
    "I": ".###.|..#..|..#..|..#..|..#..|..#..|.###.",
    "J": "..###|...#.|...#.|...#.|...#.|#..#.|.##..",
    "K": "#...#|#..#.|#.#..|##...|#.#..|#..#.|#...#",
    "L": "#....|#....|#....|#....|#....|#....|#####",
    "M": "#...#|##.##|#.#.#|#.#.#|#...#|#...#|#...#",
    "N": "#...#|#...#|##..#|#.#.#|#..##|#...#|#...#",
    "O": ".###.|#...#|#...#|#...#|#...#|#...#|.###.",
    "P": "####.|#...#|#...#|####.|#....|#....|#....",
    "Q": ".###.|#...#|#...#|#...#|#.#.#|#..#.|.##.#",
    "R": "####.|#...#|#...#|####.|#.#..|#..#.|#...#",
    "S": ".####|#....|#....|.###.|....#|....#|####.",
    "T": "#####|..#..|..#..|..#..|..#..|..#..|..#..",
    "U": "#...#|#...#|#...#|#...#|#...#|#...#|.###.",
    "V": "#...#|#...#|#...#|#...#|#...#|.#.#.|..#..",
    "W": "#...#|#...#|#...#|#.#.#|#.#.#|#.#.#|.#.#.",
    "X": "#...#|#...#|.#.#.|..#..|.#.#.|#...#|#...#",
    "Y": "#...#|#...#|.#.#.|..#..|..#..|..#..|..#..",
    "Z": "#####|....#|...#.|..#..|.#...|#....|#####",
    "0": ".###.|#...#|#..##|#.#.#|##..#|#...#|.###.",
    "1": "..#..|.##..|..#..|..#..|..#..|..#..|.###.",
    "2": ".###.|#...#|....#|...#.|..#..|.#...|#####",
    "3": "#####|...#.|..#..|...#.|....#|#...#|.###.",
    "4": "...#.|..##.|.#.#.|#..#.|#####|...#.|...#.",
    "5": "#####|#....|####.|....#|....#|#...#|.###.",
    "6": "..##.|.#...|#....|####.|#...#|#...#|.###.",
    "7": "#####|....#|...#.|..#..|.#...|.#...|.#...",
    "8": ".###.|#...#|#...#|.###.|#...#|#...#|.###.",
    "9": ".###.|#...#|#...#|.####|....#|...#.|.##..",
    ".": ".....|.....|.....|.....|.....|.##..|.##..",
    ",": ".....|.....|.....|.....|.##..|..#..|.#...",
    ":": ".....|.##..|.##..|.....|.##..|.##..|.....",
    ";": ".....|.##..|.##..|.....|.##..|..#..|.#...",
    "=": ".....|.....|#####|.....|#####|.....|.....",
    "_": ".....|.....|.....|.....|.....|.....|#####",
    "-": ".....|.....|.....|#####|.....|.....|.....",
    "+": ".....|..#..|..#..|#####|..#..|..#..|.....",
    "/": ".....|....#|...#.|..#..|.#...|#....|.....",
    "(": "...#.|..#..|.#...|.#...|.#...|..#..|...#.",
    ")": ".#...|..#..|...#.|...#.|...#.|..#..|.#...",
    "[": ".###.|.#...|.#...|.#...|.#...|.#...|.###.",
    "]": ".###.|...#.|...#.|...#.|...#.|...#.|.###.",
    "%": "##...|##..#|...#.|..#..|.#...|#..##|...##",
    "#": ".#.#.|.#.#.|#####|.#.#.|#####|.#.#.|.#.#.",
    "*": ".....|..#..|#.#.#|.###.|#.#.#|..#..|.....",
    "'": "..#..|..#..|.#...|.....|.....|.....|.....",
    '"': ".#.#.|.#.#.|.....|.....|.....|.....|.....",
    "<": "...#.|..#..|.#...|#....|.#...|..#..|...#.",
    ">": ".#...|..#..|...#.|....#|...#.|..#..|.#...",
    "!": "..#..|..#..|..#..|..#..|..#..|.....|..#..",
    "?": ".###.|#...#|....#|...#.|..#..|.....|..#..",
    "|": "..#..|..#..|..#..|..#..|..#..|..#..|..#..",
}
_BITMAPS = {ch: np.array([[c == "#" for c in row] for row in g.split("|")], bool) for ch, g in _GLYPHS.items()}
GLYPH_W, GLYPH_H = 5, 7


def _glyph(ch: str) -> np.ndarray:
    ch = {"×": "X", "→": ">", "…": "."}.get(ch, ch).upper()
    return _BITMAPS.get(ch, _BITMAPS["?"])


def text_size(text: str, scale: int = 1) -> tuple[int, int]:
    return (max(0, len(text) * (GLYPH_W + 1) - 1) * scale, GLYPH_H * scale)


def draw_text(img: np.ndarray, text: str, x: int, y: int, color: np.ndarray = LABEL, scale: int = 1) -> None:
    """Draw `text` with its top-left corner at (x, y) of a display-order image (clipped at the edges)."""
    h, w = img.shape[:2]
    for i, ch in enumerate(text):
        bm = _glyph(ch)
        if scale > 1:
            bm = np.repeat(np.repeat(bm, scale, axis=0), scale, axis=1)
        gx = x + i * (GLYPH_W + 1) * scale
        gh, gw = bm.shape
        x0, y0, x1, y1 = max(gx, 0), max(y, 0), min(gx + gw, w), min(y + gh, h)
        if x0 >= x1 or y0 >= y1:
            continue
        sub = bm[y0 - y:y1 - y, x0 - gx:x1 - gx]
        img[y0:y1, x0:x1][sub] = color


def clip_text(text: str, width: int, scale: int = 1) -> str:
    room = max(1, (width + scale) // ((GLYPH_W + 1) * scale))
    return text if len(text) <= room else text[:max(1, room - 1)] + "."


# -- contact sheets --------------------------------------------------------------------------------------
@dataclass
class Cell:
    image: np.ndarray | None  # display-order RGB, any size; None draws an empty (hatched) box
    lines: list[str] = field(default_factory=list)


def contact_sheet(cells: list[Cell], cell: int = 192, columns: int | None = None, title: str = "",
                  pad: int = 8, scale: int = 1, row_labels: list[str] | None = None,
                  column_labels: list[str] | None = None) -> np.ndarray:
    """Cells in a grid: each image shrunk to fit `cell` x `cell`, centred, with its label lines below.

    With `row_labels`/`column_labels` (a wedge) the grid gets headers on the left and on top."""
    n = max(1, len(cells))
    cols = columns or min(n, max(1, math.ceil(math.sqrt(n * 1.6))))
    rows = math.ceil(n / cols)
    line_h = (GLYPH_H + 3) * scale
    n_lines = max((len(c.lines) for c in cells), default=0)
    cell_h = cell + 4 + n_lines * line_h
    left = (max(text_size(t, scale)[0] for t in row_labels) + 2 * pad) if row_labels else 0
    top = (line_h + pad) if title else 0
    head = (line_h + pad // 2) if column_labels else 0
    width = left + pad + cols * (cell + pad)
    height = top + head + pad + rows * (cell_h + pad)
    sheet = np.empty((height, width, 3), np.float32)
    sheet[:] = SHEET_BG
    if title:
        draw_text(sheet, clip_text(title, width - 2 * pad, scale), pad, pad, LABEL, scale)
    for i, label in enumerate(column_labels or []):
        x = left + pad + i * (cell + pad)
        draw_text(sheet, clip_text(label, cell, scale), x, top + pad, LABEL, scale)
    for i, c in enumerate(cells):
        r, k = divmod(i, cols)
        x = left + pad + k * (cell + pad)
        y = top + head + pad + r * (cell_h + pad)
        if c.image is None:
            box = sheet[y:y + cell, x:x + cell]
            yy, xx = np.mgrid[0:cell, 0:cell]
            box[((xx + yy) // 6) % 2 == 0] = SHEET_BG * 1.4
        else:
            thumb = fit(c.image[:, :, :3], cell)
            th, tw = thumb.shape[:2]
            oy, ox = y + (cell - th) // 2, x + (cell - tw) // 2
            sheet[oy:oy + th, ox:ox + tw] = thumb
        for j, line in enumerate(c.lines):
            draw_text(sheet, clip_text(line, cell, scale), x, y + cell + 4 + j * line_h,
                      LABEL if j == 0 else LABEL_DIM, scale)
    for r, label in enumerate(row_labels or []):
        y = top + head + pad + r * (cell_h + pad) + cell // 2 - line_h // 2
        draw_text(sheet, label, pad, y, LABEL, scale)
    return sheet
