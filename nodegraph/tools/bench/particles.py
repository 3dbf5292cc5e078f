"""`sketchgraph bench particles --scene MESH --strokes N --json FILE`: Curtis' loose and sketchy strokes
(Curtis, "Loose and Sketchy Animation", 1998) on a real depth buffer, against the pure-Python
reference, side by side in one run.

The chain rasterize -> depth_edges -> force_field -> particle_sketch runs through the executor as a
pipeline does. Reported (times are the best of `--repeat` unless said otherwise, seconds):
- `seconds`: the particle_sketch node's compute: readback of the edge map and the field, the NumPy
  lock-step sketcher, the upload of the ink and the image pass; `simulate_seconds`: the sketcher alone;
  `gpu_seconds`: depth_edges + force_field (waited for);
- `python_reference_seconds`: `core.simulate_python`, the straightforward per-particle pure-Python
  implementation of the pseudocode, same inputs, seed and params (best of `--python-repeat`, interleaved
  with the timed node runs so both see the same machine load);
  `speedup_vs_python` = python_reference_seconds / seconds (the whole node against the bare reference);
  `speedup_simulate_vs_python(_cpu)`: the bare sketcher against it, in wall-clock (and in process CPU
  time, which other processes on a shared machine disturb less);
- `equals_python`: with batch=1 (the default) the node's sketcher is strictly sequential and must draw
  exactly what the Python reference draws (checked, strokes and ink bit for bit), so the speedup is at
  equal output;
- `lockstep_*` (`--lockstep B`, default 256, 0 = skip): the NumPy lock-step sketcher with B lanes on the
  same inputs, for comparison: its time, strokes, coverage and precision (batching adds parallel
  strokes, so it draws more);
- `coverage` / `precision`: edge pixels within 2 px of ink, ink within 2 px of an edge pixel (the edge
  map before erasing); the same for the Python reference;
- `strokes` drawn of `requested_strokes`; `exhausted`: the run ended because no valid start was left
  (the drawing is complete: every remaining edge pixel is within m px of a line).
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import click
import numpy as np

from ...fsio import atomic_write_text

CHAIN = """\
pipeline: bench-particles
size: [{w}, {h}]
scene: builtin:cloister
seed: {seed}
nodes:
  gbuf: {{type: rasterize}}
  edges: {{type: depth_edges, in: {{depth: gbuf.linear_depth}}}}
  field: {{type: force_field, in: {{gradient: edges.gradient}}}}
  particles: {{type: particle_sketch, in: {{edges: edges.edges, force: field.out}}, params: {{strokes: {strokes}}}}}
outputs:
  image: particles.image
  strokes: particles.strokes
"""


def _qualified(override: str) -> str:
    """PARAM=VALUE is a particle_sketch param; NODE.PARAM=VALUE names the node (gbuf, edges, field, particles)."""
    return override if "." in override.partition("=")[0] else f"particles.{override}"


def _stroke_lengths(strokes: list[np.ndarray]) -> np.ndarray:
    return np.array([float(np.hypot(*np.diff(s.astype(np.float64), axis=0).T).sum()) for s in strokes])


def _same(a: Any, b: Any) -> bool:
    return (len(a.strokes) == len(b.strokes) and all(map(np.array_equal, a.strokes, b.strokes))
            and np.array_equal(a.sketch, b.sketch))


def run(scene: str, strokes: int, size: tuple[int, int] = (800, 800), seed: int = 5, repeat: int = 3,
        overrides: tuple[str, ...] = (), python: bool = True, lockstep: int = 256,
        out: Path | None = None, python_repeat: int = 2) -> dict[str, Any]:
    from ... import pipeline as pl
    from ...executor import Executor
    from ...gpu import gl as glmod
    from ...node import RunContext
    from .measure import node_module

    core = node_module("particle_sketch", "core")

    gl = glmod.get()
    text = CHAIN.format(w=size[0], h=size[1], seed=seed, strokes=strokes)
    pipe = pl.loads(text, "<bench particles>", scene=scene, overrides=[_qualified(o) for o in overrides])
    requested = [("particles", "image"), ("particles", "strokes"), ("edges", "edges"), ("field", "out")]
    node = pipe.nodes["particles"]
    params = node.core_params()

    def node_run() -> tuple[Any, Any]:  # a fresh executor: nothing comes from memory
        ex = Executor(pipe, None, mode="loop", requested=requested, gl=gl, timing=True)
        return ex, ex.run(0)

    ex, res = node_run()  # compiles the shaders and uploads the mesh: not counted
    ctx = RunContext(node, gl=gl, size=pipe.size, pipeline_seed=pipe.seed, scene=pipe.scene,
                     reference_size=pipe.reference_size)
    edges = res.values[("edges", "edges")].read()[..., 0] >= 0.5
    ff = res.values[("field", "out")].read()[..., :2].astype(np.float64)

    def simulate(p: Any = params) -> Any:
        return core.simulate(edges, ff, p, node.rng(ctx))

    # interleaved, so that the node, the bare sketcher and the Python reference see the same machine load
    gpu_s = node_s = sim_s = py_s = sim_cpu = py_cpu = float("inf")
    ref = None
    for i in range(repeat):
        other, r = node_run()
        gpu_s = min(gpu_s, (r.stats["edges"].ms + r.stats["field"].ms) / 1000.0)
        node_s = min(node_s, r.stats["particles"].ms / 1000.0)
        other.clear_memory()
        t0, c0 = time.perf_counter(), time.process_time()
        sim = simulate()
        sim_s, sim_cpu = min(sim_s, time.perf_counter() - t0), min(sim_cpu, time.process_time() - c0)
        if python and i < python_repeat:
            t0, c0 = time.perf_counter(), time.process_time()
            ref = core.simulate_python(edges, ff, params, node.rng(ctx))
            py_s, py_cpu = min(py_s, time.perf_counter() - t0), min(py_cpu, time.process_time() - c0)
    cov, prec = core.coverage_precision(sim.sketch, edges)
    lengths = _stroke_lengths(sim.strokes)
    result: dict[str, Any] = {
        "benchmark": "particles", "scene": pipe.scene_spec, "size": list(size), "seed": seed,
        "renderer": gl.renderer, "params": node.params.model_dump(mode="json"),
        "edge_pixels": int(edges.sum()),
        "requested_strokes": strokes, "strokes": len(sim.strokes), "launched": sim.launched,
        "exhausted": sim.exhausted, "segments": sim.steps,
        "mean_stroke_px": float(lengths.mean()) if lengths.size else 0.0, "ink_px": float(lengths.sum()),
        "seconds": node_s, "simulate_seconds": sim_s, "gpu_seconds": gpu_s,
        "coverage": cov, "precision": prec,
    }
    if lockstep > 1:
        lock_s, lock = float("inf"), None
        for _ in range(repeat):
            t0 = time.perf_counter()
            lock = simulate(replace(params, batch=lockstep))
            lock_s = min(lock_s, time.perf_counter() - t0)
        result["lockstep_batch"] = lockstep
        result["lockstep_seconds"] = lock_s
        result["lockstep_strokes"] = len(lock.strokes)
        result["lockstep_segments"] = lock.steps
        result["lockstep_coverage"], result["lockstep_precision"] = core.coverage_precision(lock.sketch, edges)
    if ref is not None:
        py_cov, py_prec = core.coverage_precision(ref.sketch, edges)
        result.update({
            "python_reference_seconds": py_s, "python_reference_strokes": len(ref.strokes),
            "python_reference_segments": ref.steps, "python_reference_coverage": py_cov,
            "python_reference_precision": py_prec,
            "speedup_vs_python": py_s / node_s,
            "speedup_simulate_vs_python": py_s / sim_s,
            "speedup_simulate_vs_python_cpu": py_cpu / sim_cpu,
            "speedup_per_segment_vs_python": (py_s / max(ref.steps, 1)) / (node_s / max(sim.steps, 1)),
        })
        if params.batch == 1:
            result["equals_python"] = _same(sim, ref)
        if lockstep > 1:
            result["speedup_lockstep_vs_python"] = py_s / result["lockstep_seconds"]
    result["targets"] = {
        "strokes_drawn_>=_requested": len(sim.strokes) >= strokes,
        "request_served_(all_drawn_or_no_valid_start_left)": len(sim.strokes) >= strokes or sim.exhausted,
        "seconds_<=_1": node_s <= 1.0,
        "coverage_>=_0.9": cov >= 0.9,
        "precision_>=_0.9": prec >= 0.9,
        **({"speedup_>=_20": result["speedup_vs_python"] >= 20} if ref is not None else {}),
    }
    if out is not None:
        from ...output.imageio import write
        from ...output.strokes import to_svg
        from ...values import Strokes

        out.mkdir(parents=True, exist_ok=True)
        write(out / "particles.png", res.values[("particles", "image")].read()[..., :3], None, half=False)
        s = Strokes(list(sim.strokes), size, params.line_width, node.params.color)
        atomic_write_text(out / "particles.svg", to_svg(s))
    return result


@click.command()
@click.option("--scene", default="builtin:cloister", show_default=True, help="builtin:NAME, a scene YAML or a mesh.")
@click.option("--strokes", default=2000, show_default=True, help="Strokes requested (particle_sketch.strokes).")
@click.option("--size", default="800x800", show_default=True, help="WxH.")
@click.option("--seed", default=5, show_default=True, help="Pipeline seed.")
@click.option("--repeat", default=5, show_default=True, help="Timed repetitions (the best is kept).")
@click.option("--set", "overrides", multiple=True, metavar="PARAM=VALUE",
              help="Override a param (YAML value; repeatable): PARAM=VALUE for particle_sketch, NODE.PARAM=VALUE "
              "for gbuf, edges (depth_edges), field (force_field), e.g. --set batch=64 --set field.restoring=gradient.")
@click.option("--python/--no-python", default=True, show_default=True, help="Time the pure-Python reference.")
@click.option("--python-repeat", default=2, show_default=True, help="Timed runs of the Python reference.")
@click.option("--lockstep", default=256, show_default=True,
              help="Also time the NumPy lock-step sketcher with this many lanes, for comparison (0: skip).")
@click.option("--out", "out_dir", type=click.Path(path_type=Path), help="Also write particles.png and .svg here.")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def command(scene: str, strokes: int, size: str, seed: int, repeat: int, overrides: tuple[str, ...], python: bool,
            python_repeat: int, lockstep: int, out_dir: Path | None, json_path: Path | None) -> None:
    """Curtis' particle strokes on a scene: time, strokes, coverage, precision, speedup over pure Python."""
    from ...pipeline import parse_size
    from .pipeline import emit

    result = run(scene, strokes, parse_size(size), seed, max(1, repeat), overrides, python, lockstep, out_dir,
                 max(1, python_repeat))
    emit(result, json_path)
