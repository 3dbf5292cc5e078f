"""Figures for docs/pencil.md: smoothness and alignment of the hatching field, spread against smooth.

    python -m nodegraph_nodes.curvature.field_figures ../shared/meshes/spot.obj ...
"""

from __future__ import annotations

import sys
import time

import numpy as np

from nodegraph.meshes import load_mesh

from . import Curvature
from .field import alignment_deg, alignment_weight, smoothness_deg
from .principal import Reason, compute_curvature


def figures(path: str) -> list[dict]:
    mesh = load_mesh(path)
    wid, nu = mesh.weld()
    rep = np.full(nu, len(mesh.vertices), dtype=np.int64)
    np.minimum.at(rep, wid, np.arange(len(mesh.vertices)))
    V, F = mesh.vertices[rep].astype(np.float64), wid[mesh.faces]
    c = compute_curvature(V, F)
    measured = (c.reason == Reason.OK) | (c.reason == Reason.UMBILIC)
    strong = alignment_weight(c.kmin, c.kmax, measured) >= 0.5
    raw = np.asarray(c.dmin)
    rows = [{"mesh": mesh.name, "field": "measured", "smooth_deg": smoothness_deg(V, F, c.normal, raw),
             "align_deg": 0.0, "s": 0.0}]
    for field in ("spread", "smooth"):
        node = Curvature("curv", Curvature.Params(field=field))
        t = time.perf_counter()
        out = node.measure(V, F)
        dt = time.perf_counter() - t
        d = out["dmin"].astype(np.float64)
        rows.append({"mesh": mesh.name, "field": field, "smooth_deg": smoothness_deg(V, F, c.normal, d),
                     "align_deg": alignment_deg(d, raw, strong & (c.reason == Reason.OK)), "s": dt})
    return rows


def main(paths: list[str]) -> None:
    print("| mesh | field | neighbour angle (deg) | angle to measured dmin where anisotropy >= 0.5 (deg) | node s |")
    print("| --- | --- | --- | --- | --- |")
    for p in paths:
        for r in figures(p):
            print(f"| {r['mesh']} | {r['field']} | {r['smooth_deg']:.2f} | {r['align_deg']:.2f} | {r['s']:.2f} |")


if __name__ == "__main__":
    main(sys.argv[1:])
