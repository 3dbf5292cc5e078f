"""Accuracy of principal curvature against analytic surfaces: a torus and an ellipsoid whose curvatures and
directions are known in closed form. `sketchgraph bench accuracy --families curvature` runs `measure`; the
stability sweeps (`stability.py` beside this) reuse the surfaces and `curvature_errors`."""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np


def _quiet(msg: str) -> None:
    pass


TORUS_R, TORUS_r = 2.0, 0.5
ELLIPSOID_ABC = (1.0, 0.75, 0.5)


def torus_mesh(nu: int, nv: int, jitter: float = 0.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Torus about z on a wrapped (u, v) grid, outward normals; vertices exactly on the surface."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    u = (i + jitter * rng.uniform(-0.5, 0.5, i.shape)) * 2 * np.pi / nu
    v = (j + jitter * rng.uniform(-0.5, 0.5, j.shape)) * 2 * np.pi / nv
    ring = TORUS_R + TORUS_r * np.cos(v)
    V = np.stack([ring * np.cos(u), ring * np.sin(u), TORUS_r * np.sin(v)], -1).reshape(-1, 3)
    a = i * nv + j
    b = (i + 1) % nu * nv + j
    c = (i + 1) % nu * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    F = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return V, F


def torus_truth(V: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(kmin, kmax, dmin, normal) of the analytic torus at points V (ordered by magnitude, signed,
    positive where convex w.r.t. the outward normal)."""
    x, y, z = V.T
    u = np.arctan2(y, x)
    rho = np.hypot(x, y)
    v = np.arctan2(z, rho - TORUS_R)
    k_tube = np.full(len(V), 1.0 / TORUS_r)
    k_ring = np.cos(v) / (TORUS_R + TORUS_r * np.cos(v))
    d_ring = np.stack([-np.sin(u), np.cos(u), np.zeros_like(u)], 1)  # along the major circle
    normal = np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], 1)
    return k_ring, k_tube, d_ring, normal


def ellipsoid_mesh(level: int) -> tuple[np.ndarray, np.ndarray]:
    from nodegraph.scene.primitives import ellipsoid

    m = ellipsoid(*ELLIPSOID_ABC, subdiv=level)
    return np.asarray(m.vertices), np.asarray(m.faces)


def ellipsoid_truth(V: np.ndarray, abc: tuple[float, float, float] = ELLIPSOID_ABC
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(kmin, kmax, dmin, normal) of the ellipsoid x^2/a^2 + y^2/b^2 + z^2/c^2 = 1 at points V (projected
    onto it): eigen-decomposition of the shape operator P H P / |grad| on the tangent plane."""
    a, b, c = abc
    h = np.array([1 / a**2, 1 / b**2, 1 / c**2])
    s = 1.0 / np.sqrt((V**2 * h).sum(1))
    p = V * s[:, None]
    grad = p * h
    gn = np.linalg.norm(grad, axis=1)
    n = grad / gn[:, None]
    proj = np.eye(3)[None] - n[:, :, None] * n[:, None, :]
    shape = proj @ (h[None, :, None] * proj) / gn[:, None, None]
    w, vec = np.linalg.eigh(shape)
    # one eigenvalue is 0 along n; the other two are the principal curvatures (positive: convex)
    along_n = np.abs(np.einsum("kij,ki->kj", vec, n))
    order = np.argsort(along_n, axis=1)[:, :2]  # the two tangent eigenvectors
    rows = np.arange(len(V))[:, None]
    k = w[rows, order]
    d = np.stack([vec[np.arange(len(V)), :, order[:, 0]], vec[np.arange(len(V)), :, order[:, 1]]], 1)
    small = np.abs(k[:, 0]) <= np.abs(k[:, 1])
    kmin = np.where(small, k[:, 0], k[:, 1])
    kmax = np.where(small, k[:, 1], k[:, 0])
    dmin = np.where(small[:, None], d[:, 0], d[:, 1])
    return kmin, kmax, dmin, n


def curvature_errors(res: Any, kmin: np.ndarray, kmax: np.ndarray, dmin: np.ndarray,
                     aniso_min: float = 0.05) -> dict[str, Any]:
    """Value errors |k - k_true| / |kmax_true| (both principal values), direction error in degrees between
    the measured and true dmin lines, over vertices where the true direction is defined (anisotropy
    (|kmax| - |kmin|) / (|kmax| + |kmin|) >= aniso_min)."""
    scale = np.maximum(np.abs(kmax), 1e-300)
    e_max = np.abs(res.kmax - kmax) / scale
    e_min = np.abs(res.kmin - kmin) / scale
    value = np.maximum(e_max, e_min)
    aniso = (np.abs(kmax) - np.abs(kmin)) / (np.abs(kmax) + np.abs(kmin) + 1e-300)
    defined = aniso >= aniso_min
    cosang = np.abs(np.einsum("ij,ij->i", res.dmin, dmin))
    ang = np.degrees(np.arccos(np.clip(cosang, 0.0, 1.0)))[defined]
    return {
        "value_median": float(np.median(value)), "value_p95": float(np.percentile(value, 95)),
        "kmax_median": float(np.median(e_max)), "kmax_p95": float(np.percentile(e_max, 95)),
        "kmin_median": float(np.median(e_min)), "kmin_p95": float(np.percentile(e_min, 95)),
        "direction_median_deg": float(np.median(ang)) if ang.size else None,
        "direction_p95_deg": float(np.percentile(ang, 95)) if ang.size else None,
        "direction_vertices": int(defined.sum()),
        "finite": bool(np.isfinite(res.kmin).all() and np.isfinite(res.kmax).all() and np.isfinite(res.dmin).all()),
    }


def measure(quick: bool, meshes_dir: Path | None = None, log: Callable[[str], None] = _quiet) -> dict[str, Any]:
    """The `curvature` family of `sketchgraph bench accuracy`: libigl principal curvature on the analytic torus
    and ellipsoid by tessellation and radius (value and direction errors, seconds), and its time on the
    shared meshes."""
    from .principal import compute_curvature

    tori = [(48, 12), (100, 25), (200, 50)] if quick else [(48, 12), (100, 25), (200, 50), (400, 100)]
    levels = [2, 3, 4] if quick else [2, 3, 4, 5]
    radii = [2, 3, 5] if quick else [2, 3, 4, 5, 7]
    surfaces: list[tuple[str, str, Any, Callable]] = []
    for nu, nv in tori:
        surfaces.append(("torus", f"{nu}x{nv}", lambda nu=nu, nv=nv: torus_mesh(nu, nv), torus_truth))
    for lev in levels:
        surfaces.append(("ellipsoid", f"subdiv{lev}", lambda lev=lev: ellipsoid_mesh(lev), ellipsoid_truth))
    entries = []
    for surface, tess, make, truth in surfaces:
        V, F = make()
        kmin, kmax, dmin, _ = truth(V)
        for radius in radii:
            t0 = time.perf_counter()
            res = compute_curvature(V, F, radius)
            sec = time.perf_counter() - t0
            err = curvature_errors(res, kmin, kmax, dmin)
            entries.append({"surface": surface, "tessellation": tess, "vertices": int(len(V)), "radius": radius,
                            "method": f"libigl r={radius}", "s": sec, "ms": sec * 1000.0, **err})
        row = [e for e in entries if e["tessellation"] == tess and e["surface"] == surface]
        log(f"  curvature {surface} {tess} ({len(V)} v): p95 direction "
            + ", ".join(f"r{e['radius']} {e['direction_p95_deg']:.1f}deg" for e in row))
    shared = {}
    if not quick and meshes_dir is not None:
        from nodegraph.scene.meshes import load_mesh

        for p in sorted(meshes_dir.glob("*.obj")):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                m = load_mesh(p)
            t0 = time.perf_counter()
            res = compute_curvature(m.vertices, m.faces)
            shared[p.name] = {"vertices": m.n_vertices, "s": time.perf_counter() - t0, "fallbacks": res.counts}
        log("  curvature on the shared meshes: " + ", ".join(f"{k} {v['s']:.2f}s" for k, v in shared.items()))
    return {"entries": entries, "torus": {"R": TORUS_R, "r": TORUS_r}, "ellipsoid_abc": list(ELLIPSOID_ABC),
            "shared_meshes": shared}
