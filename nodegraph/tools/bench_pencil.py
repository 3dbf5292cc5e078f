"""Named benchmarks of the pencil pipeline's precomputed data: `sketchgraph bench hatching` and
`sketchgraph bench curvature --scene MESH`.

Each runs its node through the executor the way a pipeline does:
- `cold_s`: the first run with an empty disk cache (compute, upload, and the disk write), split into
  `cold_node_s` (the node's compute with its upload) and `cold_write_s` (the rest: the disk write);
- `compute_s`: the computation alone, best of `--repeat`;
- `cached_s`: a later run in a new process state (a new executor, nothing in memory): read from the disk
  cache and uploaded;
- `memory_s`: the next frame of the same executor (the value is reused from memory).
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path
from typing import Any

import click

from ..fsio import atomic_write_text

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
    from .. import gl as glmod
    from .. import pipeline as pl
    from ..cache import Cache
    from ..executor import Executor

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


def _emit(result: dict[str, Any], json_path: Path | None) -> None:
    from .bench import print_result

    print_result(result)
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json_path, json.dumps(result, indent=2) + "\n")
        click.echo(f"wrote {json_path}")


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
    _emit(result, json_path)


@click.command()
@click.option("--scene", default="builtin:torus", show_default=True, help="builtin:NAME, a scene YAML or a mesh.")
@click.option("--radius", default=3, show_default=True, help="libigl neighbourhood in rings.")
@click.option("--repeat", default=3, show_default=True, help="Repetitions of the bare computation (best is kept).")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def curvature_command(scene: str, radius: int, repeat: int, json_path: Path | None) -> None:
    """Principal curvature of every mesh in the scene: cold, cached and bare compute times."""
    import igl
    import numpy as np

    from .. import pipeline as pl

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
    _emit(result, json_path)
