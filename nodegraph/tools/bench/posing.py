"""`sketchgraph bench posing`: what posing an animated glTF character costs a frame, two ways in one run.

(a) **posing**: a frame's posed vertices of every skinned or morphed part (`GltfAsset._posed_all`: one skinning
pass per skin over all its parts) and their derived arrays (render positions, split and smooth normals,
enlargement directions: `posing.PoseBatch`), timed at successive animation times, given per frame and per 100k
skinned vertices (target: under 5 ms per 100k vertices); also the skinning alone, compiled and in NumPy.

(b) **frame ratio**: the character's frame through a pipeline against the same file drawn unanimated (the same
file with its animations removed: its rest pose, every mesh static), same size and frame count, the two taking
turns frame by frame (interleaved: this machine's speed drifts within seconds); the ratio of the medians and the
median of each frame's own ratio (target: within 1.5x).

The character is built here unless `--file` names one: a BrainStem-like figure (PARTS tubes, about TRIANGLES
triangles in all, in meshes of five primitives, on one skin of JOINTS joints in a chain, a clip of SECONDS
swaying every joint).
"""

from __future__ import annotations

import json
import math
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import click
import numpy as np

from ...fsio import atomic_write_text
from .gltfdoc import GltfDoc

PARTS, TRIANGLES, JOINTS, SECONDS = 30, 60_000, 18, 3.0
TARGET_MS_PER_100K = 5.0
TARGET_RATIO = 1.5
PIPELINES = ("nienhaus_sketchy", "pencil")


def character(path: Path, parts: int = PARTS, triangles: int = TRIANGLES, joints: int = JOINTS,
              seconds: float = SECONDS) -> Path:
    """Write the synthetic character (see the module docstring) as a .glb at `path`."""
    import pygltflib as g

    gd = GltfDoc()
    doc, accessor = gd.doc, gd.accessor

    height, seg = 2.0, 24
    rings = max(3, triangles // parts // (2 * seg) + 1)
    rng = np.random.default_rng(1)
    prims = []
    for p in range(parts):
        y0 = height * p / parts
        y1 = y0 + 1.5 * height / parts
        cx, cz = rng.normal(0.0, 0.05, 2)
        ys = np.linspace(y0, y1, rings)
        a = np.linspace(0.0, 2 * math.pi, seg, endpoint=False)
        r = 0.1 + 0.05 * np.sin(np.pi * (ys - y0) / (y1 - y0))
        v = np.stack([cx + r[:, None] * np.cos(a), np.repeat(ys[:, None], seg, 1), cz + r[:, None] * np.sin(a)],
                     -1).reshape(-1, 3)
        i, k = np.arange(rings - 1)[:, None], np.arange(seg)[None]
        k1 = (k + 1) % seg
        q = (i * seg + k, i * seg + k1, (i + 1) * seg + k1, (i + 1) * seg + k)
        f = np.concatenate([np.stack([q[0], q[2], q[1]], -1).reshape(-1, 3),
                            np.stack([q[0], q[3], q[2]], -1).reshape(-1, 3)])
        jf = np.clip(v[:, 1] / height * (joints - 1), 0, joints - 1 - 1e-6)
        j0 = np.floor(jf).astype(np.uint16)
        t = (jf - j0).astype(np.float32)
        jw = np.stack([j0, j0 + 1, 0 * j0, 0 * j0], 1).astype(np.uint16)
        ww = np.stack([1 - t, t, 0 * t, 0 * t], 1).astype(np.float32)
        ww[:, 0] = 1 - ww[:, 1]
        prim = g.Primitive(attributes=g.Attributes(
            POSITION=accessor(v.astype(np.float32), "VEC3", minmax=True), JOINTS_0=accessor(jw, "VEC4", 5123),
            WEIGHTS_0=accessor(ww, "VEC4")), indices=accessor(f.reshape(-1).astype(np.uint32), "SCALAR", 5125))
        doc.materials.append(g.Material(pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[*rng.uniform(0.3, 0.9, 3).tolist(), 1.0])))
        prim.material = len(doc.materials) - 1
        prims.append(prim)
    meshes = []
    for m in range(0, parts, 5):
        doc.meshes.append(g.Mesh(primitives=prims[m:m + 5], name=f"part{m}"))
        meshes.append(len(doc.meshes) - 1)
    jy = np.linspace(0.0, height, joints)
    for j in range(joints):
        doc.nodes.append(g.Node(name=f"j{j}", translation=[0.0, 0.0 if j == 0 else float(jy[j] - jy[j - 1]), 0.0],
                                children=[j + 1] if j + 1 < joints else []))
    doc.scenes[0].nodes.append(0)
    ibm = np.stack([np.eye(4) - np.outer(np.eye(4)[1], [0, 0, 0, 0]) for _ in range(joints)])
    ibm[:, 1, 3] = -jy
    doc.skins.append(g.Skin(joints=list(range(joints)), inverseBindMatrices=accessor(
        ibm.transpose(0, 2, 1).astype(np.float32).reshape(joints, 16), "MAT4")))
    for m in meshes:
        doc.nodes.append(g.Node(mesh=m, skin=0, name=f"body{m}"))
        doc.scenes[0].nodes.append(len(doc.nodes) - 1)
    anim = g.Animation(name="sway")
    times = np.linspace(0.0, seconds, 25).astype(np.float32)
    t_acc = accessor(times, "SCALAR", minmax=True)
    for j in range(1, joints):
        ang = 0.25 * np.sin(2 * np.pi * times / seconds + 0.4 * j)
        quat = np.stack([0 * ang, 0 * ang, np.sin(ang / 2), np.cos(ang / 2)], 1).astype(np.float32)
        anim.samplers.append(g.AnimationSampler(input=t_acc, output=accessor(quat, "VEC4"), interpolation="LINEAR"))
        anim.channels.append(g.AnimationChannel(sampler=len(anim.samplers) - 1,
                                                target=g.AnimationChannelTarget(node=j, path="rotation")))
    doc.animations.append(anim)
    gd.write(path)
    return path


def still_copy(path: Path, out: Path) -> Path:
    """The file with its animations removed (drawn in its rest pose), as a .glb."""
    import pygltflib as g

    doc = g.GLTF2().load(str(path))
    doc.animations = []
    if path.suffix.lower() == ".gltf":
        doc.convert_buffers(g.BufferFormat.BINARYBLOB)
    doc.save_binary(str(out))
    return out


def bench_posing(path: Path, frames: int) -> dict[str, Any]:
    """(a): ms a frame to pose every part and make their derived arrays, at `frames` successive times."""
    from ...scene import posing
    from ...scene.gltf import load_asset

    asset = load_asset(path)
    anim = asset.animations[0] if asset.animations else None
    if anim is None:
        raise click.ClickException(f"{path}: no animation to pose")
    span = max(anim.end - anim.start, 1e-6)
    n_vertices = 0
    pose_ms, arrays_ms, skin_ms, skin_np_ms = [], [], [], []
    for f in range(-2, frames):  # two warm-up frames (compilation, the rest poses' topology)
        t = anim.start + span * ((f % max(frames, 1)) + 0.5) / max(frames, 1) + 1e-3 * f
        world, weights = asset.pose(t, anim)
        t0 = time.perf_counter()
        posed = asset._posed_all(world, weights)
        t1 = time.perf_counter()
        first = next(iter(posed.values()))[0]
        hit = posing.batched(first)
        assert hit is not None
        hit[0].render_arrays(40.0)
        t2 = time.perf_counter()
        # the skinning alone, over all parts of the first skin, compiled and in NumPy
        stacks = [(k, v) for k, v in asset._skin_rows.items()]
        skin_t = []
        for engine in ("auto", "numpy"):
            s0 = time.perf_counter()
            for (skin_index, _, _), (prims, stacked) in stacks:
                joints, ibm = asset.skins[skin_index]
                posing.skin(stacked, world[joints] @ ibm, np.concatenate([p.positions for p in prims]), engine)
            skin_t.append(time.perf_counter() - s0)
        if f >= 0:
            pose_ms.append(1e3 * (t1 - t0))
            arrays_ms.append(1e3 * (t2 - t1))
            skin_ms.append(1e3 * skin_t[0])
            skin_np_ms.append(1e3 * skin_t[1])
        n_vertices = sum(m.n_vertices for m, _ in posed.values())
    per = 1e5 / max(n_vertices, 1)
    total = [a + b for a, b in zip(pose_ms, arrays_ms, strict=True)]
    out = {"vertices": n_vertices, "parts": len(posed), "compiled": posing._jit() is not None,
           "pose_ms": statistics.median(pose_ms), "arrays_ms": statistics.median(arrays_ms),
           "total_ms": statistics.median(total), "skin_ms": statistics.median(skin_ms),
           "skin_numpy_ms": statistics.median(skin_np_ms)}
    out.update({f"{k[:-3]}_ms_per_100k": v * per for k, v in list(out.items()) if k.endswith("_ms")})
    out["met"] = out["total_ms_per_100k"] < TARGET_MS_PER_100K
    return out


def bench_ratio(pipeline: str, animated: Path, still: Path, frames: int, size: tuple[int, int]) -> dict[str, Any]:
    """(b): the animated file's frame time against the still file's, interleaved frame by frame."""
    from ... import pipeline as pl
    from ...executor import Executor
    from ...gpu import gl as glmod

    gl = glmod.get()
    runs = {}
    for name, scene in (("animated", animated), ("still", still)):
        pipe = pl.load(pipeline, size=size, scene=str(scene))
        ref = pipe.outputs[next(iter(pipe.outputs))]
        ex = Executor(pipe, None, mode="loop", requested=[ref], gl=gl, memory_limit=256 * 1024**2)
        for f in range(2):  # warm up: programs, textures, the rest poses' topology, compiled passes
            ex.run(f)
        gl.finish()
        runs[name] = ex
    times: dict[str, list[float]] = {"animated": [], "still": []}
    for f in range(2, 2 + frames):
        order = ("animated", "still") if f % 2 else ("still", "animated")  # who goes first alternates
        for name in order:
            t0 = time.perf_counter()
            runs[name].run(f)
            gl.finish()
            times[name].append(time.perf_counter() - t0)
    a, s = statistics.median(times["animated"]), statistics.median(times["still"])
    paired = statistics.median(x / y for x, y in zip(times["animated"], times["still"], strict=True))
    return {"animated_ms": 1e3 * a, "still_ms": 1e3 * s, "ratio": a / s, "ratio_paired_median": paired,
            "met": paired <= TARGET_RATIO}


@click.command()
@click.option("--file", "file_", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="An animated .gltf/.glb (default: the synthetic BrainStem-like character built here).")
@click.option("--frames", default=24, show_default=True, help="Frames per way.")
@click.option("--size", default="512x512", show_default=True, help="WxH of the frame-ratio runs.")
@click.option("--pipeline", "pipelines", multiple=True, default=PIPELINES, show_default=True,
              help="Shipped pipeline name or YAML (repeatable).")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def command(file_: Path | None, frames: int, size: str, pipelines: tuple[str, ...], json_path: Path | None) -> None:
    """Posing cost per 100k skinned vertices, and an animated character's frame against its still twin."""
    from ... import pipeline as pl
    from ... import shipped

    w, h = pl.parse_size(size)
    with tempfile.TemporaryDirectory(prefix="sketchgraph-posing-") as tmp:
        animated = file_ if file_ is not None else character(Path(tmp) / "character.glb")
        still = still_copy(animated, Path(tmp) / "still.glb")
        result: dict[str, Any] = {"file": str(file_) if file_ else "synthetic", "frames": frames,
                                  "size": [w, h], "posing": bench_posing(animated, frames)}
        p = result["posing"]
        click.echo(f"posing: {p['parts']} parts, {p['vertices']} skinned vertices; a frame: pose "
                   f"{p['pose_ms']:.2f} ms + arrays {p['arrays_ms']:.2f} ms = {p['total_ms']:.2f} ms "
                   f"({p['total_ms_per_100k']:.2f} ms per 100k vertices, target < {TARGET_MS_PER_100K}); "
                   f"skinning alone {p['skin_ms_per_100k']:.2f} ms per 100k (NumPy: "
                   f"{p['skin_numpy_ms_per_100k']:.2f}){'' if p['compiled'] else ' [not compiled: no Numba]'}")
        result["pipelines"] = {}
        for name in pipelines:
            path = str(shipped.resolve(name))
            r = result["pipelines"][name] = bench_ratio(path, animated, still, frames, (w, h))
            click.echo(f"{name} {w}x{h}: animated {r['animated_ms']:.1f} ms a frame, still {r['still_ms']:.1f} ms; "
                       f"ratio {r['ratio']:.2f} (paired median {r['ratio_paired_median']:.2f}, target "
                       f"<= {TARGET_RATIO})")
    text = json.dumps(result, indent=2)
    click.echo(text)
    if json_path is not None:
        atomic_write_text(json_path, text + "\n")
