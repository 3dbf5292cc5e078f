"""Strokes as triangles for the GPU (mitred joins, round caps drawn by the fragment shader), and the procedural
brush textures. Pure NumPy: the tests read these arrays directly."""

from __future__ import annotations

import numpy as np

MITER_LIMIT = 4.0  # a join's offset is at most this many half-widths from its vertex
FLOATS = 9  # per vertex: x, y, across, along, beyond, half-width, dir x, dir y, alpha


def expand(xy: np.ndarray, starts: np.ndarray, half_width: np.ndarray, alpha: np.ndarray, margin: float
           ) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (V, FLOATS) float32, indices (T, 3) uint32) for polylines `xy` (N, 2) split by `starts`, each
    vertex `half_width` (N,) pixels and `alpha` (N,) darkness. Each vertex becomes two, offset from the centre
    line by (half_width + margin) along the mitred normal; a segment is two triangles; each end gets a cap quad
    reaching (half_width + margin) past it, where the shader rounds the stroke off (`beyond` > 0). A stroke of one
    point (or of coincident points) is a dot."""
    xy = np.asarray(xy, np.float64).reshape(-1, 2)
    starts = np.asarray(starts, np.int64)
    n = len(xy)
    if n == 0:
        return np.zeros((0, FLOATS), np.float32), np.zeros((0, 3), np.uint32)
    sid = np.repeat(np.arange(len(starts) - 1), np.diff(starts))
    # drop repeated points (zero-length segments have no direction)
    keep = np.ones(n, bool)
    same = (np.hypot(*(xy[1:] - xy[:-1]).T) < 1e-6) & (sid[1:] == sid[:-1])
    keep[1:] = ~same
    xy, sid, hw, alpha = xy[keep], sid[keep], np.asarray(half_width, np.float64)[keep], np.asarray(alpha)[keep]
    n = len(xy)
    first = np.r_[True, sid[1:] != sid[:-1]]
    last = np.r_[sid[1:] != sid[:-1], True]
    seg = xy[1:] - xy[:-1]
    seg_len = np.hypot(*seg.T)
    with np.errstate(invalid="ignore", divide="ignore"):
        seg_dir = seg / seg_len[:, None]
    d_next = np.zeros((n, 2))
    d_prev = np.zeros((n, 2))
    d_next[:-1] = np.where(last[:-1, None], 0.0, seg_dir)
    d_prev[1:] = np.where(first[1:, None], 0.0, seg_dir)
    tangent = d_next + d_prev
    tl = np.hypot(*tangent.T)
    # a dot, or a full reversal: the incoming direction (or +x)
    fallback = np.where((np.hypot(*d_prev.T) > 0)[:, None], d_prev, d_next)
    fallback[np.hypot(*fallback.T) == 0] = (1.0, 0.0)
    tangent = np.where((tl > 1e-9)[:, None], tangent / np.maximum(tl, 1e-12)[:, None], fallback)
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
    ref = np.where((np.hypot(*d_next.T) > 0)[:, None], d_next, d_prev)
    ref_n = np.stack([-ref[:, 1], ref[:, 0]], axis=1)
    cos_half = np.abs((normal * ref_n).sum(axis=1))
    cos_half = np.where(np.hypot(*ref.T) > 0, cos_half, 1.0)
    scale = 1.0 / np.maximum(cos_half, 1.0 / MITER_LIMIT)
    big = hw + margin
    along = np.zeros(n)
    steps = np.r_[0.0, np.where(first[1:], 0.0, seg_len)]
    along = np.cumsum(steps)
    along -= np.maximum.accumulate(np.where(first, along, 0.0))
    off = normal * (big * scale)[:, None]
    a = alpha.astype(np.float64)

    def rows(p: np.ndarray, across: np.ndarray, beyond: np.ndarray, idx: np.ndarray) -> np.ndarray:
        return np.column_stack([p, across, along[idx], beyond, hw[idx], tangent[idx], a[idx]])

    idx = np.arange(n)
    left = rows(xy + off, big, np.zeros(n), idx)
    right = rows(xy - off, -big, np.zeros(n), idx)
    body = np.empty((2 * n, FLOATS))
    body[0::2], body[1::2] = left, right
    # segments: vertices 2i, 2i+1 (left, right at i) and 2i+2, 2i+3 where i and i+1 are one stroke
    segs = np.nonzero(~last)[0]
    l0, r0, l1, r1 = 2 * segs, 2 * segs + 1, 2 * segs + 2, 2 * segs + 3
    tris = [np.column_stack([l0, r0, l1]), np.column_stack([r0, r1, l1])]
    # caps: the end's two vertices and two more pushed (half-width + margin) past it, `beyond` rising to that
    caps = []
    base = 2 * n
    for ends, sign in ((np.nonzero(first)[0], -1.0), (np.nonzero(last)[0], 1.0)):
        push = sign * tangent[ends] * big[ends, None]
        nrm = normal[ends] * big[ends, None]
        e_l = rows(xy[ends] + nrm + push, big[ends], big[ends], ends)
        e_r = rows(xy[ends] - nrm + push, -big[ends], big[ends], ends)
        s_l = rows(xy[ends] + nrm, big[ends], np.zeros(len(ends)), ends)
        s_r = rows(xy[ends] - nrm, -big[ends], np.zeros(len(ends)), ends)
        block = np.empty((4 * len(ends), FLOATS))
        block[0::4], block[1::4], block[2::4], block[3::4] = s_l, s_r, e_l, e_r
        k = base + 4 * np.arange(len(ends))
        tris += [np.column_stack([k, k + 1, k + 2]), np.column_stack([k + 1, k + 3, k + 2])]
        caps.append(block)
        base += 4 * len(ends)
    verts = np.concatenate([body, *caps]).astype(np.float32)
    return verts, np.concatenate(tris).astype(np.uint32)


def _noise(shape: tuple[int, int], rng: np.random.Generator, sigma: tuple[float, float]) -> np.ndarray:
    """Periodic Gaussian-filtered white noise (rows = v, columns = u), unit standard deviation."""
    h, w = shape
    f = np.fft.fft2(rng.standard_normal(shape))
    fy, fx = np.fft.fftfreq(h)[:, None], np.fft.fftfreq(w)[None, :]
    f *= np.exp(-2 * np.pi**2 * ((fx * sigma[0]) ** 2 + (fy * sigma[1]) ** 2))
    out = np.real(np.fft.ifft2(f))
    return (out - out.mean()) / max(out.std(), 1e-12)


BRUSH_SIZE = (256, 32)  # texels along (u, repeating) x across (v)


def brush_texture(brush: str) -> np.ndarray:
    """(32, 256) float32 in [0, 1]: the brush's darkness, rows across the stroke (v), columns along it (u),
    periodic along u. ink: 1 (solid; its soft edge is the coverage ramp); pencil: graphite streaks along the
    stroke over fine grain; chalk: broken: coarse blotches with gaps, ragged near the edges."""
    w, h = BRUSH_SIZE
    if brush == "ink":
        return np.ones((h, w), np.float32)
    rng = np.random.default_rng({"pencil": 1, "chalk": 2}[brush])
    v = np.abs(np.linspace(-1.0, 1.0, h))[:, None]
    if brush == "pencil":
        streaks = _noise((h, w), rng, (6.0, 0.7))  # long along u, thin across
        grain = _noise((h, w), rng, (0.6, 0.6))
        t = 0.78 + 0.16 * streaks + 0.10 * grain - 0.15 * v**4
        return np.clip(t, 0.0, 1.0).astype(np.float32)
    blotch = _noise((h, w), rng, (3.0, 2.0))
    grain = _noise((h, w), rng, (0.7, 0.7))
    t = 0.62 + 0.35 * blotch + 0.2 * grain - 0.45 * v**4
    return np.clip(1.6 * t, 0.0, 1.0).astype(np.float32)
