"""`sketchgraph run --watch`: re-render when the pipeline file, its scene file or the scene's meshes change.

Changes are found by polling modification times and sizes. After a change the pipeline is loaded
again and run by a new executor that adopts the previous executor's in-memory values (content
addressed, so a value is reused only where a node's key is unchanged): only nodes whose key changed
recompute. A file that fails to load is reported in one line and the watch goes on.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..errors import SketchgraphError
from ..executor import Executor
from ..pipeline import Pipeline


def adopt_memory(new: Executor, old: Executor | None, frame: int = 0) -> int:
    """`new` takes over `old`'s in-memory values (see Executor.adopt_memory)."""
    return new.adopt_memory(old, frame)


def scene_files(scene_spec: str, base: Path) -> list[Path]:
    """The files a scene comes from: a scene YAML and the meshes it names, or a mesh file; none for builtins."""
    spec = str(scene_spec).strip()
    if spec.startswith("builtin:"):
        return []
    path = Path(spec).expanduser()
    if not path.is_absolute():
        path = base / path
    files = [path]
    if path.suffix.lower() in (".yaml", ".yml") and path.exists():
        try:
            doc = yaml.safe_load(path.read_text())
        except (OSError, yaml.YAMLError):
            return files
        for obj in (doc or {}).get("objects", []) if isinstance(doc, dict) else []:
            if isinstance(obj, dict) and isinstance(obj.get("mesh"), str):
                mesh = Path(obj["mesh"]).expanduser()
                files.append(mesh if mesh.is_absolute() else path.parent / mesh)
    return files


def _stamp(path: Path) -> tuple[int, int] | None:
    try:
        st = path.stat()
    except OSError:
        return None
    return (st.st_mtime_ns, st.st_size)


@dataclass
class WatchEvent:
    changed: list[str]
    computed: list[str] = field(default_factory=list)
    reused: int = 0  # nodes whose outputs came from memory or the disk cache
    nodes: int = 0
    ms: float = 0.0  # wall time of the re-run (load, run, write)
    node_ms: float = 0.0  # time inside nodes
    wrote: Path | None = None
    error: str | None = None

    def describe(self) -> str:
        what = ", ".join(self.changed) + " changed" if self.changed else "first run"
        if self.error:
            return f"{what}: {self.error}"
        done = ", ".join(self.computed) if self.computed else "nothing"
        return (f"{what}: recomputed {done} ({len(self.computed)} of {self.nodes} nodes; {self.reused} reused) "
                f"in {self.ms:.0f} ms ({self.node_ms:.0f} ms in nodes) -> {self.wrote}")


def _watched_file(pipeline: str | Path) -> Path:
    """The file to watch: the path given, or the shipped pipeline it names (an error shows at the first step)."""
    from ..shipped import resolve

    try:
        return resolve(pipeline)
    except SketchgraphError:
        return Path(pipeline)


class Watcher:
    """Loads and runs a pipeline, and again whenever one of its files changes (see `step`)."""

    def __init__(self, pipeline: str | Path, out: str | Path | None = None, output_name: str | None = None,
                 overrides: tuple[str, ...] = (), size: str | None = None, scene: str | None = None,
                 cache: Any = None, frame: int = 0, load: Callable[..., Pipeline] | None = None,
                 out_dir: str | Path | None = None, allow_outside: bool = False, view: str | None = None,
                 up: str | None = None, fill: float | None = None):
        self.pipeline_path = _watched_file(pipeline)
        self.view, self.up, self.fill = view, up, fill
        self.out = Path(out) if out else Path("out") / f"{self.pipeline_path.stem}.png"
        self.output_name = output_name
        self.overrides = tuple(overrides)
        self.size = size
        self.scene = scene
        self.cache = cache
        self.frame = frame
        self._load = load
        self.out_dir = out_dir
        self.allow_outside = allow_outside
        self.executor: Executor | None = None
        self._stamps: dict[Path, tuple[int, int] | None] = {}
        self._files: list[Path] = [self.pipeline_path]

    def files(self) -> list[Path]:
        return list(self._files)

    def changed_files(self) -> list[Path]:
        return [p for p in self._files if _stamp(p) != self._stamps.get(p, ())]

    def _snapshot(self) -> None:
        self._stamps = {p: _stamp(p) for p in self._files}

    def _open(self) -> Pipeline:
        if self._load is not None:
            return self._load(self.pipeline_path)
        from ..render import open_pipeline

        return open_pipeline(str(self.pipeline_path), self.overrides, self.size, self.scene, out_dir=self.out_dir,
                             allow_outside=self.allow_outside, view=self.view, up=self.up, fill=self.fill)

    def step(self, force: bool = False) -> WatchEvent | None:
        """Re-run if any watched file changed since the last step (or on the first step); else None."""
        first = not self._stamps
        changed = self.changed_files()
        if not (first or changed or force):
            return None
        event = WatchEvent([str(p) for p in changed] if not first else [])
        t0 = time.perf_counter()
        # read the stamps before loading, so an edit made while we render is seen at the next step
        self._snapshot()
        try:
            pipe = self._open()
        except SketchgraphError as exc:
            event.error = str(exc)
            return event
        scene_base = Path.cwd() if self.scene else self.pipeline_path.parent  # --scene is relative to the cwd
        self._files = [self.pipeline_path, *scene_files(pipe.scene_spec, scene_base)]
        self._stamps.update({p: _stamp(p) for p in self._files if p not in self._stamps})
        try:
            self._run(pipe, event)
        except SketchgraphError as exc:
            event.error = str(exc)
        event.ms = (time.perf_counter() - t0) * 1000
        return event

    def _run(self, pipe: Pipeline, event: WatchEvent) -> None:
        from ..output.write import write_value

        name = self.output_name or next(iter(pipe.outputs))
        if name not in pipe.outputs:
            raise SketchgraphError(f"pipeline has no output '{name}'; outputs: {', '.join(pipe.outputs)}")
        ref = pipe.outputs[name]
        ex = Executor(pipe, self.cache, mode="loop", requested=[ref], gl=self.executor._gl if self.executor else None)
        adopt_memory(ex, self.executor, self.frame)
        if self.executor is not None:
            self.executor.close()
        self.executor = ex
        result = ex.run(self.frame)
        event.wrote = write_value(result.values[ref], self.out)
        event.computed = result.computed()
        event.nodes = len(result.stats)
        event.reused = sum(1 for s in result.stats.values() if s.status in ("memory", "disk"))
        event.node_ms = sum(s.ms for s in result.stats.values())

    def close(self) -> None:
        if self.executor is not None:
            self.executor.close()


def watch(watcher: Watcher, interval: float = 0.5, max_iterations: int | None = None,
          echo: Callable[[str], None] = print, sleep: Callable[[float], None] = time.sleep) -> list[WatchEvent]:
    """Poll every `interval` seconds; run the watcher's step and print what happened. Stops after
    `max_iterations` polls (None: until interrupted). Returns the events."""
    events: list[WatchEvent] = []
    i = 0
    try:
        while max_iterations is None or i < max_iterations:
            event = watcher.step()
            if event is not None:
                events.append(event)
                echo(f"[{time.strftime('%H:%M:%S')}] {event.describe()}")
            i += 1
            if max_iterations is None or i < max_iterations:
                sleep(interval)
    except KeyboardInterrupt:
        pass
    finally:
        watcher.close()
    return events
