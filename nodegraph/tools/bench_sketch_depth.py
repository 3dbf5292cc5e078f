"""Interleaved A/B of whole frames of a pipeline with a sketch, in one process, printing JSON (a benchmark,
not a test): A = the plan with the sketch's depth read (as before `Sketch.unread_inputs`: the sketch reads the
depth map, the G-buffer writes it), B = the plan as shipped (where the shade's alpha stands in, the depth is
neither read nor made). Frames alternate A/B (order swapped every frame) along the scene's orbit, no readback.

    sketchgraph bench sketch-depth --scene ../shared/meshes/ogre.obj [--frames 60] [--json F] [PIPELINE]
"""

from __future__ import annotations

import json
import statistics
import time
from pathlib import Path
from typing import Any

import click

from ..fsio import atomic_write_text


@click.command()
@click.argument("pipeline", default="nienhaus_sketchy")
@click.option("--scene", help="builtin:NAME, a scene YAML or a mesh file.")
@click.option("--frames", default=60, show_default=True, help="Frames of each plan, alternating.")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def command(pipeline: str, scene: str | None, frames: int, json_path: Path | None) -> None:
    out = run(pipeline, scene, frames)
    click.echo(json.dumps(out))
    if json_path:
        atomic_write_text(json_path, json.dumps(out, indent=2) + "\n")


def run(pipeline: str = "nienhaus_sketchy", scene: str | None = None, frames: int = 60) -> dict[str, Any]:
    from .. import gl as glmod
    from .. import pipeline as pl
    from ..executor import Executor
    from .bench import copy_pass_ms

    pipe = pl.load(pipeline, scene=scene)
    sketches = {type(n) for n in pipe.nodes.values() if n.type_name == "sketch"}
    if not sketches:
        raise click.UsageError(f"{pipeline} has no sketch node")
    Sketch = sketches.pop()  # noqa: N806 - the node class, patched for plan A
    gl = glmod.get()
    shipped = Sketch.unread_inputs
    try:
        Sketch.unread_inputs = lambda self, needed, sources: set()  # type: ignore[method-assign]
        ex_a = Executor(pipe, None, mode="loop", memory_limit=256 * 1024**2)
    finally:
        Sketch.unread_inputs = shipped  # type: ignore[method-assign]
    ex_b = Executor(pipe, None, mode="loop", memory_limit=256 * 1024**2)
    exs = {"A": ex_a, "B": ex_b}
    for ex in exs.values():
        for f in range(-3, 0):
            ex.run(f)
    gl.finish()
    ms: dict[str, list[float]] = {"A": [], "B": []}
    d0 = gl.draws.total
    for f in range(frames):
        for v in ("AB" if f % 2 else "BA"):
            t0 = time.perf_counter()
            exs[v].run(f)
            gl.finish()
            ms[v].append((time.perf_counter() - t0) * 1000)
    draws = (gl.draws.total - d0) / (2 * frames)
    copy = copy_pass_ms(gl, pipe.size)
    a, b = statistics.median(ms["A"]), statistics.median(ms["B"])
    out = {"pipeline": pipeline, "scene": pipe.scene_spec, "frames": frames, "copy_pass_ms": copy,
           "draws": draws, "A_ms": a, "B_ms": b, "B_over_A": b / a, "A_fps": 1000 / a, "B_fps": 1000 / b,
           "A_floor_ratio": a / (draws * copy), "B_floor_ratio": b / (draws * copy),
           "A_unread": {k: sorted(v) for k, v in ex_a.plan.unread.items()},
           "B_unread": {k: sorted(v) for k, v in ex_b.plan.unread.items()}}
    return out
