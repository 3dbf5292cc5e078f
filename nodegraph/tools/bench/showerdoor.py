"""The shower-door benchmark: how much the uncertainty that lands on a surface point changes between
frames along a known camera orbit (Nienhaus & Döllner 2004, §4 and §4.3).

For frames k and k+1 of the orbit, every pixel x of frame k that shows the surface (linear view depth
> 0) is taken back to the world with camera k and its depth, and projected with camera k+1 to the
sub-pixel position x'. The point counts only where frame k+1 sees it too: the four texels around x'
are all surface and their bilinear depth matches the point's depth under camera k+1 to `depth_tol`
(relative), so points that become hidden or leave the image are skipped. With O_k the shift the sketch
node applies at a pixel (`sketch.offsets`: the edge shift and the shade shift, in pixels) the metric of
the pair is

    D_k = sum_x |O_{k+1}(x') - O_k(x)| / sum_x |O_k(x)|

the change of the offset that lands on the same surface point, relative to its size (O_{k+1} is read
bilinearly at x'). The figure is the mean of D_k over all pairs. It is 0 when the uncertainty moves
with the surface and about 1 or more when it is unrelated from frame to frame; screen-space Perlin
noise stays put while the surface slides under it (it "swims"), object-space noise follows it.
"""

from __future__ import annotations

import json
import math
import statistics
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import click
import numpy as np

from ...errors import SketchgraphError
from ...fsio import atomic_write_text

# shipped pipelines, by name (nodegraph.shipped): found in a checkout and in an installed package alike
SCREEN_PIPELINE = "nienhaus_sketchy"
OBJECT_PIPELINE = "object_space_uncertainty"


def _sketch_refs(pipe: Any) -> tuple[tuple[str, str], tuple[str, str]]:
    """(G-buffer linear depth, sketch offsets) refs: the one sketch node and the rasterize feeding its shade."""
    sketches = [nid for nid, node in pipe.nodes.items() if node.type_name == "sketch"]
    if len(sketches) != 1:
        raise SketchgraphError(f"{pipe.file}: shower-door needs exactly one sketch node, found {len(sketches)}")
    sk = sketches[0]
    src = pipe.connections[sk].get("shade") or pipe.connections[sk].get("depth")
    if src is None or pipe.nodes[src[0]].type_name != "rasterize":
        raise SketchgraphError(f"{pipe.file}: the sketch node's 'shade' input must come from a rasterize node")
    return (src[0], "linear_depth"), (sk, "offsets")


def _bilinear(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """img at continuous texel coordinates (texel i has its centre at i): values, and the four corner
    samples' minimum and maximum of channel 0 (to tell whether the footprint is all surface)."""
    h, w = img.shape[:2]
    x0 = np.clip(np.floor(x).astype(np.int64), 0, w - 2)
    y0 = np.clip(np.floor(y).astype(np.int64), 0, h - 2)
    fx = np.clip(x - x0, 0.0, 1.0)
    fy = np.clip(y - y0, 0.0, 1.0)
    a, b, c, d = img[y0, x0], img[y0, x0 + 1], img[y0 + 1, x0], img[y0 + 1, x0 + 1]
    if img.ndim == 3:
        fx, fy = fx[:, None], fy[:, None]
    val = (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy
    corners = np.stack([a, b, c, d]) if img.ndim == 2 else np.stack([a[:, 0], b[:, 0], c[:, 0], d[:, 0]])
    return val, corners.min(axis=0), corners.max(axis=0)


def pair_metric(depth0: np.ndarray, off0: np.ndarray, cam0: Any, depth1: np.ndarray, off1: np.ndarray, cam1: Any,
                depth_tol: float = 0.01) -> tuple[float, float, int]:
    """(D, D relative to the offsets' spread about their mean instead of their size, pixels compared) for one
    pair of frames; depths (H, W) linear view depth (0 = background), offsets (H, W, C) in pixels, row 0 =
    bottom (as read back from GL)."""
    h, w = depth0.shape
    aspect = w / h
    ys, xs = np.nonzero(depth0 > 0)
    if len(xs) == 0:
        return 0.0, 0.0, 0
    d = depth0[ys, xs].astype(np.float64)
    p0 = cam0.projection_matrix(aspect)
    ndc_x = (xs + 0.5) / w * 2.0 - 1.0
    ndc_y = (ys + 0.5) / h * 2.0 - 1.0
    view = np.stack([ndc_x * d / p0[0, 0], ndc_y * d / p0[1, 1], -d, np.ones_like(d)], axis=1)
    world = view @ np.linalg.inv(cam0.view_matrix()).T
    v1 = world @ cam1.view_matrix().T
    clip = v1 @ cam1.projection_matrix(aspect).T
    ok = clip[:, 3] > 1e-9
    x1 = (clip[:, 0] / np.where(ok, clip[:, 3], 1.0) + 1.0) * 0.5 * w - 0.5
    y1 = (clip[:, 1] / np.where(ok, clip[:, 3], 1.0) + 1.0) * 0.5 * h - 0.5
    ok &= (x1 >= 0) & (x1 <= w - 1) & (y1 >= 0) & (y1 <= h - 1)
    expect = -v1[:, 2]
    dep, dmin, _ = _bilinear(depth1.astype(np.float64), x1, y1)
    ok &= (dmin > 0) & (np.abs(dep - expect) <= depth_tol * np.maximum(expect, 1e-12))
    if not ok.any():
        return 0.0, 0.0, 0
    o0 = off0[ys[ok], xs[ok]].astype(np.float64)
    o1, _, _ = _bilinear(off1.astype(np.float64), x1[ok], y1[ok])
    size = np.linalg.norm(o0, axis=1).sum()
    spread = np.linalg.norm(o0 - o0.mean(axis=0), axis=1).sum()
    change = np.linalg.norm(o1 - o0, axis=1).sum()
    return (float(change / size) if size > 0 else 0.0), (float(change / spread) if spread > 0 else 0.0), int(ok.sum())


def measure(pipeline: str | Path, scene: str, frames: int, size: tuple[int, int] = (400, 400),
            degrees_per_frame: float | None = None, depth_tol: float = 0.01, gl: Any = None,
            overrides: list[str] | tuple[str, ...] = ()) -> dict[str, Any]:
    """The shower-door metric of one pipeline along the scene's orbit (see the module doc); `overrides` are
    NODE.PARAM=VALUE settings as `--set` takes them."""
    from ... import pipeline as pl
    from ...executor import Executor
    from ...gpu import gl as glmod
    from ...scene.scene import Orbit

    if frames < 2:
        raise SketchgraphError(f"--frames: the metric compares consecutive frames, so at least 2 (got {frames})")
    pipe = pl.load(pipeline, size=size, scene=scene, overrides=list(overrides))
    sc = pipe.scene
    if degrees_per_frame is not None:
        orbit = sc.orbit or Orbit()
        pipe.scene = replace(sc, orbit=replace(orbit, degrees_per_frame=float(degrees_per_frame)))
    elif sc.orbit is None:
        pipe.scene = replace(sc, orbit=Orbit())
    depth_ref, off_ref = _sketch_refs(pipe)
    gl = gl or glmod.get()
    ex = Executor(pipe, None, mode="loop", requested=[depth_ref, off_ref], gl=gl)
    w, h = pipe.size
    scale = np.array([w, h, w, h], dtype=np.float64)
    prev: tuple[np.ndarray, np.ndarray, Any] | None = None
    per_pair: list[float] = []
    per_pair_spread: list[float] = []
    compared: list[int] = []
    for f in range(frames):
        res = ex.run(f)
        depth = res.values[depth_ref].read()[..., 0]
        off = res.values[off_ref].read()[..., :4] * scale  # texture units -> pixels
        cam = pipe.scene.camera_at(f)
        if prev is not None:
            m, ms, n = pair_metric(prev[0], prev[1], prev[2], depth, off, cam, depth_tol)
            per_pair.append(m)
            per_pair_spread.append(ms)
            compared.append(n)
        prev = (depth, off, cam)
    ex.clear_memory()
    orbit = pipe.scene.orbit
    return {"pipeline": str(pipeline), "metric": statistics.fmean(per_pair), "per_pair": per_pair,
            "metric_vs_spread": statistics.fmean(per_pair_spread), "pixels_compared": compared,
            "degrees_per_frame": orbit.degrees_per_frame if orbit else 0.0}


def compare(scene: str, frames: int = 60, size: tuple[int, int] = (400, 400), degrees_per_frame: float | None = None,
            screen: str | Path = SCREEN_PIPELINE, object_: str | Path = OBJECT_PIPELINE,
            depth_tol: float = 0.01) -> dict[str, Any]:
    """Screen-space and object-space uncertainty on the same scene, orbit and size."""
    from ...shipped import resolve

    t0 = time.perf_counter()
    s = measure(screen, scene, frames, size, degrees_per_frame, depth_tol)
    o = measure(object_, scene, frames, size, degrees_per_frame, depth_tol)
    def ratio_of(a: float, b: float) -> float:
        return a / b if b > 0 else (0.0 if a == 0 else math.inf)

    ratio = ratio_of(o["metric"], s["metric"])
    return {
        "scene": scene,
        "frames": frames,
        "size": list(size),
        "degrees_per_frame": s["degrees_per_frame"],
        "screen_space": s["metric"],
        "object_space": o["metric"],
        "ratio": ratio,
        "definition": "mean over consecutive frame pairs of sum |O_k+1(x') - O_k(x)| / sum |O_k(x)|, where x' is "
                      "surface pixel x of frame k reprojected into frame k+1 through its depth with the known "
                      "cameras (kept only if visible there) and O is the sketch's edge and shade shift in pixels",
        "relative_to_spread": {  # the same change divided by the offsets' spread about their mean instead
            "screen_space": s["metric_vs_spread"], "object_space": o["metric_vs_spread"],
            "ratio": ratio_of(o["metric_vs_spread"], s["metric_vs_spread"])},
        "pipelines": {"screen_space": str(resolve(screen)), "object_space": str(resolve(object_))},
        "per_pair": {"screen_space": s["per_pair"], "object_space": o["per_pair"]},
        "pixels_compared": {"screen_space": s["pixels_compared"], "object_space": o["pixels_compared"]},
        "seconds": time.perf_counter() - t0,
    }


# -- deforming meshes -------------------------------------------------------------------------------------
def surface_pair_metric(rest0: np.ndarray, off0: np.ndarray, rest1: np.ndarray, off1: np.ndarray,
                        tol_texels: float = 1.5) -> tuple[float, float, int]:
    """`pair_metric` for a deforming surface: the same surface point in two frames is found by its rest-pose
    position (rasterize.position of a posed mesh, alpha = coverage), not through depth and the cameras.
    Each surface pixel of frame k is matched to the pixel of frame k+1 with the nearest rest position; the
    match counts only within `tol_texels` times the rest-space size of a pixel (so points hidden or gone in
    frame k+1 are skipped). Returns (D, D relative to the offsets' spread, pixels compared)."""
    from scipy.spatial import cKDTree

    m0, m1 = rest0[..., 3] > 0, rest1[..., 3] > 0
    if not m0.any() or not m1.any():
        return 0.0, 0.0, 0
    p0, p1 = rest0[m0][:, :3].astype(np.float64), rest1[m1][:, :3].astype(np.float64)
    both = m1[:, 1:] & m1[:, :-1]  # rest-space size of one pixel: the median step between neighbours
    step = float(np.median(np.linalg.norm(rest1[:, 1:, :3] - rest1[:, :-1, :3], axis=-1)[both])) if both.any() else 0.0
    dist, idx = cKDTree(p1).query(p0)
    ok = dist <= tol_texels * max(step, 1e-12)
    if not ok.any():
        return 0.0, 0.0, 0
    o0 = off0[m0][ok].astype(np.float64)
    o1 = off1[m1][idx[ok]].astype(np.float64)
    size = np.linalg.norm(o0, axis=1).sum()
    spread = np.linalg.norm(o0 - o0.mean(axis=0), axis=1).sum()
    change = np.linalg.norm(o1 - o0, axis=1).sum()
    return (float(change / size) if size > 0 else 0.0), (float(change / spread) if spread > 0 else 0.0), int(ok.sum())


def _rest_run(pipeline: str | Path, scene: str, frames: range, size: tuple[int, int], rest_pose: bool,
              gl: Any) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """(rest positions, sketch offsets in pixels) per frame of an animated scene, with the rest pose carried
    by posed meshes (`rest_pose`) or dropped (object-space noise then reads posed positions)."""
    from ... import pipeline as pl
    from ...executor import Executor

    pipe = pl.load(pipeline, size=size, scene=scene)
    if pipe.scene.animation is None:
        raise SketchgraphError(f"{scene}: the deforming-mesh shower-door needs an animated scene")
    pipe.scene = replace(pipe.scene, animation=replace(pipe.scene.animation, rest_pose=rest_pose))
    depth_ref, off_ref = _sketch_refs(pipe)
    pos_ref = (depth_ref[0], "position")
    ex = Executor(pipe, None, mode="loop", requested=[pos_ref, off_ref], gl=gl)
    w, h = pipe.size
    scale = np.array([w, h, w, h], dtype=np.float64)
    rests, offs = [], []
    for f in frames:
        res = ex.run(f)
        rests.append(res.values[pos_ref].read().copy())
        offs.append(res.values[off_ref].read()[..., :4] * scale)
    ex.clear_memory()
    return rests, offs


def compare_rest_pose(scene: str, frames: int | None = None, size: tuple[int, int] = (400, 400),
                      pipeline: str | Path = OBJECT_PIPELINE, gl: Any = None) -> dict[str, Any]:
    """The shower-door metric on a deforming (skinned or morphing) scene for object-space noise read at
    posed positions ("posed", before) and at rest-pose positions ("rest", after), over the scene's
    animation (or at most its first `frames` frames). The same surface point in consecutive frames is matched by
    its rest position from the rest-pose run (`surface_pair_metric`); both runs draw the same geometry."""
    from ... import pipeline as pl
    from ...gpu import gl as glmod
    from ...scene.animation import default_frames

    gl = gl or glmod.get()
    t0 = time.perf_counter()
    all_frames = default_frames(pl.load(pipeline, size=size, scene=scene).scene) or []
    n = len(all_frames) if not frames else min(frames, len(all_frames))
    rng = range(all_frames[0], all_frames[0] + n) if all_frames else range(0)
    if len(rng) < 2:
        raise SketchgraphError(f"{scene}: the metric compares consecutive frames of an animation, so at least 2")
    rest_pos, rest_off = _rest_run(pipeline, scene, rng, size, True, gl)
    _, posed_off = _rest_run(pipeline, scene, rng, size, False, gl)
    out: dict[str, Any] = {"scene": scene, "frames": len(rng), "size": list(size), "pipeline": str(pipeline)}
    for name, offs in (("posed", posed_off), ("rest", rest_off)):
        pairs = [surface_pair_metric(rest_pos[k], offs[k], rest_pos[k + 1], offs[k + 1]) for k in range(len(rng) - 1)]
        out[name] = statistics.fmean(p[0] for p in pairs)
        out[f"{name}_vs_spread"] = statistics.fmean(p[1] for p in pairs)
        out[f"{name}_per_pair"] = [p[0] for p in pairs]
        out["pixels_compared"] = [p[2] for p in pairs]
    out["ratio"] = out["rest"] / out["posed"] if out["posed"] > 0 else math.inf
    out["seconds"] = time.perf_counter() - t0
    return out


@click.command()
@click.option("--scene", default="builtin:sphere", show_default=True, help="builtin:NAME, a scene YAML or a mesh "
              "file (a mesh file gets a framed camera and a 6 degrees/frame orbit about +Y).")
@click.option("--frames", default=60, show_default=True, help="Frames along the orbit (pairs = frames - 1).")
@click.option("--size", default="400x400", show_default=True, help="WxH of the renders measured.")
@click.option("--degrees-per-frame", type=float, default=None, help="Override the orbit's step (0 = static camera).")
@click.option("--screen", "screen", default=SCREEN_PIPELINE, show_default=True,
              help="Pipeline with screen-space uncertainty (a file or a shipped pipeline's name).")
@click.option("--object", "object_", default=OBJECT_PIPELINE, show_default=True,
              help="Pipeline with object-space uncertainty (a file or a shipped pipeline's name).")
@click.option("--deforming", is_flag=True, help="For an animated scene with skinned or morphing meshes: the "
              "object-space pipeline with noise at posed positions vs at rest-pose positions, over the animation "
              "(--frames: its first N frames; same-point matching by rest position).")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def command(scene: str, frames: int, size: str, degrees_per_frame: float | None, screen: str, object_: str,
            deforming: bool, json_path: Path | None) -> None:
    """Shower-door effect: frame-to-frame change of the uncertainty on the same surface point, relative to
    its size, for screen-space vs object-space uncertainty along the scene's orbit (lower is better)."""
    from ...pipeline import parse_size

    if deforming:
        r = compare_rest_pose(scene, frames, parse_size(size), object_)
        click.echo(f"shower-door on deforming {scene}: {r['frames']} frames, {size}, {r['pipeline']}")
        click.echo(f"  noise at posed positions: {r['posed']:.4f}")
        click.echo(f"  noise at rest positions:  {r['rest']:.4f}")
        click.echo(f"  ratio (rest / posed): {r['ratio']:.4f}")
        if json_path:
            json_path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_text(json_path, json.dumps(r, indent=2) + "\n")
            click.echo(f"wrote {json_path}")
        return
    result = compare(scene, frames, parse_size(size), degrees_per_frame, screen, object_)
    click.echo(f"shower-door on {scene}: {frames} frames at {result['degrees_per_frame']:g} deg/frame, "
               f"{size}")
    click.echo(f"  screen_space: {result['screen_space']:.4f}")
    click.echo(f"  object_space: {result['object_space']:.4f}")
    click.echo(f"  ratio (object / screen): {result['ratio']:.4f}")
    rs = result["relative_to_spread"]
    click.echo(f"  relative to the offsets' spread instead of their size: screen {rs['screen_space']:.4f}, "
               f"object {rs['object_space']:.4f}, ratio {rs['ratio']:.4f}")
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json_path, json.dumps(result, indent=2) + "\n")
        click.echo(f"wrote {json_path}")
