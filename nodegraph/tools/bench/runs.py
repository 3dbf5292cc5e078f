"""Benchmarks of whole commands, each run in a new process as a user runs it: `sketchgraph bench startup`
(`--help` and the first image from a warm cache, in CPU seconds) and `sketchgraph bench cold-cache` (one
big render with an empty cache against `--no-cache`, in wall seconds).

Both run `sketchgraph` (the console script beside this Python; `python -c` where there is none) with the
environment as it is, and take each child's CPU from `getrusage(RUSAGE_CHILDREN)` (the process and all its
threads: llvmpipe's, the cache writers'). One run of each kind comes first and is not counted (the file
system's and Mesa's shader caches warm up). On a shared machine single runs move by a fifth or more, so
`cold-cache` alternates its two commands pair by pair and reports the median of the pairs' own ratios: drift
in the machine's speed moves both runs of a pair alike.
"""

from __future__ import annotations

import importlib.util
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import click

from ...errors import SketchgraphError
from .film import DEFAULT_PIPELINE
from .pipeline import emit

STARTUP_TARGETS = {"help_cpu_s": 0.3, "first_image_cpu_s": 1.0}
COLD_TARGET = 1.25


def _command() -> list[str]:
    script = Path(sys.executable).with_name("sketchgraph")
    if script.is_file() and os.access(script, os.X_OK):
        return [str(script)]
    return [sys.executable, "-c", "import sys; from nodegraph.cli import main; sys.argv[0] = 'sketchgraph'; main()"]


def timed(args: list[str], env: dict[str, str] | None = None) -> tuple[float, float]:
    """Run `sketchgraph ARGS` in a new process: (wall seconds, CPU seconds of the child, user + system). A
    failing run raises with the last line it printed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(_command() + args, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        last = (done.stderr.strip() or done.stdout.strip() or f"exit status {done.returncode}").splitlines()[-1]
        raise SketchgraphError(f"`sketchgraph {' '.join(args)}` failed: {last.removeprefix('error: ')}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def _summary(values: list[float]) -> dict[str, float]:
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def _render_args(pipeline: str, scene: str | None, size: str | None) -> list[str]:
    return ["run", pipeline, *(["--scene", scene] if scene else []), *(["--size", size] if size else []), "--quiet"]


def _project_bytecode(env: dict[str, str]) -> bool:
    """Whether the child finds the project's own modules compiled (a `.pyc` of `nodegraph/__init__.py` where it
    looks): without one, every start compiles them (an editable install under PYTHONDONTWRITEBYTECODE)."""
    import nodegraph

    prefix = env.get("PYTHONPYCACHEPREFIX")
    saved = sys.pycache_prefix
    sys.pycache_prefix = prefix or None
    try:
        return Path(importlib.util.cache_from_source(nodegraph.__file__)).is_file()
    finally:
        sys.pycache_prefix = saved


def bench_startup(pipeline: str = DEFAULT_PIPELINE, *, scene: str | None = None, size: str | None = None,
                  runs: int = 5, bytecode: str = "as-is") -> dict[str, Any]:
    """`sketchgraph --help` and `sketchgraph run PIPELINE -o out.png` with a warm cache, `runs` times each.
    `bytecode`: "as-is" (the environment as it is), "written" (compiled modules written on the first run and
    read by the rest, as after a pip install, in a cache of their own under PYTHONPYCACHEPREFIX)."""
    if runs < 1:
        raise SketchgraphError("--runs must be at least 1")
    with tempfile.TemporaryDirectory(prefix="sketchgraph-bench-startup-") as tmp:
        env = dict(os.environ)
        if bytecode == "written":
            env.pop("PYTHONDONTWRITEBYTECODE", None)
            env["PYTHONPYCACHEPREFIX"] = str(Path(tmp) / "pyc")
        render = [*_render_args(pipeline, scene, size), "-o", str(Path(tmp) / "out.png"),
                  "--cache-dir", str(Path(tmp) / "cache")]
        timed(render, env)  # fills the cache (and writes the bytecode, where asked); not counted
        timed(["--help"], env)
        help_cpu, first_cpu, first_wall = [], [], []
        for _ in range(runs):
            help_cpu.append(timed(["--help"], env)[1])
            wall, cpu = timed(render, env)
            first_cpu.append(cpu)
            first_wall.append(wall)
        project_pyc = _project_bytecode(env)
    out: dict[str, Any] = {
        "pipeline": pipeline, "scene": scene, "size": size, "runs": runs, "bytecode": bytecode,
        "project_bytecode": project_pyc,
        "help_cpu_s": _summary(help_cpu), "first_image_cpu_s": _summary(first_cpu),
        "first_image_wall_s": _summary(first_wall),
        "seconds": {"help_cpu": help_cpu, "first_image_cpu": first_cpu, "first_image_wall": first_wall},
        "targets": STARTUP_TARGETS,
    }
    # met in every run, not in the median: a start-up is one run
    out["met"] = {k: out[k]["max"] <= t for k, t in STARTUP_TARGETS.items()}
    return out


def bench_cold_cache(pipeline: str = DEFAULT_PIPELINE, *, scene: str | None = None, size: str = "3840x2160",
                     pairs: int = 5) -> dict[str, Any]:
    """`run PIPELINE --size SIZE` with an empty cache folder (computed, then the entries the cache chooses
    written) against the same with `--no-cache`, `pairs` times, the two taking turns going first."""
    if pairs < 1:
        raise SketchgraphError("--pairs must be at least 1")
    with tempfile.TemporaryDirectory(prefix="sketchgraph-bench-cold-") as tmp:
        base = [*_render_args(pipeline, scene, size), "-o", str(Path(tmp) / "out.png")]
        cold_dir = Path(tmp) / "cold"

        def no_cache() -> tuple[float, float]:
            return timed([*base, "--no-cache"])

        def cold() -> tuple[float, float]:
            shutil.rmtree(cold_dir, ignore_errors=True)
            return timed([*base, "--cache-dir", str(cold_dir)])

        no_cache()  # not counted: warms the file system's and the shader caches
        cold()
        entries = sorted(cold_dir.rglob("*.exr"))
        written = {"entries": len(entries), "bytes": sum(p.stat().st_size for p in entries)}
        walls: dict[str, list[float]] = {"no_cache": [], "cold": []}
        cpus: dict[str, list[float]] = {"no_cache": [], "cold": []}
        for i in range(pairs):
            order = (("no_cache", no_cache), ("cold", cold))
            for name, fn in order if i % 2 == 0 else order[::-1]:
                wall, cpu = fn()
                walls[name].append(wall)
                cpus[name].append(cpu)
    ratios = [c / n for c, n in zip(walls["cold"], walls["no_cache"], strict=True)]
    cpu_ratios = [c / n for c, n in zip(cpus["cold"], cpus["no_cache"], strict=True)]
    out: dict[str, Any] = {
        "pipeline": pipeline, "scene": scene, "size": size, "pairs": pairs,
        "seconds": walls, "cpu_seconds": cpus, "cache_written": written,
        "ratio_per_pair": ratios, "ratio_paired_median": statistics.median(ratios),
        "ratio_of_medians": statistics.median(walls["cold"]) / statistics.median(walls["no_cache"]),
        "cpu_ratio_paired_median": statistics.median(cpu_ratios),
        "target": COLD_TARGET,
    }
    out["met"] = out["ratio_paired_median"] <= COLD_TARGET
    return out


_pipeline = click.option("--pipeline", default=DEFAULT_PIPELINE, show_default="pipelines/nienhaus_sketchy.yaml")
_scene = click.option("--scene", help="builtin:NAME, a scene YAML or a mesh file (default: the pipeline's).")
_json = click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")


@click.command()
@_pipeline
@_scene
@click.option("--size", default=None, help="WxH (default: the pipeline's).")
@click.option("--runs", default=5, show_default=True, help="Runs of each command (after one not counted).")
@click.option("--bytecode", type=click.Choice(["as-is", "written"]), default="as-is", show_default=True,
              help="as-is: the environment as it is; written: compiled modules written by the first run and read "
                   "by the rest (as after a pip install).")
@_json
def startup_command(pipeline: str, scene: str | None, size: str | None, runs: int, bytecode: str,
                    json_path: Path | None) -> None:
    """CPU seconds of `sketchgraph --help` and of the first image from a warm cache, each in a new process."""
    emit(bench_startup(pipeline, scene=scene, size=size, runs=runs, bytecode=bytecode), json_path)


@click.command()
@_pipeline
@_scene
@click.option("--size", default="3840x2160", show_default=True, help="WxH.")
@click.option("--pairs", default=5, show_default=True, help="Pairs of runs (after one pair not counted).")
@_json
def cold_cache_command(pipeline: str, scene: str | None, size: str, pairs: int, json_path: Path | None) -> None:
    """Wall seconds of a render with an empty cache against `--no-cache`, each in a new process."""
    emit(bench_cold_cache(pipeline, scene=scene, size=size, pairs=pairs), json_path)
