"""Measures the particle sketcher: `python -m nodegraph_nodes.particle_sketch.bench [--size 800] [--out DIR]`.

Side by side in one run (this machine is noisy, so ratios beat absolute figures; each time is the best
of `--repeat` runs): the vectorised `simulate` with the default parameters against the pure-Python
`simulate_python` (same seed and params), the sequential run on one NumPy lane (engine="numpy", also
identical to the reference), the effect of the batch size (NumPy lock-step lanes) against the sequential
run, and a scene with enough edges for 2000 strokes.
With `--out`, writes the default sketch as PNG (if matplotlib is installed) and SVG.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from nodegraph.fsio import atomic_output, atomic_write_text
from nodegraph.output.strokes import to_svg
from nodegraph.values import Strokes

from . import core, synthetic


def _best(fn: Callable[[], core.SketchResult], repeat: int) -> tuple[float, core.SketchResult]:
    best, res = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        res = fn()
        best = min(best, time.perf_counter() - t)
    assert res is not None
    return best, res


def _row(name: str, seconds: float, res: core.SketchResult, edges: np.ndarray) -> dict:
    cov, prec = core.coverage_precision(res.sketch, edges)
    ink = sum(float(np.hypot(*np.diff(s.astype(np.float64), axis=0).T).sum()) for s in res.strokes)
    return {"run": name, "ms": round(seconds * 1e3, 1), "launched": res.launched, "strokes": len(res.strokes),
            "steps": res.steps, "ink_px": round(ink), "coverage": round(cov, 4), "precision": round(prec, 4),
            "exhausted": res.exhausted}


def run(size: int = 800, seed: int = 1, repeat: int = 5, python_repeat: int = 3,
        batches: tuple[int, ...] = (16, 64, 256, 1024, 2048), out: Path | None = None) -> dict:
    params = core.ParticleParams()
    t = time.perf_counter()
    edges, ff = core.prepare(synthetic.cow_depth(size), 0.03)
    prep = time.perf_counter() - t
    rows = []

    def sim(p: core.ParticleParams, e: np.ndarray = edges, f: np.ndarray = ff) -> core.SketchResult:
        return core.simulate(e, f, p, np.random.default_rng(seed))

    sim(params)  # warm up
    t_vec = t_py = float("inf")
    for _ in range(python_repeat):  # interleaved, so both see the same machine load
        tp, res_py = _best(lambda: core.simulate_python(edges, ff, params, np.random.default_rng(seed)), 1)
        tv, res = _best(lambda: sim(params), repeat)
        t_py, t_vec = min(t_py, tp), min(t_vec, tv)
    rows.append(_row(f"simulate batch={params.batch}", t_vec, res, edges))
    rows.append(_row("simulate_python", t_py, res_py, edges))
    t1, r1 = _best(lambda: core.simulate(edges, ff, replace(params, batch=1), np.random.default_rng(seed),
                                         engine="numpy"), 1)
    rows.append(_row("batch=1 engine=numpy", t1, r1, edges))
    for b in batches:
        tb, rb = _best(lambda b=b: sim(replace(params, batch=b)), repeat)
        rows.append(_row(f"batch={b}", tb, rb, edges))
    herd_edges, herd_ff = core.prepare(synthetic.herd_depth(size), 0.03)
    t_herd, res_herd = _best(lambda: sim(params, herd_edges, herd_ff), repeat)
    rows.append(_row(f"herd (4 cows) batch={params.batch}", t_herd, res_herd, herd_edges))
    report = {"size": size, "seed": seed, "params": asdict(params), "prepare_ms": round(prep * 1e3, 1),
              "speedup_vs_python": round(t_py / t_vec, 1), "rows": rows}
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / "particle_sketch.svg", to_svg(Strokes(res.strokes, (size, size), params.line_width,
                                                                        (0.0, 0.0, 0.0))))
        try:
            import matplotlib.pyplot as plt

            with atomic_output(out / "particle_sketch.png") as tmp:
                plt.imsave(tmp, 1.0 - res.sketch[::-1], cmap="gray", vmin=0, vmax=1, format="png")
        except ImportError:
            pass
        atomic_write_text(out / "particle_sketch_bench.json", json.dumps(report, indent=1))
    return report


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=800)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    rep = run(args.size, args.seed, args.repeat, out=args.out)
    print(f"{rep['size']}x{rep['size']} cow, prepare {rep['prepare_ms']} ms, "
          f"speedup vs simulate_python: {rep['speedup_vs_python']}x")
    keys = list(rep["rows"][0])
    print(" | ".join(keys))
    for r in rep["rows"]:
        print(" | ".join(str(r[k]) for k in keys))


if __name__ == "__main__":
    main()
