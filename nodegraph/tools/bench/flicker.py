"""`sketchgraph bench flicker`: how much edge_detect's lines flicker on a slowly bending low-poly skinned figure.

Where the dashes come from. rasterize splits normals (so edge_detect draws a crease line) where two faces meet at
a dihedral angle over `crease_angle` (40 degrees). Taken from each posed frame, that choice flips as a joint
bends a face pair across 40 degrees, and a short segment of line appears or vanishes from one frame to the next:
the dashes on a low-poly character's torso. rasterize takes it from the rest pose instead (a posed mesh shares its
rest pose's smoothing groups: nodegraph/scene/posing.py), so a crease line stays on or off for the whole shot.

The figure is built here: a CesiumMan-like faceted torso (a closed tube of RINGS rings of SEGMENTS vertices, 960
triangles, radii irregular by +-NOISE, so some faces meet at creases and most at faint folds, on one skin of two
joints) whose upper half leans by LEAN degrees and back over SECONDS (49 frames at 24 fps, about 1.2 degrees a
frame at most), seen by a fixed framed camera. The edge map (`edges.out` of nienhaus_sketchy: width 2, normal
threshold 0.4) is rendered for every frame under each rule (RULES): smoothing groups from each posed frame
(`posed_creases`, the dashes) and from the rest pose (`step`, what rasterize does, edge_detect as shipped). For
consecutive frames a and b,

    flicker = sum_x |E_b(x) - E_a(x)| / sum_x max(E_a(x), E_b(x))

over the pixels covered in both frames whose surface point moved less than `--still-px` pixels between them
(rasterize.position, the rest-pose position, at the pixel in a against b, in pixels at that depth; the same
pixels for every rule): the share of the edge mass that switches on or off where the surface barely moved;
0 = lines that hold, 1 = lines all new every frame. `switching` is the same with the maps binarised at 0.5 (the
share of edge pixels that switch). Figures are the mean over all pairs. `intermediate` is the share of edge
pixels (E > 0.05) drawn at an intensity strictly between 0.05 and 0.95: the pixels where the threshold's ramp,
not the stencil's reach, sets the line.

Measured (`sketchgraph bench flicker`, 800x800, 49 frames, docs/charts/flicker.json and flicker_dashes.png):

    --still-px     posed_creases   step
    0.5            0.0161          0.0068
    0.2            0.0036          0.0015
    2              0.0929          0.0630

Rest-pose smoothing groups cut the flicker 2.4x where the surface barely moved; what is left grows with the motion
allowed (0.0015 at 0.2 px, 0.0068 at 0.5 px): a crease line sliding by a fraction of a pixel moves the stencil's
reach across pixel centres, not a threshold crossing (6 % of edge pixels lie on the ramp). Tried and not kept: a
wider threshold ramp in edge_detect (its inner-edge ramp [t, 1.25 t] widened to [t (1 - s), t (1.25 + s)]) measured
0.0071 at s = 0.5 and 0.0073 at s = 0.75 against 0.0068, and thinned lines, so hysteresis on the threshold would
not reach this either; filtering along the motion (rasterize's `motion`) is what is left to try."""

from __future__ import annotations

import json
import math
import statistics
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import click
import numpy as np

from ...errors import SketchgraphError
from ...fsio import atomic_write_text
from .gltfdoc import GltfDoc, quaternion

RINGS, SEGMENTS, LEAN, SECONDS, NOISE = 30, 16, 30.0, 2.0, 0.08
PIPELINE = "nienhaus_sketchy"
# name -> edge_detect params set over the pipeline's (and `rest_pose`)
# `creases: posed` draws every frame as a still scene of fresh meshes, so rasterize splits normals where that
# frame's posed surface has creases (dihedral angle over crease_angle) and a crease comes and goes as a joint bends;
# the other rules keep the rest pose's smoothing groups, as rasterize does for a posed mesh
RULES: dict[str, dict[str, Any]] = {
    "posed_creases": {"creases": "posed"},
    "step": {},
}


def figure(path: Path, rings: int = RINGS, segments: int = SEGMENTS, lean: float = LEAN, seconds: float = SECONDS,
           seed: int = 3) -> Path:
    """Write the low-poly torso (module docstring) as a .glb at `path`: a tube along +y from 0 to 2, radius
    about 0.45, +-NOISE per vertex (seeded), skinned to joint 0 at the origin and joint 1 at y = 1 (weights blend over
    0.7 < y < 1.3); joint 1 turns by `lean` degrees about +x then back over `seconds`."""
    import pygltflib as g

    gd = GltfDoc()
    doc, accessor = gd.doc, gd.accessor

    rng = np.random.default_rng(seed)
    ys = np.linspace(0.0, 2.0, rings)
    a = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    r = 0.45 * (1.0 + NOISE * rng.uniform(-1.0, 1.0, (rings, segments))) * (0.8 + 0.2 * np.sin(np.pi * ys / 2))[:, None]
    v = np.stack([r * np.cos(a), np.repeat(ys[:, None], segments, 1), r * np.sin(a)], -1).reshape(-1, 3)
    v = np.concatenate([v, [[0.0, 0.0, 0.0], [0.0, 2.0, 0.0]]]).astype(np.float32)
    i, k = np.arange(rings - 1)[:, None], np.arange(segments)[None]
    k1 = (k + 1) % segments
    q = (i * segments + k, i * segments + k1, (i + 1) * segments + k1, (i + 1) * segments + k)
    f = [np.stack([q[0], q[2], q[1]], -1).reshape(-1, 3), np.stack([q[0], q[3], q[2]], -1).reshape(-1, 3)]
    c0, c1, last = rings * segments, rings * segments + 1, (rings - 1) * segments
    ks = np.arange(segments)
    f.append(np.stack([np.full(segments, c0), ks, (ks + 1) % segments], -1))
    f.append(np.stack([np.full(segments, c1), last + (ks + 1) % segments, last + ks], -1))
    faces = np.concatenate(f).astype(np.uint32)
    s = np.clip((v[:, 1] - 0.7) / 0.6, 0.0, 1.0)
    w1 = s * s * (3 - 2 * s)
    weights = np.stack([1 - w1, w1, 0 * w1, 0 * w1], 1).astype(np.float32)
    joints = np.tile(np.array([0, 1, 0, 0], np.uint8), (len(v), 1))
    pos = accessor(v, "VEC3", minmax=True)
    prim = g.Primitive(attributes=g.Attributes(POSITION=pos, JOINTS_0=accessor(joints, "VEC4", 5121),
                                               WEIGHTS_0=accessor(weights, "VEC4")),
                       indices=accessor(faces.reshape(-1), "SCALAR", 5125), mode=4)
    doc.materials.append(g.Material(pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0.7, 0.6, 0.5, 1])))
    prim.material = 0
    doc.meshes.append(g.Mesh(primitives=[prim]))
    doc.nodes.append(g.Node(name="j0", children=[1]))
    doc.nodes.append(g.Node(name="j1", translation=[0.0, 1.0, 0.0]))
    ibm = np.stack([np.eye(4), np.array([[1, 0, 0, 0], [0, 1, 0, -1], [0, 0, 1, 0], [0, 0, 0, 1]], float)])
    doc.skins.append(g.Skin(joints=[0, 1], inverseBindMatrices=accessor(
        ibm.transpose(0, 2, 1).astype(np.float32).reshape(2, 16), "MAT4")))
    doc.nodes.append(g.Node(mesh=0, skin=0, name="torso"))
    doc.scenes[0].nodes = [0, 2]

    times = np.array([0.0, seconds / 2, seconds], np.float32)
    values = np.array([quaternion((1, 0, 0), 0.0), quaternion((1, 0, 0), lean), quaternion((1, 0, 0), 0.0)], np.float32)
    doc.animations.append(g.Animation(name="lean", samplers=[g.AnimationSampler(
        input=accessor(times, "SCALAR", minmax=True), output=accessor(values, "VEC4"))], channels=[
        g.AnimationChannel(sampler=0, target=g.AnimationChannelTarget(node=1, path="rotation"))]))
    gd.write(path)
    return Path(path)


def _fresh(mesh: Any) -> Any:
    """A copy of a posed mesh without its rest pose, so its smoothing groups come from its own (posed) surface.
    GL buffers and stored arrays are found by content hash, which the posed mesh shares: the copy's hash is
    made distinct so neither run reads the other's normals."""
    import hashlib

    from ...scene.meshes import Mesh

    out = Mesh(mesh.name, np.array(mesh.vertices), np.array(mesh.faces), mesh.source)
    out._cache["hash"] = hashlib.sha256(f"flicker.posed-creases:{mesh.content_hash()}".encode()).hexdigest()
    return out


def pair_flicker(e0: np.ndarray, e1: np.ndarray, keep: np.ndarray) -> tuple[float, float]:
    """(flicker, switching) of two edge maps over the pixels in `keep` (module docstring); 0 where no edges."""
    a, b = e0[keep].astype(np.float64), e1[keep].astype(np.float64)
    mass = np.maximum(a, b).sum()
    on0, on1 = a >= 0.5, b >= 0.5
    union = np.count_nonzero(on0 | on1)
    return (float(np.abs(b - a).sum() / mass) if mass > 0 else 0.0,
            float(np.count_nonzero(on0 ^ on1) / union) if union else 0.0)


def still_mask(pos0: np.ndarray, pos1: np.ndarray, depth0: np.ndarray, depth1: np.ndarray, px_per_unit: np.ndarray,
               still_px: float) -> np.ndarray:
    """Pixels covered in both frames whose world position at that pixel moved less than `still_px` pixels
    (world distance x pixels per world unit at that depth)."""
    cov = (depth0 > 0) & (depth1 > 0)
    moved = np.linalg.norm(pos1[..., :3].astype(np.float64) - pos0[..., :3], axis=-1) * px_per_unit
    return cov & (moved < still_px)


def measure(rules: dict[str, dict[str, Any]], frames: int | None = None, size: tuple[int, int] = (800, 800),
            still_px: float = 0.5, pipeline: str = PIPELINE, file: Path | None = None, gl: Any = None,
            keep_maps: bool = False) -> dict[str, Any]:
    """Flicker of the edge map under each rule (name -> edge_detect params set over the pipeline's) on the
    figure's shot."""
    from ... import pipeline as pl
    from ...executor import Executor
    from ...gpu import gl as glmod
    from ...scene.animation import default_frames

    gl = gl or glmod.get()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        path = file or figure(Path(tmp) / "torso.glb")
        out: dict[str, Any] = {"scene": str(path) if file else "built-in low-poly torso", "size": list(size),
                               "pipeline": pipeline, "still_px": still_px, "rules": {}}
        if not file:
            out["figure"] = {"rings": RINGS, "segments": SEGMENTS, "noise": NOISE, "lean_degrees": LEAN,
                             "seconds": SECONDS, "triangles": 2 * (RINGS - 1) * SEGMENTS + 2 * SEGMENTS}

        def load() -> tuple[Any, str, str, list[int]]:
            pipe = pl.load(pipeline, size=size, scene=str(path))
            edges = [nid for nid, node in pipe.nodes.items() if node.type_name == "edge_detect"][0]
            gbuf = [nid for nid, node in pipe.nodes.items() if node.type_name == "rasterize"][0]
            seq = default_frames(pipe.scene) or [0]
            return pipe, edges, gbuf, seq[:frames] if frames else seq

        def run(pipe: Any, refs: list[tuple[str, str]], seq: list[int]) -> list[list[np.ndarray]]:
            ex = Executor(pipe, None, mode="loop", requested=refs, gl=gl)
            got: list[list[np.ndarray]] = [[] for _ in refs]
            for f in seq:
                res = ex.run(f)
                for i, ref in enumerate(refs):
                    got[i].append(res.values[ref].read().copy())
            ex.clear_memory()
            return got

        # the pixels compared, the same for every rule (no rule changes the geometry): from the rest-pose run, whose
        # rasterize.position is the surface point's rest position, so a point sliding under a pixel counts as moved
        pipe, _, gbuf, seq = load()
        if pipe.scene.animation is None or len(seq) < 2:
            raise SketchgraphError(f"{path}: flicker compares consecutive frames of an animation, so at least 2")
        pos, dep = run(pipe, [(gbuf, "position"), (gbuf, "linear_depth")], seq)
        # pixels per world unit at depth z: the vertical field of view spans the (shorter) height
        tan = math.tan(math.radians(pipe.scene.camera_at(seq[0]).fov_y_deg) / 2)
        keeps = [still_mask(pos[k], pos[k + 1], dep[k][..., 0], dep[k + 1][..., 0],
                            size[1] / (2.0 * np.maximum(dep[k][..., 0], 1e-9) * tan), still_px)
                 for k in range(len(seq) - 1)]
        for name, params in rules.items():
            params = dict(params)
            creases = params.pop("creases", "rest")
            pipe, edges, _, seq = load()
            node = pipe.nodes[edges]
            node.params = type(node.params)(**{**node.params.model_dump(), **params})
            if creases == "rest":
                maps = [m[..., 0] for m in run(pipe, [(edges, "out")], seq)[0]]
            else:  # each frame a still scene of fresh meshes: smoothing groups from the posed surface
                scene, maps = pipe.scene, []
                for f in seq:
                    posed = scene.animation.pose(scene, f)
                    pipe.scene = replace(posed, objects=tuple(replace(o, mesh=_fresh(o.mesh)) for o in posed.objects))
                    maps.append(run(pipe, [(edges, "out")], [0])[0][0][..., 0])
            pairs = [(*pair_flicker(maps[k], maps[k + 1], keeps[k]), int(keeps[k].sum())) for k in range(len(seq) - 1)]
            stack = np.array(maps)
            drawn = np.count_nonzero(stack > 0.05)
            entry: dict[str, Any] = {"params": rules[name], "frames": len(seq),
                                     "intermediate": float(np.count_nonzero((stack > 0.05) & (stack < 0.95)) / drawn)
                                     if drawn else 0.0,
                                     "flicker": statistics.fmean(p[0] for p in pairs),
                                     "switching": statistics.fmean(p[1] for p in pairs),
                                     "edge_mass": float(statistics.fmean(float(m.sum()) for m in maps)),
                                     "pixels_compared": int(statistics.fmean(p[2] for p in pairs))}
            if keep_maps:
                entry["maps"] = maps
            out["rules"][name] = entry
    out["seconds"] = time.perf_counter() - t0
    return out


def chart(out: dict[str, Any], path: Path, before: str = "posed_creases", after: str = "step") -> Path:
    """A picture of the pair of consecutive frames where rule `before` switches the most edge mass more than
    `after` does, both rules side by side (needs `measure(..., keep_maps=True)`): grey where both frames draw,
    red where the later frame switches a line on, blue where it switches one off."""
    from ...fsio import atomic_output
    from .accuracy_charts import _plt

    plt = _plt()
    mb, ma = (np.array(out["rules"][name]["maps"]) for name in (before, after))
    gain = np.abs(np.diff(mb, axis=0)).sum((1, 2)) - np.abs(np.diff(ma, axis=0)).sum((1, 2))
    k = int(np.argmax(gain))
    ys, xs = np.nonzero((mb[k] > 0) | (ma[k] > 0))
    h = mb.shape[1]
    rows = slice(h - 1 - ys.max() - 10, h - ys.min() + 10)
    cols = slice(max(xs.min() - 10, 0), xs.max() + 11)
    fig, axes = plt.subplots(1, 2, figsize=(9, 5.5))
    titles = {before: "smoothing groups from each posed frame", after: "smoothing groups from the rest pose"}
    for ax, name, m in ((axes[0], before, mb), (axes[1], after, ma)):
        a0, a1 = m[k][::-1][rows, cols], m[k + 1][::-1][rows, cols]
        rgb = np.ones(a0.shape + (3,)) - 0.8 * np.minimum(a0, a1)[..., None]
        on, off = np.clip(a1 - a0, 0, 1), np.clip(a0 - a1, 0, 1)
        rgb[..., 0] -= off
        rgb[..., 1] -= on + off
        rgb[..., 2] -= on
        ax.imshow(np.clip(rgb, 0, 1), interpolation="nearest")
        e = out["rules"][name]
        ax.set_title(f"{titles.get(name, name)}\nframes {k}-{k + 1}; flicker over the shot {e['flicker']:.4f}",
                     fontsize=10)
        ax.axis("off")
    fig.suptitle("edge_detect on a leaning low-poly torso: red switched on, blue switched off", fontsize=9)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=90, bbox_inches="tight", metadata={"Software": None}, format="png")
    plt.close(fig)
    return path


@click.command(help="Flicker of edge_detect's lines on a slowly bending low-poly skinned torso: the share of edge "
                    "mass (and of edge pixels) that switches between consecutive frames where the surface barely "
                    "moved, with smoothing groups from each posed frame against the rest pose's (rasterize's).")
@click.option("--frames", type=int, default=None, help="Only the first N frames of the shot (default: all, 49).")
@click.option("--size", default="800x800", show_default=True, help="WxH of the renders measured.")
@click.option("--still-px", type=float, default=0.5, show_default=True,
              help="Pixels whose surface moved this far or more between two frames are left out.")
@click.option("--file", "file", type=click.Path(exists=True, path_type=Path),
              help="Measure this animated glTF instead.")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
@click.option("--chart", "chart_path", type=click.Path(path_type=Path),
              help="Draw the frame pair where posed creases flicker most, beside the rest pose's (a PNG).")
def command(frames: int | None, size: str, still_px: float, file: Path | None, json_path: Path | None,
            chart_path: Path | None) -> None:
    try:
        w, h = (int(x) for x in size.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"'{size}' is not WxH (e.g. 800x800)", param_hint="--size") from None
    if w < 16 or h < 16:
        raise click.BadParameter(f"'{size}': at least 16x16", param_hint="--size")
    out = measure(RULES, frames=frames, size=(w, h), still_px=still_px, file=file, keep_maps=chart_path is not None)
    if chart_path:
        print(f"wrote {chart(out, chart_path)}")
        for e in out["rules"].values():
            e.pop("maps")
    for name, e in out["rules"].items():
        print(f"{name:>10}  flicker {e['flicker']:.4f}  switching {e['switching']:.4f}  intermediate "
              f"{e['intermediate']:.3f}  edge mass {e['edge_mass']:.0f}"
              f"  pixels compared {e['pixels_compared']}  {e['params']}")
    print(f"({out['seconds']:.1f} s)")
    if json_path:
        atomic_write_text(json_path, json.dumps(out, indent=1) + "\n")
