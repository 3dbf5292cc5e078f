"""Benchmarks: commands that print figures and write JSON (never timed tests).

`sketchgraph bench PIPELINE` renders frames back to back along the scene's orbit with no readback and
no disk cache, and reports fps (1000 / the median frame time, each frame waited for), `fps_back_to_back`
(the same frames issued one after another with a single wait at the end, as a frame loop with nothing to
read back runs them), the median frame time, the median time of every node, the time of a plain
full-screen RGBA16F copy pass measured in the same run between the waited frames (after each frame one
copy to warm up and one timed: the floor for one pass; `copy_pass_in_a_row_ms` is 30 copies in a row after
the frames, for comparison), and the time of the image-space stages in their float64 NumPy references on
the same G-buffer. `draws` counts the full-screen passes and geometry draws of one frame as the GL wrapper
issued them (`GL.draws`), and `floor_ratio` is ms per frame / (draws x copy pass): 1.0 would mean every
draw costs a plain copy (`floor_ratio_back_to_back`: the same with the back-to-back time a frame).
"""

from __future__ import annotations

import importlib
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import click

from ...errors import SketchgraphError
from ...fsio import atomic_write_text

# named benchmarks: name -> "module:click_command"
NAMED: dict[str, str] = {
    "shower-door": "nodegraph.tools.bench.showerdoor:command",
    "accuracy": "nodegraph.tools.bench.accuracy:command",
    "hatching": "nodegraph.tools.bench.pencil:hatching_command",
    "curvature": "nodegraph.tools.bench.pencil:curvature_command",
    "pencil-shade": "nodegraph.tools.bench.pencil:shade_command",
    "particles": "nodegraph.tools.bench.particles:command",
    "distributed": "nodegraph.tools.bench.distributed:command",
    "film": "nodegraph.tools.bench.film:command",
    "startup": "nodegraph.tools.bench.runs:startup_command",
    "cold-cache": "nodegraph.tools.bench.runs:cold_cache_command",
    "uncertainty-cost": "nodegraph.tools.bench.lines:uncertainty_command",
    "feature-lines": "nodegraph.tools.bench.lines:feature_lines_command",
    "sizes": "nodegraph.tools.bench.sizes:command",
    "sketch-depth": "nodegraph.tools.bench.sketch_depth:command",
    "footprint": "nodegraph.tools.bench.sketch_depth:footprint_command",
    "targets": "nodegraph.tools.bench.targets:command",
    "peer": "nodegraph.tools.bench.peer:command",
    "checksum": "nodegraph.tools.bench.checksum:command",
    "orientation": "nodegraph.tools.bench.orientation:command",
    "posing": "nodegraph.tools.bench.posing:command",
    "flicker": "nodegraph.tools.bench.flicker:command",
    "coherence": "nodegraph.tools.bench.coherence:command",
    "strokes": "nodegraph_nodes.mesh_lines.bench:command",
    "serve": "nodegraph.tools.bench.serve:command",
}

IMAGE_SPACE_TYPES = ("edge_detect", "sketch", "depth_sprite")


def command_for(target: str) -> click.Command:
    if target in NAMED:
        module, attr = NAMED[target].split(":")
        return getattr(importlib.import_module(module), attr)
    if target.endswith((".yaml", ".yml")) or Path(target).exists():
        return _pipeline_command(target)
    from ... import shipped

    if target in shipped.paths():  # a shipped pipeline by name, as `sketchgraph run NAME` takes it
        return _pipeline_command(target)
    names = ", ".join(sorted(NAMED)) or "none yet"
    raise SketchgraphError(f"bench: '{target}' is neither a pipeline file, a shipped pipeline "
                           f"({', '.join(shipped.names())}) nor a named benchmark ({names})")


def _pipeline_command(path: str) -> click.Command:
    from ...scene.views import click_options as framing_options

    @click.command(help="Frames back to back along the scene's orbit, no readback: fps, ms a frame, each node's "
                        "median, the copy-pass floor and the float64 NumPy references of the image-space stages.")
    @click.option("--scene", help="builtin:NAME, a scene YAML or a mesh file.")
    @framing_options
    @click.option("--frames", default=60, show_default=True, help="Frames to render along the orbit.")
    @click.option("--size", default=None, help="WxH (default: the pipeline's).")
    @click.option("--set", "overrides", multiple=True, help="NODE.PARAM=VALUE")
    @click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
    def cmd(scene: str | None, frames: int, size: str | None, overrides: tuple[str, ...],
            json_path: Path | None, view: str | None = None, up: str | None = None, fill: float | None = None) -> None:
        emit(bench_pipeline(path, scene=scene, frames=frames, size=size, overrides=overrides, view=view, up=up,
                            fill=fill), json_path)

    return cmd


def emit(result: dict[str, Any], json_path: Path | None) -> None:
    """Print a benchmark's figures and, where asked, write them as JSON."""
    print_result(result)
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json_path, json.dumps(result, indent=2) + "\n")
        click.echo(f"wrote {json_path}")


def print_result(result: dict[str, Any]) -> None:
    for k, v in result.items():
        if isinstance(v, dict):
            click.echo(f"{k}:")
            for kk, vv in v.items():
                click.echo(f"  {kk}: {_fmt(vv)}")
        else:
            click.echo(f"{k}: {_fmt(v)}")


def _fmt(v: Any) -> str:
    return f"{v:.3f}" if isinstance(v, float) else str(v)


def bench_pipeline(path: str, *, scene: str | None = None, frames: int = 60, size: str | None = None,
                   overrides: tuple[str, ...] = (), warmup: int = 3, view: str | None = None,
                   up: str | None = None, fill: float | None = None) -> dict[str, Any]:
    from ... import pipeline as pl
    from ...executor import Executor
    from ...gpu import gl as glmod

    pipe = pl.load(path, overrides=list(overrides), size=pl.parse_size(size) if size else None, scene=scene,
                   view=view, up=up, fill=fill)
    gl = glmod.get()
    ex = Executor(pipe, None, mode="loop", memory_limit=256 * 1024**2)
    for f in range(-warmup, 0):
        ex.run(f)
    gl.finish()
    frame_ms = []
    # the floor is measured between the frames, not in a block before or after them: on a shared VM the
    # machine's speed drifts within seconds (a block of 30 copies measured 2.0 to 4.1 ms in one process), and
    # a ratio of two figures taken at different moments carries that drift. After each frame one copy warms
    # up (the first copy after a frame is 15-20% slower than the next: its textures left the caches) and the
    # second is timed, the steady state a block in a row measures
    copy = CopyPass(gl, pipe.size)
    copy_each: list[float] = []
    copy_draws = 0
    fs0, geo0 = gl.draws.fullscreen, gl.draws.geometry
    for f in _bar(range(frames), "frames"):
        t0 = time.perf_counter()
        ex.run(f)
        gl.finish()
        frame_ms.append((time.perf_counter() - t0) * 1000)
        d0 = gl.draws.fullscreen
        copy.once()
        copy_each.append(copy.once())
        copy_draws += gl.draws.fullscreen - d0   # the floor's own passes are not the frame's
    copy.release()
    draws = {"fullscreen": (gl.draws.fullscreen - fs0 - copy_draws) / frames,
             "geometry": (gl.draws.geometry - geo0) / frames}
    draws["total"] = draws["fullscreen"] + draws["geometry"]
    # the same frames back to back, one wait at the end: llvmpipe rasterises a pass while the next is issued
    # unless that one reads its output, so a frame's first (geometry) pass overlaps the last frame's last
    t0 = time.perf_counter()
    for f in _bar(range(frames), "frames"):
        ex.run(f)
    gl.finish()
    back_to_back_s = time.perf_counter() - t0
    # per-node times: a second pass that waits for the GPU after every node
    ex.timing = True
    per_node: dict[str, list[float]] = {nid: [] for nid in ex.plan.order}
    for f in range(min(frames, 20)):
        res = ex.run(f)
        for nid, st in res.stats.items():
            if st.status == "computed":
                per_node[nid].append(st.ms)
    nodes_ms = {nid: statistics.median(v) for nid, v in per_node.items() if v}
    copy_ms = statistics.median(copy_each)
    copy_in_a_row_ms = copy_pass_ms(gl, pipe.size)   # reported beside it: copies in a row, caches warm
    numpy_ms, gpu_ms = _numpy_reference(pipe, nodes_ms)
    median = statistics.median(frame_ms)
    out: dict[str, Any] = {
        "pipeline": str(path),
        "scene": pipe.scene_spec,
        "size": list(pipe.size),
        "frames": frames,
        "renderer": gl.renderer,
        "fps": 1000.0 / median,
        "fps_back_to_back": frames / back_to_back_s,
        "ms_per_frame": median,
        "ms_per_frame_p90": sorted(frame_ms)[int(0.9 * (len(frame_ms) - 1))],
        "nodes": nodes_ms,
        "copy_pass_ms": copy_ms,
        "copy_pass_in_a_row_ms": copy_in_a_row_ms,
        "ms_per_frame_over_copy_pass": median / copy_ms,
        "draws": draws,
        "floor_ratio": median / (draws["total"] * copy_ms) if draws["total"] else None,
        "floor_ratio_back_to_back": (back_to_back_s * 1000.0 / frames) / (draws["total"] * copy_ms)
        if draws["total"] else None,
    }
    if numpy_ms is not None:
        out.update(numpy_reference_ms=numpy_ms, image_space_gpu_ms=gpu_ms, speedup_vs_numpy=numpy_ms / gpu_ms)
    return out


def alternate(gl: Any, runs: dict[str, Any], frames: int) -> tuple[dict[str, list[float]], float]:
    """Frames 0..frames-1 of two ways of rendering (name -> function of the frame), alternating (which goes first
    swapped every frame) so the machine's drift hits both alike, each frame waited for; the ms of each frame by
    way, and the draws a frame (`GL.draws`) over both ways."""
    a, b = runs
    ms: dict[str, list[float]] = {a: [], b: []}
    d0 = gl.draws.total
    for f in range(frames):
        for way in ((b, a) if f % 2 else (a, b)):
            t0 = time.perf_counter()
            runs[way](f)
            gl.finish()
            ms[way].append((time.perf_counter() - t0) * 1000)
    return ms, (gl.draws.total - d0) / (2 * max(frames, 1))


class CopyPass:
    """A plain full-screen RGBA16F copy of `size`, chained A->B->A so no draw can be skipped: the floor for one
    pass. `once()` draws one, waits for it and returns its ms."""

    def __init__(self, gl: Any, size: tuple[int, int]) -> None:
        import numpy as np

        from ...gpu.glsl import ENGINE_GLSL

        self.gl = gl
        self.prog = gl.program(ENGINE_GLSL / "copy.glsl", node="bench")
        w, h = size
        self.a = gl.upload(np.random.default_rng(0).random((h, w, 4), dtype=np.float32), "RGBA16F")
        self.b = gl.texture(size, "RGBA16F")
        self.flip = True   # A->B first: B starts empty
        self.once()   # the program's first draw compiles and binds; not timed

    def once(self) -> float:
        src, dst = (self.a, self.b) if self.flip else (self.b, self.a)
        self.flip = not self.flip
        self.gl.finish()
        t0 = time.perf_counter()
        self.gl.fullscreen(self.prog, [dst], {"t_src": src})
        self.gl.finish()
        return (time.perf_counter() - t0) * 1000

    def release(self) -> None:
        self.gl.release(self.a)
        self.gl.release(self.b)


def copy_pass_ms(gl: Any, size: tuple[int, int], passes: int = 30) -> float:
    """Median time of `passes` copy passes (`CopyPass`) in a row."""
    copy = CopyPass(gl, size)
    times = [copy.once() for _ in range(passes)]
    copy.release()
    return statistics.median(times)


def _numpy_reference(pipe: Any, nodes_ms: dict[str, float]) -> tuple[float | None, float | None]:
    """float64 NumPy time of the image-space stages on the same G-buffer, and their GPU time."""
    from ...executor import Executor

    stages = [nid for nid, node in pipe.nodes.items() if node.type_name in IMAGE_SPACE_TYPES and nid in nodes_ms]
    if not stages:
        return None, None
    refs = sorted({ref for nid in stages for ref in pipe.connections[nid].values()})
    ex = Executor(pipe, None, requested=refs)
    res = ex.run(0)
    values = {ref: res.values[ref].read() for ref in refs}
    times = []
    for _ in range(3):  # best of three: fair to NumPy on a noisy machine
        t0 = time.perf_counter()
        produced: dict[tuple[str, str], Any] = {}
        for nid in [n for n in ex.plan.order if n in stages] or stages:
            node = pipe.nodes[nid]
            ins = {p: produced.get(ref, values.get(ref)) for p, ref in pipe.connections[nid].items()}
            for port, arr in reference_for(node, ins).items():
                produced[(nid, port)] = arr
        times.append((time.perf_counter() - t0) * 1000)
    return min(times), sum(nodes_ms[n] for n in stages)


def reference_for(node: Any, ins: dict[str, Any]) -> dict[str, Any]:
    """Run the float64 reference of an image-space node on read-back inputs: `reference(node, ins)` of the
    `bench` module beside the node (found through the registry)."""
    from .measure import node_module

    if node.type_name not in IMAGE_SPACE_TYPES:
        raise KeyError(node.type_name)
    return node_module(node.type_name, "bench").reference(node, ins)


def _bar(it: Any, unit: str) -> Any:
    from tqdm import tqdm

    return tqdm(it, unit=unit, file=sys.stderr, leave=False, disable=not sys.stderr.isatty())
