"""The stylisation of `stroke_style` as float64 NumPy on flat stroke arrays (no GL): surface points, screen
tangents, uncertainty, shake, pressure, overshoot, width and taper. Each function is documented with the formula
the tests check by hand."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodegraph.node import derive_seed
from nodegraph.values import Strokes

from .._shared import noise

# what each copy's sub-seed is for (derive_seed(seed, "stroke_style:" + purpose, copy))
PURPOSES = ("uncertainty", "shake", "pressure", "overshoot")


def sub_seed(seed: int, copy: int, purpose: str) -> int:
    """The seed of one purpose of copy `copy`: a sha256-derived 32-bit number (nodegraph.node.derive_seed)."""
    return derive_seed(int(seed), f"stroke_style:{purpose}", int(copy))


def noise_at(points: np.ndarray, frequency: float, seed: int, octaves: int) -> np.ndarray:
    """(N,) signed fractal Perlin noise (improved noise, nodes/_shared/noise.py `fbm`) at points (N, 3) scaled by
    `frequency`, the domain moved by `noise.seed_offset(seed)`: fbm(points * frequency + seed_offset(seed))."""
    q = np.asarray(points, np.float64) * frequency + noise.seed_offset(seed)
    return noise.fbm(q[:, 0], q[:, 1], q[:, 2], octaves)


def stroke_ids(starts: np.ndarray) -> np.ndarray:
    """(N,) the stroke each vertex belongs to."""
    return np.repeat(np.arange(len(starts) - 1), np.diff(starts))


def closed_strokes(xy: np.ndarray, starts: np.ndarray, tol: float = 1e-3) -> np.ndarray:
    """(M,) bool: strokes of 3 or more vertices whose last vertex is their first (within `tol` px)."""
    a, b = starts[:-1], starts[1:]
    n = b - a
    ok = n >= 3
    out = np.zeros(len(n), bool)
    if ok.any():
        d = np.hypot(*(xy[b[ok] - 1] - xy[a[ok]]).T)
        out[ok] = d <= tol
    return out


def neighbour(starts: np.ndarray, closed: np.ndarray, step: int) -> np.ndarray:
    """(N,) index of the vertex `step` vertices further along each vertex's stroke: clamped to the stroke's ends on
    open strokes, wrapped around the loop (whose last vertex repeats the first) on closed ones."""
    sid = stroke_ids(starts)
    a = starts[:-1][sid]
    n = np.diff(starts)[sid]
    r = np.arange(len(sid)) - a
    clamped = np.clip(r + step, 0, np.maximum(n - 1, 0))
    period = np.maximum(n - 1, 1)
    wrapped = np.mod(np.minimum(r, period - 1) + step, period)
    return a + np.where(closed[sid], wrapped, clamped)


def tangents(xy: np.ndarray, starts: np.ndarray, closed: np.ndarray, span: int = 2) -> np.ndarray:
    """(N, 2) unit screen tangents: xy[i + span] - xy[i - span] (neighbours as `neighbour`) normalised; zero on
    strokes of one vertex."""
    p = xy.astype(np.float64)
    d = p[neighbour(starts, closed, span)] - p[neighbour(starts, closed, -span)]
    norm = np.hypot(d[:, 0], d[:, 1])
    return np.where(norm[:, None] > 1e-12, d / np.maximum(norm, 1e-12)[:, None], 0.0)


def normals(t: np.ndarray) -> np.ndarray:
    """(N, 2) the screen normal left of the direction of travel: (-t_y, t_x)."""
    return np.stack([-t[:, 1], t[:, 0]], axis=1)


def curvature(xy: np.ndarray, starts: np.ndarray, closed: np.ndarray, span: int = 3) -> np.ndarray:
    """(N,) screen curvature in 1/px: the turning angle between xy[i] - xy[i - span] and xy[i + span] - xy[i]
    over the mean of their lengths (0 at the ends of open strokes)."""
    p = xy.astype(np.float64)
    a = p - p[neighbour(starts, closed, -span)]
    b = p[neighbour(starts, closed, span)] - p
    la, lb = np.hypot(*a.T), np.hypot(*b.T)
    ang = np.abs(np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], (a * b).sum(1)))
    ok = (la > 1e-9) & (lb > 1e-9)
    return np.where(ok, ang / np.maximum(0.5 * (la + lb), 1e-9), 0.0)


def end_directions(xy: np.ndarray, starts: np.ndarray, reach: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
    """((M, 2), (M, 2)) unit directions out of each stroke's first and last vertex: from the first vertex at least
    `reach` px along the stroke (or the far end) back to the end vertex; zero on strokes shorter than 2 vertices
    or of zero length."""
    m = len(starts) - 1
    head, tail = np.zeros((m, 2)), np.zeros((m, 2))
    p = xy.astype(np.float64)
    seg = np.hypot(*np.diff(p, axis=0).T) if len(p) > 1 else np.zeros(0)
    cum = np.r_[0.0, np.cumsum(seg)]
    for i in range(m):  # per stroke: searchsorted on its arc length
        a, b = int(starts[i]), int(starts[i + 1])
        if b - a < 2:
            continue
        s = cum[a:b] - cum[a]
        j = min(int(np.searchsorted(s, reach)), b - a - 1)
        k = max(int(np.searchsorted(s, s[-1] - reach, side="right")) - 1, 0)
        for out, u, v in ((head, p[a], p[a + j]), (tail, p[b - 1], p[a + k])):
            d = u - v
            n = float(np.hypot(*d))
            if n > 1e-9:
                out[i] = d / n
    return head, tail


def taper(arc: np.ndarray, total: np.ndarray, length: float, floor: float) -> np.ndarray:
    """Width factor near the ends: floor + (1 - floor) * smoothstep(0, length, min(arc, total - arc))."""
    if length <= 0:
        return np.ones_like(arc)
    u = np.clip(np.minimum(arc, total - arc) / length, 0.0, 1.0)
    return floor + (1.0 - floor) * u * u * (3.0 - 2.0 * u)


def arc_lengths(xy: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((N,) arc length of each vertex from its stroke's first vertex, (N,) its stroke's length), pixels."""
    p = xy.astype(np.float64)
    if len(p) == 0:
        return np.zeros(0), np.zeros(0)
    seg = np.r_[0.0, np.hypot(*np.diff(p, axis=0).T)]
    seg[starts[:-1][np.diff(starts) > 0]] = 0.0  # no segment between strokes
    cum = np.cumsum(seg)
    sid = stroke_ids(starts)
    first = cum[starts[:-1]][sid] if len(starts) > 1 else cum
    arc = cum - first
    lens = np.diff(starts)
    last = cum[np.maximum(starts[1:] - 1, 0)] - cum[np.minimum(starts[:-1], len(p) - 1)]
    return arc, np.where(lens > 0, last, 0.0)[sid]


@dataclass(frozen=True)
class Style:
    """The stylisation, in pixels of the image being drawn (px_scale applied) and cycles per object-space unit."""

    repeats: int = 2
    amplitude: float = 4.0
    frequency: float = 1.0
    octaves: int = 2
    shake: float = 2.0
    shake_frequency: float = 0.25
    pressure: float = 0.35
    repeat_tone: float = 0.8
    overshoot: float = 5.0
    overshoot_jitter: float = 0.5
    overshoot_cap: float = 0.5  # at most this fraction of the stroke's length at each end
    spacing: float = 1.0
    width_by: str = "depth"
    width_range: tuple[float, float] = (0.6, 1.6)
    curvature_radius: float = 20.0
    taper: float = 8.0
    taper_floor: float = 0.2
    screen_frequency: float = 0.01  # cycles per pixel for vertices without a surface point


def surface_points(strokes: Strokes, rest_vertices: dict[int, tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """(N, 3) the point each vertex's noise is evaluated at: sum_k bary_k * V[F[face, k]] on the object's rest-pose
    mesh (`rest_vertices[obj]` = (V, F)) where face and bary are known, else `pos`, else NaN."""
    obj, face = strokes["obj"], strokes["face"]
    bary = strokes["bary"].astype(np.float64)
    out = strokes["pos"].astype(np.float64).copy()
    for o in np.unique(obj[obj >= 0]):
        if int(o) not in rest_vertices:
            continue
        V, F = rest_vertices[int(o)]
        sel = (obj == o) & (face >= 0) & (face < len(F)) & np.isfinite(bary).all(1)
        if sel.any():
            out[sel] = np.einsum("nk,nkd->nd", bary[sel], V[F[face[sel]]])
    return out


def stylise(strokes: Strokes, points: np.ndarray, style: Style, seed: int, z_ref: float | None = None) -> Strokes:
    """`style.repeats` stylised copies of every stroke (copy c of stroke i is output stroke c * M + i):

    * noise point q: `points` (surface points, scene units), or (x, y, 0) * screen_frequency / frequency where
      NaN (strokes without a surface point: screen-space noise);
    * uncertainty: xy += amplitude * fbm(q * frequency + seed_offset(s_u)) * normal (screen normal of the input
      stroke, `tangents`/`normals`), s_u = sub_seed(seed, c, "uncertainty");
    * shake: xy += shake * noise3_at(q, 1, s_s, "fbm", shake_frequency) (two channels: a smooth 2D shift);
    * pressure: tone *= repeat_tone^c * (1 - pressure * clip(0.5 + fbm(q * frequency + seed_offset(s_p)), 0, 1));
    * overshoot: open strokes extended past each end by overshoot * (1 + jitter * n), n = fbm at the end's point
      (seed s_o, one octave, clipped to [-1, 1]), at most overshoot_cap x the stroke's length,
      along `end_directions` of the input stroke, vertices at most `spacing` px apart (attributes of the end vertex);
    * width: the vertex's width (or the strokes' width) x by-depth factor clip(z_ref / depth, lo, hi) or
      by-curvature factor lo + (hi - lo) * min(1, curvature * curvature_radius), x `taper` over the extended
      stroke (open strokes only)."""
    m = len(strokes)
    if m == 0 or style.repeats == 0:
        return Strokes.from_arrays(np.zeros((0, 2), np.float32), np.zeros(1, np.int64), strokes.size,
                                   strokes.width, strokes.color)
    xy = strokes.xy.astype(np.float64)
    starts = strokes.starts
    n_v = np.diff(starts)
    closed = closed_strokes(xy, starts)
    nrm = normals(tangents(xy, starts, closed))
    head_dir, tail_dir = end_directions(xy, starts)
    q = np.asarray(points, np.float64).copy()
    bad = ~np.isfinite(q).all(1)
    if bad.any():
        f = style.frequency if style.frequency > 0 else 1.0
        q[bad] = np.c_[xy[bad] * style.screen_frequency / f, np.zeros(int(bad.sum()))]
    lo, hi = style.width_range
    base_w = np.where(np.isnan(strokes["width"]), strokes.width, strokes["width"]).astype(np.float64)
    if style.width_by == "depth" and z_ref is not None and z_ref > 0:
        z = strokes["depth"].astype(np.float64)
        fac = np.where(np.isfinite(z) & (z > 0), np.clip(z_ref / np.where(z > 0, z, 1.0), lo, hi), 1.0)
    elif style.width_by == "curvature":
        fac = lo + (hi - lo) * np.minimum(1.0, curvature(xy, starts, closed) * style.curvature_radius)
    else:
        fac = np.ones(len(xy))
    width0 = base_w * fac
    open_ = ~closed & (n_v >= 2) & (np.hypot(*head_dir.T) > 0)
    first, last = starts[:-1], np.maximum(starts[1:] - 1, 0)
    lengths = strokes.lengths()
    parts = []
    for c in range(style.repeats):
        p = xy.copy()
        if style.amplitude:
            p += style.amplitude * noise_at(q, style.frequency, sub_seed(seed, c, "uncertainty"), style.octaves)[:,
                                                                                                          None] * nrm
        if style.shake:
            p += style.shake * noise.noise3_at(q, 1, sub_seed(seed, c, "shake"), "fbm", style.shake_frequency)
        tone = strokes["tone"].astype(np.float64) * style.repeat_tone ** c
        if style.pressure:
            pr = np.clip(0.5 + noise_at(q, style.frequency, sub_seed(seed, c, "pressure"), style.octaves), 0, 1)
            tone = tone * (1.0 - style.pressure * pr)
        # overshoot lengths at each end
        over_h = np.zeros(m)
        over_t = np.zeros(m)
        if style.overshoot > 0 and open_.any():
            so = sub_seed(seed, c, "overshoot")
            nh = np.clip(noise_at(q[first[open_]], style.frequency, so, 1), -1, 1)
            nt = np.clip(noise_at(q[last[open_]], style.frequency, so, 1), -1, 1)
            cap = style.overshoot_cap * lengths[open_]
            over_h[open_] = np.clip(style.overshoot * (1 + style.overshoot_jitter * nh), 0, cap)
            over_t[open_] = np.clip(style.overshoot * (1 + style.overshoot_jitter * nt), 0, cap)
        parts.append(_extend(strokes, p, tone, width0, over_h, over_t, head_dir, tail_dir, style.spacing))
    xy_o = np.concatenate([pt[0] for pt in parts])
    lens = np.concatenate([np.diff(pt[1]) for pt in parts])
    starts_o = np.r_[0, np.cumsum(lens)].astype(np.int64)
    attrs = {k: np.concatenate([pt[2][k] for pt in parts]) for k in parts[0][2]}
    if style.taper > 0:
        arc, total = arc_lengths(xy_o, starts_o)
        closed_o = np.tile(closed, style.repeats)
        t = taper(arc, total, style.taper, style.taper_floor)
        attrs["width"] = np.where(closed_o[stroke_ids(starts_o)], attrs["width"], attrs["width"] * t)
    return Strokes.from_arrays(xy_o, starts_o, strokes.size, strokes.width, strokes.color, attrs)


def _extend(strokes: Strokes, xy: np.ndarray, tone: np.ndarray, width: np.ndarray, over_h: np.ndarray,
            over_t: np.ndarray, head_dir: np.ndarray, tail_dir: np.ndarray,
            spacing: float) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """The strokes with `over_h` / `over_t` px added before the first and after the last vertex (ceil(len /
    spacing) new vertices evenly spaced, the end vertex's attributes): (xy, starts, attrs)."""
    starts = strokes.starts
    n_v = np.diff(starts)
    nh = np.where(over_h > 0, np.ceil(over_h / spacing), 0).astype(np.int64)
    nt = np.where(over_t > 0, np.ceil(over_t / spacing), 0).astype(np.int64)
    n_new = nh + n_v + nt
    new_starts = np.r_[0, np.cumsum(n_new)].astype(np.int64)
    sid = stroke_ids(new_starts)
    r = np.arange(new_starts[-1]) - new_starts[:-1][sid]
    h, n = nh[sid], n_v[sid]
    in_head = r < h
    in_tail = r >= h + n
    src = starts[:-1][sid] + np.clip(r - h, 0, np.maximum(n - 1, 0))
    dist = np.zeros(len(r))
    dist[in_head] = (over_h[sid] * (h - r) / np.maximum(h, 1))[in_head]
    j = r - h - n + 1
    dist[in_tail] = (over_t[sid] * j / np.maximum(nt[sid], 1))[in_tail]
    direction = np.where(in_head[:, None], head_dir[sid], np.where(in_tail[:, None], tail_dir[sid], 0.0))
    out_xy = xy[src] + dist[:, None] * direction
    attrs = {k: v[src] for k, v in strokes.attrs.items()}
    attrs["tone"] = tone[src].astype(np.float32)
    attrs["width"] = width[src].astype(np.float32)
    return out_xy.astype(np.float32), new_starts, attrs
