"""The per-frame passes of nodegraph/scene/posing.py compiled with Numba: linear blend skinning, per-part bounds
and the derived arrays of all posed parts, one loop over vertices or faces each, no temporaries.

They do what the NumPy code in posing.py (the reference, used where Numba cannot be imported) does, statement for
statement and in the same operation order (Numba keeps IEEE semantics without fastmath), except a face's third
corner angle: pi less the other two instead of its own atan2 (within 2e-15 radians); tests compare the two. They
run on one thread: in a pipeline, threads (OpenMP, `prange`) contend with llvmpipe's and made a frame slower.
Compiled on first use and cached on disk (`cache=True`, in `__pycache__` beside this file).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def skin(indptr, indices, data, mats, v, out, linear):  # pragma: no cover - compiled
    """out[n] = B_n[:, :3] @ v[n] + B_n[:, 3], B_n = sum_k w_k mats[j_k] (the CSR rows of the skin weights, in
    their order, as scipy's sparse product sums them); linear[n] = B_n[:, :3]."""
    b = np.empty(12)
    for n in range(v.shape[0]):
        for c in range(12):
            b[c] = 0.0
        for jj in range(indptr[n], indptr[n + 1]):
            w = data[jj]
            j = indices[jj]
            for c in range(12):
                b[c] += w * mats[j, c]
        x, y, z = v[n, 0], v[n, 1], v[n, 2]
        for r in range(3):
            out[n, r] = b[4 * r] * x + b[4 * r + 1] * y + b[4 * r + 2] * z + b[4 * r + 3]
            for c in range(3):
                linear[n, r, c] = b[4 * r + c]


@njit(cache=True, nogil=True)
def _unit(acc, i, fallback, out, j):  # pragma: no cover - compiled
    """out[j] = acc[i] / |acc[i]|, or `fallback` (NaN: any NaN component) where the length is 0 or not finite."""
    x, y, z = acc[i, 0], acc[i, 1], acc[i, 2]
    length = math.sqrt(x * x + y * y + z * z)
    if math.isfinite(length) and length > 1e-300:
        out[j, 0], out[j, 1], out[j, 2] = x / length, y / length, z / length
        return True
    out[j, 0], out[j, 1], out[j, 2] = fallback[0], fallback[1], fallback[2]
    return False


@njit(cache=True, nogil=True)
def arrays(v, faces, diag_f, welded_bad, wf, wid, n_welded, gid, rep, key_of_corner, n_keys, key_of_vertex,
           key_found, fallback, positions, normals, smooth, enlarge, vnormals):  # pragma: no cover - compiled
    """Face normals and corner angles of every face (Mesh._face_geometry), summed per welded vertex
    (Mesh.vertex_normals), per render vertex (Mesh._render_arrays' split normals) and per enlargement key
    (rasterize's enlargement directions); written into the float32 outputs."""
    acc_w = np.zeros((n_welded, 3))
    acc_g = np.zeros((rep.shape[0], 3))
    acc_k = np.zeros((n_keys, 3))
    e = np.empty((3, 3))
    angles = np.empty(3)
    for f in range(faces.shape[0]):
        for i in range(3):
            a, b = faces[f, i], faces[f, (i + 1) % 3]
            for c in range(3):
                e[i, c] = v[b, c] - v[a, c]
        # (p1 - p0) x (p2 - p0) = e0 x (-e2)
        c0 = e[0, 1] * -e[2, 2] - e[0, 2] * -e[2, 1]
        c1 = e[0, 2] * -e[2, 0] - e[0, 0] * -e[2, 2]
        c2 = e[0, 0] * -e[2, 1] - e[0, 1] * -e[2, 0]
        area2 = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        degenerate = area2 <= 1e-14 * diag_f[f] * diag_f[f] or welded_bad[f]
        if area2 > 0:
            n0, n1, n2 = c0 / area2, c1 / area2, c2 / area2
        else:
            n0, n1, n2 = 0.0, 0.0, 0.0
        for i in range(3):
            p = (i + 2) % 3
            cos = -(e[i, 0] * e[p, 0] + e[i, 1] * e[p, 1] + e[i, 2] * e[p, 2])
            # the angles sum to pi: the third is pi less the other two (within 2e-15 of its own atan2, which
            # would be a third of the pass's time)
            angle = math.atan2(area2, cos) if i < 2 else math.pi - angles[0] - angles[1]
            angles[i] = angle
            k = key_of_corner[3 * f + i]
            acc_k[k, 0] += n0 * angle
            acc_k[k, 1] += n1 * angle
            acc_k[k, 2] += n2 * angle
            if not degenerate:
                w = wf[3 * f + i]
                g = gid[3 * f + i]
                acc_w[w, 0] += n0 * angle
                acc_w[w, 1] += n1 * angle
                acc_w[w, 2] += n2 * angle
                acc_g[g, 0] += n0 * angle
                acc_g[g, 1] += n1 * angle
                acc_g[g, 2] += n2 * angle
    unit = np.empty((n_welded, 3))
    for i in range(n_welded):
        _unit(acc_w, i, fallback, unit, i)
    for i in range(wid.shape[0]):
        for c in range(3):
            vnormals[i, c] = unit[wid[i], c]
    nan = np.full(3, np.nan)
    one = np.empty((1, 3))
    ok_k = np.empty(n_keys, np.bool_)
    unit_k = np.empty((n_keys, 3))
    for i in range(n_keys):
        x, y, z = acc_k[i, 0], acc_k[i, 1], acc_k[i, 2]
        length = math.sqrt(x * x + y * y + z * z)
        ok_k[i] = length > 1e-12
        if ok_k[i]:
            unit_k[i, 0], unit_k[i, 1], unit_k[i, 2] = x / length, y / length, z / length
    for r in range(rep.shape[0]):
        for c in range(3):
            smooth[r, c] = vnormals[rep[r], c]
            positions[r, c] = v[rep[r], c]
        good = _unit(acc_g, r, nan, one, 0)
        for c in range(3):
            normals[r, c] = one[0, c] if good and math.isfinite(one[0, c]) else smooth[r, c]
        s = key_of_vertex[r]
        use = n_keys > 0 and key_found[r] and ok_k[s]
        for c in range(3):
            enlarge[r, c] = unit_k[s, c] if use else smooth[r, c]


@njit(cache=True, nogil=True)
def bounds(v, at, lo, hi):  # pragma: no cover - compiled
    """lo[p], hi[p] = the componentwise min and max of v[at[p]:at[p + 1]] (NaN where any is NaN, as NumPy's)."""
    for p in range(at.shape[0] - 1):
        for c in range(3):
            a = np.inf
            b = -np.inf
            for i in range(at[p], at[p + 1]):
                x = v[i, c]
                if x < a or math.isnan(x):
                    a = x if not math.isnan(a) else a
                if x > b or math.isnan(x):
                    b = x if not math.isnan(b) else b
            lo[p, c] = a
            hi[p, c] = b
