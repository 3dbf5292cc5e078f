"""`sketchgraph bench accuracy`: every method family's accuracy against an independent reference, and
its cost, measured side by side in one run; JSON plus time-against-accuracy charts.

Families (each a key of the JSON):
- `edges`: edge_detect (operator x mode x thresholds x width) on the shared meshes and built-in scenes at
  several sizes; precision, recall and F1 against the line drawing computed from the mesh itself
  (`groundtruth`), 1-px tolerance; ms of the GPU pass (median, waiting for the GPU after each).
- `curvature`: libigl principal curvature (`nodes.curvature.principal`) on an analytic torus and ellipsoid
  at several tessellations and radii; median and 95th-percentile value and direction errors; s per mesh.
- `particles`: the particle sketch core on a real depth buffer; stroke count, step, Euler vs RK4;
  coverage and precision against its edge map (and against the ground-truth lines); time.
- `hatching`: tonal art maps by texture size and stroke width; strokes drawn, tone error, time.
- `noise`: perlin_noise on the GPU against its float64 reference: max error, ms per frame.
- `pipelines`: ms per frame of the pipelines in `pipelines/` at several sizes.
- `stability`: the failure-mode sweeps of `nodegraph.tools.stability`.

Timings are medians of a few runs on a shared machine: compare ratios within one run, never across runs.
"""

from __future__ import annotations

import json
import math
import statistics
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
import numpy as np

# the shared test meshes sit beside a checkout (../shared/meshes); an installed package has no such
# folder, so there the command asks for --meshes DIR
SHARED_MESHES = Path(__file__).resolve().parents[3] / "shared" / "meshes"
TARGET_MESHES = ("fandisk.obj", "spot.obj", "stanford-bunny.obj")
TARGET_F1 = 0.85
FAMILIES = ("edges", "curvature", "particles", "hatching", "noise", "pipelines", "stability")
BUILTIN_EDGE_SCENES = ("builtin:box", "builtin:torus", "builtin:cloister")


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _median_ms(fn: Callable[[], Any], repeats: int, finish: Callable[[], None] | None = None) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        if finish is not None:
            finish()
        times.append((time.perf_counter() - t0) * 1000.0)
    return statistics.median(times)


# -- running single nodes -------------------------------------------------------------------------
class _Plan:
    def __init__(self, formats: dict | None = None) -> None:
        self.formats = formats or {}


class _Pipe:
    def __init__(self, size: tuple[int, int], scene: Any, seed: int) -> None:
        self.size, self.scene, self.seed = size, scene, seed


class NodeRunner:
    """Runs one node's `compute()` outside a pipeline, with declared (or given) output formats."""

    def __init__(self, gl: Any, size: tuple[int, int], scene: Any = None, seed: int = 0,
                 formats: dict | None = None) -> None:
        self.gl = gl
        self.pipeline = _Pipe(size, scene, seed)
        self.plan = _Plan(formats)

    def run(self, node: Any, inputs: dict[str, Any], needed: frozenset[str] | None = None, frame: int = 0) -> dict:
        from ..executor import RunContext

        ctx = RunContext(self, node, frame)  # type: ignore[arg-type]
        return node.compute(ctx, inputs, frozenset(node.outputs) if needed is None else needed)


def gbuffer(gl: Any, scene: Any, size: tuple[int, int], ports: tuple[str, ...] = ("normal_depth",),
            frame: int = 0, **params: Any) -> dict[str, Any]:
    """Rasterize `scene` into the requested G-buffer outputs (textures) at `size`."""
    from nodegraph_nodes.rasterize import Rasterize

    node = Rasterize("gbuf", Rasterize.Params(**params))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return NodeRunner(gl, size, scene).run(node, {}, frozenset(ports), frame)


def release(gl: Any, values: dict[str, Any]) -> None:
    for v in values.values():
        gl.release(v)


def scene_for(spec: str) -> Any:
    from ..scene import load_scene

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(spec)


# -- edges ---------------------------------------------------------------------------------------
def edge_settings(quick: bool) -> list[dict[str, Any]]:
    """Parameter sets of edge_detect to measure (the node's defaults first)."""
    out: list[dict[str, Any]] = []
    for op in ("four_neighbour", "sobel"):
        if quick:
            grid = [("normal_depth", 0.4, 0.03), ("normal", 0.4, 0.03), ("depth", 0.4, 0.03)]
        else:
            grid = [("normal_depth", nt, dt) for nt in (0.2, 0.4, 0.8) for dt in (0.01, 0.03, 0.1)]
            grid += [("normal", nt, 0.03) for nt in (0.1, 0.2, 0.4, 0.8)]
            grid += [("depth", 0.4, dt) for dt in (0.003, 0.01, 0.03, 0.1)]
        for mode, nt, dt in grid:
            out.append(dict(operator=op, mode=mode, normal_threshold=nt, depth_threshold=dt, width=1))
        out.append(dict(operator=op, mode="normal_depth", normal_threshold=0.4, depth_threshold=0.03, width=2))
    return out


def setting_label(s: dict[str, Any]) -> str:
    parts = []
    if s["mode"] != "depth":
        parts.append(f"n>{s['normal_threshold']:g}")
    if s["mode"] != "normal":
        parts.append(f"d>{s['depth_threshold']:g}")
    parts.append(f"w{s['width']}")
    return " ".join(parts)


def edge_scenes(meshes_dir: Path, quick: bool) -> list[tuple[str, str]]:
    """(name, scene spec) of the scenes to measure edges on."""
    names = TARGET_MESHES if quick else tuple(sorted(p.name for p in meshes_dir.glob("*.obj")))
    out = [(n, str(meshes_dir / n)) for n in names if (meshes_dir / n).exists()]
    if not quick:
        out += [(s, s) for s in BUILTIN_EDGE_SCENES]
    return out


def bench_edges(meshes_dir: Path, quick: bool, sizes: list[int] | None = None,
                repeats: int | None = None) -> dict[str, Any]:
    from nodegraph_nodes.edge_detect import EdgeDetect

    from .. import gl as glmod
    from .bench import copy_pass_ms
    from .groundtruth import line_drawing, precision_recall

    gl = glmod.get()
    sizes = sizes or ([800] if quick else [400, 800, 1600])
    repeats = repeats or (3 if quick else 5)
    settings = edge_settings(quick)
    entries: list[dict[str, Any]] = []
    gt_info: list[dict[str, Any]] = []
    copy_ms = {}
    scenes = edge_scenes(meshes_dir, quick)
    for size in sizes:
        dims = (size, size)
        copy_ms[str(size)] = copy_pass_ms(gl, dims)
        for name, spec in scenes:
            scene = scene_for(spec)
            t_gt = time.perf_counter()
            g = gbuffer(gl, scene, dims)
            nd = g["normal_depth"]
            gbuf_ms = _median_ms(lambda scene=scene, dims=dims: release(gl, gbuffer(gl, scene, dims)), 3, gl.finish)
            truth = line_drawing(scene, dims, nd.read()[..., 3])
            gt_ms = (time.perf_counter() - t_gt) * 1000.0
            gt_info.append({"mesh": name, "size": size, "line_pixels": truth.counts["line_pixels"],
                            **{k: v for k, v in truth.counts.items() if k.endswith("_edges")}})
            runner = NodeRunner(gl, dims, scene)
            for s in settings:
                node = EdgeDetect("edges", EdgeDetect.Params(**s))
                release(gl, runner.run(node, {"normal_depth": nd}, frozenset({"out"})))  # compile, warm
                ms = _median_ms(lambda node=node, runner=runner, nd=nd: release(
                    gl, runner.run(node, {"normal_depth": nd}, frozenset({"out"}))), repeats, gl.finish)
                out = runner.run(node, {"normal_depth": nd}, frozenset({"out"}))
                detected = out["out"].read()[..., 0] > 0.5
                release(gl, out)
                pr = precision_recall(detected, truth.lines, 1)
                entries.append({"mesh": name, "method": f"{s['operator']}/{s['mode']}", "setting": setting_label(s),
                                "size": size, "ms": ms, "precision": pr["precision"], "recall": pr["recall"],
                                "f1": pr["f1"], **s, "gbuffer_ms": gbuf_ms,
                                "ms_over_copy_pass": ms / copy_ms[str(size)]})
            best = max((e for e in entries if e["mesh"] == name and e["size"] == size), key=lambda e: e["f1"])
            log(f"  edges {name} {size}px: best F1 {best['f1']:.3f} ({best['method']} {best['setting']}), "
                f"G-buffer {gbuf_ms:.1f} ms, ground truth {gt_ms:.0f} ms")
            gl.release(nd)
    summary = edge_summary(entries)
    return {"entries": entries, "ground_truth": gt_info, "copy_pass_ms": copy_ms, "summary": summary}


def edge_summary(entries: list[dict[str, Any]]) -> dict[str, Any]:
    """Best setting per mesh at each size, and the target check at 800 px."""
    best: dict[str, dict[str, Any]] = {}
    for e in entries:
        k = f"{e['mesh']}@{e['size']}"
        if k not in best or e["f1"] > best[k]["f1"]:
            best[k] = e
    target = {m: best.get(f"{m}@800", {}).get("f1") for m in TARGET_MESHES}
    return {
        "best": {k: {"f1": v["f1"], "precision": v["precision"], "recall": v["recall"], "method": v["method"],
                     "setting": v["setting"], "ms": v["ms"]} for k, v in best.items()},
        "target_f1": TARGET_F1,
        "target_meshes_best_f1_at_800": target,
        "target_met": all(v is not None and v >= TARGET_F1 for v in target.values()),
    }


# -- curvature -----------------------------------------------------------------------------------
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
    from ..primitives import ellipsoid

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


def bench_curvature(quick: bool, meshes_dir: Path | None = None) -> dict[str, Any]:
    from nodegraph_nodes.curvature.principal import compute_curvature

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
        from ..meshes import load_mesh

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


# -- particles -----------------------------------------------------------------------------------
def particle_depth(meshes_dir: Path, size: int) -> tuple[np.ndarray, Any, np.ndarray]:
    """Window depth (1 = background) of cow.obj (or the built-in torus) at size^2, the scene, and its
    ground-truth line drawing."""
    from .. import gl as glmod
    from .groundtruth import line_drawing

    gl = glmod.get()
    spec = str(meshes_dir / "cow.obj") if (meshes_dir / "cow.obj").exists() else "builtin:torus"
    scene = scene_for(spec)
    g = gbuffer(gl, scene, (size, size), ("depth", "linear_depth"))
    depth = g["depth"].read()[..., 0].astype(np.float64)
    lin = g["linear_depth"].read()[..., 0]
    release(gl, g)
    return depth, spec, line_drawing(scene, (size, size), lin).lines


def bench_particles(meshes_dir: Path, quick: bool) -> dict[str, Any] | None:
    try:
        from nodegraph_nodes.particle_sketch import core
    except ImportError as exc:
        return {"skipped": f"particle core not importable: {exc}"}
    from .groundtruth import precision_recall

    size = 400 if quick else 800
    depth, spec, truth = particle_depth(meshes_dir, size)
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
                gt = precision_recall(res.sketch > 0.1, truth, 2)
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


# -- hatching ------------------------------------------------------------------------------------
def strokes_needed(size: int, stroke_width: float, tones: int = 32, max_darkness: float = 0.8) -> int:
    """Strokes the darkest tone takes (to 64 strokes): the smallest cap that synthesis accepts."""
    from nodegraph_nodes.hatching_synthesis.tam import synthesize_tam

    def ok(cap: int) -> bool:
        try:
            synthesize_tam(size=size, tones=2, strokes=cap, stroke_width=stroke_width, max_darkness=max_darkness)
            return True
        except ValueError:
            return False

    hi = 256
    while not ok(hi):
        hi *= 2
        if hi > 1 << 22:
            raise RuntimeError("hatching: darkness never reached")
    lo = hi // 2 if hi > 256 else 0
    while hi - lo > 64:
        mid = (lo + hi) // 2
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return hi


def local_tone_error(tam: np.ndarray, blocks: int = 8) -> float:
    """RMS over tones of the standard deviation of darkness over blocks x blocks tiles of the texture:
    how unevenly a tone covers the tile (what a viewer sees as blotches)."""
    t, h, w = tam.shape
    bh, bw = h // blocks, w // blocks
    d = 1.0 - tam[:, :bh * blocks, :bw * blocks].reshape(t, blocks, bh, blocks, bw).mean(axis=(2, 4))
    return float(np.sqrt(np.mean(d.reshape(t, -1).std(axis=1) ** 2)))


def bench_hatching(quick: bool) -> dict[str, Any]:
    from nodegraph_nodes.hatching_synthesis.tam import measured_darkness, synthesize_tam, tone_targets

    sizes = [64, 128, 256] if quick else [64, 128, 256, 512]
    widths = [1.1] if quick else [0.7, 1.1, 2.0]
    entries = []
    for size in sizes:
        for sw in widths:
            ms = _median_ms(lambda size=size, sw=sw: synthesize_tam(size=size, stroke_width=sw, strokes=400000),
                            1 if size >= 512 else 3)
            tam = synthesize_tam(size=size, stroke_width=sw, strokes=400000)
            err = np.abs(measured_darkness(tam) - tone_targets(32, 0.8))
            entries.append({"method": f"{size}px w{sw:g}", "size": size, "stroke_width": sw,
                            "strokes": None if quick else strokes_needed(size, sw),
                            "tone_error_max": float(err.max()), "tone_error_mean": float(err.mean()),
                            "local_tone_error": local_tone_error(tam), "ms": ms})
    log("  hatching: " + ", ".join(f"{e['method']} {e['ms']:.0f} ms local {e['local_tone_error']:.3f}"
                                   for e in entries))
    return {"entries": entries, "tones": 32, "max_darkness": 0.8}


# -- noise ---------------------------------------------------------------------------------------
def bench_noise(quick: bool) -> dict[str, Any]:
    from nodegraph_nodes.perlin_noise import PerlinNoise

    from .. import gl as glmod
    from ..node import derive_seed

    gl = glmod.get()
    size = (800, 800)
    runner = NodeRunner(gl, size, None, seed=3)
    entries = []
    configs = [("perlin", o) for o in ((1, 4) if quick else (1, 2, 4, 8))] + [("white", 1)]
    for kind, octaves in configs:
        node = PerlinNoise("noise", PerlinNoise.Params(kind=kind, octaves=octaves))
        release(gl, runner.run(node, {}))
        ms = _median_ms(lambda node=node: release(gl, runner.run(node, {})), 5, gl.finish)
        out = runner.run(node, {})
        got = out["out"].read()
        release(gl, out)
        t0 = time.perf_counter()
        ref = node.reference(size[0], size[1], derive_seed(3, "noise", 0))
        ref_ms = (time.perf_counter() - t0) * 1000.0
        entries.append({"method": f"{kind} x{octaves}", "kind": kind, "octaves": octaves, "size": list(size),
                        "ms": ms, "reference_ms": ref_ms, "max_error": float(np.abs(got - ref).max()),
                        "mean_error": float(np.abs(got - ref).mean())})
    log("  noise: " + ", ".join(f"{e['method']} {e['ms']:.1f} ms err {e['max_error']:.1e}" for e in entries))
    return {"entries": entries}


# -- pipelines -----------------------------------------------------------------------------------
def bench_pipelines(quick: bool) -> dict[str, Any]:
    from .bench import bench_pipeline

    sizes = [400, 800] if quick else [400, 800, 1600]
    frames = 5 if quick else 12
    entries = []
    from ..shipped import paths

    files = list(paths().values())  # the shipped pipelines, in a checkout and installed alike
    for f in files:
        for s in sizes:
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    r = bench_pipeline(str(f), frames=frames, size=f"{s}x{s}", warmup=2)
            except Exception as exc:  # noqa: BLE001 - a colleague's pipeline may be mid-change; record why
                entries.append({"pipeline": f.stem, "size": s, "error": f"{type(exc).__name__}: {exc}"[:300]})
                log(f"  pipeline {f.stem} {s}px: failed: {exc}"[:200])
                break
            entries.append({"pipeline": f.stem, "method": f.stem, "size": s, "ms": r["ms_per_frame"],
                            "ms_p90": r["ms_per_frame_p90"], "copy_pass_ms": r["copy_pass_ms"],
                            "nodes": r["nodes"]})
            log(f"  pipeline {f.stem} {s}px: {r['ms_per_frame']:.1f} ms/frame")
    return {"entries": entries, "frames": frames}


# -- the command -----------------------------------------------------------------------------------
def run(families: tuple[str, ...], quick: bool, meshes_dir: Path) -> dict[str, Any]:
    from .. import gl as glmod

    result: dict[str, Any] = {"quick": quick, "meshes": str(meshes_dir)}
    try:
        result["renderer"] = glmod.get().renderer
    except Exception as exc:  # noqa: BLE001
        result["renderer"] = f"unavailable: {exc}"
    seconds: dict[str, float] = {}
    for fam in families:
        log(f"{fam} ...")
        t0 = time.perf_counter()
        if fam == "edges":
            e = bench_edges(meshes_dir, quick)
            result["edges"] = e.pop("entries")
            result["edges_info"] = e
        elif fam == "curvature":
            c = bench_curvature(quick, meshes_dir)
            result["curvature"] = c.pop("entries")
            result["curvature_info"] = c
        elif fam == "particles":
            p = bench_particles(meshes_dir, quick)
            result["particles"] = p.pop("entries", []) if p else []
            result["particles_info"] = p
        elif fam == "hatching":
            h = bench_hatching(quick)
            result["hatching"] = h.pop("entries")
            result["hatching_info"] = h
        elif fam == "noise":
            result["noise"] = bench_noise(quick)["entries"]
        elif fam == "pipelines":
            p = bench_pipelines(quick)
            result["pipelines"] = p.pop("entries")
            result["pipelines_info"] = p
        elif fam == "stability":
            from .stability import run_sweeps

            result["stability"] = run_sweeps(meshes_dir, quick)
        seconds[fam] = time.perf_counter() - t0
        log(f"{fam}: {seconds[fam]:.1f} s")
    result["seconds"] = seconds
    return result


@click.command()
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
@click.option("--charts", "charts_dir", type=click.Path(path_type=Path), help="Write PNG and SVG charts here.")
@click.option("--quick", is_flag=True, help="Fewer meshes, settings and sizes (about a minute or two).")
@click.option("--families", default=",".join(FAMILIES), show_default=True,
              help="Comma-separated families to run.")
@click.option("--meshes", "meshes_dir", type=click.Path(path_type=Path), default=None,
              help="Folder of the shared test meshes (default: ../shared/meshes beside the checkout).")
def command(json_path: Path | None, charts_dir: Path | None, quick: bool, families: str,
            meshes_dir: Path | None) -> None:
    """Accuracy against independent references and cost, per method family; JSON and charts."""
    from ..errors import SketchgraphError

    fams = tuple(f.strip() for f in families.split(",") if f.strip())
    unknown = [f for f in fams if f not in FAMILIES]
    if unknown:
        raise SketchgraphError(f"bench accuracy: unknown families {unknown}; choose from {', '.join(FAMILIES)}")
    if meshes_dir is None:
        if not SHARED_MESHES.is_dir():
            raise SketchgraphError("bench accuracy: needs the shared test meshes; pass --meshes DIR (a folder of .obj "
                                   f"files, the repository's ../shared/meshes; not found at {SHARED_MESHES})")
        meshes_dir = SHARED_MESHES
    if not meshes_dir.is_dir():
        raise SketchgraphError(f"bench accuracy: mesh folder {meshes_dir} not found; pass --meshes DIR")
    result = run(fams, quick, meshes_dir)
    print_summary(result)
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(json.dumps(_jsonable(result), indent=1) + "\n")
        click.echo(f"wrote {json_path}")
    if charts_dir:
        from .accuracy_charts import draw_all

        for p in draw_all(result, charts_dir):
            click.echo(f"wrote {p}")


def _jsonable(v: Any) -> Any:
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, (np.floating, float)):
        f = float(v)
        return f if math.isfinite(f) else str(f)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.ndarray):
        return _jsonable(v.tolist())
    return v


def print_summary(result: dict[str, Any]) -> None:
    info = result.get("edges_info")
    if info:
        s = info["summary"]
        click.echo(f"edges: best F1 at 800px (target {s['target_f1']}): "
                   + ", ".join(f"{m} {f:.3f}" if f is not None else f"{m} n/a"
                               for m, f in s["target_meshes_best_f1_at_800"].items())
                   + (" - target met" if s["target_met"] else " - TARGET MISSED"))
    if result.get("curvature"):
        for surf in ("torus", "ellipsoid"):
            rows = [e for e in result["curvature"] if e["surface"] == surf]
            if rows:
                b = min(rows, key=lambda e: e["direction_p95_deg"] or 1e9)
                click.echo(f"curvature {surf}: best p95 direction error {b['direction_p95_deg']:.2f} deg "
                           f"({b['tessellation']}, radius {b['radius']}), value p95 {b['value_p95']:.3f}")
    for fam in ("particles", "hatching", "noise", "pipelines"):
        if result.get(fam):
            click.echo(f"{fam}: {len(result[fam])} measurements")
    st = result.get("stability")
    if st:
        for name, sweep in st.items():
            click.echo(f"stability {name}: breaks at {sweep.get('break')}")
