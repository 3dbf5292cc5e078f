"""`sketchgraph bench targets`: the targets of "Speed where users wait" (frame output, pencil, rebuilds, big
renders, start-up, the default pipeline's floor and fps), all measured in one run.

Every benchmark a target names is run as a user runs it, in a new process, one after the other: `bench film`
on spot (the PNG sequence against frames only, `--repeat 5`), `bench pencil` and `bench pencil-shade` on ogre,
`gallery build --cold` then `--force` on a copy of the gallery, `bench cold-cache` at 3840x2160, `bench
startup` with the environment's bytecode as it is and with bytecode written, and `bench nienhaus_sketchy` on
spot and on ogre. `--runs` sets how many times each runs (film and the default pipeline: `--runs`; the others
`(--runs + 1) // 2`; startup once each way, five processes each). 4.5 to 6 minutes at the defaults on the
project's 2-core VM.

Each target is met by a run when that run's figure is within the limit (`met_runs` of `runs`); the sitting
meets it when every run does. The figures of one run belong together: on a shared VM whose speed drifts
over the day, the targets move in opposite directions (docs/performance.md, "Where the targets stand"), so
compare sittings, not single figures. Meshes come from `--meshes` (`../shared/meshes` by default; the
benchmarks that need spot or ogre say so and stop where they are missing).
"""

from __future__ import annotations

import json
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click

from ...errors import SketchgraphError
from ...fsio import atomic_write_text
from .film import DEFAULT_PIPELINE
from .film import TARGETS as FILM_TARGETS
from .runs import COLD_TARGET, STARTUP_TARGETS, timed


@dataclass(frozen=True)
class Target:
    key: str
    label: str
    limit: float
    at_least: bool  # the figure must be >= limit (else <= limit)

    def met(self, value: float) -> bool:
        return value >= self.limit if self.at_least else value <= self.limit


TARGETS: tuple[Target, ...] = (
    Target("png_sequence", "PNG sequence rate / frames only (spot, `bench film` paired median)", FILM_TARGETS["png"],
           True),
    Target("pencil_floor_ogre", "pencil on ogre: ms a frame / (draws x copy pass)", 5.0, False),
    Target("pencil_shade_speedup", "pencil_shade against its geometry-shader version (ogre)", 2.0, True),
    Target("gallery_force", "gallery build: --cold wall / --force wall, every node cached", 5.0, True),
    Target("cold_cache_4k", "3840x2160 with an empty cache / --no-cache (median of pairs)", COLD_TARGET, False),
    Target("help_cpu_s", "sketchgraph --help, CPU seconds (each process)", STARTUP_TARGETS["help_cpu_s"], False),
    Target("first_image_cpu_s", "first image of the default pipeline, warm cache, CPU seconds",
           STARTUP_TARGETS["first_image_cpu_s"], False),
    Target("default_floor_spot", "default pipeline on spot: ms a frame / (draws x copy pass)", 3.5, False),
    Target("default_floor_ogre", "default pipeline on ogre: ms a frame / (draws x copy pass)", 3.5, False),
    Target("ogre_fps", "default pipeline on ogre, fps", 30.0, True),
)
BY_KEY = {t.key: t for t in TARGETS}


@dataclass(frozen=True)
class Job:
    """One benchmark process: `args` after `sketchgraph`, with `--json FILE` added; `read` turns its JSON into
    {target key: [figures]}."""

    title: str
    args: tuple[str, ...]
    read: Callable[[dict[str, Any]], dict[str, list[float]]]


def _film(r: dict[str, Any]) -> dict[str, list[float]]:
    return {"png_sequence": [r["ratio_paired_median"]["png"]]}


def _pencil(r: dict[str, Any]) -> dict[str, list[float]]:
    return {"pencil_floor_ogre": [r["floor_ratio"]]}


def _shade(r: dict[str, Any]) -> dict[str, list[float]]:
    return {"pencil_shade_speedup": [r["speedup"]]}


def _cold(r: dict[str, Any]) -> dict[str, list[float]]:
    return {"cold_cache_4k": [r["ratio_paired_median"]]}


def _startup(r: dict[str, Any]) -> dict[str, list[float]]:
    return {"help_cpu_s": list(r["seconds"]["help_cpu"]), "first_image_cpu_s": list(r["seconds"]["first_image_cpu"])}


def _default(scene: str) -> Callable[[dict[str, Any]], dict[str, list[float]]]:
    def read(r: dict[str, Any]) -> dict[str, list[float]]:
        out = {f"default_floor_{scene}": [r["floor_ratio"]]}
        if scene == "ogre":
            out["ogre_fps"] = [r["fps"]]
        return out
    return read


def _half(runs: int) -> int:
    """How often the benchmarks other than film and the default pipeline run: half of `--runs`, rounded up."""
    return max(1, (runs + 1) // 2)


def jobs(meshes: Path, runs: int = 5, quick: bool = False) -> list[Job]:
    """The sitting's benchmark processes, in order (the gallery's pairs are run apart: `gallery_pairs`).
    `quick`: a few frames and small sizes, to see that everything runs (the figures mean little)."""
    spot, ogre = str(meshes / "spot.obj"), str(meshes / "ogre.obj")
    few = _half(runs)
    frames = ("--frames", "6") if quick else ()
    film = ("--frames", "6", "--repeat", "1") if quick else ("--frames", "60", "--repeat", "5")
    out = [Job(f"bench film, spot ({i + 1}/{runs})", ("bench", "film", "--scene", spot, *film), _film)
           for i in range(runs)]
    out += [Job(f"bench pencil, ogre ({i + 1}/{few})", ("bench", "pencil", "--scene", ogre, *frames), _pencil)
            for i in range(few)]
    shade_frames = ("--frames", "2") if quick else ()
    out += [Job(f"bench pencil-shade, ogre ({i + 1}/{few})", ("bench", "pencil-shade", "--scene", ogre, *shade_frames),
                _shade) for i in range(few)]
    cold = ("--pairs", "1", "--size", "640x360") if quick else ("--pairs", "5")
    out += [Job(f"bench cold-cache ({i + 1}/{few})", ("bench", "cold-cache", *cold), _cold) for i in range(few)]
    startup_runs = ("--runs", "1") if quick else ("--runs", "5")
    out += [Job(f"bench startup, bytecode {b}", ("bench", "startup", *startup_runs, "--bytecode", b), _startup)
            for b in ("as-is", "written")]
    for scene, mesh in (("spot", spot), ("ogre", ogre)):
        out += [Job(f"bench nienhaus_sketchy, {scene} ({i + 1}/{runs})",
                    ("bench", "nienhaus_sketchy", "--scene", mesh, *frames), _default(scene)) for i in range(runs)]
    return out


def evaluate(figures: dict[str, list[float]]) -> dict[str, dict[str, Any]]:
    """Per target: its figures, the limit, how many runs met it and whether all did (targets without figures
    are left out)."""
    out = {}
    for t in TARGETS:
        values = figures.get(t.key) or []
        if not values:
            continue
        met = sum(t.met(v) for v in values)
        out[t.key] = {"label": t.label, "limit": t.limit, "at_least": t.at_least, "values": values,
                      "runs": len(values), "met_runs": met, "met": met == len(values)}
    return out


def _copy_gallery(gallery: Path, into: Path) -> Path:
    """A copy of the gallery file beside a copy of the pipelines it names (as the repository lays them out:
    gallery/ and pipelines/ side by side), with `shared` linked beside them where it is beside the original,
    so the copy's builds write nothing into the repository. Returns the copy's gallery file."""
    src_root = gallery.resolve().parent.parent
    root = into / "gallery-copy"
    (root / "gallery").mkdir(parents=True)
    shutil.copy2(gallery, root / "gallery" / gallery.name)
    if (src_root / "pipelines").is_dir():
        shutil.copytree(src_root / "pipelines", root / "pipelines")
    shared = src_root.parent / "shared"
    if shared.is_dir():
        (into / "shared").symlink_to(shared.resolve(), target_is_directory=True)
    return root / "gallery" / gallery.name


def gallery_pairs(gallery: Path, work: Path, pairs: int, only: str | None = None,
                  progress: Callable[[str], None] = lambda s: None) -> list[float]:
    """`pairs` times: `gallery build --cold` then `--force` of a copy of `gallery`, each process timed (wall);
    returns each pair's ratio cold / force."""
    copy = _copy_gallery(gallery, work)
    pick = ("--only", only) if only else ()
    ratios = []
    for i in range(pairs):
        progress(f"gallery build --cold, then --force ({i + 1}/{pairs})")
        cold, _ = timed(["gallery", "build", "--cold", "-q", "--gallery", str(copy), *pick])
        force, _ = timed(["gallery", "build", "--force", "-q", "--gallery", str(copy), *pick])
        ratios.append(cold / force)
    return ratios


def sitting(meshes: Path, gallery: Path, runs: int = 5, quick: bool = False,
            progress: Callable[[str], None] = lambda s: None) -> dict[str, Any]:
    """Run the sitting: every job, then the gallery's pairs. Returns the figures, the evaluation, the renderer
    and the copy pass of each pipeline benchmark (the VM's speed at the time)."""
    missing = [m for m in ("spot.obj", "ogre.obj") if not (meshes / m).is_file()]
    if missing:
        raise SketchgraphError(f"bench targets: {', '.join(missing)} not found in {meshes} (--meshes DIR: the "
                               "folder of the project's test meshes, ../shared/meshes)")
    if not gallery.is_file():
        raise SketchgraphError(f"bench targets: no gallery file at {gallery} (--gallery PATH)")
    figures: dict[str, list[float]] = {}
    copy_pass: list[float] = []
    renderer = None
    started = time.strftime("%Y-%m-%d %H:%M:%S %Z")
    todo = jobs(meshes, runs, quick)
    with tempfile.TemporaryDirectory(prefix="sketchgraph-bench-targets-") as tmp:
        work = Path(tmp)
        for n, job in enumerate(todo):
            progress(f"[{n + 1}/{len(todo) + 1}] {job.title}")
            out = work / f"job{n}.json"
            timed([*job.args, "--json", str(out)])
            result = json.loads(out.read_text())
            for key, values in job.read(result).items():
                figures.setdefault(key, []).extend(float(v) for v in values)
            if "copy_pass_ms" in result:
                copy_pass.append(float(result["copy_pass_ms"]))
            renderer = renderer or result.get("renderer")
        pairs = 1 if quick else _half(runs)
        only = Path(DEFAULT_PIPELINE).stem if quick else None
        figures["gallery_force"] = gallery_pairs(
            gallery, work, pairs, only, lambda s: progress(f"[{len(todo) + 1}/{len(todo) + 1}] {s}"))
    return {"benchmark": "targets", "started": started, "finished": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
            "runs": runs, "quick": quick, "renderer": renderer,
            "copy_pass_ms": {"min": min(copy_pass), "max": max(copy_pass)} if copy_pass else None,
            "targets": (done := evaluate(figures)), "met": bool(done) and all(t["met"] for t in done.values())}


def table(result: dict[str, Any]) -> list[str]:
    """The sitting as lines of text: one per target."""
    lines = [f"renderer: {result.get('renderer')}", f"copy pass: {_span(result.get('copy_pass_ms'))} ms"]
    for key, t in result["targets"].items():
        sign = ">=" if t["at_least"] else "<="
        values = ", ".join(f"{v:.3g}" for v in t["values"])
        verdict = "met" if t["met"] else "NOT met"
        lines.append(f"{key}: {verdict} ({t['met_runs']} of {t['runs']} runs {sign} {t['limit']:g}): {values}")
    lines.append(f"all targets met: {'yes' if result['met'] else 'no'}")
    return lines


def _span(s: dict[str, float] | None) -> str:
    return "-" if not s else f"{s['min']:.2f}-{s['max']:.2f}"


@click.command()
@click.option("--meshes", type=click.Path(path_type=Path), default=Path("../shared/meshes"), show_default=True,
              help="Folder holding spot.obj and ogre.obj.")
@click.option("--gallery", type=click.Path(path_type=Path), default=Path("gallery/gallery.yaml"), show_default=True,
              help="The gallery file (built from a copy; nothing is written beside it).")
@click.option("--runs", default=5, show_default=True, type=click.IntRange(1, 50),
              help="Runs of `bench film` and of the default pipeline on each mesh; the other benchmarks run "
                   "half as often (rounded up).")
@click.option("--quick", is_flag=True, help="A few frames and small sizes: checks that everything runs; the "
                                            "figures mean little.")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def command(meshes: Path, gallery: Path, runs: int, quick: bool, json_path: Path | None) -> None:
    """Every target of "Speed where users wait" in one run (4.5 to 6 minutes at the defaults)."""
    result = sitting(meshes, gallery, runs, quick, progress=lambda s: click.echo(s, err=True))
    for line in table(result):
        click.echo(line)
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json_path, json.dumps(result, indent=2) + "\n")
        click.echo(f"wrote {json_path}")
