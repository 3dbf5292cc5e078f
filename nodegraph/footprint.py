"""Footprints: the part of an image a texture's content can differ from its blank value in.

A node that knows where its output can be anything but one constant (the G-buffer's clear values outside the
objects' projected boxes, no edge where no surface was drawn) gives the texture a `values.Footprint`: a pixel
rectangle and the blank value everywhere outside it. A full-screen pass whose output outside some rectangle is
known to be constant draws only inside it (`GL.fullscreen(..., footprint=)`: the targets cleared to their
blank values, the pass scissored), so the pixels are the ones the whole pass would give and the work is the
part of the image the scene covers (docs/performance.md, "Footprints"). A texture without a footprint may
differ anywhere.

Rectangles are (x, y, w, h) in pixels, rows counted from the bottom as OpenGL counts them (the scissor's
form), clipped to the image; an empty one is (x, y, 0, 0)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from .values import Footprint

Rect = tuple[int, int, int, int]

ENABLED = True
"""Passes use footprints when True. Tests and `bench footprint` switch it off to compare the same frames drawn
over the whole image."""


def project_box(mvp: np.ndarray, lo: Sequence[float], hi: Sequence[float], size: tuple[int, int],
                margin: int) -> Rect | None:
    """The pixel rectangle holding the projection by `mvp` (clip space from the box's coordinates) of the
    axis-aligned box [lo, hi], grown by `margin` pixels and clipped to the image; None when a corner lies on or
    behind the eye's plane. A perspective projection keeps a box in front of the eye inside the hull of its
    projected corners."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    return project_points(mvp, corners.T, size, margin)


def project_points(mvp: np.ndarray, points: np.ndarray, size: tuple[int, int], margin: int) -> Rect | None:
    """The pixel rectangle holding the projections by `mvp` of `points` ((3, N), any float type: float32 is
    twice as fast and the GPU projects in float32 too), grown by `margin` pixels and clipped to the image; None
    when a point lies on or behind the eye's plane (w <= 0: the projection is unbounded). Every pixel whose
    centre a triangle between these points covers lies inside it: each triangle projects inside the hull of
    its corners' projections."""
    w, h = size
    if points.shape[1] == 0:
        return (0, 0, 0, 0)
    m = np.asarray(mvp, dtype=np.float64)[[0, 1, 3]]
    clip = m[:, :3].astype(points.dtype) @ points + m[:, 3:4].astype(points.dtype)
    cw = clip[2]
    if not np.isfinite(clip).all() or cw.min() <= 1e-9:
        return None
    x, y = clip[0] / cw, clip[1] / cw
    lo_px = np.array([x.min(), y.min()], dtype=np.float64)
    hi_px = np.array([x.max(), y.max()], dtype=np.float64)
    lo_px, hi_px = (lo_px + 1.0) * 0.5 * np.array([w, h]), (hi_px + 1.0) * 0.5 * np.array([w, h])
    if not (np.isfinite(lo_px).all() and np.isfinite(hi_px).all()):
        return None
    x0 = int(np.clip(np.floor(lo_px[0]) - margin, 0, w))
    y0 = int(np.clip(np.floor(lo_px[1]) - margin, 0, h))
    x1 = int(np.clip(np.ceil(hi_px[0]) + margin, 0, w))
    y1 = int(np.clip(np.ceil(hi_px[1]) + margin, 0, h))
    return (x0, y0, max(x1 - x0, 0), max(y1 - y0, 0))


def union(rects: Iterable[Rect | None]) -> Rect | None:
    """The smallest rectangle holding every one of `rects` (empty ones add nothing); None if any is None."""
    x0 = y0 = np.inf
    x1 = y1 = -np.inf
    for r in rects:
        if r is None:
            return None
        if r[2] <= 0 or r[3] <= 0:
            continue
        x0, y0 = min(x0, r[0]), min(y0, r[1])
        x1, y1 = max(x1, r[0] + r[2]), max(y1, r[1] + r[3])
    if x0 == np.inf:
        return (0, 0, 0, 0)
    return (int(x0), int(y0), int(x1 - x0), int(y1 - y0))


def grow(rect: Rect | None, dx: int, dy: int, size: tuple[int, int]) -> Rect | None:
    """`rect` grown by `dx` pixels left and right and `dy` up and down, clipped to the image (None stays
    None; an empty rectangle stays empty: nothing in it to spread)."""
    if rect is None or rect[2] <= 0 or rect[3] <= 0:
        return rect
    w, h = size
    x0, y0 = max(rect[0] - dx, 0), max(rect[1] - dy, 0)
    x1, y1 = min(rect[0] + rect[2] + dx, w), min(rect[1] + rect[3] + dy, h)
    return (x0, y0, max(x1 - x0, 0), max(y1 - y0, 0))


def of(value: Any) -> Footprint | None:
    """A value's footprint (None: unknown, or footprints switched off)."""
    return getattr(value, "footprint", None) if ENABLED else None


def covers_image(rect: Rect | None, size: tuple[int, int]) -> bool:
    """Whether `rect` is the whole image (or unknown): a pass gains nothing from it."""
    return rect is None or (rect[0] <= 0 and rect[1] <= 0 and rect[0] + rect[2] >= size[0]
                            and rect[1] + rect[3] >= size[1])
