"""The streamline loop of `hatch` (streamlines.Hatcher with hatch's grid field and tone spacing) compiled with
Numba: streamline growth, the separation test against the grid of earlier samples, and the seeding (Jobard and
Lefer's queue of neighbour seeds, or fixed seeds in their order).

It is the Python code of streamlines.Hatcher and hatch's `field` / `dsep` statement for statement, in the same
floating-point operation order (Numba keeps IEEE semantics without fastmath), so the streamlines are the same
bit for bit (tested against the Python path, `hatch(..., engine="python")`). The Python grid (a dict of lists per
cell) becomes linked lists per cell in flat arrays: a rejected streamline is always the newest, so removing it
pops its samples off the lists' heads. The queue of accepted streamlines is the list of streamlines itself: each
is queued as it is accepted and taken in that order.

One thread (threads contend with llvmpipe's in a pipeline). Compiled on first use and cached on disk
(`cache=True`, in `__pycache__` beside this file, or NUMBA_CACHE_DIR).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _pixel(x, y, w, h):  # pragma: no cover - compiled
    return min(max(int(y), 0), h - 1), min(max(int(x), 0), w - 1)


@njit(cache=True, nogil=True)
def _field(x, y, dirs, strength, ids, bright, obj, limit, fcell, w, h):  # pragma: no cover - compiled
    """hatch's `field`: (defined, dx, dy)."""
    r, c = _pixel(x, y, w, h)
    if ids[r, c] == 0 or ids[r, c] != obj or bright[r, c] >= limit:
        return False, 0.0, 0.0
    rows, cols = strength.shape
    gr, gc = min(int(y / fcell), rows - 1), min(int(x / fcell), cols - 1)
    if gr < 0:  # Python's negative index
        gr += rows
    if gc < 0:
        gc += cols
    if strength[gr, gc] <= 1e-9:
        return False, 0.0, 0.0
    return True, dirs[gr, gc, 0], dirs[gr, gc, 1]


@njit(cache=True, nogil=True)
def _dsep(x, y, bright, lo, hi, w, h):  # pragma: no cover - compiled
    """hatch's `dsep`: lo + (hi - lo) x min(max(b, 0), 1), Python's min / max (NaN stays)."""
    r, c = _pixel(x, y, w, h)
    b = bright[r, c]
    if b < 0.0:
        b = 0.0
    if b > 1.0:
        b = 1.0
    return lo + (hi - lo) * b


@njit(cache=True, nogil=True)
def _free(x, y, line, index, gpts, gmeta, head, gcell, gcols, bright, lo, hi, stop_ratio, step, w,
          h):  # pragma: no cover - compiled
    """Hatcher._free: no sample of another streamline (nor of this one, more than 3 d_test back) within d_test.
    The cells r x cols + c of the 3 x 3 neighbourhood, as the dict keys are (one off the side wraps a row)."""
    dt = stop_ratio * _dsep(x, y, bright, lo, hi, w, h)
    dt2 = dt * dt
    ci, ri = int(x / gcell), int(y / gcell)
    guard = 3.0 * dt / step
    ncells = head.shape[0]
    for r in range(ri - 1, ri + 2):
        for c in range(ci - 1, ci + 2):
            key = r * gcols + c
            if key < 0 or key >= ncells:
                continue
            p = head[key]
            while p >= 0:
                if not (gmeta[p, 0] == line and abs(gmeta[p, 1] - index) <= guard) \
                        and (gpts[p, 0] - x) ** 2 + (gpts[p, 1] - y) ** 2 < dt2:
                    return False
                p = gmeta[p, 2]
    return True


@njit(cache=True, nogil=True)
def _add(x, y, line, index, gpts, gmeta, head, n, gcell, gcols):  # pragma: no cover - compiled
    key = int(y / gcell) * gcols + int(x / gcell)
    gpts[n, 0], gpts[n, 1] = x, y
    gmeta[n, 0], gmeta[n, 1], gmeta[n, 2] = line, index, head[key]
    head[key] = n


@njit(cache=True, nogil=True)
def _grow(x, y, d0, d1, line, sign, buf, gpts, gmeta, head, n, gcell, gcols, dirs, strength, ids, bright, obj,
          limit, fcell, lo, hi, stop_ratio, step, max_steps, w, h):  # pragma: no cover - compiled
    """Hatcher._grow into buf; returns the number of samples (each also added to the grid from index n on)."""
    m = 0
    dx, dy = d0 * sign, d1 * sign
    for k in range(1, max_steps):
        ok, fx, fy = _field(x + 0.5 * step * dx, y + 0.5 * step * dy, dirs, strength, ids, bright, obj, limit,
                            fcell, w, h)
        if not ok:
            break
        if not (fx * dx + fy * dy >= 0):
            fx, fy = -fx, -fy
        if fx * dx + fy * dy < 0.5:
            break
        nx, ny = x + step * fx, y + step * fy
        if not (0.0 <= nx < w and 0.0 <= ny < h):
            break
        ok2, _, _ = _field(nx, ny, dirs, strength, ids, bright, obj, limit, fcell, w, h)
        if not ok2 or not _free(nx, ny, line, sign * k, gpts, gmeta, head, gcell, gcols, bright, lo, hi,
                                stop_ratio, step, w, h):
            break
        buf[m, 0], buf[m, 1] = nx, ny
        m += 1
        x, y, dx, dy = nx, ny, fx, fy
        _add(nx, ny, line, sign * k, gpts, gmeta, head, n + m - 1, gcell, gcols)
    return m


@njit(cache=True, nogil=True)
def _streamline(x, y, line, out, o, fwd, back, gpts, gmeta, head, n, gcell, gcols, dirs, strength, ids, bright,
                obj, limit, fcell, lo, hi, stop_ratio, step, min_length, max_steps, w,
                h):  # pragma: no cover - compiled
    """Hatcher.streamline: grows one streamline from (x, y); if kept, writes it to out[o:] and returns its number
    of samples and the grid's new count; else (0, n), its samples taken off the grid again."""
    ok, d0, d1 = _field(x, y, dirs, strength, ids, bright, obj, limit, fcell, w, h)
    if not ok or not (0.0 <= x < w and 0.0 <= y < h) or not _free(x, y, line, 0, gpts, gmeta, head, gcell, gcols,
                                                                 bright, lo, hi, stop_ratio, step, w, h):
        return 0, n
    _add(x, y, line, 0, gpts, gmeta, head, n, gcell, gcols)
    m = n + 1
    nf = _grow(x, y, d0, d1, line, 1, fwd, gpts, gmeta, head, m, gcell, gcols, dirs, strength, ids, bright, obj,
               limit, fcell, lo, hi, stop_ratio, step, max_steps, w, h)
    m += nf
    nb = _grow(x, y, d0, d1, line, -1, back, gpts, gmeta, head, m, gcell, gcols, dirs, strength, ids, bright, obj,
               limit, fcell, lo, hi, stop_ratio, step, max_steps, w, h)
    m += nb
    count = nb + 1 + nf
    length = step * (count - 1)
    if length < min_length or count < 2:
        for p in range(m - 1, n - 1, -1):  # the newest samples are the heads of their cells' lists
            key = int(gpts[p, 1] / gcell) * gcols + int(gpts[p, 0] / gcell)
            head[key] = gmeta[p, 2]
        return 0, n
    for i in range(nb):
        out[o + i, 0], out[o + i, 1] = back[nb - 1 - i, 0], back[nb - 1 - i, 1]
    out[o + nb, 0], out[o + nb, 1] = x, y
    for i in range(nf):
        out[o + nb + 1 + i, 0], out[o + nb + 1 + i, 1] = fwd[i, 0], fwd[i, 1]
    return count, m


@njit(cache=True, nogil=True)
def _grown(a, need):  # pragma: no cover - compiled
    """`a` with room for `need` rows (doubled as often as needed), its rows kept."""
    if need <= a.shape[0]:
        return a
    cap = a.shape[0]
    while cap < need:
        cap *= 2
    b = np.empty((cap,) + a.shape[1:], a.dtype)
    b[:a.shape[0]] = a
    return b


@njit(cache=True, nogil=True)
def hatch_lines(dirs, strength, ids, bright, seeds, objs, limit, lo, hi, fcell, stop_ratio, step, min_length,
                max_steps, queue):  # pragma: no cover - compiled
    """The streamlines of hatch (its Hatcher, fed group by group of object `objs`, the groups in order):
    `queue` True is Hatcher.run (Jobard and Lefer's neighbour seeds first), False Hatcher.run_fixed. Returns the
    samples (n, 2) of all streamlines and their starts (lines + 1)."""
    h, w = ids.shape
    gcell = max(hi * stop_ratio, step)
    gcols, grows = int(w / gcell) + 1, int(h / gcell) + 1
    head = np.full(grows * gcols, -1, np.int64)
    gpts = np.empty((1 << 14, 2))
    gmeta = np.empty((1 << 14, 3), np.int64)
    out = np.empty((1 << 14, 2))
    starts = np.zeros(1 << 10, np.int64)
    fwd = np.empty((max(max_steps, 1), 2))
    back = np.empty((max(max_steps, 1), 2))
    per_line = 2 * max_steps + 1  # the most samples one streamline adds
    n = 0  # samples in the grid
    lines = 0
    done = 0  # streamlines whose neighbour seeds have been tried (the queue: done .. lines - 1)
    nxt = 0
    while True:
        if queue and done < lines:
            q = done
            done += 1
            a, b = starts[q], starts[q + 1]
            for k in range(0, b - a, 2):
                # np.gradient along the streamline, normalised; the normal to the left
                if k == 0:
                    tx, ty = out[a + 1, 0] - out[a, 0], out[a + 1, 1] - out[a, 1]
                elif k == b - a - 1:
                    tx, ty = out[a + k, 0] - out[a + k - 1, 0], out[a + k, 1] - out[a + k - 1, 1]
                else:
                    tx = (out[a + k + 1, 0] - out[a + k - 1, 0]) / 2.0
                    ty = (out[a + k + 1, 1] - out[a + k - 1, 1]) / 2.0
                norm = math.sqrt(tx * tx + ty * ty)
                if not (norm >= 1e-12):
                    norm = 1e-12 if not math.isnan(norm) else norm
                tx, ty = tx / norm, ty / norm
                nx, ny = -ty, tx
                x, y = out[a + k, 0], out[a + k, 1]
                ds = _dsep(x, y, bright, lo, hi, w, h)
                for s in (1.0, -1.0):
                    gpts = _grown(gpts, n + per_line)
                    gmeta = _grown(gmeta, n + per_line)
                    out = _grown(out, starts[lines] + per_line)
                    starts = _grown(starts, lines + 2)
                    count, n = _streamline(x + s * ds * nx, y + s * ds * ny, lines, out, starts[lines], fwd, back,
                                           gpts, gmeta, head, n, gcell, gcols, dirs, strength, ids, bright,
                                           objs[nxt - 1], limit, fcell, lo, hi, stop_ratio, step, min_length,
                                           max_steps, w, h)
                    if count:
                        starts[lines + 1] = starts[lines] + count
                        lines += 1
            continue
        if nxt >= seeds.shape[0]:
            break
        gpts = _grown(gpts, n + per_line)
        gmeta = _grown(gmeta, n + per_line)
        out = _grown(out, starts[lines] + per_line)
        starts = _grown(starts, lines + 2)
        count, n = _streamline(seeds[nxt, 0], seeds[nxt, 1], lines, out, starts[lines], fwd, back, gpts, gmeta,
                               head, n, gcell, gcols, dirs, strength, ids, bright, objs[nxt], limit, fcell, lo, hi,
                               stop_ratio, step, min_length, max_steps, w, h)
        nxt += 1
        if count:
            starts[lines + 1] = starts[lines] + count
            lines += 1
    return out[:starts[lines]].copy(), starts[:lines + 1].copy()
