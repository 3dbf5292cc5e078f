"""The strictly sequential particle sketcher, compiled with Numba: one particle at a time, as Curtis
describes it, each seeing every line drawn before it.

It is the algorithm of `core.simulate_python` (the pure-Python reference) statement for statement: the
same random streams, the same operation order in every floating-point expression (Numba keeps IEEE
semantics without fastmath), the same padding, the same order of inking and erasing. So its strokes,
ink and remaining edge map equal the reference's bit for bit (tested), at a small fraction of the cost:
the reference spends its time in the interpreter, not in arithmetic.

Why Numba rather than NumPy lock-steps or a compute shader: the method is sequential (a particle erases
what the next would trace, and a start is tested against the ink drawn so far), and a stroke is a few
dozen dependent steps. Vectorising across particles (`core.simulate` with batch > 1) has to run
particles concurrently, which changes the drawing (docs/particles.md measures how); a GPU would have the
same problem with thousands of threads and one shared ink image. Compiled scalar code keeps the
semantics exact and is faster than both on this machine.

The kernel is compiled on first use and cached on disk (`cache=True`, in `__pycache__` beside this
file), one specialisation per field dtype (float32 from the GPU, float64 from the references).
"""

from __future__ import annotations

import math
import os
import sys

import numpy as np
from numba import njit

from . import rng
from .common import LINE_LEVEL, ParticleParams, Sites, SketchResult, disc_offsets, pad_for

_U = np.uint64
GOLD, STROKE, M1, M2 = _U(rng.GOLD), _U(rng.STROKE), _U(rng.M1), _U(rng.M2)
TO_UNIT, TO_UNIT32 = rng.TO_UNIT, rng.TO_UNIT32
S11, S27, S30, S31, S32 = _U(11), _U(27), _U(30), _U(31), _U(32)
LOW32, ONE, TWO = _U(0xFFFFFFFF), _U(1), _U(2)


@njit(cache=True, nogil=True)
def _mix(z):
    z = z + GOLD
    z = (z ^ (z >> S30)) * M1
    z = (z ^ (z >> S27)) * M2
    return z ^ (z >> S31)


@njit(cache=True, nogil=True)
def _near(mask, ix, iy, pad, off):
    for k in range(off.shape[0]):  # noqa: SIM110 - an explicit loop compiles to a plain loop
        if mask[iy + pad + off[k, 1], ix + pad + off[k, 0]]:
            return True
    return False


@njit(cache=True, nogil=True)
def _near_ink(ink, ix, iy, pad, off):
    for k in range(off.shape[0]):  # noqa: SIM110
        if ink[iy + pad + off[k, 1], ix + pad + off[k, 0]] >= LINE_LEVEL:
            return True
    return False


@njit(cache=True, nogil=True)
def _sample(ff, c, w, h, x, y):
    """Component c of the field, bilinear between pixel centres, clamped; corners widened to float64."""
    u, v = x - 0.5, y - 0.5
    u = (w - 1.0 if u > w - 1.0 else u) if u >= 0.0 else 0.0
    v = (h - 1.0 if v > h - 1.0 else v) if v >= 0.0 else 0.0
    i, j = min(int(u), w - 2), min(int(v), h - 2)
    tx, ty = u - i, v - j
    f00, f10 = np.float64(ff[j, i, c]), np.float64(ff[j, i + 1, c])
    f01, f11 = np.float64(ff[j + 1, i, c]), np.float64(ff[j + 1, i + 1, c])
    a0 = f00 + ty * (f01 - f00)
    a1 = f10 + ty * (f11 - f10)
    return a0 + tx * (a1 - a0)


@njit(cache=True, nogil=True)
def _draw(ink, edge, pad, hw, re, reach, ax, ay, bx, by):
    dx, dy = bx - ax, by - ay
    l2 = dx * dx + dy * dy
    l2 = l2 if l2 > 0.0 else 1.0
    for j in range(math.ceil(min(ay, by) - 0.5 - reach), math.floor(max(ay, by) - 0.5 + reach) + 1):
        for i in range(math.ceil(min(ax, bx) - 0.5 - reach), math.floor(max(ax, bx) - 0.5 + reach) + 1):
            ex, ey = (i + 0.5) - ax, (j + 0.5) - ay
            t = min(max((ex * dx + ey * dy) / l2, 0.0), 1.0)
            ex = ex - t * dx
            ey = ey - t * dy
            d = math.sqrt(ex * ex + ey * ey)
            cov = hw + 0.5 - d
            if cov > 0.0 and min(cov, 1.0) > ink[j + pad, i + pad]:
                ink[j + pad, i + pad] = min(cov, 1.0)
            if d <= re:
                edge[j + pad, i + pad] = False


@njit(cache=True, nogil=True)
def _run(edge, ink, ff, pad, n_off, m_off, key, strokes, retries, max_steps, rk4,
         dt, drag, inv_mass, rnd, hw, re, reach, site_xy, site_key, use_sites):
    """Draws into the padded maps `edge` and `ink`; returns (points (k, 2), points per stroke, launched,
    segments, exhausted). With `use_sites`, the starts are the sites (`site_xy`, in order: the next valid one
    each stroke) and a stroke's forces come from its site's key."""
    h, w = ff.shape[0], ff.shape[1]
    hdt, dt6 = 0.5 * dt, dt / 6.0
    pts = np.empty((max(1024, 4 * (max_steps + 1)), 2), np.float64)
    counts = np.empty(max(16, min(strokes, 1 << 16)), np.int64)
    npts = nstrokes = launched = total = 0
    exhausted = False
    key = np.uint64(key)
    sp = 0  # the next site to try: a site found invalid stays so (the valid set only shrinks)
    for s in range(strokes):
        skey = _mix(key + (TWO * np.uint64(s)) * STROKE)
        fkey = _mix(key + (TWO * np.uint64(s) + ONE) * STROKE)
        found = False
        x = y = 0.0
        if use_sites:
            while sp < site_xy.shape[0]:
                x, y = site_xy[sp, 0], site_xy[sp, 1]
                fkey = _mix(key + (TWO * site_key[sp] + ONE) * STROKE)
                sp += 1
                ix, iy = min(int(x), w - 1), min(int(y), h - 1)
                if _near(edge, ix, iy, pad, n_off) and not _near_ink(ink, ix, iy, pad, m_off):
                    found = True
                    break
        else:
            for k in range(retries):
                z = _mix(skey + np.uint64(k) * GOLD)
                x = np.float64(z >> S32) * TO_UNIT32 * w
                y = np.float64(z & LOW32) * TO_UNIT32 * h
                ix, iy = min(int(x), w - 1), min(int(y), h - 1)
                if _near(edge, ix, iy, pad, n_off) and not _near_ink(ink, ix, iy, pad, m_off):
                    found = True
                    break
        if not found:
            exhausted = True
            break
        launched += 1
        if npts + max_steps + 1 > pts.shape[0]:  # room for the whole stroke
            grown = np.empty((2 * pts.shape[0] + max_steps + 1, 2), np.float64)
            grown[:npts] = pts[:npts]
            pts = grown
        first = npts
        pts[npts, 0], pts[npts, 1] = x, y
        npts += 1
        vx = vy = 0.0
        for t in range(max_steps):
            rx = rnd * (2.0 * (np.float64(_mix(fkey + np.uint64(2 * t) * GOLD) >> S11) * TO_UNIT) - 1.0)
            ry = rnd * (2.0 * (np.float64(_mix(fkey + np.uint64(2 * t + 1) * GOLD) >> S11) * TO_UNIT) - 1.0)
            a1x = (_sample(ff, 0, w, h, x, y) - drag * vx + rx) * inv_mass
            a1y = (_sample(ff, 1, w, h, x, y) - drag * vy + ry) * inv_mass
            if rk4:
                x2, y2 = x + hdt * vx, y + hdt * vy
                v2x, v2y = vx + hdt * a1x, vy + hdt * a1y
                a2x = (_sample(ff, 0, w, h, x2, y2) - drag * v2x + rx) * inv_mass
                a2y = (_sample(ff, 1, w, h, x2, y2) - drag * v2y + ry) * inv_mass
                x3, y3 = x + hdt * v2x, y + hdt * v2y
                v3x, v3y = vx + hdt * a2x, vy + hdt * a2y
                a3x = (_sample(ff, 0, w, h, x3, y3) - drag * v3x + rx) * inv_mass
                a3y = (_sample(ff, 1, w, h, x3, y3) - drag * v3y + ry) * inv_mass
                x4, y4 = x + dt * v3x, y + dt * v3y
                v4x, v4y = vx + dt * a3x, vy + dt * a3y
                a4x = (_sample(ff, 0, w, h, x4, y4) - drag * v4x + rx) * inv_mass
                a4y = (_sample(ff, 1, w, h, x4, y4) - drag * v4y + ry) * inv_mass
                nx = x + dt6 * (vx + 2.0 * v2x + 2.0 * v3x + v4x)
                ny = y + dt6 * (vy + 2.0 * v2y + 2.0 * v3y + v4y)
                nvx = vx + dt6 * (a1x + 2.0 * a2x + 2.0 * a3x + a4x)
                nvy = vy + dt6 * (a1y + 2.0 * a2y + 2.0 * a3y + a4y)
            else:
                nx, ny = x + dt * vx, y + dt * vy
                nvx, nvy = vx + dt * a1x, vy + dt * a1y
            if not (math.isfinite(nvx) and math.isfinite(nvy) and 0.0 <= nx < w and 0.0 <= ny < h):
                break
            alive = _near(edge, int(nx), int(ny), pad, n_off)  # before this segment's erasure
            _draw(ink, edge, pad, hw, re, reach, x, y, nx, ny)
            total += 1
            pts[npts, 0], pts[npts, 1] = nx, ny
            npts += 1
            x, y, vx, vy = nx, ny, nvx, nvy
            if not alive:
                break
        if npts - first >= 2:
            if nstrokes == counts.shape[0]:
                grown_c = np.empty(2 * counts.shape[0], np.int64)
                grown_c[:nstrokes] = counts[:nstrokes]
                counts = grown_c
            counts[nstrokes] = npts - first
            nstrokes += 1
        else:
            npts = first  # a stroke of one point is not kept
    return pts[:npts], counts[:nstrokes], launched, total, exhausted


def _offsets(r: float) -> np.ndarray:
    return np.array(disc_offsets(r), np.int64).reshape(-1, 2)


def _say_if_compiling() -> None:
    """One line on stderr before the kernel is compiled rather than loaded from the disk cache, so that a
    first run's pause is explained. Reads Numba's cache index path (not public API): silent if that fails."""
    if _run.signatures:  # already loaded in this process
        return
    try:
        cached = os.path.exists(_run._cache._cache_file._index_path)
    except Exception:  # noqa: BLE001 - only a message depends on it
        return
    if not cached:
        print("particle_sketch: compiling the sequential sketcher with Numba (first use after install or an "
              "update; cached on disk afterwards) ...", file=sys.stderr, flush=True)


def simulate_sequential(edges: np.ndarray, ff: np.ndarray, params: ParticleParams, key: int,
                        sites: Sites | None = None) -> SketchResult:
    """Runs the compiled sequential sketcher on checked inputs (`core.simulate` checks them)."""
    h, w = np.shape(edges)
    pad = pad_for(params)
    edge = np.zeros((h + 2 * pad, w + 2 * pad), np.bool_)
    edge[pad:pad + h, pad:pad + w] = np.asarray(edges, bool)
    ink = np.zeros(edge.shape, np.float64)
    ffa = np.asarray(ff)
    if ffa.dtype not in (np.float32, np.float64):
        ffa = ffa.astype(np.float64)
    hw, re = params.line_width / 2.0, params.erase / 2.0
    _say_if_compiling()
    pts, counts, launched, total, exhausted = _run(
        edge, ink, ffa, pad, _offsets(params.n), _offsets(params.m), np.uint64(key), params.strokes, params.retries,
        params.max_steps, params.integrator == "rk4", float(params.step), float(params.drag),
        1.0 / params.mass, float(params.randomness), hw, re, max(hw + 0.5, re),
        sites.xy if sites is not None else np.zeros((0, 2)), sites.key if sites is not None else np.zeros(0, np.uint64),
        sites is not None)
    pts32 = pts.astype(np.float32)
    ends = np.cumsum(counts)
    strokes = [pts32[a:b] for a, b in zip((ends - counts).tolist(), ends.tolist(), strict=True)]
    return SketchResult(sketch=ink[pad:pad + h, pad:pad + w].astype(np.float32), edges=edge[pad:pad + h, pad:pad + w],
                        strokes=strokes, launched=int(launched), steps=int(total), exhausted=bool(exhausted))
