"""Charts of `sketchgraph bench accuracy`: time against accuracy, one point per method and setting, the
Pareto front (no other point is both faster and more accurate) drawn as a step line. PNG and SVG."""

from __future__ import annotations

import statistics
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from ...fsio import atomic_output

MODE_COLORS = {"normal_depth": "#1b6ca8", "normal": "#d1495b", "depth": "#edae49"}
OP_MARKERS = {"four_neighbour": "o", "sobel": "s"}
PARETO_STYLE = dict(color="#222222", lw=1.0, ls="--", zorder=1)


def _plt() -> Any:
    try:
        import matplotlib
    except ImportError as exc:  # optional dependency: pip install sketchgraph[charts]
        from ...errors import SketchgraphError

        raise SketchgraphError(f"charts need matplotlib ({exc}); pip install 'sketchgraph[charts]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 9, "svg.fonttype": "none", "axes.grid": True, "grid.alpha": 0.3,
                         "svg.hashsalt": "sketchgraph"})
    return plt


def pareto(xs: list[float], ys: list[float], maximize_y: bool = True) -> list[int]:
    """Indices of the Pareto-optimal points (smaller x better; larger y better unless maximize_y is
    False), sorted by x."""
    order = sorted(range(len(xs)), key=lambda i: (xs[i], -ys[i] if maximize_y else ys[i]))
    front: list[int] = []
    best = -np.inf if maximize_y else np.inf
    for i in order:
        y = ys[i]
        if (maximize_y and y > best) or (not maximize_y and y < best):
            front.append(i)
            best = y
    return front


def _front(ax: Any, xs: list[float], ys: list[float], maximize_y: bool = True, label: str = "Pareto front") -> list:
    idx = pareto(xs, ys, maximize_y)
    if idx:
        px = [xs[i] for i in idx]
        py = [ys[i] for i in idx]
        ax.step(px, py, where="post", label=label, **PARETO_STYLE)
        ax.scatter(px, py, s=70, facecolors="none", edgecolors="#222222", lw=1.0, zorder=4)
    return idx


def _save(fig: Any, out: Path, name: str) -> list[Path]:
    from matplotlib.ticker import NullFormatter

    for ax in fig.axes:  # minor tick labels of log axes overlap the major ones
        for axis, scale in ((ax.xaxis, ax.get_xscale()), (ax.yaxis, ax.get_yscale())):
            if scale == "log":
                axis.set_minor_formatter(NullFormatter())
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for ext in ("png", "svg"):
        p = out / f"{name}.{ext}"
        meta = {"Date": None} if ext == "svg" else {"Software": None}
        with atomic_output(p) as tmp:
            fig.savefig(tmp, dpi=110, bbox_inches="tight", metadata=meta, format=ext)
        paths.append(p)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return paths


# -- edges -----------------------------------------------------------------------------------------
def _edge_points(entries: list[dict[str, Any]], size: int, meshes: tuple[str, ...] | None = None) -> list[dict]:
    """One point per (method, setting): mean F1 over meshes, median ms."""
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for e in entries:
        if e["size"] == size and (meshes is None or e["mesh"] in meshes):
            groups[(e["method"], e["setting"])].append(e)
    pts = []
    for (method, setting), rows in groups.items():
        pts.append({"method": method, "setting": setting, "operator": rows[0]["operator"], "mode": rows[0]["mode"],
                    "f1": float(np.mean([r["f1"] for r in rows])), "ms": statistics.median(r["ms"] for r in rows),
                    "n": len(rows)})
    return pts


def _edge_scatter(ax: Any, pts: list[dict], title: str, annotate: int = 4) -> None:
    for p in pts:
        ax.scatter(p["ms"], p["f1"], c=MODE_COLORS[p["mode"]], marker=OP_MARKERS[p["operator"]], s=28,
                   alpha=0.85, zorder=3, edgecolors="white", linewidths=0.4)
    xs, ys = [p["ms"] for p in pts], [p["f1"] for p in pts]
    idx = _front(ax, xs, ys)
    offsets = [(6, -12), (6, 4), (-10, -24), (6, -36)]
    for k, i in enumerate(idx[-annotate:][::-1]):
        p = pts[i]
        ax.annotate(f"{p['operator'].replace('four_neighbour', '4n')} {p['setting']}", (p["ms"], p["f1"]),
                    textcoords="offset points", xytext=offsets[k % len(offsets)], fontsize=7,
                    arrowprops=dict(arrowstyle="-", color="#999999", lw=0.5))
    ax.set_title(title)
    ax.set_xlabel("ms per frame (edge_detect pass, llvmpipe)")
    ax.set_ylabel("F1 vs ground-truth lines (1 px)")


def _edge_legend(ax: Any) -> None:
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], marker="o", ls="", color=c, label=m) for m, c in MODE_COLORS.items()]
    handles += [Line2D([], [], marker=mk, ls="", color="grey", label=op) for op, mk in OP_MARKERS.items()]
    handles.append(Line2D([], [], **PARETO_STYLE, label="Pareto front"))
    ax.legend(handles=handles, loc="lower right", fontsize=7)


def chart_edges(result: dict[str, Any], out: Path) -> list[Path]:
    plt = _plt()
    entries = result.get("edges") or []
    if not entries:
        return []
    paths: list[Path] = []
    sizes = sorted({e["size"] for e in entries})
    meshes = sorted({e["mesh"] for e in entries})
    # one chart per size: all meshes averaged
    for size in sizes:
        fig, ax = plt.subplots(figsize=(6.4, 4.4))
        pts = _edge_points(entries, size)
        _edge_scatter(ax, pts, f"Edge detection at {size}x{size}: mean over {len(meshes)} scenes")
        _edge_legend(ax)
        ax.set_ylim(min(0.0, min(p["f1"] for p in pts)) - 0.02, 1.02)
        paths += _save(fig, out, f"edges_{size}")
    # per mesh at 800 (or the middle size)
    size = 800 if 800 in sizes else sizes[len(sizes) // 2]
    cols = 3
    rows = int(np.ceil(len(meshes) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.0 * cols, 3.2 * rows), squeeze=False)
    for ax, mesh in zip(axes.ravel(), meshes, strict=False):
        pts = _edge_points(entries, size, (mesh,))
        _edge_scatter(ax, pts, mesh, annotate=1)
        ax.axhline(0.85, color="#2a9d8f", lw=0.8, ls=":")
        ax.set_ylim(-0.02, 1.02)
        ax.xaxis.label.set_size(7)
    for ax in axes.ravel()[len(meshes):]:
        ax.axis("off")
    _edge_legend(axes.ravel()[0])
    fig.suptitle(f"Edge detection per scene at {size}x{size} (dotted: target F1 0.85)")
    fig.tight_layout()
    paths += _save(fig, out, f"edges_by_mesh_{size}")
    # resolution: the Pareto fronts of every size on one chart
    if len(sizes) > 1:
        fig, ax = plt.subplots(figsize=(6.4, 4.4))
        colors = plt.cm.viridis(np.linspace(0.1, 0.85, len(sizes)))
        for c, s in zip(colors, sizes, strict=True):
            pts = _edge_points(entries, s)
            xs, ys = [p["ms"] for p in pts], [p["f1"] for p in pts]
            ax.scatter(xs, ys, color=c, s=14, alpha=0.5, label=f"{s}x{s}")
            idx = pareto(xs, ys)
            ax.step([xs[i] for i in idx], [ys[i] for i in idx], where="post", color=c, lw=1.4)
        ax.set_xscale("log")
        ax.set_xlabel("ms per frame (edge_detect pass)")
        ax.set_ylabel("mean F1 over scenes")
        ax.set_title("Edge detection: Pareto front per resolution")
        ax.set_ylim(-0.02, 1.02)
        ax.legend(fontsize=7)
        paths += _save(fig, out, "edges_sizes")
    return paths


# -- curvature -------------------------------------------------------------------------------------
def chart_curvature(result: dict[str, Any], out: Path) -> list[Path]:
    plt = _plt()
    entries = result.get("curvature") or []
    if not entries:
        return []
    surfaces = [s for s in ("torus", "ellipsoid") if any(e["surface"] == s for e in entries)]
    fig, axes = plt.subplots(len(surfaces), 2, figsize=(11, 3.8 * len(surfaces)), squeeze=False)
    radii = sorted({e["radius"] for e in entries})
    cmap = [plt.cm.tab10(i % 10) for i in range(len(radii))]
    color = dict(zip(radii, cmap, strict=True))
    for row, surface in zip(axes, surfaces, strict=True):
        rows = [e for e in entries if e["surface"] == surface and e["direction_p95_deg"] is not None]
        for ax, key, label in ((row[0], "direction_p95_deg", "p95 direction error (deg)"),
                               (row[1], "value_p95", "p95 value error |dk| / |kmax|")):
            for e in rows:
                ax.scatter(e["ms"], e[key], color=color[e["radius"]], s=30, zorder=3)
                ax.annotate(f"{e['vertices']}", (e["ms"], e[key]), textcoords="offset points", xytext=(3, 2),
                            fontsize=6, color="#555555")
            _front(ax, [e["ms"] for e in rows], [e[key] for e in rows], maximize_y=False)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("ms per mesh (compute_curvature; labels: vertices)")
            ax.set_ylabel(label)
            ax.set_title(f"{surface}", fontsize=9)
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], marker="o", ls="", color=color[r], label=f"radius {r}") for r in radii]
    handles.append(Line2D([], [], **PARETO_STYLE, label="Pareto front"))
    axes[0][0].legend(handles=handles, fontsize=7)
    fig.suptitle("Principal curvature (libigl) against analytic torus and ellipsoid")
    fig.tight_layout()
    return _save(fig, out, "curvature")


# -- particles, hatching, noise, pipelines ---------------------------------------------------------
def chart_particles(result: dict[str, Any], out: Path) -> list[Path]:
    plt = _plt()
    entries = result.get("particles") or []
    if not entries:
        return []
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    colors = {"euler": "#d1495b", "rk4": "#1b6ca8"}
    for e in entries:
        ax.scatter(e["ms"], e["f1"], color=colors[e["integrator"]], s=12 + 10 * np.log2(max(e["strokes"], 1) / 50),
                   alpha=0.8, zorder=3)
        ax.annotate(f"{e['strokes']}/{e['step']:g}", (e["ms"], e["f1"]), textcoords="offset points",
                    xytext=(3, 2), fontsize=6, color="#555555")
    _front(ax, [e["ms"] for e in entries], [e["f1"] for e in entries])
    from matplotlib.lines import Line2D

    ax.legend(handles=[Line2D([], [], marker="o", ls="", color=c, label=k) for k, c in colors.items()]
              + [Line2D([], [], **PARETO_STYLE, label="Pareto front")], fontsize=7, loc="lower right")
    ax.set_xscale("log")
    ax.set_xlabel("ms per drawing (CPU; labels: strokes/step, marker size: strokes)")
    ax.set_ylabel("F1 of coverage and precision vs the edge map (2 px)")
    ax.set_title("Particle sketch: strokes, step size, Euler vs RK4")
    return _save(fig, out, "particles")


def chart_hatching(result: dict[str, Any], out: Path) -> list[Path]:
    plt = _plt()
    entries = result.get("hatching") or []
    if not entries:
        return []
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    widths = sorted({e["stroke_width"] for e in entries})
    colors = dict(zip(widths, plt.cm.viridis(np.linspace(0.1, 0.8, len(widths))), strict=True))
    for ax, key, label, log in ((axes[0], "local_tone_error", "local tone error (RMS std of 1/8-tile darkness)",
                                 False),
                                (axes[1], "tone_error_max", "tone error (max |darkness - target| over tones)",
                                 True)):
        for e in entries:
            ax.scatter(e["ms"], e[key], color=colors[e["stroke_width"]], s=30, zorder=3)
            txt = f"{e['size']}px" + (f", {e['strokes']} strokes" if e.get("strokes") else "")
            ax.annotate(txt, (e["ms"], e[key]), textcoords="offset points", xytext=(3, 2), fontsize=6)
        _front(ax, [e["ms"] for e in entries], [e[key] for e in entries], maximize_y=False)
        ax.set_xscale("log")
        if log:
            ax.set_yscale("log")
        ax.set_xlabel("ms per tonal art map (32 tones, CPU)")
        ax.set_ylabel(label)
    from matplotlib.lines import Line2D

    axes[0].legend(handles=[Line2D([], [], marker="o", ls="", color=c, label=f"stroke width {w:g}")
                            for w, c in colors.items()] + [Line2D([], [], **PARETO_STYLE, label="Pareto front")],
                   fontsize=7)
    fig.suptitle("Hatching synthesis: texture size and stroke width (stroke count follows)")
    fig.tight_layout()
    return _save(fig, out, "hatching")


def chart_noise(result: dict[str, Any], out: Path) -> list[Path]:
    plt = _plt()
    entries = result.get("noise") or []
    if not entries:
        return []
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for e in entries:
        err = max(e["max_error"], 1e-9)
        ax.plot([e["ms"], e["reference_ms"]], [err, 1e-9], color="#bbbbbb", lw=0.6, zorder=1)
        ax.scatter(e["ms"], err, color="#1b6ca8", zorder=3)
        ax.scatter(e["reference_ms"], 1e-9, color="#d1495b", marker="s", zorder=3)
        ax.annotate(e["method"], (e["reference_ms"], 1e-9), textcoords="offset points", xytext=(0, 8),
                    fontsize=7, rotation=60)
        # each noise function is its own trade-off: the GPU is faster, the float64 reference exact, so both
        # points are on that function's Pareto front
        ax.scatter([e["ms"], e["reference_ms"]], [err, 1e-9], s=70, facecolors="none", edgecolors="#222222",
                   lw=1.0, zorder=4)
    from matplotlib.lines import Line2D

    ax.legend(handles=[Line2D([], [], marker="o", ls="", color="#1b6ca8", label="GPU (perlin_noise node)"),
                       Line2D([], [], marker="s", ls="", color="#d1495b", label="float64 NumPy reference"),
                       Line2D([], [], marker="o", ls="", mfc="none", mec="#222222",
                              label="Pareto front (per noise function)")], fontsize=7, loc="center right")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(5e-10, 5e-5)
    ax.set_xlabel("ms per 800x800 frame (labels: kind x octaves)")
    ax.set_ylabel("max |GPU - float64| (exact 0 drawn at 1e-9)")
    ax.set_title("perlin_noise: GPU against its float64 reference")
    return _save(fig, out, "noise")


def chart_pipelines(result: dict[str, Any], out: Path) -> list[Path]:
    plt = _plt()
    entries = [e for e in result.get("pipelines") or [] if "ms" in e]
    if not entries:
        return []
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    by: dict[str, list[dict]] = defaultdict(list)
    for e in entries:
        by[e["pipeline"]].append(e)
    colours = plt.get_cmap("tab20").colors  # more pipelines than the default cycle's ten colours
    markers = "osD^v<>ph*"
    for i, (name, rows) in enumerate(sorted(by.items())):
        rows.sort(key=lambda r: r["size"])
        ax.plot([r["size"] ** 2 / 1e6 for r in rows], [r["ms"] for r in rows], marker=markers[i % len(markers)],
                color=colours[(2 * i) % 20 if i < 10 else (2 * i + 1) % 20], label=name)
    ax.set_xscale("log")
    ax.set_yscale("log")
    sizes = sorted({r["size"] for r in entries})
    ax.set_xticks([s_**2 / 1e6 for s_ in sizes], [f"{s_}²" for s_ in sizes])
    ax.set_xlabel("pixels per frame")
    ax.set_ylabel("ms per frame (median, llvmpipe)")
    ax.set_title("Whole pipelines: time per frame against resolution")
    ax.legend(fontsize=7)
    return _save(fig, out, "pipelines")


def chart_stability(result: dict[str, Any], out: Path) -> list[Path]:
    plt = _plt()
    sweeps = result.get("stability") or {}
    if not sweeps:
        return []
    names = [n for n, s in sweeps.items() if s.get("points")]
    cols = 3
    rows = int(np.ceil(len(names) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.3 * rows), squeeze=False)
    for ax, name in zip(axes.ravel(), names, strict=False):
        s = sweeps[name]
        pts = s["points"]
        series = s.get("series") or sorted({p["series"] for p in pts})
        for ser in series:
            rows_ = [p for p in pts if p["series"] == ser and p.get("value") is not None]
            if rows_:
                ax.plot([p["x"] for p in rows_], [p["value"] for p in rows_], marker="o", ms=3, label=ser)
        if s.get("log_x"):
            ax.set_xscale("log")
        if s.get("log_y"):
            ax.set_yscale("log")
        for bx in (s.get("breaks") or {}).values():
            for x in bx if isinstance(bx, list) else [bx]:
                if x is not None:
                    ax.axvline(x, color="#d1495b", lw=0.8, ls=":")
        if s.get("threshold") is not None:
            ax.axhline(s["threshold"], color="#888888", lw=0.8, ls="--")
        ax.set_title(s.get("title", name), fontsize=8)
        ax.set_xlabel(s.get("x_label", ""), fontsize=7)
        ax.set_ylabel(s.get("y_label", ""), fontsize=7)
        ax.legend(fontsize=6)
    for ax in axes.ravel()[len(names):]:
        ax.axis("off")
    fig.suptitle("Stability sweeps (dashed: the accuracy that counts as broken; dotted: where it breaks)")
    fig.tight_layout()
    return _save(fig, out, "stability")


# -- hatching field (nodes/curvature/field_figures.py) --------------------------------------------
FIELD_COLORS = {"spread": "#d1495b", "smooth": "#1b6ca8"}


def chart_field(result: dict[str, Any], out: Path) -> list[Path]:
    """Per mesh: node seconds against the field's smoothness (field.png) and the alignment with strong
    principal directions against smoothness (field_alignment.png), one line per `field` method through
    its `smoothing` values (labels)."""
    plt = _plt()
    meshes = result.get("field") or []
    if not meshes:
        return []
    cols = min(4, len(meshes))
    nrows = int(np.ceil(len(meshes) / cols))
    paths: list[Path] = []
    for name, xkey, ykey, xlabel, ylabel, title in (
            ("field", "s", "smooth_deg", "node seconds (median; libigl included: dotted)",
             "neighbour angle (deg, lower: smoother)",
             "Hatching field: curvature node time against smoothness"),
            ("field_alignment", "smooth_deg", "align_deg", "neighbour angle (deg, lower: smoother)",
             "angle to strong measured dmin (deg)",
             "Hatching field: alignment against smoothness (lower left is better)")):
        fig, axes = plt.subplots(nrows, cols, figsize=(3.3 * cols, 2.9 * nrows), squeeze=False)
        for ax, m in zip(axes.ravel(), meshes, strict=False):
            for field, color in FIELD_COLORS.items():
                rows = sorted((r for r in m["rows"] if r["field"] == field), key=lambda r: r["smoothing"])
                if not rows:
                    continue
                xs, ys = [r[xkey] for r in rows], [r[ykey] for r in rows]
                ax.plot(xs, ys, marker="o", ms=3.5, lw=1.0, color=color, label=field)
                if xkey == "s":
                    ax.hlines(ys, [r["s_min"] for r in rows], [r["s_max"] for r in rows], color=color, lw=0.6)
                for r, x, y in zip(rows, xs, ys, strict=True):
                    ax.annotate(f"{r['smoothing']:g}", (x, y), textcoords="offset points", xytext=(3, 2),
                                fontsize=5.5, color=color)
            if xkey == "s":
                ax.axvline(m["curvature_s"], color="#888888", lw=0.8, ls=":")
                ax.axhline(m["measured_smooth_deg"], color="#888888", lw=0.8, ls="--")
                ax.set_xscale("log")
            ax.set_title(f"{m['mesh']} ({m['vertices']} vertices)", fontsize=8)
            ax.set_xlabel(xlabel, fontsize=7)
            ax.set_ylabel(ylabel, fontsize=7)
            ax.tick_params(labelsize=7)
        for ax in axes.ravel()[len(meshes):]:
            ax.axis("off")
        axes[0][0].legend(fontsize=7)
        note = " (dashed: as measured; labels: smoothing)" if name == "field" else " (labels: smoothing)"
        fig.suptitle(title + note, fontsize=9)
        fig.tight_layout()
        paths += _save(fig, out, name)
    return paths


def draw_all(result: dict[str, Any], out: Path) -> list[Path]:
    paths: list[Path] = []
    for fn in (chart_edges, chart_curvature, chart_particles, chart_hatching, chart_noise, chart_pipelines,
               chart_stability):
        paths += fn(result, Path(out))
    return paths


CHARTS = {"field": chart_field, "edges": chart_edges, "curvature": chart_curvature, "particles": chart_particles,
          "hatching": chart_hatching, "noise": chart_noise, "pipelines": chart_pipelines,
          "stability": chart_stability}


def main(argv: list[str] | None = None) -> int:
    """python -m nodegraph.tools.bench.accuracy_charts CHART FIGURES.json OUTDIR: draws one chart family from a
    JSON of figures (field: nodes/curvature/field_figures.py's --json; the others: `bench accuracy --json`, e.g.
    docs/charts/accuracy.json after merging a family measured again)."""
    import argparse
    import json

    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("chart", choices=sorted(CHARTS))
    ap.add_argument("figures", type=Path)
    ap.add_argument("out", type=Path)
    a = ap.parse_args(argv)
    for p in CHARTS[a.chart](json.loads(a.figures.read_text()), a.out):
        print(f"wrote {p}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
