"""Stability of the particle sketcher at extreme parameters: each sweep starts at the core's default and moves
one parameter (drag, randomness, mass) away; coverage and precision against the edge map at every step.
`sweep` returns a sweep spec that `nodegraph.tools.bench.stability` turns into its record."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from . import core


def _quiet(msg: str) -> None:
    pass


def _spec(title: str, x_label: str, y_label: str, points: list[dict[str, Any]], **criteria: Any) -> dict[str, Any]:
    return {"title": title, "x_label": x_label, "y_label": y_label, "points": points, **criteria}


def sweep(depth: np.ndarray, quick: bool, log: Callable[[str], None] = _quiet) -> dict[str, Any]:
    """Parameter sweeps (drag, randomness, mass) from the core's defaults on `depth` (window depth, 400 px)."""
    edges, ff = core.prepare(depth, 0.03)
    base = core.ParticleParams()  # each sweep starts at the core's default and moves one parameter away
    sweeps = {
        "drag": [base.drag, 0.1, 0.0] if quick else [base.drag, 0.5, 0.2, 0.1, 0.01, 0.0],
        "randomness": [base.randomness, 10.0, 1000.0] if quick else [base.randomness, 2.0, 10.0, 100.0, 1000.0, 1e6],
        "mass": [base.mass, 0.1, 1e-6] if quick else [base.mass, 1.0, 0.1, 1e-2, 1e-3, 1e-6],
    }
    points = []
    for name, values in sweeps.items():
        for v in values:
            params = core.ParticleParams(strokes=400, **{name: v})
            t0 = time.perf_counter()
            res = core.simulate(edges, ff, params, np.random.default_rng(2))
            sec = time.perf_counter() - t0
            cov, prec = core.coverage_precision(res.sketch, edges)
            f1 = 2 * cov * prec / (cov + prec) if cov + prec else 0.0
            finite = bool(np.isfinite(res.sketch).all() and all(np.isfinite(s).all() for s in res.strokes))
            x = v if name != "drag" else max(v, 1e-3)
            points.append({"series": name, "x": x, "param": v, "value": f1, "coverage": cov, "precision": prec,
                           "segments": res.steps, "launched": res.launched, "s": sec, "finite": finite})
    log("  particles: " + ", ".join(f"{p['series']}={p['param']:g} F1 {p['value']:.2f} {p['s']:.1f}s"
                                    for p in points))
    defaults = {k: getattr(base, k) for k in ("mass", "drag", "randomness", "step", "max_steps", "integrator")}
    return {**_spec("Particles at extreme parameters (400 strokes, cow.obj 400 px)",
                  "parameter value (drag 0 drawn at 1e-3)", "F1 of coverage and precision", points, drop=0.2,
                  log_x=True,
                  finding="Without drag, with tiny mass or huge random forces particles leave the edges (or the "
                          "image) at once: coverage collapses but the run stays bounded.",
                  behaviour="simulate: strokes that leave the image or overflow end undrawn; finite ink, bounded "
                            "time."), "defaults": defaults}
