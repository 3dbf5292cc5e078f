"""Stability sweeps: where each method fails, and what the node does there.

Each sweep varies one thing (near/far ratio, scale, viewing angle, resolution, vertex noise, anisotropy,
broken meshes, particle parameters), measures the method's accuracy against an independent reference at
every step, and reports where it breaks: the first step along the sweep where the accuracy falls below
`threshold` (absolute) or more than `drop` below its value at the sweep's first, best-conditioned step.
`sketchgraph bench accuracy --families stability` runs them all; tests/nodegraph/tools/test_stability.py checks
the node behaviour at the break points (a warning, a fallback or a clear error: never NaN, a hang or a crash).
"""

from __future__ import annotations

import inspect
import math
import tempfile
import time
import warnings
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ...fsio import atomic_write_text
from .measure import NodeRunner, gbuffer, log, node_class, node_module, particle_depth, release, scene_for


# -- helpers ---------------------------------------------------------------------------------------
def first_break(points: list[dict[str, Any]], series: str, *, threshold: float | None = None,
                drop: float | None = None, higher_is_better: bool = True) -> Any:
    """x of the first point of `series` (in sweep order) whose value is broken, else None. A missing or
    non-finite value counts as broken."""
    rows = [p for p in points if p["series"] == series]
    if not rows:
        return None
    ref = rows[0]["value"]
    for p in rows:
        v = p["value"]
        if v is None or not math.isfinite(v):
            return p["x"]
        if threshold is not None and ((v < threshold) if higher_is_better else (v > threshold)):
            return p["x"]
        if drop is not None and ref is not None and ((v < ref - drop) if higher_is_better else (v > ref + drop)):
            return p["x"]
    return None


def _sweep(title: str, x_label: str, y_label: str, points: list[dict[str, Any]], *, threshold: float | None = None,
           drop: float | None = None, higher_is_better: bool = True, log_x: bool = False, log_y: bool = False,
           finding: str = "", behaviour: str = "", ref_x: float | None = None) -> dict[str, Any]:
    """A sweep's record. Without `ref_x` the sweep starts at its best-conditioned point and the break is the
    first broken point; with it the sweep runs both ways from `ref_x` and the break is [below, above]."""
    series = list(dict.fromkeys(p["series"] for p in points))
    kw = dict(threshold=threshold, drop=drop, higher_is_better=higher_is_better)
    breaks: dict[str, Any] = {}
    for s in series:
        if ref_x is None:
            breaks[s] = first_break(points, s, **kw)
            continue
        rows = [p for p in points if p["series"] == s]
        down = sorted((p for p in rows if p["x"] <= ref_x), key=lambda p: -p["x"])
        up = sorted((p for p in rows if p["x"] >= ref_x), key=lambda p: p["x"])
        breaks[s] = [first_break(down, s, **kw), first_break(up, s, **kw)]
    return {"title": title, "x_label": x_label, "y_label": y_label, "points": points, "series": series,
            "threshold": threshold, "drop": drop, "breaks": breaks, "break": breaks, "log_x": log_x,
            "log_y": log_y, "finding": finding, "behaviour": behaviour}


def _from_spec(spec: dict[str, Any]) -> dict[str, Any]:
    """A sweep record from a node's sweep spec (the arguments of `_sweep`; other keys are kept as they are)."""
    names = set(inspect.signature(_sweep).parameters)
    extra = {k: spec.pop(k) for k in list(spec) if k not in names}
    return {**_sweep(**spec), **extra}


def edge_scores(gl: Any, scene: Any, size: tuple[int, int], truth: np.ndarray, nd: Any = None,
                **params: Any) -> dict[str, float]:
    """edge_detect (`params`) on the scene's normal_depth (or `nd`, a texture), scored against `truth`."""
    from .groundtruth import precision_recall

    EdgeDetect = node_class("edge_detect")
    own = nd is None
    if own:
        nd = gbuffer(gl, scene, size)["normal_depth"]
    out = NodeRunner(gl, size, scene).run(EdgeDetect("edges", EdgeDetect.Params(**params)), {"normal_depth": nd},
                                           frozenset({"out"}))
    e = out["out"].read()[..., 0]
    release(gl, out)
    if own:
        gl.release(nd)
    finite = bool(np.isfinite(e).all())
    pr = precision_recall(np.nan_to_num(e, nan=0.0) > 0.5, truth, 1)
    return {**pr, "finite": finite}


def reference_truth(gl: Any, scene: Any, size: tuple[int, int]) -> np.ndarray:
    from .groundtruth import line_drawing

    g = gbuffer(gl, scene, size, ("linear_depth",))
    lin = g["linear_depth"].read()[..., 0]
    release(gl, g)
    return line_drawing(scene, size, lin).lines


def with_camera(scene: Any, **changes: Any) -> Any:
    return replace(scene, camera=replace(scene.camera, **changes), orbit=None)


def single_object_scene(mesh: Any, direction: Any = (0.55, 0.45, 1.0), name: str = "sweep") -> Any:
    from ...scene.scene import Scene, SceneObject, frame_camera

    lo, hi = mesh.bounds()
    return Scene(name=name, objects=(SceneObject(mesh, np.eye(4), (0.8, 0.7, 0.5), True, name),),
                 camera=frame_camera(lo, hi, direction=direction), source=name)


# -- depth precision -------------------------------------------------------------------------------
def linearize_window_depth(z: np.ndarray, near: float, far: float, bits: int | None = None) -> np.ndarray:
    """View depth from window depth z in [0, 1] (1 = background -> 0), as a float32 shader would compute it;
    `bits` quantises z to a fixed-point depth buffer of that many bits first."""
    z = np.asarray(z, np.float32)
    if bits is not None:
        q = float(2**bits - 1)
        z = (np.round(z.astype(np.float64) * q) / q).astype(np.float32)
    n, f = np.float32(near), np.float32(far)
    zn = np.float32(2.0) * z - np.float32(1.0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        lin = (np.float32(2.0) * n * f) / (f + n - zn * (f - n))
    return np.where(z < 1.0, lin, 0.0).astype(np.float32)


def sweep_depth_precision(meshes_dir: Path, quick: bool, size: int = 800) -> dict[str, Any]:
    from ...gpu import gl as glmod

    gl = glmod.get()
    dims = (size, size)
    spec = str(meshes_dir / "spot.obj") if (meshes_dir / "spot.obj").exists() else "builtin:torus"
    base = scene_for(spec)
    base = replace(base, orbit=None)
    truth = reference_truth(gl, base, dims)
    ratios = [10, 1e3, 1e5, 1e6] if quick else [10, 1e2, 1e3, 1e4, 3e4, 1e5, 2e5, 5e5, 1e6, 1e7]
    far = base.camera.far
    points = []
    for ratio in ratios:
        scene = with_camera(base, near=far / ratio)
        g = gbuffer(gl, scene, dims, ("normal_depth", "depth"))
        nd = g["normal_depth"].read()
        z = g["depth"].read()[..., 0]
        s = edge_scores(gl, scene, dims, truth, nd=g["normal_depth"])
        points.append({"series": "linear view depth (float32)", "x": ratio, "value": s["f1"],
                       "finite": s["finite"] and bool(np.isfinite(nd).all())})
        for bits, label in ((None, "window depth, linearised (float32)"), (16, "window depth, 16-bit")):
            w = linearize_window_depth(z, scene.camera.near, far, bits)
            arr = np.concatenate([nd[..., :3], w[..., None]], axis=2)
            arr = np.nan_to_num(arr, nan=0.0, posinf=0.0, neginf=0.0)
            tex = gl.upload(arr, "RGBA32F")
            s2 = edge_scores(gl, scene, dims, truth, nd=tex)
            gl.release(tex)
            points.append({"series": label, "x": ratio, "value": s2["f1"], "finite": s2["finite"]})
        release(gl, g)
        log(f"  depth precision far/near {ratio:g}: " + ", ".join(
            f"{p['series'].split(' (')[0]} {p['value']:.3f}" for p in points if p["x"] == ratio))
    return _sweep("Depth precision: far/near ratio (spot.obj, 800 px)", "far / near", "edge F1", points,
                  drop=0.05, log_x=True,
                  finding="Edges from linear view depth written by the vertex stage (float32, normal_depth.w) hold "
                          "as long as the 24-bit depth test still orders the surfaces; edges from the window "
                          "depth buffer, linearised afterwards, break much earlier (16-bit first).",
                  behaviour="rasterize + edge_detect: outputs stay finite at every ratio; no warning is given.")


# -- scale -----------------------------------------------------------------------------------------
def sweep_scale(meshes_dir: Path, quick: bool, size: int = 400) -> dict[str, Any]:
    from ...gpu import gl as glmod
    from ...scene.meshes import Mesh, load_mesh

    compute_curvature = node_module("curvature", "principal").compute_curvature
    curv = node_module("curvature", "accuracy")
    curvature_errors, torus_mesh, torus_truth = curv.curvature_errors, curv.torus_mesh, curv.torus_truth
    gl = glmod.get()
    dims = (size, size)
    path = meshes_dir / "spot.obj"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = load_mesh(path) if path.exists() else None
    if mesh is None:
        from ...scene.primitives import torus

        mesh = torus(1.0, 0.35, 64, 32)
    exps = list(range(-6, 7, 3)) if quick else list(range(-42, 43, 3))
    V, F = torus_mesh(100, 25)
    kmin, kmax, dmin, _ = torus_truth(V)
    points = []
    for k in exps:
        s = 10.0**k
        scaled = Mesh(mesh.name, mesh.vertices * s, mesh.faces)
        try:
            scene = single_object_scene(scaled)
            truth = reference_truth(gl, scene, dims)
            sc = edge_scores(gl, scene, dims, truth)
            f1 = sc["f1"] if sc["finite"] else None
            lines = int(truth.sum())
            err = None
        except Exception as exc:  # noqa: BLE001 - the sweep records how it fails
            f1, lines, err = None, 0, f"{type(exc).__name__}: {exc}"
        points.append({"series": "edges F1 (spot)", "x": s, "value": f1 if lines else None, "truth_pixels": lines,
                       "error": err})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                res = compute_curvature(V * s, F)
                e = curvature_errors(res, kmin / s, kmax / s, dmin)
                cval = e["direction_p95_deg"] if e["finite"] else None
                cerr = None
            except Exception as exc:  # noqa: BLE001
                cval, cerr = None, f"{type(exc).__name__}: {exc}"
        points.append({"series": "curvature p95 direction error / 10 deg (torus)", "x": s,
                       "value": None if cval is None else 1.0 - cval / 10.0, "direction_p95_deg": cval,
                       "error": cerr})
    log("  scale: " + ", ".join(f"{p['x']:.0e} {p['value'] if p['value'] is None else round(p['value'], 3)}"
                                for p in points if p["series"].startswith("edges")))
    return _sweep("Scale: the same mesh from 1e-42 to 1e42 units" if not quick else "Scale",
                  "uniform scale", "edge F1 / 1 - p95 curvature direction error / 10 deg", points, drop=0.05,
                  log_x=True, ref_x=1.0,
                  finding="Edges and curvature are scale invariant over many decades (every tolerance is relative "
                          "to the bounding box); rasterize breaks where float32 normals under- or overflow.",
                  behaviour="see the break points: past them the G-buffer normals are not finite.")


# -- grazing angles and thin features --------------------------------------------------------------
def sweep_grazing(quick: bool, size: int = 800) -> dict[str, Any]:
    from ...gpu import gl as glmod
    from ...scene.primitives import box, plane
    from ...scene.scene import Camera, Scene, SceneObject, rotation, translation

    gl = glmod.get()
    dims = (size, size)
    angles = [0, 45, 80, 85, 88, 89.5] if quick else [0, 30, 60, 75, 80, 85, 87, 88, 89, 89.5, 89.8, 89.95]
    points = []
    for a in angles:
        # the box's front face (+z) turned by `a` degrees away from the camera, seen slightly from above
        mesh = box((1.0, 1.0, 1.0)).transformed(rotation((0, 1, 0), a))
        el = math.radians(20.0)
        angle = math.degrees(math.acos(math.cos(math.radians(a)) * math.cos(el)))
        eye = np.array([0.0, 4.0 * math.sin(el), 4.0 * math.cos(el)])
        cam = Camera(eye=eye, target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov_y_deg=30.0, near=1.0, far=8.0)
        scene = Scene("grazing", (SceneObject(mesh, np.eye(4), (0.8, 0.7, 0.5), True, "box"),), cam)
        truth = reference_truth(gl, scene, dims)
        for op in ("four_neighbour", "sobel"):
            sc = edge_scores(gl, scene, dims, truth, operator=op)
            points.append({"series": f"box face, {op}", "x": round(angle, 2), "yaw": a, "value": sc["f1"],
                           "precision": sc["precision"], "recall": sc["recall"], "finite": sc["finite"]})
    # a box standing on a large floor, seen from lower and lower elevations: the floor turns grazing
    elevations = [30, 10, 5, 2, 1] if quick else [45, 30, 20, 10, 5, 3, 2, 1, 0.5]
    floor = plane(40.0, 1)
    cube = box((1.0, 1.0, 1.0)).transformed(translation((0.0, 0.5, 0.0)))
    for el in elevations:
        e = math.radians(el)
        eye = np.array([0.0, 0.5 + 6.0 * math.sin(e), 6.0 * math.cos(e)])
        cam = Camera(eye=eye, target=(0.0, 0.5, 0.0), up=(0.0, 1.0, 0.0), fov_y_deg=40.0, near=0.3, far=60.0)
        objs = (SceneObject(floor, np.eye(4), (0.7, 0.7, 0.6), True, "floor"),
                SceneObject(cube, np.eye(4), (0.8, 0.7, 0.5), True, "box"))
        scene = Scene("grazing-floor", objs, cam)
        truth = reference_truth(gl, scene, dims)
        for op in ("four_neighbour", "sobel"):
            sc = edge_scores(gl, scene, dims, truth, operator=op)
            points.append({"series": f"floor, {op}", "x": 90.0 - el, "elevation": el, "value": sc["f1"],
                           "precision": sc["precision"], "recall": sc["recall"], "finite": sc["finite"]})
    log("  grazing: " + ", ".join(f"{p['series'][:12]} {p['x']:.1f}deg {p['value']:.2f}" for p in points))
    return _sweep("Grazing: a box face turned edge-on; a floor seen from low elevations",
                  "angle between surface normal and view (deg)", "edge F1", points, threshold=0.85,
                  finding="The crease lines bounding a face seen edge-on merge once the face is about a pixel "
                          "wide, within the 1-px tolerance; a floor seen at grazing angles makes false depth "
                          "edges where the relative depth step between neighbouring pixels exceeds the threshold.",
                  behaviour="edge_detect: finite output at every angle, no warning.")


def sweep_thin_features(meshes_dir: Path, quick: bool) -> dict[str, Any]:
    from ...gpu import gl as glmod

    gl = glmod.get()
    spec = str(meshes_dir / "cow.obj") if (meshes_dir / "cow.obj").exists() else "builtin:torus"
    scene = replace(scene_for(spec), orbit=None)
    sizes = [800, 200, 50] if quick else [800, 400, 200, 100, 50, 25]
    points = []
    for s in sizes:
        dims = (s, s)
        truth = reference_truth(gl, scene, dims)
        for op in ("four_neighbour", "sobel"):
            sc = edge_scores(gl, scene, dims, truth, operator=op)
            points.append({"series": op, "x": s, "value": sc["f1"], "precision": sc["precision"],
                           "recall": sc["recall"]})
    log("  thin features (cow): " + ", ".join(f"{p['series'][:4]} {p['x']}px {p['value']:.2f}" for p in points))
    return _sweep("Thin features: cow.obj (legs, horns) at falling resolution", "image size (px)", "edge F1",
                  points, threshold=0.85, log_x=True,
                  finding="With a 1-px tolerance F1 does not fall with resolution: where the two outlines of a leg "
                          "merge they still lie within a pixel of the truth; see the rod sweep for the width at "
                          "which outlines merge and vanish.",
                  behaviour="edge_detect: finite output, lines merge; no warning.")


def rod_scene(diameter_px: float, size: int) -> Any:
    """A horizontal cylinder (rod) `diameter_px` pixels thick across the middle of a size^2 view."""
    from ...scene.primitives import cylinder
    from ...scene.scene import Camera, Scene, SceneObject, rotation

    dist, fov = 10.0, 30.0
    px_world = 2.0 * dist * math.tan(math.radians(fov) / 2.0) / size
    r = diameter_px * px_world / 2.0
    rod = cylinder(r, 2.0 * dist * math.tan(math.radians(fov) / 2.0) * 0.8, 32).transformed(
        rotation((0, 0, 1), 92.0) @ rotation((0, 1, 0), 11.25))  # tilted: sub-pixel parts cross pixel centres
    cam = Camera(eye=(0.0, 0.0, dist), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov_y_deg=fov, near=dist / 2,
                 far=dist * 2)
    return Scene("rod", (SceneObject(rod, np.eye(4), (0.8, 0.7, 0.5), True, "rod"),), cam)


def outlines_resolved(edges: np.ndarray, diameter_px: float) -> float:
    """Fraction of the rod's middle columns where the detected edges form two separate runs."""
    h, w = edges.shape
    mid = h // 2
    half = int(math.ceil(diameter_px / 2.0)) + 3 + int(math.ceil(0.2 * w * math.tan(math.radians(2.0))))
    band = edges[max(0, mid - half):mid + half + 1, int(0.3 * w):int(0.7 * w)]
    runs = (np.diff(band.astype(np.int8), axis=0) == 1).sum(axis=0) + band[0]
    return float(np.mean(runs >= 2))


def sweep_thin_rod(quick: bool, size: int = 400) -> dict[str, Any]:
    from ...gpu import gl as glmod
    from .groundtruth import precision_recall

    EdgeDetect = node_class("edge_detect")
    gl = glmod.get()
    dims = (size, size)
    diams = [16, 4, 1, 0.5] if quick else [32, 16, 8, 4, 3, 2, 1.5, 1, 0.75, 0.5, 0.25]
    points = []
    for d in diams:
        scene = rod_scene(d, size)
        truth = reference_truth(gl, scene, dims)
        nd = gbuffer(gl, scene, dims)["normal_depth"]
        for op in ("four_neighbour", "sobel"):
            out = NodeRunner(gl, dims, scene).run(EdgeDetect("e", EdgeDetect.Params(operator=op)),
                                                   {"normal_depth": nd}, frozenset({"out"}))
            e = out["out"].read()[..., 0] > 0.5
            release(gl, out)
            pr = precision_recall(e, truth, 1)
            points.append({"series": f"recall, {op}", "x": d, "value": pr["recall"], "precision": pr["precision"],
                           "f1": pr["f1"]})
            points.append({"series": f"two outlines resolved, {op}", "x": d, "value": outlines_resolved(e, d)})
        gl.release(nd)
    log("  thin rod: " + ", ".join(f"{p['series'][:14]} {p['x']}px {p['value']:.2f}" for p in points))
    return _sweep("Thin features: a rod of falling width (400 px)", "rod diameter (px)",
                  "recall / share of columns with two outlines", points, threshold=0.85, log_x=True,
                  finding="The two outlines of a thin feature stay separate down to a few pixels, merge into "
                          "one line below that, and the feature itself breaks up below a pixel (rasterization "
                          "samples pixel centres).",
                  behaviour="edge_detect: finite output; a sub-pixel feature gives a broken line, no warning.")


# -- curvature: resolution, noise, umbilics (measured beside the node) ---------------------------------
def sweep_curvature_noise(quick: bool) -> dict[str, Any]:
    return _from_spec(node_module("curvature", "stability").sweep_noise(quick, log))


def sweep_curvature_resolution(quick: bool) -> dict[str, Any]:
    return _from_spec(node_module("curvature", "stability").sweep_resolution(quick, log))


def sweep_umbilic(quick: bool) -> dict[str, Any]:
    return _from_spec(node_module("curvature", "stability").sweep_umbilic(quick, log))


# -- broken meshes ---------------------------------------------------------------------------------
def _write(tmp: Path, name: str, text: str) -> Path:
    p = tmp / name
    atomic_write_text(p, text)
    return p


def broken_mesh_cases(tmp: Path, meshes_dir: Path) -> dict[str, Path]:
    """Files for the broken-mesh sweep: the shared meshes with known defects and synthetic ones."""
    cases = {n: meshes_dir / n for n in ("teapot.obj", "suzanne.obj", "stanford-bunny.obj", "cow.obj")
             if (meshes_dir / n).exists()}
    quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    cases["degenerate_duplicate.obj"] = _write(
        tmp, "degenerate_duplicate.obj",
        quad + "v 2 0 0\nf 1 2 3\nf 1 3 4\nf 1 2 3\nf 2 3 1\nf 1 1 2\nf 1 2 5\n")
    cases["nan_vertex.obj"] = _write(tmp, "nan_vertex.obj", quad + "v nan 0 0\nf 1 2 3\nf 1 3 5\n")
    cases["inf_vertex.obj"] = _write(tmp, "inf_vertex.obj", quad + "v 0 inf 0\nf 1 2 3\nf 1 3 5\n")
    cases["empty.obj"] = _write(tmp, "empty.obj", "")
    cases["vertices_only.obj"] = _write(tmp, "vertices_only.obj", quad)
    cases["bad_index.obj"] = _write(tmp, "bad_index.obj", quad + "f 1 2 9\n")
    cases["only_degenerate.obj"] = _write(tmp, "only_degenerate.obj", quad + "f 1 1 2\nf 3 3 3\n")
    return cases


def broken_mesh_report(path: Path, size: int = 400) -> dict[str, Any]:
    """Load, draw, detect edges and measure curvature on one mesh file; record every warning and error."""
    from ...errors import MeshError
    from ...gpu import gl as glmod
    from ...scene.meshes import clear_mesh_cache, load_mesh

    compute_curvature = node_module("curvature", "principal").compute_curvature

    out: dict[str, Any] = {"file": path.name}
    clear_mesh_cache()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            mesh = load_mesh(path)
        except MeshError as exc:
            out.update(outcome="MeshError", message=str(exc), names_file=str(path) in str(exc))
            return out
        out["warnings"] = [str(w.message) for w in caught]
    topo = mesh.topology()
    out["topology"] = dict(topo.__dict__)
    out["outcome"] = "warning" if out["warnings"] else "ok"
    gl = glmod.get()
    scene = single_object_scene(mesh, name=path.stem)
    dims = (size, size)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        truth = reference_truth(gl, scene, dims)
        sc = edge_scores(gl, scene, dims, truth)
        t0 = time.perf_counter()
        res = compute_curvature(mesh.vertices, mesh.faces)
        out["curvature_s"] = time.perf_counter() - t0
        out["render_warnings"] = [str(w.message) for w in caught]
    out["edges_f1"] = sc["f1"]
    out["edges_finite"] = sc["finite"]
    out["curvature_counts"] = res.counts
    out["curvature_finite"] = bool(np.isfinite(res.kmin).all() and np.isfinite(res.dmin).all())
    return out


def sweep_broken_meshes(meshes_dir: Path) -> dict[str, Any]:
    cases: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, path in broken_mesh_cases(Path(tmp), meshes_dir).items():
            r = broken_mesh_report(path)
            def plain(text: str) -> str:  # no temporary or machine-specific folder names in the record
                return text.replace(str(Path(tmp)), "<tmp>").replace(str(meshes_dir), "<meshes>")

            for key in ("message", "warnings", "render_warnings"):
                if isinstance(r.get(key), str):
                    r[key] = plain(r[key])
                elif isinstance(r.get(key), list):
                    r[key] = [plain(w) for w in r[key]]
            cases[name] = r
            log(f"  broken {name}: {r['outcome']}" + (f" F1 {r['edges_f1']:.3f}" if "edges_f1" in r else "")
                + (f" ({r.get('message', '')[:90]})" if "message" in r else ""))
    return {"title": "Broken meshes", "cases": cases, "points": [], "break": None,
            "finding": "Open boundaries, several components, holes, unreferenced vertices, degenerate and "
                       "duplicate faces load and draw (a MeshWarning for each repair, and for holes in an otherwise "
                       "closed surface); NaN/Inf coordinates, empty files, files without faces and out-of-range "
                       "indices raise MeshError naming the file.",
            "behaviour": "load_mesh: MeshWarning or MeshError; edge_detect and curvature stay finite."}


# -- particles (measured beside the node) -----------------------------------------------------------
def sweep_particles(meshes_dir: Path, quick: bool) -> dict[str, Any]:
    try:
        mod = node_module("particle_sketch", "stability")
    except ImportError as exc:
        return {"title": "Particles", "skipped": str(exc), "points": [], "break": None}
    depth, _, _ = particle_depth(meshes_dir, 400)
    return _from_spec(mod.sweep(depth, quick, log))


def run_sweeps(meshes_dir: Path, quick: bool) -> dict[str, Any]:
    out: dict[str, Any] = {}
    steps = [
        ("depth_precision", lambda: sweep_depth_precision(meshes_dir, quick)),
        ("scale", lambda: sweep_scale(meshes_dir, quick)),
        ("grazing", lambda: sweep_grazing(quick)),
        ("thin_features", lambda: sweep_thin_features(meshes_dir, quick)),
        ("thin_rod", lambda: sweep_thin_rod(quick)),
        ("curvature_noise", lambda: sweep_curvature_noise(quick)),
        ("curvature_resolution", lambda: sweep_curvature_resolution(quick)),
        ("umbilic", lambda: sweep_umbilic(quick)),
        ("broken_meshes", lambda: sweep_broken_meshes(meshes_dir)),
        ("particles", lambda: sweep_particles(meshes_dir, quick)),
    ]
    for name, fn in steps:
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out[name] = fn()
        out[name]["seconds"] = time.perf_counter() - t0
    return out
