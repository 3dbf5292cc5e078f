"""The Python API: load a pipeline, render it, inspect any node's port, iterate frames.

```python
import nodegraph as ng

pipe = ng.load("nienhaus_sketchy", scene="spot.obj", size=(1200, 900), set={"edges.width": 3})
img = pipe.render()                  # uint8 (H, W, 4), row 0 at the top, as the PNG would be
hdr = pipe.render(dtype="float32")   # the output's float values
edges = pipe.inspect("edges.out")    # any node's port, float32
for frame, img in pipe.frames(range(0, 48)):
    ...
```

**One convention for arrays:** every array this module returns has row 0 at the top, as image files
do. (GPU textures keep OpenGL's bottom-up order inside the engine; the API flips once, on the way out.)

A `Session` keeps one GL context, its texture pool and the in-memory node values between calls; values
are content-addressed, so after `pipe.set(...)` only the nodes whose key changed run again (see
`Pipe.last_run`). Errors are the same `SketchgraphError` subclasses the command line prints as one line.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from . import render
from .errors import SketchgraphError
from .output import write

__all__ = ["Pipe", "Session", "default_session", "load"]


class Session:
    """One GL context, the texture pool, the disk cache and the in-memory values, kept between calls.

    `cache`: True for the default disk cache (`$SKETCHGRAPH_CACHE_DIR` or ~/.cache/sketchgraph), False for
    none, or a folder. `memory_limit`: bytes of node values kept in memory (least recently used go first).
    """

    def __init__(self, cache: bool | str | Path = True, memory_limit: int = 1024**3) -> None:
        self._cache_arg = cache
        self._cache: Any = None
        self.memory_limit = memory_limit
        self._executor: Any = None  # the last executor: its in-memory values pass to the next one
        self.compute_counts: dict[str, int] = {}  # node id -> computes in this session

    @property
    def cache(self) -> Any:
        if self._cache is None and self._cache_arg is not False:
            from .cache import Cache

            self._cache = Cache(None if self._cache_arg is True else Path(self._cache_arg))
        return self._cache

    @property
    def gl(self) -> Any:
        from .gpu import gl as glmod

        return glmod.get()

    def load(self, pipeline: str | Path, *, scene: str | Path | None = None, size: tuple[int, int] | str | None = None,
             set: Mapping[str, Any] | Iterable[str] | None = None,  # noqa: A002 - the CLI's --set
             out_dir: str | Path | None = None, allow_outside: bool = False, view: str | None = None,
             up: str | None = None, reference_size: int | None = None) -> Pipe:
        """A pipeline by path or shipped name, with the command line's overrides: `scene` (builtin:NAME, a
        scene YAML or a mesh file, relative to the current directory), `size` ((width, height) or 'WxH'),
        `set` ({"node.param": value} or ["node.param=value"]), and `view` and `up` (`--view`, `--up`: the
        side a mesh file is seen from and its up axis; nodegraph/scene/framing.py). Files the pipeline's nodes
        write (`write`, `strokes_svg`) resolve against `out_dir` (default: the current directory) and may not leave it
        unless `allow_outside` (the CLI's --out-dir and --allow-outside-out-dir). `reference_size` replaces the
        pipeline's (the shorter side at which its image-space params hold as written; docs/sizes.md). A mesh
        file parsed by an earlier process with the same disk cache is read from it (nodegraph/scene/meshstore.py)."""
        from .scene import meshstore

        meshstore.use_cache(self.cache)
        return Pipe(self, str(pipeline), scene=None if scene is None else str(scene), size=size,
                    overrides=_overrides(set), out_dir=out_dir, allow_outside=allow_outside, view=view, up=up,
                    reference_size=reference_size)

    def executor(self, pipe: Any, requested: list[tuple[str, str]], mode: str, frame: int, like: Any = None) -> Any:
        """A new executor for `requested` that adopts the last one's in-memory values (same GL context)."""
        from .executor import Executor

        ex = Executor(pipe, self.cache, mode=mode, requested=requested, memory_limit=self.memory_limit, like=like)
        ex.adopt_memory(self._executor, frame)
        if self._executor is not None and self._executor is not ex:
            self._executor.close()
        self._executor = ex
        return ex

    def count(self, result: Any) -> None:
        for nid in result.computed():
            self.compute_counts[nid] = self.compute_counts.get(nid, 0) + 1

    def close(self) -> None:
        """Release every texture this session holds and flush pending cache writes."""
        if self._executor is not None:
            self._executor.clear_memory()
            self._executor.close()
            self._executor = None

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


_DEFAULT: Session | None = None


def default_session() -> Session:
    """The session `nodegraph.load` uses (created on first use)."""
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = Session()
    return _DEFAULT


def load(pipeline: str | Path, *, scene: str | Path | None = None, size: tuple[int, int] | str | None = None,
         set: Mapping[str, Any] | Iterable[str] | None = None, session: Session | None = None,  # noqa: A002
         out_dir: str | Path | None = None, allow_outside: bool = False, view: str | None = None,
         up: str | None = None, reference_size: int | None = None) -> Pipe:
    """Load and validate a pipeline (a path, or the name of a shipped one) in the default session."""
    return (session or default_session()).load(pipeline, scene=scene, size=size, set=set, out_dir=out_dir,
                                               allow_outside=allow_outside, view=view, up=up,
                                               reference_size=reference_size)


class Pipe:
    """A loaded, validated pipeline in a session. Everything is checked when it is made, before any GL."""

    def __init__(self, session: Session, source: str, *, scene: str | None, size: tuple[int, int] | str | None,
                 overrides: list[str], out_dir: str | Path | None = None, allow_outside: bool = False,
                 view: str | None = None, up: str | None = None, reference_size: int | None = None) -> None:
        self.session = session
        self.reference_size = reference_size
        self.out_dir = Path.cwd() if out_dir is None else Path(out_dir)  # fixed at load: set() keeps it
        self.allow_outside = allow_outside
        self.source = source
        self.scene_arg = scene
        self.size_arg = size
        self.overrides = list(overrides)
        self.view, self.up = view, up
        size_text = size if isinstance(size, str) or size is None else f"{int(size[0])}x{int(size[1])}"
        self.pipeline = render.open_pipeline(source, tuple(self.overrides), size_text, scene, out_dir=self.out_dir,
                                             allow_outside=allow_outside, view=view, up=up,
                                             reference_size=reference_size)
        self.last_run: Any = None  # the last RunResult: .computed() names the nodes that ran

    # -- what it is ------------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self.pipeline.name

    @property
    def size(self) -> tuple[int, int]:
        return self.pipeline.size

    @property
    def outputs(self) -> list[str]:
        return list(self.pipeline.outputs)

    @property
    def nodes(self) -> dict[str, str]:
        """Node id -> node type."""
        return {nid: node.type_name for nid, node in self.pipeline.nodes.items()}

    def params(self, node: str) -> dict[str, Any]:
        """A node's parameters as the pipeline has them (defaults filled in)."""
        if node not in self.pipeline.nodes:
            self.pipeline.parse_ref(node)  # raises the one-line error with a suggestion
        return self.pipeline.nodes[node].params.model_dump(mode="json")

    def set(self, values: Mapping[str, Any] | Iterable[str] | None = None, **kw: Any) -> Pipe:
        """The same pipeline with more overrides ({"node.param": value}); shares this session, so only what
        the change reaches is computed again. `pipe.set(edges__width=3)` is the keyword spelling."""
        more = _overrides(values) + _overrides({k.replace("__", "."): v for k, v in kw.items()})
        return Pipe(self.session, self.source, scene=self.scene_arg, size=self.size_arg,
                    overrides=self.overrides + more, out_dir=self.out_dir, allow_outside=self.allow_outside,
                    view=self.view, up=self.up, reference_size=self.reference_size)

    # -- running ---------------------------------------------------------------------------------
    def _ref(self, output: str | None) -> tuple[str, str]:
        if output is None:
            return next(iter(self.pipeline.outputs.values()))
        if output in self.pipeline.outputs:
            return self.pipeline.outputs[output]
        return self.pipeline.parse_ref(output)

    def _run(self, refs: list[tuple[str, str]], frame: int, mode: str = "single", like: Any = None) -> Any:
        ex = self.session.executor(self.pipeline, refs, mode, frame, like=like)
        result = ex.run(frame)
        self.last_run = result
        self.session.count(result)
        return result

    def value(self, output: str | None = None, frame: int = 0) -> Any:
        """The raw engine value of an output or NODE.PORT (a GPU texture, Strokes, Arrays, ...)."""
        ref = self._ref(output)
        return self._run([ref], frame).values[ref]

    def render(self, output: str | None = None, frame: int = 0, dtype: str = "uint8") -> np.ndarray:
        """An output (default: the first) as an (H, W, C) array, row 0 at the top. `dtype="uint8"` gives the
        values the PNG file holds; `"float32"` gives the output's own values."""
        ref = self._ref(output)
        return to_array(self._run([ref], frame).values[ref], dtype)

    def inspect(self, port: str, frame: int = 0) -> np.ndarray:
        """Any node's port (NODE.PORT, or an output name) as float32 (H, W, C), row 0 at the top. Formats are
        planned as for the pipeline's outputs, so inspecting never changes what downstream nodes see."""
        from .plan import plan

        ref = self._ref(port)
        like = plan(self.pipeline)
        return to_array(self._run([ref], frame, like=like).values[ref], "float32")

    def frames(self, frames: Iterable[int] | str, output: str | None = None, dtype: str = "uint8", *,
               scheduler: Any = None, chunk: int | None = None) -> Iterator[tuple[int, np.ndarray]]:
        """(frame, image) for each frame (an iterable of ints, or 'START:END[:STEP]' as on the command line);
        frame-independent nodes run once, per-frame buffers are never written to the disk cache.

        `scheduler`: a `dask.distributed.Client` (or "local:N", "tcp://HOST:PORT") renders the frames on that
        cluster, `chunk` frames a task; the images arrive in frame order (docs/distributed.md)."""
        frame_list = write.parse_frames(frames) if isinstance(frames, str) else [int(f) for f in frames]
        ref = self._ref(output)
        if scheduler is not None:
            yield from self._frames_on(scheduler, frame_list, output, dtype, chunk)
            return
        ex = self.session.executor(self.pipeline, [ref], "loop", frame_list[0] if frame_list else 0)
        for frame in frame_list:
            result = ex.run(frame)
            self.last_run = result
            self.session.count(result)
            yield frame, to_array(result.values[ref], dtype)

    def _frames_on(self, scheduler: Any, frame_list: list[int], output: str | None, dtype: str,
                   chunk: int | None) -> Iterator[tuple[int, np.ndarray]]:
        import shutil

        from . import distributed as dist
        from .output.imageio import read, to_uint8

        if dtype not in ("uint8", "float32"):
            raise SketchgraphError(f"dtype: expected 'uint8' or 'float32', found '{dtype}'")
        arg = self.session._cache_arg
        root: Any = arg if arg is False else (None if arg is True else str(arg))
        size = self.size_arg if isinstance(self.size_arg, str) or self.size_arg is None else \
            f"{int(self.size_arg[0])}x{int(self.size_arg[1])}"
        spec = dist.PipeSpec.make(self.source, self.overrides, size, self.scene_arg, output, view=self.view,
                                  up=self.up)
        with dist.connect(scheduler, cache_root=root) as client:
            scratch = dist.scratch_dir(root, "frames-")
            try:  # EXR keeps every channel and the float values; uint8 is quantised here as to_array does
                run = dist.FrameRun(client, spec, frame_list, scratch / "f_########.exr", chunk=chunk,
                                    cache_root=root, manifest=False, many=True)
                for frame, path in run:
                    arr = np.ascontiguousarray(read(path)[::-1], dtype=np.float32)
                    path.unlink(missing_ok=True)
                    yield frame, (to_uint8(arr) if dtype == "uint8" else arr)
            finally:
                shutil.rmtree(scratch, ignore_errors=True)

    def write(self, path: str | Path, output: str | None = None, frame: int = 0) -> Path:
        """Write an output to a file (PNG, EXR, SVG for strokes), as `sketchgraph run -o` does."""
        ref = self._ref(output)
        return write.write_frame(self._run([ref], frame).values[ref], Path(path), lambda: self.session.gl)

    def _repr_png_(self) -> bytes:
        """Jupyter shows a pipeline as its first output."""
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            path = self.write(Path(tmp) / "image.png")
            return path.read_bytes()

    def __repr__(self) -> str:
        w, h = self.size
        return f"<Pipe {self.name!r} {w}x{h}, {len(self.pipeline.nodes)} nodes, outputs: {', '.join(self.outputs)}>"


def to_array(value: Any, dtype: str = "float32") -> np.ndarray:
    """A node value as an image array, row 0 at the top: float32 values, or uint8 as an 8-bit file holds them."""
    if dtype not in ("uint8", "float32"):
        raise SketchgraphError(f"dtype: expected 'uint8' or 'float32', found '{dtype}'")
    arr = write.to_image(value)[::-1]
    if dtype == "uint8":
        from .output.imageio import to_uint8

        return to_uint8(arr)
    return np.ascontiguousarray(arr, dtype=np.float32)


def _overrides(values: Mapping[str, Any] | Iterable[str] | None) -> list[str]:
    """{"node.param": value} as the command line's NODE.PARAM=VALUE strings (JSON is valid YAML)."""
    if values is None:
        return []
    if isinstance(values, Mapping):
        return [f"{k}={json.dumps(_plain(v))}" for k, v in values.items()]
    if isinstance(values, str):
        return [values]
    return [str(v) for v in values]


def _plain(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    return v
