"""Stability sweeps of principal curvature (vertex noise, mesh resolution, umbilic and flat regions), each
measured against the analytic surfaces of `accuracy.py`. Each returns a sweep spec (title, axis labels,
points, break criteria, finding, behaviour) that `nodegraph.tools.bench.stability` turns into its record."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .accuracy import curvature_errors, ellipsoid_truth, torus_mesh, torus_truth
from .principal import DirectionSource, Reason, compute_curvature


def _quiet(msg: str) -> None:
    pass


def _spec(title: str, x_label: str, y_label: str, points: list[dict[str, Any]], **criteria: Any) -> dict[str, Any]:
    return {"title": title, "x_label": x_label, "y_label": y_label, "points": points, **criteria}


def sweep_noise(quick: bool, log: Callable[[str], None] = _quiet) -> dict[str, Any]:
    V0, F = torus_mesh(100, 25)
    kmin, kmax, dmin, normal = torus_truth(V0)
    edge = float(np.mean(np.linalg.norm(V0[F[:, 0]] - V0[F[:, 1]], axis=1)))
    noises = [0.0, 0.05, 0.2, 0.5] if quick else [0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5]
    radii = [2, 3, 5]
    rng = np.random.default_rng(11)
    dirs = rng.normal(size=V0.shape)
    points = []
    for sigma in noises:
        V = V0 + sigma * edge * dirs
        for r in radii:
            res = compute_curvature(V, F, r)
            e = curvature_errors(res, kmin, kmax, dmin)
            points.append({"series": f"radius {r}", "x": sigma, "value": e["direction_p95_deg"],
                           "value_p95": e["value_p95"], "direction_median_deg": e["direction_median_deg"],
                           "fallbacks": res.counts, "finite": e["finite"]})
    log("  curvature noise: " + ", ".join(f"{p['series']} {p['x']} {p['value']:.1f}" for p in points))
    return _spec("Curvature: vertex noise (torus 100x25)", "noise sigma / mean edge length",
                  "p95 direction error (deg)", points, threshold=20.0, higher_is_better=False, log_y=True,
                  finding="Directions degrade with noise; larger radii average it out at the cost of bias on "
                          "clean meshes.",
                  behaviour="compute_curvature: finite unit directions at any noise; unreliable vertices get "
                            "confidence < 1 and smoothed directions.")


def sweep_resolution(quick: bool, log: Callable[[str], None] = _quiet) -> dict[str, Any]:
    grids = [(200, 50), (48, 12), (16, 6)] if quick else [(400, 100), (200, 50), (100, 25), (48, 12), (24, 8),
                                                            (16, 6), (12, 4), (8, 3)]
    points = []
    for nu, nv in grids:
        V, F = torus_mesh(nu, nv)
        kmin, kmax, dmin, _ = torus_truth(V)
        for r in (2, 3, 5):
            res = compute_curvature(V, F, r)
            e = curvature_errors(res, kmin, kmax, dmin)
            points.append({"series": f"radius {r}", "x": len(V), "value": e["direction_p95_deg"],
                           "value_p95": e["value_p95"], "grid": f"{nu}x{nv}", "fallbacks": res.counts,
                           "finite": e["finite"]})
    log("  curvature resolution: " + ", ".join(f"{p['grid']} {p['series']} {p['value']:.1f}" for p in points))
    return _spec("Curvature: mesh resolution (torus)", "vertices", "p95 direction error (deg)", points,
                  threshold=20.0, higher_is_better=False, log_x=True, log_y=True,
                  finding="Direction error grows as the tessellation coarsens; very coarse grids (a few vertices "
                          "around the tube) fall back to smoothed or fixed-frame directions.",
                  behaviour="compute_curvature: finite output with fallbacks counted in `counts`.")


def sweep_umbilic(quick: bool, log: Callable[[str], None] = _quiet) -> dict[str, Any]:
    from nodegraph.scene.primitives import sphere

    s = sphere(1.0, 4)
    U = np.asarray(s.vertices)
    F = np.asarray(s.faces)
    es = [0.5, 0.1, 0.01, 0.0] if quick else [1.0, 0.5, 0.3, 0.2, 0.15, 0.1, 0.05, 0.03, 0.01, 0.003, 0.0]
    points = []
    for e in es:
        abc = (1.0 + e, 1.0, 1.0 / (1.0 + e))
        V = U * np.array(abc)
        kmin, kmax, dmin, _ = ellipsoid_truth(V, abc)
        res = compute_curvature(V, F)
        err = curvature_errors(res, kmin, kmax, dmin, aniso_min=0.0)
        measured = res.source == DirectionSource.MEASURED
        cosang = np.abs(np.einsum("ij,ij->i", res.dmin, dmin))[measured]
        ang = np.degrees(np.arccos(np.clip(cosang, 0, 1)))
        fallback = float(np.mean(res.reason == Reason.UMBILIC)) * 100.0
        points.append({"series": "vertices flagged umbilic/flat (%)", "x": max(e, 1e-4), "value": fallback,
                       "e": e})
        points.append({"series": "p95 direction error of measured vertices (deg)", "x": max(e, 1e-4),
                       "value": float(np.percentile(ang, 95)) if ang.size else None, "e": e,
                       "measured": int(measured.sum()), "value_p95": err["value_p95"]})
    log("  umbilic: " + ", ".join(f"{p['e']} {p['value']}" for p in points))
    return _spec("Umbilic and flat: sphere -> ellipsoid (1+e, 1, 1/(1+e))", "e (0 = sphere, drawn at 1e-4)",
                  "%  /  deg", points, threshold=50.0, higher_is_better=False, log_x=True,
                  finding="On a sphere every vertex is umbilic: directions are undefined and the fallbacks take "
                          "over; the fallback share falls as the surface grows anisotropic.",
                  behaviour="compute_curvature: reason UMBILIC, confidence 0..1, directions smoothed from "
                            "neighbours or the fixed frame; never NaN.")
