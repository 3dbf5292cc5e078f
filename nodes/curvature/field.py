"""A smooth line field (2-RoSy) aligned to the principal directions by one global sparse solve, after
Knöppel, Crane, Pinkall and Schröder 2013 ("Globally optimal direction fields").

Per vertex a tangent frame (b1, b2 = n x b1); a line at angle a in it is the complex number z = e^{2ia}
(doubled: d and -d are the same line). Transport along edge ij matches the edge's angle in both frames
(discrete Levi-Civita): r_ij = e^{2i(theta_j - theta_i)}, theta the angle of the edge in each frame. The
field minimises

    l^2 sum_ij w_ij |z_j - r_ij z_i|^2  +  sum_i A_i a_i |z_i - q_i|^2

with w_ij cotangent weights (clipped at 0), A_i the vertex area, q_i the measured direction doubled and
a_i the alignment weight: the anisotropy | |k1| - |k2| | normalised by its 90th percentile over the mesh
(the same as |k1 - k2| where both curvatures have one sign; smaller at saddles, where dmin, the direction
of least bending by magnitude, is undefined), zero where nothing was measured. l is the smoothing length.
Where alignment is strong the field follows the measurement; elsewhere it is the smoothest interpolant.
Also: the measures the docs report (smoothness after transport, alignment where anisotropy is large).
"""

from __future__ import annotations

import numpy as np


def tangent_frames(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(b1, b2) per vertex: world x (y near the x axis) projected onto the tangent plane, and n x b1."""
    axis = np.zeros_like(normal)
    near_x = np.abs(normal[:, 0]) > 0.9
    axis[~near_x, 0] = 1.0
    axis[near_x, 1] = 1.0
    b1 = axis - np.sum(axis * normal, axis=1, keepdims=True) * normal
    b1 /= np.maximum(np.linalg.norm(b1, axis=1, keepdims=True), 1e-300)
    return b1, np.cross(normal, b1)


def edges_of(F: np.ndarray) -> np.ndarray:
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    return np.unique(e[e[:, 0] != e[:, 1]], axis=0)


def transport(V: np.ndarray, E: np.ndarray, normal: np.ndarray, b1: np.ndarray, b2: np.ndarray) -> np.ndarray:
    """r_ij per edge: the doubled-angle rotation taking a line in frame i to frame j."""
    d = V[E[:, 1]] - V[E[:, 0]]
    ti = np.arctan2(np.sum(d * b2[E[:, 0]], 1), np.sum(d * b1[E[:, 0]], 1))
    tj = np.arctan2(np.sum(d * b2[E[:, 1]], 1), np.sum(d * b1[E[:, 1]], 1))
    return np.exp(2j * (tj - ti))


def to_complex(d: np.ndarray, b1: np.ndarray, b2: np.ndarray) -> np.ndarray:
    return np.exp(2j * np.arctan2(np.sum(d * b2, 1), np.sum(d * b1, 1)))


def cotan_weights(V: np.ndarray, F: np.ndarray, E: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cotangent weight per edge of E (clipped at 0) and the barycentric vertex areas."""
    n = len(V)
    p = V[F]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    keys, vals = [], []
    for c in range(3):
        a, b, o = F[:, (c + 1) % 3], F[:, (c + 2) % 3], F[:, c]
        u, v = V[a] - V[o], V[b] - V[o]
        cot = np.sum(u * v, 1) / np.maximum(np.linalg.norm(np.cross(u, v), axis=1), 1e-300)
        keys.append(np.sort(np.stack([a, b], 1), axis=1))
        vals.append(0.5 * cot)
    k = np.concatenate(keys)
    code = k[:, 0] * n + k[:, 1]
    ecode = E[:, 0] * n + E[:, 1]
    order = np.argsort(ecode)
    pos = order[np.searchsorted(ecode[order], code)]
    wt = np.bincount(pos, np.concatenate(vals), minlength=len(E))
    varea = np.zeros(n)
    for c in range(3):
        np.add.at(varea, F[:, c], area / 3.0)
    return np.maximum(wt, 0.0), varea


def alignment_weight(kmin: np.ndarray, kmax: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """| |kmax| - |kmin| | / its 90th percentile over measured vertices, clipped to [0, 1]; 0 where not measured."""
    a = np.abs(np.abs(kmax) - np.abs(kmin))
    ref = np.percentile(a[measured], 90) if measured.any() else 0.0
    out = np.clip(a / ref, 0.0, 1.0) if ref > 0 else np.zeros_like(a)
    return np.where(measured, out, 0.0)


def smooth_field(V: np.ndarray, F: np.ndarray, normal: np.ndarray, d: np.ndarray, weight: np.ndarray,
                 length: float) -> tuple[np.ndarray, np.ndarray]:
    """The aligned smooth line field per vertex (unit, tangent) and |z| (0: no direction at all reaches the
    vertex, e.g. nothing measured in its component)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    n = len(V)
    E = edges_of(F)
    b1, b2 = tangent_frames(normal)
    r = transport(V, E, normal, b1, b2)
    w, area = cotan_weights(V, F, E)
    i, j = E[:, 0], E[:, 1]
    # sum w |z_j - r z_i|^2 = z^H L z with L_ii += w, L_jj += w, L_ji -= w r, L_ij -= w conj(r)
    diag = np.bincount(i, w, minlength=n) + np.bincount(j, w, minlength=n)
    L = sp.coo_matrix((np.r_[-w * r, -w * np.conj(r)], (np.r_[j, i], np.r_[i, j])), shape=(n, n)).tocsr()
    L = L + sp.diags(diag.astype(complex))
    m = area * weight
    eps = 1e-8 * max(float(area.mean()), 1e-300)
    A = (length ** 2) * L + sp.diags(m + eps)
    q = to_complex(d, b1, b2)
    z = spla.spsolve(A.tocsc(), m * q)
    ang = 0.5 * np.angle(z)
    out = np.cos(ang)[:, None] * b1 + np.sin(ang)[:, None] * b2
    return out, np.abs(z)


def smoothness_deg(V: np.ndarray, F: np.ndarray, normal: np.ndarray, d: np.ndarray) -> float:
    """Mean angle in degrees between neighbouring vertices' lines after transport (0..90)."""
    E = edges_of(F)
    b1, b2 = tangent_frames(normal)
    r = transport(V, E, normal, b1, b2)
    z = to_complex(d, b1, b2)
    diff = np.abs(np.angle(z[E[:, 1]] * np.conj(r * z[E[:, 0]]))) / 2
    return float(np.degrees(diff).mean())


def alignment_deg(d: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> float:
    """Mean angle in degrees between the lines d and ref (0..90) over mask."""
    c = np.abs(np.sum(d[mask] * ref[mask], axis=1))
    return float(np.degrees(np.arccos(np.clip(c, 0.0, 1.0))).mean()) if mask.any() else float("nan")
