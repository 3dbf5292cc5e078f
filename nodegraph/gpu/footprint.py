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

from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from ..values import Footprint

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


def blank_results(gl: Any, key: Any, inputs: Sequence[tuple[str, tuple[float, ...]]],
                  run: Callable[[list[Any]], list[Any]]) -> list[tuple[float, ...]] | None:
    """What a chain of passes writes at a pixel where everything it reads holds its blank value, for passes
    whose output depends on the pixel only through what they fetch (filters, not noise by position).

    `run` draws the passes on 1x1 textures of `inputs` (format and blank value each, in order) and returns
    its 1x1 outputs; their texels are read back once and kept by `key` for the GL context. The programs and
    uniforms are the full image's, and every fetch of a 1x1 texture, clamped, returns its one texel, so the
    values carry the same bits the passes give outside their inputs' footprints (a sum of equal terms in
    the same order). A pass's own formula for such a constant would have to match the shader's rounding and
    signs (depth_edges gives its gradient -0.0 on a constant depth, and force_field's field differs between a
    -0.0 and a 0.0 gradient); this asks the shader. None when a value is not finite."""
    # by the blank values' bits: -0.0 == 0.0 (and hashes alike), but a pass may give different bits for them
    cache_key = ("blank-results", key, tuple((fmt, np.asarray(blank, np.float32).tobytes()) for fmt, blank in inputs))
    if cache_key in gl.resources:
        return gl.resources[cache_key]
    from .. import types

    # each source holds its blank as a clear stores it, which is how the passes' targets got it outside their
    # footprints (`GL.fullscreen(rect=, blanks=)`): the same conversion to the format, whatever its rounding
    sources = [gl.texture((1, 1), fmt, filter="nearest") for fmt, _ in inputs]
    for tex, (_, blank) in zip(sources, inputs, strict=True):
        gl.framebuffer([tex]).clear(*(tuple(float(b) for b in blank) + (0.0,) * (4 - len(blank))))
    outputs: list[Any] = []
    try:
        outputs = run(sources)
        values = []
        for tex in outputs:
            comps = types.components(tex.fmt)
            texel = np.empty(comps, np.float32)
            gl.framebuffer([tex]).read_into(texel, viewport=(0, 0, 1, 1), components=comps, alignment=1, dtype="f4")
            values.append(tuple(float(v) for v in texel))
    finally:
        for tex in sources + outputs:
            gl.release(tex)
    result = values if all(np.isfinite(v).all() for v in values) else None
    gl.resources[cache_key] = result
    return result
