"""Accuracy of the particle sketcher on a real depth buffer: stroke count, step and Euler against RK4; coverage
and precision against its own edge map, and (through `truth_score`) against the ground-truth line drawing.
`sketchgraph bench accuracy --families particles` runs `measure` on the depth buffer it renders."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from . import core


def _quiet(msg: str) -> None:
    pass


def measure(depth: np.ndarray, spec: str, truth_score: Callable[[np.ndarray], dict[str, float]], quick: bool,
            log: Callable[[str], None] = _quiet) -> dict[str, Any]:
    """Sketch `depth` (window depth, 1 = background) at several stroke counts, steps and integrators;
    `truth_score(ink)` scores a sketch against the ground truth (a dict with `recall` and `precision`)."""
    size = depth.shape[0]
    threshold = 0.03
    edges, ff = core.prepare(depth, threshold)
    strokes = [100, 400, 1600] if quick else [100, 200, 400, 800, 1600, 3200]
    steps = [0.75, 1.5, 3.0] if quick else [0.5, 0.75, 1.5, 3.0, 5.0]
    entries = []
    # the compiled engine loads (or compiles) its machine code on first use: not part of any entry
    core.simulate(edges, ff, core.ParticleParams(strokes=1), np.random.default_rng(5))
    for integrator in ("euler", "rk4"):
        for step in steps:
            for n in strokes:
                if quick and step != 1.5 and n != 1600:
                    continue
                params = core.ParticleParams(strokes=n, step=step, integrator=integrator)
                t0 = time.perf_counter()
                res = core.simulate(edges, ff, params, np.random.default_rng(5))
                sec = time.perf_counter() - t0
                cov, prec = core.coverage_precision(res.sketch, edges)
                gt = truth_score(res.sketch)
                entries.append({"method": f"{integrator} step={step:g}", "integrator": integrator, "step": step,
                                "strokes": n, "launched": res.launched, "segments": res.steps,
                                "coverage": cov, "precision": prec,
                                "f1": 2 * cov * prec / (cov + prec) if cov + prec else 0.0,
                                "gt_recall": gt["recall"], "gt_precision": gt["precision"],
                                "s": sec, "ms": sec * 1000.0})
        log(f"  particles {integrator}: " + ", ".join(
            f"{e['strokes']}@{e['step']:g} cov {e['coverage']:.2f} {e['s']:.1f}s"
            for e in entries if e["integrator"] == integrator)[:400])
    base = core.ParticleParams()
    return {"entries": entries, "scene": spec, "size": size, "threshold": threshold,
            "edge_pixels": int(edges.sum()),
            "defaults": {k: getattr(base, k) for k in ("mass", "drag", "randomness", "step", "max_steps", "batch")}}
