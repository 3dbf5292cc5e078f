"""The pair loop of nodes/mesh_lines/intersect.py `_grid_pairs` compiled with Numba: one pass over the grid's cells
with no temporaries, instead of the NumPy code's repeated index arrays (the reference, used where Numba cannot be
imported). Same pairs in the same order: within a cell each entry pairs with the entries after it (or, for a
coarser level's lead faces, with every other entry, a pair of two lead faces once), a pair is kept in the cell
where both ranges start to overlap (`own`) and where the two boxes overlap. Tests compare the two. One thread, as
posing_jit: in a pipeline, threads contend with llvmpipe's. Compiled on first use and cached on disk
(`cache=True`, in `__pycache__` beside this file).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def cell_pairs(starts, sizes, rep, cell, c0, ids, lead, use_lead, lo, hi, boxes, corners, apart
               ):  # pragma: no cover - compiled
    """(k, 2) pairs (min id, max id) of the entries sorted by cell (`starts`, `sizes` of each cell's run; `rep`
    the entry's face among `ids`, `cell` its cell), as intersect._grid_pairs makes them; with `apart`, less the
    pairs whose faces share a corner id (`corners`, by face id). What a pair's tests read is first gathered per
    entry, so that a cell's entries lie side by side in memory."""
    n = len(rep)
    first = np.empty((n, 3), np.int64)  # the entry's face's first cell
    box = np.empty((n, 6), np.float64)  # its box (lo, hi) where boxes are tested
    face = np.empty(n, np.int64)  # its face id
    own_lead = np.zeros(n, np.bool_)
    corner = np.empty((n if apart else 0, 3), np.int64)  # its corners' ids where shared corners part pairs
    for i in range(n):
        a = rep[i]
        face[i] = ids[a]
        if apart:
            for d in range(3):
                corner[i, d] = corners[ids[a], d]
        for d in range(3):
            first[i, d] = c0[a, d]
            if boxes:
                box[i, d] = lo[ids[a], d]
                box[i, 3 + d] = hi[ids[a], d]
        if use_lead:
            own_lead[i] = lead[a]
    cap = 1024
    out = np.empty((cap, 2), np.int64)
    k = 0
    for c in range(len(starts)):
        s, e = starts[c], starts[c] + sizes[c]
        for i in range(s, e):
            if use_lead and not own_lead[i]:
                continue
            j0 = s if use_lead else i + 1
            for j in range(j0, e):
                if j == i:
                    continue
                if use_lead and own_lead[j] and rep[i] >= rep[j]:
                    continue
                # kept in the cell where both ranges first overlap
                if cell[i, 0] != max(first[i, 0], first[j, 0]) or cell[i, 1] != max(first[i, 1], first[j, 1]) \
                        or cell[i, 2] != max(first[i, 2], first[j, 2]):
                    continue
                if boxes and (box[i, 0] > box[j, 3] or box[j, 0] > box[i, 3] or box[i, 1] > box[j, 4]
                              or box[j, 1] > box[i, 4] or box[i, 2] > box[j, 5] or box[j, 2] > box[i, 5]):
                    continue
                if apart:
                    shared = False
                    for u in range(3):
                        for v in range(3):
                            if corner[i, u] == corner[j, v]:
                                shared = True
                    if shared:
                        continue
                if k == cap:
                    cap *= 2
                    grown = np.empty((cap, 2), np.int64)
                    grown[:k] = out[:k]
                    out = grown
                out[k, 0] = min(face[i], face[j])
                out[k, 1] = max(face[i], face[j])
                k += 1
    return out[:k]
