"""Interleaved A/B of whole frames of a pipeline, in one process, printing JSON (benchmarks, not tests). Frames
alternate A/B (order swapped every frame) along the scene's orbit, no readback.

`bench sketch-depth`: A = the plan with the sketch's depth read (as before `Sketch.unread_inputs`: the sketch
reads the depth map, the G-buffer writes it), B = the plan as shipped (where the shade's alpha stands in, the
depth is neither read nor made).

    sketchgraph bench sketch-depth --scene ../shared/meshes/ogre.obj [--frames 60] [--json F] [PIPELINE]

`bench footprint`: A = every full-screen pass over the whole image (`nodegraph.gpu.footprint.ENABLED` off), B = as
shipped (passes whose output is blank outside the objects' projected boxes draw only inside them; the same
pixels). Also reports the share of the image the last node's output footprint covered, over the frames.

    sketchgraph bench footprint --scene ../shared/meshes/ogre.obj [--frames 60] [--json F] [PIPELINE]
"""

from __future__ import annotations

import json
import statistics
from pathlib import Path
from typing import Any

import click

from ...fsio import atomic_write_text


def _ab_command(run_ab: Any, help_text: str) -> click.Command:
    """The command of an A/B benchmark `run_ab(pipeline, scene, frames)`: prints its JSON, writes it with --json."""

    @click.command(help=help_text)
    @click.argument("pipeline", default="nienhaus_sketchy")
    @click.option("--scene", help="builtin:NAME, a scene YAML or a mesh file.")
    @click.option("--frames", default=60, show_default=True, help="Frames of each way, alternating.")
    @click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
    def command(pipeline: str, scene: str | None, frames: int, json_path: Path | None) -> None:
        out = run_ab(pipeline, scene, frames)
        click.echo(json.dumps(out))
        if json_path:
            atomic_write_text(json_path, json.dumps(out, indent=2) + "\n")

    return command


def run(pipeline: str = "nienhaus_sketchy", scene: str | None = None, frames: int = 60) -> dict[str, Any]:
    from ... import pipeline as pl
    from ...executor import Executor
    from ...gpu import gl as glmod
    from .pipeline import alternate, copy_pass_ms

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
    ms, draws = alternate(gl, {"B": exs["B"].run, "A": exs["A"].run}, frames)
    copy = copy_pass_ms(gl, pipe.size)
    a, b = statistics.median(ms["A"]), statistics.median(ms["B"])
    out = {"pipeline": pipeline, "scene": pipe.scene_spec, "frames": frames, "copy_pass_ms": copy,
           "draws": draws, "A_ms": a, "B_ms": b, "B_over_A": b / a, "A_fps": 1000 / a, "B_fps": 1000 / b,
           "A_floor_ratio": a / (draws * copy), "B_floor_ratio": b / (draws * copy),
           "A_unread": {k: sorted(v) for k, v in ex_a.plan.unread.items()},
           "B_unread": {k: sorted(v) for k, v in ex_b.plan.unread.items()}}
    return out


def run_footprint(pipeline: str = "nienhaus_sketchy", scene: str | None = None, frames: int = 60) -> dict[str, Any]:
    from ... import pipeline as pl
    from ...executor import Executor
    from ...gpu import footprint
    from ...gpu import gl as glmod
    from .pipeline import alternate, copy_pass_ms

    pipe = pl.load(pipeline, scene=scene)
    ref = pipe.outputs[next(iter(pipe.outputs))]
    gl = glmod.get()
    exs = {v: Executor(pipe, None, mode="loop", requested=[ref], memory_limit=256 * 1024**2) for v in "AB"}
    shares: list[float] = []

    def way(v: str) -> Any:
        def render(frame: int) -> None:
            footprint.ENABLED = v == "B"
            try:
                value = exs[v].run(frame).values[ref]
            finally:
                footprint.ENABLED = True
            fp = getattr(value, "footprint", None)
            if v == "B":
                w, h = value.size
                shares.append(1.0 if fp is None else fp.rect[2] * fp.rect[3] / (w * h))
        return render

    runs = {"A": way("A"), "B": way("B")}
    for f in range(-3, 0):
        for render in runs.values():
            render(f)
    gl.finish()
    shares.clear()
    ms, draws = alternate(gl, runs, frames)
    copy = copy_pass_ms(gl, pipe.size)
    a, b = statistics.median(ms["A"]), statistics.median(ms["B"])
    return {"pipeline": pipeline, "scene": pipe.scene_spec, "frames": frames, "renderer": gl.renderer,
            "copy_pass_ms": copy, "draws": draws, "A_ms": a, "B_ms": b, "B_over_A": b / a, "A_fps": 1000 / a,
            "B_fps": 1000 / b, "A_floor_ratio": a / (draws * copy), "B_floor_ratio": b / (draws * copy),
            "output_footprint_share": statistics.fmean(shares) if shares else 1.0}


command = _ab_command(run, "Whole frames with the sketch pass reading the depth map against without it, "
                              "alternating in one process (ms a frame, ratio).")
footprint_command = _ab_command(run_footprint, "Whole frames with footprints on against off (passes drawn only near "
                                               "the objects), alternating in one process (ms a frame, ratio).")
