"""`sketchgraph bench distributed`: serial frames/s against `local:1` and `local:2` in one run, the per-task
overhead (scheduling and transfer of a no-op task, and what a worker's kept GL context saves), chunk size
against throughput, and the shared-cache traffic per frame. Every run starts from an empty cache, so the
frame-independent nodes are computed once in each (serially on frame 0; on a cluster in one task first).
"""

from __future__ import annotations

import json
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import click

from ...fsio import atomic_write_text

WARMUP_SIZE = "24x24"
"""Every process renders one frame at this size before the clock starts (imports, numba JIT, shader compiles),
so serial and cluster runs are compared in the same state; no node key is shared with the measured size."""


def _serial(spec: Any, frames: list[int], out: Path, cache_root: Path) -> float:
    from ...cache import Cache
    from ...executor import Executor
    from ...gpu import gl as glmod
    from ...output import write

    glmod.get()  # the context exists before the clock starts, as on a warmed worker
    warm = type(spec)(spec.source, spec.overrides, WARMUP_SIZE, spec.scene, spec.output).open()
    wref = next(iter(warm.outputs.values())) if spec.output is None else warm.outputs[spec.output]
    wex = Executor(warm, None, mode="loop", requested=[wref])
    wex.run(0)  # imports, JIT and shader compiles happen here, at another size (no key in common)
    wex.clear_memory()
    t0 = time.perf_counter()  # opening the pipeline counts, as it does in a cluster run (client and workers)
    pipe = spec.open()
    ref = next(iter(pipe.outputs.values())) if spec.output is None else pipe.outputs[spec.output]
    ex = Executor(pipe, Cache(cache_root), mode="loop", requested=[ref])
    try:
        for f in frames:
            write.write_value(ex.run(f).values[ref], write.frame_path(str(out / "f_####.png"), f, True))
    finally:
        ex.close()
        ex.clear_memory()
    return time.perf_counter() - t0


def _overhead(client: Any, n: int = 200) -> dict[str, float]:
    from ... import distributed as dist

    client.submit(dist.noop_task, 0, pure=False).result()
    lat = []
    for i in range(20):
        t0 = time.perf_counter()
        client.submit(dist.noop_task, i, pure=False).result()
        lat.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    futs = [client.submit(dist.noop_task, i, pure=False) for i in range(n)]
    client.gather(futs)
    return {"round_trip_ms": statistics.median(lat) * 1000, "pipelined_ms": (time.perf_counter() - t0) / n * 1000}


def _cluster_runs(scheduler: str, spec: Any, frames: list[int], tmp: Path, chunks: list[int | None],
                  echo: Any) -> dict[str, Any]:
    from ... import distributed as dist

    t0 = time.perf_counter()
    out: dict[str, Any] = {}
    with dist.connect(scheduler) as client:
        client.wait_for_workers(int(scheduler.split(":")[1]), timeout=120)
        out["start_s"] = time.perf_counter() - t0
        t1 = time.perf_counter()
        renderers = dist.worker_renderers(client)  # creates each worker's GL context in its task thread
        out["gl_context_s"] = time.perf_counter() - t1
        t1 = time.perf_counter()
        warm = dist.PipeSpec(spec.source, spec.overrides, WARMUP_SIZE, spec.scene, spec.output)
        client.gather([client.submit(dist.render_frames_task, warm, [0], str(tmp / "warm" / "f_####.png"), True,
                                     False, workers=[a], pure=False) for a in renderers])
        out["warmup_s"] = time.perf_counter() - t1  # imports, JIT, shader compiles, at another size
        out["overhead"] = _overhead(client)
        runs = []
        for i, chunk in enumerate(chunks):
            root = tmp / f"cache-{scheduler.replace(':', '')}-{i}"
            dest = tmp / f"out-{scheduler.replace(':', '')}-{i}"
            rep = dist.render_frames(client, spec, frames, dest / "f_####.png", chunk=chunk, cache_root=root)
            traffic = sum(p.stat().st_size for p in root.rglob("*") if p.is_file())
            frame_bytes = sum(p.stat().st_size for p in dest.glob("f_*.png")) / max(1, len(frames))
            runs.append({"chunk": rep.chunk, "default": chunk is None, "fps": rep.fps(), "wall_s": rep.wall_s,
                         "tasks": rep.tasks, "prepare_s": rep.prepare_s, "prepared": rep.prepared,
                         "cache_bytes_written": traffic, "output_bytes_per_frame": frame_bytes,
                         "median_task_ms": statistics.median(rep.task_ms) if rep.task_ms else 0.0,
                         "median_frame_ms": statistics.median(rep.frame_ms) if rep.frame_ms else 0.0})
            echo(f"  {scheduler} chunk {rep.chunk:>3}{' (default)' if chunk is None else '':<10} "
                 f"{rep.fps():6.1f} frames/s  ({rep.tasks} tasks, {rep.wall_s:.2f} s)")
        out["runs"] = runs
        out["renderers"] = sorted(set(renderers.values()))
        # context reuse: a one-frame task on a worker whose GL context, programs and pool already exist,
        # against the same on a fresh worker process (restart), both measured inside the task
        rep = [dist.render_frames(client, spec, frames[:1], tmp / f"reuse-{i}" / "f_####.png", chunk=1,
                                  cache_root=tmp / "cache-reuse") for i in range(2)]
        client.restart()
        client.wait_for_workers(int(scheduler.split(":")[1]), timeout=120)
        fresh = dist.render_frames(client, spec, frames[:1], tmp / "reuse-fresh" / "f_####.png", chunk=1,
                                   cache_root=tmp / "cache-reuse")
        out["one_frame_task_ms"] = {"kept_context": rep[1].task_ms[0], "fresh_process": fresh.task_ms[0]}
    return out


@click.command()
@click.option("--pipeline", "pipeline", default="pencil", show_default=True, help="A pipeline path or shipped name.")
@click.option("--size", default="160x160", show_default=True, help="WxH.")
@click.option("--frames", "n_frames", default=48, show_default=True, help="Frames per run.")
@click.option("--chunks", default="1,2,4,8,16", show_default=True, help="Chunk sizes to sweep on local:2.")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def command(pipeline: str, size: str, n_frames: int, chunks: str, json_path: Path | None) -> None:
    """Serial vs local:1 vs local:2 frames/s, per-task overhead, chunk size against throughput."""
    from ... import distributed as dist

    spec = dist.PipeSpec.make(pipeline, size=size)
    frames = list(range(n_frames))
    sweep = [int(c) for c in chunks.split(",") if c.strip()]
    with tempfile.TemporaryDirectory(prefix="sketchgraph-bench-dist-") as tmpdir:
        tmp = Path(tmpdir)
        serial_s = _serial(spec, frames, tmp / "serial", tmp / "cache-serial")
        serial_fps = n_frames / serial_s
        click.echo(f"  serial {serial_fps:6.1f} frames/s  ({serial_s:.2f} s)")
        one = _cluster_runs("local:1", spec, frames, tmp, [None], click.echo)
        two = _cluster_runs("local:2", spec, frames, tmp, [None, *sweep], click.echo)
    t_frame = serial_s / n_frames
    t_task = two["overhead"]["pipelined_ms"] / 1000
    for r in two["runs"]:
        c = r["chunk"]
        r["model_fps"] = 2 * c / (c * t_frame + t_task)
    result = {
        "pipeline": pipeline, "size": size, "frames": n_frames, "cores": dist.os.cpu_count(),
        "serial_fps": serial_fps, "t_frame_ms": t_frame * 1000,
        "local1": one, "local2": two,
        "local1_fps": one["runs"][0]["fps"], "local2_fps": two["runs"][0]["fps"],
        "local1_vs_serial": one["runs"][0]["fps"] / serial_fps,
        "local2_vs_serial": two["runs"][0]["fps"] / serial_fps,
        "t_task_ms": t_task * 1000,
        "model": "frames/s = N*c / (c*t_frame + t_task)",
    }
    click.echo(f"serial {serial_fps:.1f} frames/s; local:1 {result['local1_fps']:.1f} "
               f"({result['local1_vs_serial']:.2f}x); local:2 {result['local2_fps']:.1f} "
               f"({result['local2_vs_serial']:.2f}x); per-task overhead {t_task * 1000:.1f} ms pipelined, "
               f"{two['overhead']['round_trip_ms']:.1f} ms round trip; one-frame task "
               f"{two['one_frame_task_ms']['kept_context']:.0f} ms with a kept context, "
               f"{two['one_frame_task_ms']['fresh_process']:.0f} ms on a fresh worker")
    if json_path:
        atomic_write_text(json_path, json.dumps(result, indent=2) + "\n")
        click.echo(f"wrote {json_path}")
