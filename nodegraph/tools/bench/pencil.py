"""Named benchmarks of the pencil pipeline: its precomputed data (`sketchgraph bench hatching`,
`sketchgraph bench curvature --scene MESH`) and its shading pass against the previous implementation
(`sketchgraph bench pencil-shade --scene MESH`, see `shade_command`).

The precomputed data's benchmarks run their node through the executor the way a pipeline does:
- `cold_s`: the first run with an empty disk cache (compute, upload, and the disk write), split into
  `cold_node_s` (the node's compute with its upload) and `cold_write_s` (the rest: the disk write);
- `compute_s`: the computation alone, best of `--repeat`;
- `cached_s`: a later run in a new process state (a new executor, nothing in memory): read from the disk
  cache and uploaded;
- `memory_s`: the next frame of the same executor (the value is reused from memory).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import click

from .pipeline import emit

HATCHING = """\
pipeline: bench-hatching
size: [64, 64]
scene: builtin:box
nodes:
  tam: {{type: hatching_synthesis, params: {{size: {size}, tones: {tones}}}}}
outputs:
  tones: tam.tones
"""

CURVATURE = """\
pipeline: bench-curvature
size: [64, 64]
scene: builtin:torus
nodes:
  curv: {{type: curvature, params: {{radius: {radius}}}}}
outputs:
  out: curv.out
"""


def _timed_runs(text: str, node: str, scene: str | None) -> dict[str, Any]:
    from ... import pipeline as pl
    from ...cache import Cache
    from ...executor import Executor
    from ...gpu import gl as glmod

    gl = glmod.get()
    with tempfile.TemporaryDirectory(prefix="sketchgraph-bench-") as tmp:
        cache = Cache(Path(tmp))
        pipe = pl.loads(text, "<bench>", scene=scene)
        ex = Executor(pipe, cache, mode="single", gl=gl)
        t0 = time.perf_counter()
        first = ex.run(0)
        gl.finish()
        cold = time.perf_counter() - t0
        cold_node = first.stats[node].ms / 1000.0
        t0 = time.perf_counter()
        ex.run(1)
        gl.finish()
        memory = time.perf_counter() - t0
        cache.flush()
        fresh = Executor(pl.loads(text, "<bench>", scene=scene), cache, mode="single", gl=gl)
        t0 = time.perf_counter()
        res = fresh.run(0)
        gl.finish()
        cached = time.perf_counter() - t0
        status = res.stats[node].status
        cache.close()
    return {"cold_s": cold, "cold_node_s": cold_node, "cold_write_s": cold - cold_node, "cached_s": cached,
            "memory_s": memory, "cached_from": status, "renderer": gl.renderer}


def _best(fn: Any, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


@click.command()
@click.option("--size", default=256, show_default=True, help="Tile size in texels.")
@click.option("--tones", default=32, show_default=True, help="Number of tones.")
@click.option("--repeat", default=3, show_default=True, help="Repetitions of the bare synthesis (best is kept).")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def hatching_command(size: int, tones: int, repeat: int, json_path: Path | None) -> None:
    """Tonal art map synthesis: cold, cached and bare compute times."""
    from .measure import node_module

    tam = node_module("hatching_synthesis", "tam")
    measured_darkness, synthesize_tam = tam.measured_darkness, tam.synthesize_tam

    result: dict[str, Any] = {"benchmark": "hatching", "size": size, "tones": tones}
    result.update(_timed_runs(HATCHING.format(size=size, tones=tones), "tam", None))
    result["compute_s"] = _best(lambda: synthesize_tam(size=size, tones=tones), repeat)
    d = measured_darkness(synthesize_tam(size=size, tones=tones))
    result["darkness_range"] = [float(d[0]), float(d[-1])]
    emit(result, json_path)


@click.command()
@click.option("--scene", default="builtin:torus", show_default=True, help="builtin:NAME, a scene YAML or a mesh.")
@click.option("--radius", default=3, show_default=True, help="libigl neighbourhood in rings.")
@click.option("--repeat", default=3, show_default=True, help="Repetitions of the bare computation (best is kept).")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def curvature_command(scene: str, radius: int, repeat: int, json_path: Path | None) -> None:
    """Principal curvature of every mesh in the scene: cold, cached and bare compute times."""
    import igl
    import numpy as np

    from ... import pipeline as pl

    text = CURVATURE.format(radius=radius)
    result: dict[str, Any] = {"benchmark": "curvature", "scene": scene, "radius": radius}
    result.update(_timed_runs(text, "curv", scene))
    pipe = pl.loads(text, "<bench>", scene=scene)
    node = pipe.nodes["curv"]
    meshes = {o.mesh.content_hash(): o.mesh for o in pipe.scene.objects}
    result["vertices"] = sum(m.n_vertices for m in meshes.values())
    result["faces"] = sum(m.n_faces for m in meshes.values())
    result["compute_s"] = _best(lambda: [node.measure(m.vertices, m.faces, m.weld()) for m in meshes.values()],
                                repeat)
    result["libigl_s"] = _best(lambda: [igl.principal_curvature(np.asarray(m.vertices, dtype=np.float64),
                                                                np.asarray(m.faces, dtype=np.int64), radius)
                                        for m in meshes.values()], repeat)
    emit(result, json_path)


@click.command()
@click.option("--scene", default="builtin:torus", show_default=True, help="builtin:NAME, a scene YAML or a mesh.")
@click.option("--frames", default=20, show_default=True, help="Frames along the orbit (each draws both).")
@click.option("--size", default=None, help="WxH (default: pencil.yaml's, 800x800).")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def shade_command(scene: str, frames: int, size: str | None, json_path: Path | None) -> None:
    """pencil_shade against its previous, geometry-shader implementation (nodes/pencil_shade/geometry_shader.py)
    on the same inputs: the two alternate frame by frame along the orbit in one process (which goes first
    alternates too), each followed by a wait for the GPU, with a plain copy pass timed every frame; reports
    the median times, the median of the per-frame ratios old / new, and each over the copy pass."""
    import statistics

    from ... import pipeline as pl
    from ...executor import Executor
    from ...gpu import gl as glmod
    from ...node import RunContext
    from .measure import node_module
    from .pipeline import copy_pass_ms

    legacy = node_module("pencil_shade", "geometry_shader")
    pipe = pl.load("pencil", scene=scene, size=pl.parse_size(size) if size else None)
    gl = glmod.get()
    ex = Executor(pipe, None, mode="loop", gl=gl,
                  requested=[("tam", "tones"), ("curv", "out"), ("paper", "out"), ("contour", "out")])
    node = pipe.nodes["shade"]
    needed = frozenset({"color"})  # what pencil.yaml asks of it
    implementations = {"deferred": node.compute,
                       "geometry_shader": lambda c, i, n: legacy.compute(node, c, i, n)}
    times: dict[str, list[float]] = {k: [] for k in implementations}
    draws: dict[str, float] = dict.fromkeys(implementations, 0.0)
    copy: list[float] = []
    for f in range(-2, frames):  # two warm-up frames: programs compiled, buffers uploaded
        res = ex.run(max(f, 0))
        ins = {"tam": res.values[("tam", "tones")], "curvature": res.values[("curv", "out")],
               "paper": res.values[("paper", "out")], "contour": res.values[("contour", "out")]}
        order = list(implementations) if f % 2 == 0 else list(reversed(implementations))
        for name in order:
            ctx = RunContext(node, gl=gl, size=pipe.size, frame=max(f, 0), pipeline_seed=pipe.seed, scene=pipe.scene)
            gl.finish()
            d0 = gl.draws.total
            t0 = time.perf_counter()
            out = implementations[name](ctx, ins, needed)
            gl.finish()
            if f >= 0:
                times[name].append((time.perf_counter() - t0) * 1000)
                draws[name] += (gl.draws.total - d0) / frames
            for value in out.values():
                gl.release(value)
        if f >= 0:
            copy.append(copy_pass_ms(gl, pipe.size, passes=5))
    copy_ms = statistics.median(copy)
    ratios = [a / b for a, b in zip(times["geometry_shader"], times["deferred"], strict=True)]
    result: dict[str, Any] = {"benchmark": "pencil-shade", "scene": pipe.scene_spec, "size": list(pipe.size),
                              "frames": frames, "renderer": gl.renderer,
                              "triangles": sum(o.mesh.n_faces for o in pipe.scene.objects)}
    for name, t in times.items():
        result[f"{name}_ms"] = statistics.median(t)
        result[f"{name}_over_copy_pass"] = statistics.median(t) / copy_ms
        result[f"{name}_draws"] = draws[name]
    result.update(copy_pass_ms=copy_ms, speedup=statistics.median(ratios), speedup_min=min(ratios),
                  speedup_max=max(ratios))
    emit(result, json_path)
