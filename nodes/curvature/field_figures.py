"""Figures for docs/pencil.md and docs/charts/field.png: the hatching field's smoothness, its alignment with
the measured principal directions and the node's time, for both `field` methods over a sweep of `smoothing`.

    python -m nodegraph_nodes.curvature.field_figures ../shared/meshes/{spot,cow,...}.obj --json docs/charts/field.json
    python -m nodegraph.tools.bench.accuracy_charts field docs/charts/field.json docs/charts   # the charts

Smoothness: the mean angle between neighbouring vertices' lines after transport into a common frame (0 to
90 degrees; lower is smoother). Alignment: the mean angle to libigl's measured dmin over the measured
vertices whose anisotropy (field.anisotropy) is at least 0.5 (lower follows the strong directions more
closely). Node seconds: `Curvature.measure` on the welded mesh, libigl's measurement included, the median
of `--repeats` runs (min and max kept too); `curvature_s` is libigl's measurement alone.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from nodegraph.fsio import atomic_write_text
from nodegraph.scene.meshes import load_mesh

from . import Curvature
from .field import alignment_deg, anisotropy, smoothness_deg
from .principal import Reason, compute_curvature

SWEEP = {"spread": (0.01, 0.02, 0.05, 0.1, 0.2), "smooth": (0.005, 0.01, 0.02, 0.03, 0.05, 0.1)}


def welded(path: str) -> tuple[str, np.ndarray, np.ndarray]:
    mesh = load_mesh(path)
    wid, nu = mesh.weld()
    rep = np.full(nu, len(mesh.vertices), dtype=np.int64)
    np.minimum.at(rep, wid, np.arange(len(mesh.vertices)))
    return mesh.name, mesh.vertices[rep].astype(np.float64), wid[mesh.faces]


def _timed(fn: Any, repeats: int) -> tuple[Any, list[float]]:
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return out, times


def figures(path: str, sweep: dict[str, tuple[float, ...]] = SWEEP, repeats: int = 3) -> dict[str, Any]:
    """One mesh: its vertex count, the measured field's smoothness, libigl's seconds, and per (method,
    smoothing) the smoothness, alignment and node seconds."""
    name, V, F = welded(path)
    c, ctimes = _timed(lambda: compute_curvature(V, F), repeats)
    measured = (c.reason == Reason.OK) | (c.reason == Reason.UMBILIC)
    strong = (anisotropy(c.kmin, c.kmax, measured) >= 0.5) & (c.reason == Reason.OK)
    raw = np.asarray(c.dmin)
    rows = []
    for field, values in sweep.items():
        for s in values:
            node = Curvature("curv", Curvature.Params(field=field, smoothing=s))
            out, times = _timed(lambda node=node: node.measure(V, F), repeats)
            d = out["dmin"].astype(np.float64)
            rows.append({"field": field, "smoothing": s, "smooth_deg": smoothness_deg(V, F, c.normal, d),
                         "align_deg": alignment_deg(d, raw, strong), "s": statistics.median(times),
                         "s_min": min(times), "s_max": max(times)})
    return {"mesh": name, "vertices": len(V), "strong": int(strong.sum()),
            "measured_smooth_deg": smoothness_deg(V, F, c.normal, raw), "curvature_s": statistics.median(ctimes),
            "rows": rows}


def table(results: list[dict[str, Any]], picks: dict[str, float]) -> str:
    """Markdown: per mesh the measured field and each method at its `picks` smoothing."""
    head = ["mesh", "vertices", "measured: neighbour"]
    head += [f"{f} {s:g}: neighbour / alignment / s" for f, s in picks.items()]
    lines = ["| " + " | ".join(head) + " |", "| " + " | ".join("---" for _ in head) + " |"]
    for r in results:
        cells = [r["mesh"], str(r["vertices"]), f"{r['measured_smooth_deg']:.1f}"]
        for f, s in picks.items():
            row = next(x for x in r["rows"] if x["field"] == f and abs(x["smoothing"] - s) < 1e-12)
            cells.append(f"{row['smooth_deg']:.1f} / {row['align_deg']:.1f} / {row['s']:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("meshes", nargs="*")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", type=Path, help="write the figures here")
    ap.add_argument("--from-json", action="store_true", help="only print the table from --json")
    a = ap.parse_args(argv)
    if a.from_json:
        result = json.loads(a.json.read_text())
    else:
        results = []
        for p in a.meshes:
            results.append(figures(p, repeats=a.repeats))
            print(f"{results[-1]['mesh']}: done", file=sys.stderr)
        result = {"field": results, "repeats": a.repeats,
                  "command": "python -m nodegraph_nodes.curvature.field_figures " + " ".join(sys.argv[1:])}
        if a.json:
            a.json.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_text(a.json, json.dumps(result, indent=1) + "\n")
    defaults = Curvature.Params()
    print(table(result["field"], {"spread": 0.05, "smooth": defaults.smoothing}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
