"""GIF frames: one palette for the whole film, ordered dithering that depends on a pixel's colour and position
only, and frame delays that follow the exact times.

The palette (`GifPalette.for_frame`, computed once from the film's first frame) has 256 entries:
- `GREYS` greys, evenly spaced from black to white (a step of about 4 levels): graphite and paper;
- the colours of a `CUBE`-level RGB cube that are not grey: whatever the first frame does not show;
- the rest (`256 - GREYS - (CUBE**3 - CUBE)` entries) from the first frame's colours that the greys and the
  cube miss (`MISS`), by median cut weighted by pixel count: the flat colours of the sketchy pipelines are
  drawn with their own entries.
Each pixel is drawn as a mix of two entries (`GifPalette.indices`): `a`, the nearest, and `b`, the entry that
best makes up the rest, in the proportion `r` that brings the mean closest to the pixel (`a + r·(b - a)`);
the pair minimises the mean's squared error plus `NOISE` times the pattern's variance `|b - a|²·r·(1 - r)`, so
near entries are mixed before far ones and a colour that is an entry is drawn pure. The pixel shows `b` where
`r` exceeds the 8x8 Bayer threshold at its position, `a` elsewhere: identical input pixels at the same place give
identical indices in every frame, and a still background does not crawl.
"""

from __future__ import annotations

from fractions import Fraction
from functools import cache

import numpy as np

GREYS = 64
CUBE = 4
MISS = 6.0
"""A first-frame colour farther than this (RGB, 0-255) from every grey and cube entry is given entries of its
own, by median cut."""
NOISE = 0.02
LUT_BITS = 5
"""Candidate pairs are looked up in a table of `2**LUT_BITS` cells a channel (each holding the `CANDIDATES`
entries nearest to its centre)."""
CANDIDATES = 8
SIZE = 256
CHUNK = 65536
"""Colours paired at a time (bounds the temporaries: about 100 bytes a colour and candidate)."""


@cache
def bayer(n: int = 8) -> np.ndarray:
    """The n x n Bayer threshold matrix as thresholds (k + 0.5) / n² in (0, 1), float32."""
    m = np.zeros((1, 1), np.int64)
    while m.shape[0] < n:
        m = np.block([[4 * m, 4 * m + 2], [4 * m + 3, 4 * m + 1]])
    return ((m + 0.5) / m.size).astype(np.float32)


def fixed_colours() -> np.ndarray:
    """The palette's fixed part: `GREYS` greys, then the cube's colours that are not grey (uint8, (n, 3))."""
    greys = np.round(np.arange(GREYS) * 255.0 / (GREYS - 1))
    ramp = np.repeat(greys[:, None], 3, axis=1)
    levels = np.round(np.arange(CUBE) * 255.0 / (CUBE - 1))
    cube = np.stack(np.meshgrid(levels, levels, levels, indexing="ij"), axis=-1).reshape(-1, 3)
    cube = cube[~((cube[:, 0] == cube[:, 1]) & (cube[:, 1] == cube[:, 2]))]
    return np.concatenate([ramp, cube]).astype(np.uint8)


def _median_cut(colours: np.ndarray, weights: np.ndarray, k: int) -> np.ndarray:
    """At most `k` colours (uint8) representing `colours` (n, 3) with `weights`: the box with the largest
    weight x extent is split at the weighted median of its widest channel, until there are `k` boxes or none
    can be split; each box gives its weighted mean."""
    if len(colours) <= k:
        return colours.astype(np.uint8)
    c = colours.astype(np.float64)

    def box(idx: np.ndarray) -> tuple[float, int, np.ndarray]:
        extent = c[idx].max(axis=0) - c[idx].min(axis=0)
        return float(weights[idx].sum()) * float(extent.max()), int(extent.argmax()), idx

    boxes = [box(np.arange(len(c)))]
    while len(boxes) < k:
        best = max(range(len(boxes)), key=lambda i: boxes[i][0])
        score, axis, idx = boxes[best]
        if score <= 0:  # every box holds one colour
            break
        boxes.pop(best)
        idx = idx[np.argsort(c[idx, axis], kind="stable")]
        cum = np.cumsum(weights[idx])
        cut = int(np.searchsorted(cum, cum[-1] / 2.0)) + 1
        cut = min(max(cut, 1), len(idx) - 1)
        boxes += [box(idx[:cut]), box(idx[cut:])]
    means = [np.average(c[idx], axis=0, weights=weights[idx]) for _, _, idx in boxes]
    return np.clip(np.round(np.array(means)), 0, 255).astype(np.uint8)


class GifPalette:
    """A film's palette (`colours`, (256, 3) uint8) and the table of candidate entries `indices` searches."""

    def __init__(self, colours: np.ndarray):
        colours = np.asarray(colours, np.uint8).reshape(-1, 3)
        if not 1 <= len(colours) <= SIZE:
            raise ValueError(f"a GIF palette has 1 to {SIZE} colours, found {len(colours)}")
        self.colours = np.concatenate([colours, np.repeat(colours[-1:], SIZE - len(colours), axis=0)])
        self.used = len(colours)
        self._pal = colours.astype(np.float32)
        cells = 1 << LUT_BITS
        centre = (np.arange(cells, dtype=np.float32) + 0.5) * (256.0 / cells)
        grid = np.stack(np.meshgrid(centre, centre, centre, indexing="ij"), axis=-1).reshape(-1, 3)
        k = min(CANDIDATES, self.used)
        self._cells = np.empty((len(grid), k), np.int16)
        for start in range(0, len(grid), 4096):
            d = ((grid[start:start + 4096, None, :] - self._pal[None, :, :]) ** 2).sum(-1)
            near = np.argpartition(d, k - 1, axis=1)[:, :k] if k < self.used else np.tile(np.arange(k), (len(d), 1))
            order = np.take_along_axis(d, near, axis=1).argsort(axis=1, kind="stable")
            self._cells[start:start + 4096] = np.take_along_axis(near, order, axis=1)

    @classmethod
    def for_frame(cls, rgb: np.ndarray) -> GifPalette:
        """The palette for a film whose first frame is `rgb` (uint8, (h, w, 3)): see the module's docstring."""
        fixed = fixed_colours()
        flat = np.asarray(rgb, np.uint8).reshape(-1, 3)
        packed = (flat[:, 0].astype(np.int64) << 16) | (flat[:, 1].astype(np.int64) << 8) | flat[:, 2]
        values, counts = np.unique(packed, return_counts=True)
        colours = np.stack([(values >> 16) & 255, (values >> 8) & 255, values & 255], axis=1).astype(np.float64)
        f = fixed.astype(np.float64)
        nearest = np.full(len(colours), np.inf)
        for start in range(0, len(colours), 4096):
            part = colours[start:start + 4096]
            nearest[start:start + 4096] = ((part[:, None, :] - f[None]) ** 2).sum(-1).min(axis=1)
        missed = nearest > MISS * MISS
        extra = _median_cut(colours[missed], counts[missed].astype(np.float64), SIZE - len(fixed))
        return cls(np.concatenate([fixed, extra.reshape(-1, 3)]))

    def argb(self) -> np.ndarray:
        """The palette as PyAV's pal8 palette: (256, 4) uint8, A R G B, every entry opaque."""
        out = np.full((SIZE, 4), 255, np.uint8)
        out[:, 1:] = self.colours
        return out

    def indices(self, rgb: np.ndarray) -> np.ndarray:
        """`rgb` (uint8, (h, w, 3)) as palette indices (uint8, (h, w)), ordered-dithered (module docstring). The
        pair and proportion depend on the colour alone: they are found once for each distinct colour."""
        rgb = np.asarray(rgb, np.uint8)
        h, w = rgb.shape[:2]
        n = bayer().shape[0]
        thresholds = np.tile(bayer(), ((h + n - 1) // n, (w + n - 1) // n))[:h, :w].reshape(-1)
        flat = rgb.reshape(-1, 3)
        packed = (flat[:, 0].astype(np.int32) << 16) | (flat[:, 1].astype(np.int32) << 8) | flat[:, 2]
        values, inverse = np.unique(packed, return_inverse=True)
        colours = np.stack([values >> 16, (values >> 8) & 255, values & 255], axis=1).astype(np.uint8)
        a, b, ratio = self.pairs(colours)
        inverse = inverse.reshape(-1)
        return np.where(ratio[inverse] > thresholds, b[inverse], a[inverse]).astype(np.uint8).reshape(h, w)

    def pairs(self, colours: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For each colour (uint8, (n, 3)): the nearest entry `a`, the entry `b` it is mixed with and the
        proportion `r` of `b` (module docstring)."""
        m = len(colours)
        a_out, b_out = np.empty(m, np.int16), np.empty(m, np.int16)
        r_out = np.empty(m, np.float32)
        shift = 8 - LUT_BITS
        for s in range(0, m, CHUNK):
            block = colours[s:s + CHUNK].astype(np.int32)
            cell = ((block[:, 0] >> shift) << (2 * LUT_BITS)) | ((block[:, 1] >> shift) << LUT_BITS) | (
                block[:, 2] >> shift)
            cand = self._cells[cell]  # (m, k)
            c = self._pal[cand]  # (m, k, 3)
            p = block.astype(np.float32)[:, None, :]
            dx, dy, dz = (c[..., i] - p[..., i] for i in range(3))
            ia = (dx * dx + dy * dy + dz * dz).argmin(axis=1)
            rows = np.arange(len(cand))
            a = c[rows, ia][:, None, :]  # (m, 1, 3)
            ex, ey, ez = (c[..., i] - a[..., i] for i in range(3))  # b - a
            fx, fy, fz = (p[..., i] - a[..., i] for i in range(3))  # pixel - a
            span = ex * ex + ey * ey + ez * ez
            r = np.clip((fx * ex + fy * ey + fz * ez) / np.where(span > 0, span, np.float32(1)), 0, 1)
            r = np.where(span > 0, r, np.float32(0)).astype(np.float32)
            gx, gy, gz = (a[..., i] + r * ex - p[..., i] for i in range(3))
            score = gx * gx + gy * gy + gz * gz + np.float32(NOISE) * span * r * (1 - r)
            ib = score.argmin(axis=1)
            a_out[s:s + CHUNK], b_out[s:s + CHUNK] = cand[rows, ia], cand[rows, ib]
            r_out[s:s + CHUNK] = r[rows, ib]
        return a_out, b_out, r_out


def centiseconds(i: int, rate: Fraction) -> int:
    """The time of frame `i` of a film at `rate` frames/s in whole centiseconds (GIF's unit), rounded half up:
    floor(i·100/rate + 1/2). A frame's delay is the difference to the next one's, so the delays sum to the exact
    times, rounded, with no drift (24 frames/s: 4, 4, 5, 4, 4, 4, ...; 30: 3, 4, 3, 3, 4, 3, ...)."""
    return int((Fraction(i * 100) / rate + Fraction(1, 2)) // 1)
