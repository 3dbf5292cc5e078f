"""Interleaved A/B of whole frames of a pipeline with a sketch, in one process, printing JSON (a benchmark,
not a test): A = the plan with the sketch's depth read (as before `Sketch.unread_inputs`: the sketch reads the
depth map, the G-buffer writes it), B = the plan as shipped (where the shade's alpha stands in, the depth is
neither read nor made). Frames alternate A/B (order swapped every frame) along the scene's orbit, no readback.

    python -m nodegraph_nodes.sketch.ab_bench --scene ../shared/meshes/ogre.obj [--frames 60] [PIPELINE]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time


def main(argv: list[str] | None = None) -> dict:
    from nodegraph import gl as glmod
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor
    from nodegraph.tools.bench import copy_pass_ms

    from . import Sketch

    ap = argparse.ArgumentParser()
    ap.add_argument("pipeline", nargs="?", default="nienhaus_sketchy")
    ap.add_argument("--scene")
    ap.add_argument("--frames", type=int, default=60)
    args = ap.parse_args(argv)
    pipe = pl.load(args.pipeline, scene=args.scene)
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
    for f in range(args.frames):
        for v in ("AB" if f % 2 else "BA"):
            t0 = time.perf_counter()
            exs[v].run(f)
            gl.finish()
            ms[v].append((time.perf_counter() - t0) * 1000)
    draws = (gl.draws.total - d0) / (2 * args.frames)
    copy = copy_pass_ms(gl, pipe.size)
    a, b = statistics.median(ms["A"]), statistics.median(ms["B"])
    out = {"pipeline": args.pipeline, "scene": pipe.scene_spec, "frames": args.frames, "copy_pass_ms": copy,
           "draws": draws, "A_ms": a, "B_ms": b, "B_over_A": b / a, "A_fps": 1000 / a, "B_fps": 1000 / b,
           "A_floor_ratio": a / (draws * copy), "B_floor_ratio": b / (draws * copy),
           "A_unread": {k: sorted(v) for k, v in ex_a.plan.unread.items()},
           "B_unread": {k: sorted(v) for k, v in ex_b.plan.unread.items()}}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
