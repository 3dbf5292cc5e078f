"""Two benchmarks of the line pipelines, each a command that prints figures, writes JSON and draws charts.

* `sketchgraph bench uncertainty-cost`: time against shower-door motion for screen-space uncertainty
  (nienhaus_sketchy: Perlin noise fixed on the screen) and object-space uncertainty
  (object_space_uncertainty: noise attached to the surface), several noise settings each, on several
  meshes. x is the shower-door metric of `sketchgraph bench shower-door` (showerdoor.py: the change of the
  offset that lands on the same surface point between orbit frames, relative to its size; 0 = the strokes
  move with the object), y the median ms per frame of `sketchgraph bench PIPELINE` with the same settings.
* `sketchgraph bench feature-lines`: what feature lines cost on top of the edge-only pipeline, per mesh:
  ms per frame of nienhaus_sketchy and of sketchy_lines (the same plus curvature and feature_lines), the
  feature_lines node's own time per frame, and the one-off per mesh (the first frame, curvature and the
  frame-independent line data, against a later frame).

Timings are medians of `repeats` runs of each setting; the JSON keeps every run, and the charts draw the
range (min to max over the runs) as error bars. All pipelines of one command are measured in one process,
interleaved per repeat, so the ratios between them are what to read on a loaded machine.
"""

from __future__ import annotations

import json
import statistics
import time
from pathlib import Path
from typing import Any

import click

from ...errors import SketchgraphError
from ...fsio import atomic_write_text

SCREEN = "nienhaus_sketchy"
OBJECT = "object_space_uncertainty"
EDGES_ONLY = "nienhaus_sketchy"
WITH_LINES = "sketchy_lines"

# (label, overrides): the noise frequency and octaves of each method
SCREEN_SETTINGS: list[tuple[str, list[str]]] = [
    ("scale 0.005, 4 oct", ["noise.scale=0.005"]),
    ("scale 0.01, 4 oct (default)", []),
    ("scale 0.02, 4 oct", ["noise.scale=0.02"]),
    ("scale 0.01, 1 oct", ["noise.octaves=1"]),
]
OBJECT_SETTINGS: list[tuple[str, list[str]]] = [
    ("scale 3, 3 oct", ["noise.scale=3.0"]),
    ("scale 6, 3 oct (default)", []),
    ("scale 12, 3 oct", ["noise.scale=12.0"]),
    ("scale 6, 1 oct", ["noise.octaves=1"]),
]
UNCERTAINTY_MESHES = ("spot.obj", "cow.obj")
LINE_MESHES = ("spot.obj", "cow.obj", "fandisk.obj", "stanford-bunny.obj", "ogre.obj")


def _mesh_path(name: str, meshes: Path | None) -> str:
    from .accuracy import SHARED_MESHES

    if name.startswith("builtin:"):
        return name
    folder = meshes or SHARED_MESHES
    p = Path(name) if Path(name).exists() else folder / name
    if not p.exists():
        raise SketchgraphError(f"mesh {name} not found (looked in {folder}; --meshes DIR names the folder)")
    return str(p)


def _frame_times(ex: Any, gl: Any, frames: range) -> list[float]:
    out = []
    for f in frames:
        t0 = time.perf_counter()
        ex.run(f)
        gl.finish()
        out.append((time.perf_counter() - t0) * 1000)
    return out


def time_pipeline(pipeline: str, scene: str, size: tuple[int, int], frames: int, overrides: list[str] = (),
                  warmup: int = 2, node_frames: int = 0) -> dict[str, Any]:
    """Median ms per frame along the orbit, no disk cache (as `sketchgraph bench PIPELINE` renders); with
    `node_frames`, the per-node medians of a second pass that waits for the GPU after every node."""
    from ... import pipeline as pl
    from ...executor import Executor
    from ...gpu import gl as glmod

    pipe = pl.load(pipeline, overrides=list(overrides), size=size, scene=scene)
    gl = glmod.get()
    ex = Executor(pipe, None, mode="loop", memory_limit=256 * 1024**2)
    _frame_times(ex, gl, range(-warmup, 0))
    ms = _frame_times(ex, gl, range(frames))
    out: dict[str, Any] = {"ms": statistics.median(ms), "frame_ms": ms}
    if node_frames:
        ex.timing = True
        per: dict[str, list[float]] = {}
        for f in range(node_frames):
            for nid, st in ex.run(f).stats.items():
                if st.status == "computed":
                    per.setdefault(nid, []).append(st.ms)
        out["nodes"] = {nid: statistics.median(v) for nid, v in per.items()}
    ex.clear_memory()
    return out


def first_frame(pipeline: str, scene: str, size: tuple[int, int], later: int = 3) -> dict[str, Any]:
    """The first frame of a fresh run (nothing in memory, no disk cache, the feature_lines node's per-mesh
    data dropped) against the median of the `later` frames after it; per node too."""
    from ... import pipeline as pl
    from ...executor import Executor
    from ...gpu import gl as glmod

    pipe = pl.load(pipeline, size=size, scene=scene)
    gl = glmod.get()
    gl.resources.pop("feature_lines.ops", None)
    ex = Executor(pipe, None, mode="loop", memory_limit=256 * 1024**2)
    ex.timing = True
    runs = []
    for f in range(later + 1):
        t0 = time.perf_counter()
        res = ex.run(f)
        gl.finish()
        runs.append(((time.perf_counter() - t0) * 1000,
                     {nid: st.ms for nid, st in res.stats.items() if st.status == "computed"}))
    ex.clear_memory()
    nodes = sorted({n for _, d in runs for n in d})
    return {"first_ms": runs[0][0], "later_ms": statistics.median(r[0] for r in runs[1:]),
            "first_nodes": runs[0][1],
            "later_nodes": {n: statistics.median(d.get(n, 0.0) for _, d in runs[1:]) for n in nodes}}


def _summary(runs: list[float]) -> dict[str, float]:
    return {"median": statistics.median(runs), "min": min(runs), "max": max(runs)}


def _renderer() -> str:
    from ...gpu import gl as glmod

    return glmod.get().renderer


def _write(result: dict[str, Any], json_path: Path | None, charts_dir: Path | None, draw: Any) -> None:
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json_path, json.dumps(result, indent=2) + "\n")
        click.echo(f"wrote {json_path}")
    if charts_dir:
        for p in draw(result, charts_dir):
            click.echo(f"wrote {p}")


# -- time against shower-door motion -----------------------------------------------------------------------
def uncertainty_cost(meshes: tuple[str, ...], size: tuple[int, int], sd_frames: int, frames: int, repeats: int,
                     meshes_dir: Path | None = None, progress: bool = True) -> dict[str, Any]:
    from .showerdoor import measure

    t0 = time.perf_counter()
    entries: list[dict[str, Any]] = []
    plan = [(m, method, pipe, label, ov) for m in meshes
            for method, pipe, settings in (("screen-space", SCREEN, SCREEN_SETTINGS),
                                           ("object-space", OBJECT, OBJECT_SETTINGS))
            for label, ov in settings]
    for mesh, method, pipe, label, ov in plan:
        scene = _mesh_path(mesh, meshes_dir)
        sd = measure(pipe, scene, sd_frames, size, overrides=ov)
        entries.append({"mesh": Path(mesh).name, "method": method, "pipeline": pipe, "setting": label,
                        "overrides": ov, "shower_door": sd["metric"], "shower_door_vs_spread": sd["metric_vs_spread"],
                        "degrees_per_frame": sd["degrees_per_frame"], "runs_ms": []})
        if progress:
            click.echo(f"  {Path(mesh).name:20s} {method:13s} {label:28s} shower-door {sd['metric']:.3f}", err=True)
    for r in range(repeats):  # interleaved: every setting once per repeat
        for e in entries:
            e["runs_ms"].append(time_pipeline(e["pipeline"], _mesh_path(e["mesh"], meshes_dir), size, frames,
                                              e["overrides"])["ms"])
        if progress:
            click.echo(f"  timing repeat {r + 1}/{repeats} done", err=True)
    for e in entries:
        e["ms"] = _summary(e["runs_ms"])
    return {"benchmark": "uncertainty-cost", "size": list(size), "shower_door_frames": sd_frames,
            "frames_timed": frames, "repeats": repeats, "renderer": _renderer(), "entries": entries,
            "definition": "x: mean over orbit frame pairs of sum |O_k+1(x') - O_k(x)| / sum |O_k(x)| "
                          "(sketchgraph bench shower-door); y: median ms per frame, no disk cache",
            "seconds": time.perf_counter() - t0}


def chart_uncertainty(result: dict[str, Any], out: Path) -> list[Path]:
    from .accuracy_charts import _front, _plt, _save

    plt = _plt()
    colors = {"screen-space": "#d1495b", "object-space": "#1b6ca8"}
    markers = ["o", "s", "^", "D", "v"]
    meshes = sorted({e["mesh"] for e in result["entries"]})
    fig, axes = plt.subplots(1, len(meshes), figsize=(5.0 * len(meshes), 4.2), squeeze=False, sharey=True)
    for ax, mesh in zip(axes[0], meshes, strict=True):
        rows = [e for e in result["entries"] if e["mesh"] == mesh]
        for method, color in colors.items():
            mine = [e for e in rows if e["method"] == method]
            for k, e in enumerate(mine):
                m = e["ms"]
                ax.errorbar(e["shower_door"], m["median"], yerr=[[m["median"] - m["min"]], [m["max"] - m["median"]]],
                            fmt=markers[k % len(markers)], color=color, ms=6, capsize=2, lw=0.8, zorder=3,
                            label=f"{method}: {e['setting']}")
        xs = [e["shower_door"] for e in rows]
        ys = [e["ms"]["median"] for e in rows]
        _front(ax, xs, ys, maximize_y=False)  # lower motion and lower time are both better
        ax.set_title(mesh)
        ax.set_xlabel("shower-door motion (0 = strokes stick to the surface)")
        ax.set_ylabel("ms per frame (median; bars: range over repeats)")
        ax.set_xlim(left=0)
        ax.legend(fontsize=6, loc="best")
    w, h = result["size"]
    fig.suptitle(f"Uncertainty on the screen vs on the surface: time against shower-door motion "
                 f"({w}x{h}, llvmpipe, shared 2-core machine)", fontsize=9)
    fig.tight_layout()
    return _save(fig, out, "uncertainty_cost")


# -- feature-line cost -------------------------------------------------------------------------------------
def feature_line_cost(meshes: tuple[str, ...], size: tuple[int, int], frames: int, repeats: int,
                      meshes_dir: Path | None = None, progress: bool = True) -> dict[str, Any]:
    from ... import pipeline as pl

    t0 = time.perf_counter()
    entries: dict[str, dict[str, Any]] = {}
    for mesh in meshes:
        scene = _mesh_path(mesh, meshes_dir)
        objs = pl.load(WITH_LINES, size=size, scene=scene).scene.objects
        entries[mesh] = {"mesh": Path(mesh).name, "triangles": int(sum(o.mesh.n_faces for o in objs)),
                         "vertices": int(sum(o.mesh.n_vertices for o in objs)),
                         "edges_only_runs": [], "with_lines_runs": [], "lines_node_runs": [], "curvature_runs": [],
                         "first_frame_runs": [], "later_frame_runs": [], "first_lines_runs": [],
                         "first_curvature_runs": []}
    for r in range(repeats):
        for mesh, e in entries.items():
            scene = _mesh_path(mesh, meshes_dir)
            a = time_pipeline(EDGES_ONLY, scene, size, frames)
            b = time_pipeline(WITH_LINES, scene, size, frames, node_frames=min(frames, 10))
            c = first_frame(WITH_LINES, scene, size)
            e["edges_only_runs"].append(a["ms"])
            e["with_lines_runs"].append(b["ms"])
            e["lines_node_runs"].append(b["nodes"].get("lines", 0.0))
            e["curvature_runs"].append(b["nodes"].get("curv", 0.0))
            e["first_frame_runs"].append(c["first_ms"])
            e["later_frame_runs"].append(c["later_ms"])
            e["first_lines_runs"].append(c["first_nodes"].get("lines", 0.0))
            e["first_curvature_runs"].append(c["first_nodes"].get("curv", 0.0))
            if progress:
                click.echo(f"  {e['mesh']:20s} repeat {r + 1}/{repeats}: edges only {a['ms']:.1f} ms, with lines "
                           f"{b['ms']:.1f} ms (lines node {e['lines_node_runs'][-1]:.1f}), first frame "
                           f"{c['first_ms']:.0f} ms", err=True)
    rows = []
    for e in entries.values():
        for k in [k for k in e if k.endswith("_runs")]:
            e[k[:-5]] = _summary(e[k])
        rows.append(e)
    return {"benchmark": "feature-lines", "size": list(size), "frames_timed": frames, "repeats": repeats,
            "renderer": _renderer(), "pipelines": {"edges_only": EDGES_ONLY, "with_lines": WITH_LINES},
            "entries": rows, "seconds": time.perf_counter() - t0}


def chart_feature_lines(result: dict[str, Any], out: Path) -> list[Path]:
    import numpy as np

    from .accuracy_charts import _plt, _save

    plt = _plt()
    rows = sorted(result["entries"], key=lambda e: e["triangles"])
    labels = [f"{e['mesh'].removesuffix('.obj')}\n{e['triangles'] / 1000:.1f}k tris" for e in rows]
    x = np.arange(len(rows))
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11.0, 4.2))

    def bars(axis: Any, keys: list[tuple[str, str, str]], width: float) -> None:
        for k, (key, label, color) in enumerate(keys):
            med = np.array([e[key]["median"] for e in rows])
            lo = med - np.array([e[key]["min"] for e in rows])
            hi = np.array([e[key]["max"] for e in rows]) - med
            axis.bar(x + (k - (len(keys) - 1) / 2) * width, med, width, yerr=[lo, hi], capsize=2, color=color,
                     label=label, error_kw={"lw": 0.7})
        axis.set_xticks(x, labels, fontsize=7)

    bars(ax, [("edges_only", "nienhaus_sketchy (edges only)", "#bbbbbb"),
              ("with_lines", "sketchy_lines (edges + feature lines)", "#1b6ca8"),
              ("lines_node", "feature_lines node alone", "#edae49")], 0.27)
    ax.set_ylabel("ms per frame (median; bars: range over repeats)")
    ax.set_title("Per frame, after the first")
    ax.legend(fontsize=7)
    bars(bx, [("first_frame", "first frame (sketchy_lines)", "#d1495b"),
              ("first_curvature", "  of it: curvature node", "#7d3c98"),
              ("first_lines", "  of it: feature_lines (per-mesh data)", "#edae49"),
              ("later_frame", "a later frame", "#1b6ca8")], 0.2)
    bx.set_yscale("log")
    bx.set_ylabel("ms (log)")
    bx.set_title("The one-off per mesh: first frame against later frames")
    bx.legend(fontsize=7)
    w, h = result["size"]
    fig.suptitle(f"What feature lines cost ({w}x{h}, llvmpipe, shared 2-core machine)", fontsize=9)
    fig.tight_layout()
    return _save(fig, out, "feature_lines_cost")


def _common(f: Any) -> Any:
    f = click.option("--charts", "charts_dir", type=click.Path(path_type=Path),
                     help="Write PNG and SVG charts here.")(f)
    f = click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")(f)
    f = click.option("--meshes", "meshes_dir", type=click.Path(path_type=Path, file_okay=False),
                     help="Folder of the meshes (default: ../shared/meshes beside the checkout).")(f)
    f = click.option("--repeats", default=3, show_default=True, help="Timed runs of every setting (interleaved).")(f)
    return f


@click.command()
@click.option("--mesh", "meshes", multiple=True, default=UNCERTAINTY_MESHES, show_default=True,
              help="Mesh file names (repeatable).")
@click.option("--size", default="400x400", show_default=True, help="WxH of the renders.")
@click.option("--shower-door-frames", default=12, show_default=True, help="Orbit frames of the shower-door metric.")
@click.option("--frames", default=20, show_default=True, help="Frames timed per run.")
@_common
def uncertainty_command(meshes: tuple[str, ...], size: str, shower_door_frames: int, frames: int, repeats: int,
                        meshes_dir: Path | None, json_path: Path | None, charts_dir: Path | None) -> None:
    """Time against shower-door motion: screen-space vs object-space uncertainty, several noise settings."""
    from ...pipeline import parse_size

    r = uncertainty_cost(tuple(meshes), parse_size(size), shower_door_frames, frames, repeats, meshes_dir)
    for e in r["entries"]:
        m = e["ms"]
        click.echo(f"{e['mesh']:12s} {e['method']:13s} {e['setting']:28s} shower-door {e['shower_door']:.3f}  "
                   f"{m['median']:.1f} ms [{m['min']:.1f}-{m['max']:.1f}]")
    _write(r, json_path, charts_dir, chart_uncertainty)


@click.command()
@click.option("--mesh", "meshes", multiple=True, default=LINE_MESHES, show_default=True,
              help="Mesh file names (repeatable).")
@click.option("--size", default="800x800", show_default=True, help="WxH of the renders.")
@click.option("--frames", default=10, show_default=True, help="Frames timed per run.")
@_common
def feature_lines_command(meshes: tuple[str, ...], size: str, frames: int, repeats: int, meshes_dir: Path | None,
                          json_path: Path | None, charts_dir: Path | None) -> None:
    """What feature lines cost: nienhaus_sketchy vs sketchy_lines per frame, the feature_lines node alone, and
    the first frame (curvature and the per-mesh line data) against later ones."""
    from ...pipeline import parse_size

    r = feature_line_cost(tuple(meshes), parse_size(size), frames, repeats, meshes_dir)
    for e in r["entries"]:
        def f(k: str, e: dict[str, Any] = e) -> str:
            return f"{e[k]['median']:.1f} [{e[k]['min']:.1f}-{e[k]['max']:.1f}]"
        click.echo(f"{e['mesh']} ({e['triangles']} triangles): edges only {f('edges_only')} ms, with lines "
                   f"{f('with_lines')} ms, lines node {f('lines_node')} ms; first frame {f('first_frame')} ms "
                   f"(curvature {f('first_curvature')}, lines {f('first_lines')}), later {f('later_frame')} ms")
    _write(r, json_path, charts_dir, chart_feature_lines)
