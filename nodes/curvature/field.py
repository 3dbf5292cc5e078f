"""A smooth line field (2-RoSy) aligned to the principal directions by one global sparse solve, after
Knöppel, Crane, Pinkall and Schröder 2013 ("Globally optimal direction fields") and Hertzmann and Zorin
2000 (curvature directions weighted by how well they are defined).

Per vertex a tangent frame (b1, b2 = n x b1); a line at angle t in it is the complex number z = e^{2it}
(doubled: d and -d are the same line). Transport along edge ij matches the edge's angle in both frames
(discrete Levi-Civita): r_ij = e^{2i(theta_j - theta_i)}, theta the angle of the edge in each frame. The
field minimises

    l^2 sum_ij w_ij |z_j - r_ij z_i|^2  +  sum_i A_i |a_i z_i - a_i q_i|^2

with w_ij cotangent weights (clipped at 0), A_i the vertex area, q_i the measured direction doubled, a_i the
anisotropy | |k1| - |k2| | over its 90th percentile on the mesh (capped at 2; 0 where nothing was measured)
and l the smoothing length. a_i q_i is Knöppel's curvature target (the doubled direction with magnitude
|k1 - k2|, here by magnitude so that dmin, the direction of least bending, is defined at saddles too); the
alignment residual is measured at that scale, so its weight is a_i^2: strongly curved vertices are pinned
to their direction, weakly curved ones hardly at all and take the smoothest interpolant. Both terms are
areas (l^2 times the dimensionless cotangent form, A_i a_i^2), so the balance does not depend on the
mesh's density or scale. 2-RoSy, not 4-RoSy: pencil_shade's first layer hatches along dmin alone and its
other layers are turned by +-layer_angle (30 degrees), not 90, so a cross field would let the light tones
swap between dmin and dmax.

The normal equations (l^2 L + diag(A a^2)) z = A a^2 q are Hermitian positive definite; they are solved
by conjugate gradients with a Jacobi preconditioner (relative residual 1e-6: within 0.25 degrees of the
direct solve on the bunny and the ogre, and faster: see solve_hpd), falling back to a sparse LU in the
minimum-degree ordering of A + A^T where CG does not converge.
Also: the measures the docs report (smoothness after transport, alignment where anisotropy is large).
"""

from __future__ import annotations

from typing import Any

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


def anisotropy(kmin: np.ndarray, kmax: np.ndarray, measured: np.ndarray, cap: float = 2.0) -> np.ndarray:
    """| |kmax| - |kmin| | over its 90th percentile on the measured vertices, capped at `cap` (one noisy
    spike must not pin its neighbourhood); 0 where not measured."""
    a = np.abs(np.abs(kmax) - np.abs(kmin))
    ref = np.percentile(a[measured], 90) if measured.any() else 0.0
    out = np.minimum(a / ref, cap) if ref > 0 else np.zeros_like(a)
    return np.where(measured, out, 0.0)


def alignment_weight(kmin: np.ndarray, kmax: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """The weight a_i^2 of vertex i's alignment term (see the module docstring)."""
    return anisotropy(kmin, kmax, measured) ** 2


CG_RTOL = 1e-6
CG_MAXITER = 3000


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """Re(a^H b) by elementwise products: no BLAS call (see solve_hpd)."""
    return float(np.sum(a.real * b.real + a.imag * b.imag))


def pcg(A: Any, b: np.ndarray, rtol: float = CG_RTOL, maxiter: int = CG_MAXITER) -> tuple[np.ndarray, int]:
    """Jacobi-preconditioned conjugate gradients for Hermitian positive definite A, started from D^-1 b:
    (x, iterations), iterations -1 when |b - A x| > rtol |b| after maxiter."""
    dinv = 1.0 / A.diagonal().real
    x = dinv * b
    r = b - A @ x
    z = dinv * r
    p = z.copy()
    rz = _dot(r, z)
    stop = rtol * rtol * _dot(b, b)
    for k in range(maxiter):
        if _dot(r, r) <= stop:
            return x, k
        Ap = A @ p
        alpha = rz / _dot(p, Ap)
        x += alpha * p
        r -= alpha * Ap
        z = dinv * r
        rz, rz_old = _dot(r, z), rz
        p = z + (rz / rz_old) * p
    return x, (maxiter if _dot(r, r) <= stop else -1)


def solve_hpd(A: Any, b: np.ndarray) -> tuple[np.ndarray, str]:
    """x with A x = b for Hermitian positive definite sparse A, and how: "cg" (pcg), "lu" (SuperLU in the
    minimum-degree ordering of A + A^T, where CG does not converge) or "zero" (b = 0).

    The CG loop is written here rather than scipy.sparse.linalg.cg because scipy's calls BLAS level-1
    routines (vdot, axpy) whose OpenBLAS threads busy-wait: on the shared 2-core machine that made the
    same 250 iterations on the bunny 0.2 s single-threaded and 1.3-5 s threaded. The iterates agree with
    scipy's to 1e-9 degrees."""
    import scipy.sparse.linalg as spla

    A = A.tocsr()
    if not np.any(b):
        return np.zeros_like(b), "zero"
    x, iterations = pcg(A, b)
    if iterations >= 0 and np.all(np.isfinite(x)):
        return x, "cg"
    lu = spla.splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    return lu.solve(b), "lu"


def field_system(V: np.ndarray, F: np.ndarray, normal: np.ndarray, d: np.ndarray, weight: np.ndarray,
                 length: float) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray]:
    """The normal equations (l^2 L + diag(A w)) z = A w q of the energy (a scipy sparse matrix and the
    right-hand side) and the frames (b1, b2) z is expressed in."""
    import scipy.sparse as sp

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
    return A, m * to_complex(d, b1, b2), b1, b2


def smooth_field(V: np.ndarray, F: np.ndarray, normal: np.ndarray, d: np.ndarray, weight: np.ndarray,
                 length: float) -> tuple[np.ndarray, np.ndarray]:
    """The aligned smooth line field per vertex (unit, tangent) and |z| (0: no direction at all reaches the
    vertex, e.g. nothing measured in its component). `weight` is the alignment weight per vertex."""
    A, b, b1, b2 = field_system(V, F, normal, d, weight, length)
    z, _ = solve_hpd(A, b)
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
