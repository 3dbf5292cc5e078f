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

**Arguments are checked before anything runs.** A wrong type raises `ArgumentTypeError` (also a `TypeError`), a
value out of range `ArgumentValueError` (also a `ValueError`), and a `load` option or an output the pipeline
cannot take `PipelineArgumentError` (a `PipelineError` and a `ValueError`); each message is one line that names
the argument as this API spells it (`scene='x.yaml': scene file not found: ...`, never the command line's
`--scene`). A bool is not a number here: `size=(True, True)` and `frame=True` are refused. Frame numbers are
integers with |frame| <= `MAX_FRAME` (2**31 - 1).
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import json
import math
import numbers
import os
import reprlib
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from . import render
from .errors import (
    ArgumentTypeError,
    ArgumentValueError,
    Location,
    PipelineArgumentError,
    PipelineError,
    SketchgraphError,
)
from .output import write

__all__ = ["Pipe", "Session", "default_session", "load", "to_array"]

MAX_FRAME = write.MAX_FRAME
MAX_FRAMES = write.MAX_FRAMES
MAX_MEMORY_LIMIT = 2**63 - 1
"""The largest `Session(memory_limit=...)`: a byte count the engine's 64-bit counters hold."""
DTYPES = ("uint8", "float32")

_F = TypeVar("_F", bound=Callable[..., Any])


# -- argument checks: one line naming the argument as the API spells it ----------------------------
_REPR = reprlib.Repr()
_REPR.maxstring = _REPR.maxother = _REPR.maxlong = 48
_REPR.maxlist = _REPR.maxtuple = _REPR.maxdict = _REPR.maxset = 4
_REPR.maxlevel = 2


def _shown(value: Any) -> str:
    """A value for a message: its repr, short, on one line, printable ASCII (never the whole of a big value)."""
    try:
        text = _REPR.repr(value)
    except Exception:  # a repr that fails (an int of 5000 digits, a broken __repr__)
        text = f"<{type(value).__name__} object>"
    text = " ".join("".join(c if 32 <= ord(c) < 127 else "?" for c in text).split())
    return text if len(text) <= 80 else text[:77] + "..."


def _type_error(arg: str, value: Any, expected: str) -> ArgumentTypeError:
    return ArgumentTypeError(f"{arg}={_shown(value)}: expected {expected}, found {type(value).__name__}")


def _value_error(arg: str, value: Any, expected: str, cls: type[SketchgraphError] = ArgumentValueError
                 ) -> SketchgraphError:
    return cls(f"{arg}={_shown(value)}: expected {expected}")


def _is_int(value: Any) -> bool:
    """An integer that is not a bool (numpy's integers count; numpy's bool does not)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


def _int(arg: str, value: Any, lo: int, hi: int, what: str = "an integer",
         cls: type[SketchgraphError] = ArgumentValueError) -> int:
    if not _is_int(value):
        raise _type_error(arg, value, f"{what} (not a bool)" if isinstance(value, (bool, np.bool_)) else what)
    n = int(value)
    if not lo <= n <= hi:
        raise _value_error(arg, value, f"{what} between {lo} and {hi}", cls)
    return n


def _frame(value: Any, arg: str = "frame") -> int:
    return _int(arg, value, -MAX_FRAME, MAX_FRAME, "an integer frame number")


def _path(arg: str, value: Any, optional: bool = False) -> str | None:
    """A str or os.PathLike naming a file: not empty, no NUL character."""
    if value is None and optional:
        return None
    if not isinstance(value, (str, os.PathLike)):
        raise _type_error(arg, value, "a str or os.PathLike" + (" or None" if optional else ""))
    try:
        text = os.fspath(value)
    except TypeError:
        raise _type_error(arg, value, "a str or os.PathLike") from None
    if not isinstance(text, str):
        raise _type_error(arg, value, "a str path (not bytes)")
    if not text:
        raise _value_error(arg, value, "a non-empty path")
    if "\0" in text:
        raise _value_error(arg, value, "a path without NUL characters")
    return text


def _str(arg: str, value: Any, optional: bool = True) -> str | None:
    if value is None and optional:
        return None
    if not isinstance(value, str):
        raise _type_error(arg, value, "a str" + (" or None" if optional else ""))
    return value


def _bool(arg: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise _type_error(arg, value, "True or False")
    return bool(value)


def _choice(arg: str, value: Any, choices: tuple[str, ...], cls: type[SketchgraphError] = ArgumentValueError
            ) -> str | None:
    if value is None:
        return None
    if not isinstance(value, str):
        raise _type_error(arg, value, f"one of {', '.join(choices)} or None")
    if value not in choices:
        raise _value_error(arg, value, f"one of {', '.join(choices)}", cls)
    return value


def _fill(value: Any) -> float | None:
    """`fill=` (--fill): the share of the picture's shorter side a mesh file's subject spans."""
    from .scene.framing import FILL_MAX

    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise _type_error("fill", value, f"a number in (0, {FILL_MAX:g}] or None")
    if not (math.isfinite(float(value)) and 0.0 < float(value) <= FILL_MAX):
        raise _value_error("fill", value, f"a share of the picture's shorter side in (0, {FILL_MAX:g}] (0.85: 85%)",
                           PipelineArgumentError)
    return float(value)


def _dtype(value: Any) -> str:
    if not isinstance(value, str):
        raise _type_error("dtype", value, "'uint8' or 'float32'")
    if value not in DTYPES:
        raise _value_error("dtype", value, "'uint8' or 'float32'")
    return value


def _size(value: Any) -> str | None:
    """(width, height) of ints, or 'WxH', as the command line's --size text (checked here, named `size=`)."""
    from .pipeline import MAX_SIZE, parse_size

    if value is None:
        return None
    expected = "(width, height) of integers or 'WxH'"
    if isinstance(value, str):
        try:
            w, h = parse_size(value)
        except PipelineError as exc:
            raise _value_error("size", value, _strip_flag(exc.message, "--size").removeprefix("expected "),
                               PipelineArgumentError) from None
        return f"{w}x{h}"
    if not isinstance(value, (tuple, list, np.ndarray)):
        raise _type_error("size", value, expected)
    items = (list(value) if value.ndim == 1 else []) if isinstance(value, np.ndarray) else list(value)
    if len(items) != 2:
        raise _value_error("size", value, f"{expected}: two numbers", PipelineArgumentError)
    if not all(_is_int(v) for v in items):
        raise _type_error("size", value, f"{expected} (not bools or floats)")
    w, h = (int(v) for v in items)
    if not (1 <= w <= MAX_SIZE and 1 <= h <= MAX_SIZE):
        raise _value_error("size", value, f"width and height between 1 and {MAX_SIZE}", PipelineArgumentError)
    return f"{w}x{h}"


def _strip_flag(message: str, flag: str) -> str:
    return message[len(flag) + 2:] if message.startswith(flag + ": ") else message


def _check_scheduler(scheduler: Any, chunk: Any) -> None:
    if scheduler is not None and not isinstance(scheduler, str) and not (
            callable(getattr(scheduler, "submit", None)) and callable(getattr(scheduler, "gather", None))):
        raise _type_error("scheduler", scheduler, "None, 'local:N', 'tcp://HOST:PORT' or a dask.distributed.Client")
    if chunk is not None:
        _int("chunk", chunk, 1, MAX_FRAMES, "a number of frames a task")
        if scheduler is None:
            raise ArgumentValueError(f"chunk={_shown(chunk)}: splits frames for scheduler=; give scheduler= too")


# CLI flags that load-time errors name, as this API spells them
_FLAGS = {"--scene": "scene=", "--size": "size=", "--view": "view=", "--up": "up=", "--frames": "frames=",
          "--out-dir": "out_dir=", "--allow-outside-out-dir": "allow_outside=True",
          "--reference-size": "reference_size=", "--fill": "fill=", "--animation": "animation=",
          "--animation-end": "animation_end=", "--front": "front="}


def _api_words(text: str) -> str:
    """A message with the command line's option names replaced by this API's argument names."""
    import re

    if text.startswith("--set "):  # a location: --set NODE.PARAM=VALUE (the value as JSON, from `_overrides`)
        key, eq, val = text[len("--set "):].partition("=")
        return f"set={{{key!r}: {val}}}" if eq else f"set={text[len('--set '):]!r}"
    text = text.replace("--allow-outside-out-dir (API: allow_outside=True)", "--allow-outside-out-dir")
    return re.sub(r"(?<![\w-])(--[a-z][a-z-]*)", lambda m: _FLAGS[m.group(1)] if m.group(1) in _FLAGS
                  else m.group(1), text)


def _one_line(exc: SketchgraphError) -> None:
    """Make `str(exc)` one line (a path or a value quoted in it may hold line breaks)."""
    text = str(exc)
    if "\n" in text or "\r" in text:
        exc.args = (" ".join(text.split()),)


def _api(fn: _F) -> _F:
    """Every SketchgraphError leaving an API call is one line."""

    @functools.wraps(fn)
    def call(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except SketchgraphError as exc:
            _one_line(exc)
            raise

    return call  # type: ignore[return-value]


@contextlib.contextmanager
def _load_errors(scene: Any) -> Iterator[None]:
    """Load-time errors about an option (located at `--scene`, `--set ...`, or naming `--view`) become a
    `PipelineArgumentError` in this API's words (`scene='x.yaml': ...`); errors in the pipeline's own files stay
    as they are."""
    try:
        yield
    except PipelineArgumentError:
        raise
    except PipelineError as exc:
        where = exc.location.file if exc.location is not None else None
        about_option = (where is not None and exc.location.line is None and where.startswith("--")) or \
            exc.message.startswith("--")
        if not about_option:  # the pipeline's own files: the same class, its advice in this API's words
            words = _api_words(exc.message)
            if words != exc.message:
                exc.message = words
                exc.args = (f"{exc.location}: {words}" if exc.location else words,)
            raise
        if where == "--scene":
            location: Location | None = Location(f"scene={_shown(scene)}")
        elif where is not None and where.startswith("--"):
            location = Location(_api_words(where))
        else:
            location = exc.location
        raise PipelineArgumentError(_api_words(exc.message), location) from None


def _check_set(values: Any, arg: str = "set") -> None:
    if values is None or isinstance(values, str):
        return
    if isinstance(values, (bytes, bytearray)):
        raise _type_error(arg, values, "a mapping {'node.param': value}, 'node.param=value' or a list of those")
    if isinstance(values, Mapping):
        for key in values:
            if not isinstance(key, str):
                raise _type_error(arg, values, "a mapping with 'node.param' str keys")
        return
    if not isinstance(values, Iterable):
        raise _type_error(arg, values, "a mapping {'node.param': value}, 'node.param=value' or a list of those")


class Session:
    """One GL context, the texture pool, the disk cache and the in-memory values, kept between calls.

    `cache`: True for the default disk cache (`$SKETCHGRAPH_CACHE_DIR` or ~/.cache/sketchgraph), False for
    none, or a folder. `memory_limit`: bytes of node values kept in memory (least recently used go first).
    """

    @_api
    def __init__(self, cache: bool | str | Path = True, memory_limit: int = 1024**3) -> None:
        if not isinstance(cache, (bool, np.bool_)):
            _path("cache", cache)
        else:
            cache = bool(cache)
        self._cache_arg = cache
        self._cache: Any = None
        self.memory_limit = _int("memory_limit", memory_limit, 0, MAX_MEMORY_LIMIT, "a number of bytes")
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

    @_api
    def load(self, pipeline: str | Path, *, scene: str | Path | None = None, size: tuple[int, int] | str | None = None,
             set: Mapping[str, Any] | Iterable[str] | None = None,  # noqa: A002 - the CLI's --set
             out_dir: str | Path | None = None, allow_outside: bool = False, view: str | None = None,
             up: str | None = None, reference_size: int | None = None, fill: float | None = None,
             animation: str | int | None = None, animation_end: str | None = None, front: str | None = None,
             film: bool = False) -> Pipe:
        """A pipeline by path or shipped name, with the command line's overrides: `scene` (builtin:NAME, a
        scene YAML or a mesh file, relative to the current directory), `size` ((width, height) or 'WxH'),
        `set` ({"node.param": value} or ["node.param=value"]), and `view` and `up` (`--view`, `--up`: the
        side a mesh file is seen from and its up axis; nodegraph/scene/framing.py), `front` (`--front`: the axis of
        the file a mesh file's front faces, auto by default: found by the same rules). Files the pipeline's nodes
        write (`write`, `strokes_svg`) resolve against `out_dir` (default: the current directory) and may not leave it
        unless `allow_outside` (the CLI's --out-dir and --allow-outside-out-dir). `reference_size` replaces the
        pipeline's (the shorter side at which its image-space params hold as written; docs/sizes.md).
        `animation` (`--animation`: a clip's name or index, or "all", the default) and `animation_end`
        (`--animation-end`: hold, the default, or loop) choose what glTF files play (docs/animation.md). `film`
        (`--film`): the pipeline's film setting (nodegraph/films.py: every hold at 0 and, for a shipped pipeline, its
        variant file or parameters; `set` applies on top; docs/animation.md, Making films). A mesh
        file parsed by an earlier process with the same disk cache is read from it (nodegraph/scene/meshstore.py).
        Every argument is checked before anything is read (see the module's docstring)."""
        from .pipeline import resolve
        from .scene import meshstore
        from .scene.views import UP_AXES, VIEWS

        source = _path("pipeline", pipeline)
        scene_text = _path("scene", scene, optional=True)
        size_text = _size(size)
        _check_set(set)
        overrides = _overrides(set)
        out = _path("out_dir", out_dir, optional=True)
        allow = _bool("allow_outside", allow_outside)
        view = _choice("view", view, VIEWS, PipelineArgumentError)
        up = _choice("up", up, (*UP_AXES, "auto"), PipelineArgumentError)
        front = _choice("front", front, (*UP_AXES, "auto"), PipelineArgumentError)
        fill = _fill(fill)
        if animation is not None and (isinstance(animation, bool) or not isinstance(animation, (str, int))):
            raise _type_error("animation", animation, "a clip name, an index, 'all' or None")
        from .scene.timeline import ANIMATION_ENDS

        animation_end = _choice("animation_end", animation_end, ANIMATION_ENDS, PipelineArgumentError)
        if reference_size is not None:
            reference_size = _int("reference_size", reference_size, 1, 16384, "a size in pixels",
                                  PipelineArgumentError)
        film = _bool("film", film)
        try:
            resolve(source)
            if film:
                from .films import film_setting

                source, film_overrides = film_setting(source)
                overrides = [*film_overrides, *overrides]
        except PipelineError as exc:
            raise PipelineArgumentError(f"pipeline={_shown(pipeline)}: {exc}") from None
        meshstore.use_cache(self.cache)
        return Pipe(self, source, scene=scene_text, size=size_text, overrides=overrides, out_dir=out,
                    allow_outside=allow, view=view, up=up, reference_size=reference_size, fill=fill,
                    animation=None if animation is None else str(animation), animation_end=animation_end,
                    front=front)

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


@_api
def load(pipeline: str | Path, *, scene: str | Path | None = None, size: tuple[int, int] | str | None = None,
         set: Mapping[str, Any] | Iterable[str] | None = None, session: Session | None = None,  # noqa: A002
         out_dir: str | Path | None = None, allow_outside: bool = False, view: str | None = None,
         up: str | None = None, reference_size: int | None = None, fill: float | None = None,
         animation: str | int | None = None, animation_end: str | None = None, front: str | None = None,
         film: bool = False) -> Pipe:
    """Load and validate a pipeline (a path, or the name of a shipped one) in the default session."""
    if session is not None and not isinstance(session, Session):
        raise _type_error("session", session, "a nodegraph.Session or None")
    return (session or default_session()).load(pipeline, scene=scene, size=size, set=set, out_dir=out_dir,
                                               allow_outside=allow_outside, view=view, up=up,
                                               reference_size=reference_size, fill=fill, animation=animation,
                                               animation_end=animation_end, front=front, film=film)


class Pipe:
    """A loaded, validated pipeline in a session. Everything is checked when it is made, before any GL."""

    def __init__(self, session: Session, source: str, *, scene: str | None, size: tuple[int, int] | str | None,
                 overrides: list[str], out_dir: str | Path | None = None, allow_outside: bool = False,
                 view: str | None = None, up: str | None = None, reference_size: int | None = None,
                 fill: float | None = None, animation: str | None = None, animation_end: str | None = None,
                 front: str | None = None) -> None:
        self.session = session
        self.reference_size = reference_size
        self.out_dir = Path.cwd() if out_dir is None else Path(out_dir)  # fixed at load: set() keeps it
        self.allow_outside = allow_outside
        self.source = source
        self.scene_arg = scene
        self.size_arg = size
        self.overrides = list(overrides)
        self.view, self.up, self.fill = view, up, fill
        self.play = (animation, animation_end)  # what glTF files play (scene.views.playing)
        self.front = front  # the axis a mesh file's front faces (scene.views.facing; None: found)
        size_text = size if isinstance(size, str) or size is None else f"{int(size[0])}x{int(size[1])}"
        from .scene.views import facing, playing

        with _load_errors(scene), playing(*self.play), facing(front):
            self.pipeline = render.open_pipeline(source, tuple(self.overrides), size_text, scene, out_dir=self.out_dir,
                                                 allow_outside=allow_outside, view=view, up=up,
                                                 reference_size=reference_size, fill=fill)
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

    @_api
    def params(self, node: str) -> dict[str, Any]:
        """A node's parameters as the pipeline has them (defaults filled in)."""
        _str("node", node, optional=False)
        if node not in self.pipeline.nodes:
            self._ref(node, "node")  # raises the one-line error with a suggestion
            raise PipelineArgumentError(f"node={_shown(node)}: names an output, not a node; nodes: "
                                        f"{', '.join(self.pipeline.nodes)}")
        return self.pipeline.nodes[node].params.model_dump(mode="json")

    @_api
    def set(self, values: Mapping[str, Any] | Iterable[str] | None = None, **kw: Any) -> Pipe:
        """The same pipeline with more overrides ({"node.param": value}); shares this session, so only what
        the change reaches is computed again. `pipe.set(edges__width=3)` is the keyword spelling."""
        _check_set(values, "values")
        more = _overrides(values, "values") + _overrides({k.replace("__", "."): v for k, v in kw.items()}, "set")
        return Pipe(self.session, self.source, scene=self.scene_arg, size=self.size_arg,
                    overrides=self.overrides + more, out_dir=self.out_dir, allow_outside=self.allow_outside,
                    view=self.view, up=self.up, reference_size=self.reference_size, fill=self.fill,
                    animation=self.play[0], animation_end=self.play[1], front=self.front)

    # -- running ---------------------------------------------------------------------------------
    def _ref(self, output: str | None, arg: str = "output") -> tuple[str, str]:
        if output is None:
            return next(iter(self.pipeline.outputs.values()))
        _str(arg, output)
        if output in self.pipeline.outputs:
            return self.pipeline.outputs[output]
        try:
            return self.pipeline.parse_ref(output)
        except PipelineError as exc:
            raise PipelineArgumentError(f"{arg}={_shown(output)}: {exc.message}") from None

    def _run(self, refs: list[tuple[str, str]], frame: int, mode: str = "single", like: Any = None) -> Any:
        ex = self.session.executor(self.pipeline, refs, mode, frame, like=like)
        result = ex.run(frame)
        self.last_run = result
        self.session.count(result)
        return result

    @_api
    def value(self, output: str | None = None, frame: int = 0) -> Any:
        """The raw engine value of an output or NODE.PORT (a GPU texture, Strokes, Arrays, ...)."""
        ref = self._ref(output)
        return self._run([ref], _frame(frame)).values[ref]

    @_api
    def render(self, output: str | None = None, frame: int = 0, dtype: str = "uint8") -> np.ndarray:
        """An output (default: the first) as an (H, W, C) array, row 0 at the top. `dtype="uint8"` gives the
        values the PNG file holds; `"float32"` gives the output's own values."""
        ref = self._ref(output)
        frame, dtype = _frame(frame), _dtype(dtype)
        return to_array(self._run([ref], frame).values[ref], dtype)

    @_api
    def inspect(self, port: str, frame: int = 0) -> np.ndarray:
        """Any node's port (NODE.PORT, or an output name) as float32 (H, W, C), row 0 at the top. Formats are
        planned as for the pipeline's outputs, so inspecting never changes what downstream nodes see."""
        from .plan import plan

        _str("port", port, optional=False)
        ref = self._ref(port, "port")
        frame = _frame(frame)
        like = plan(self.pipeline)
        return to_array(self._run([ref], frame, like=like).values[ref], "float32")

    @_api
    def frames(self, frames: Iterable[int] | str, output: str | None = None, dtype: str = "uint8", *,
               scheduler: Any = None, chunk: int | None = None) -> Iterator[tuple[int, np.ndarray]]:
        """(frame, image) for each frame (an iterable of ints, or 'START:END[:STEP]' as on the command line);
        frame-independent nodes run once, per-frame buffers are never written to the disk cache.

        The frames are taken one at a time as the images are asked for (`range(10**12)` costs nothing until
        iterated) and each is checked as it comes (an int, not a bool, |frame| <= MAX_FRAME): a bad one raises
        `ArgumentTypeError` / `ArgumentValueError` there, after the frames before it. The other arguments (and
        a range's first frame) are checked at the call, before anything runs.

        `scheduler`: a `dask.distributed.Client` (or "local:N", "tcp://HOST:PORT") renders the frames on that
        cluster, `chunk` frames a task; the images arrive in frame order (docs/distributed.md). The cluster takes
        the frames as a list: at most MAX_FRAMES of them."""
        source = _frame_source(frames)
        ref = self._ref(output)
        dtype = _dtype(dtype)
        _check_scheduler(scheduler, chunk)
        if scheduler is not None:
            frame_list = list(itertools.islice(source, MAX_FRAMES + 1))
            if len(frame_list) > MAX_FRAMES:
                raise ArgumentValueError(f"frames={_shown(frames)}: expected at most {MAX_FRAMES} frames with "
                                         "scheduler= (a cluster takes them as a list); give fewer, or iterate "
                                         "without scheduler=")
            return _one_line_errors(self._frames_on(scheduler, frame_list, output, dtype, chunk))
        return _one_line_errors(self._frames_here(ref, source, dtype))

    def _frames_here(self, ref: tuple[str, str], source: Iterator[int], dtype: str
                     ) -> Iterator[tuple[int, np.ndarray]]:
        first = next(source, None)
        if first is None:
            return
        ex = self.session.executor(self.pipeline, [ref], "loop", first)
        for frame in itertools.chain((first,), source):
            result = ex.run(frame)
            self.last_run = result
            self.session.count(result)
            yield frame, to_array(result.values[ref], dtype)

    def _frames_on(self, scheduler: Any, frame_list: list[int], output: str | None, dtype: str,
                   chunk: int | None) -> Iterator[tuple[int, np.ndarray]]:
        import shutil

        from . import distributed as dist
        from .output.imageio import read, to_uint8

        arg = self.session._cache_arg
        root: Any = arg if arg is False else (None if arg is True else str(arg))
        size = self.size_arg if isinstance(self.size_arg, str) or self.size_arg is None else \
            f"{int(self.size_arg[0])}x{int(self.size_arg[1])}"
        from .scene.views import facing, playing

        with playing(*self.play), facing(self.front):  # the spec carries them to the workers
            spec = dist.PipeSpec.make(self.source, self.overrides, size, self.scene_arg, output, view=self.view,
                                      up=self.up, fill=self.fill)
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

    @_api
    def write(self, path: str | Path, output: str | None = None, frame: int = 0) -> Path:
        """Write an output to a file (PNG, EXR, SVG for strokes), as `sketchgraph run -o` does. The path is
        checked before anything renders (`fsio.check_output`: no part of its folder is a file, it is not a
        folder or a device, its folder takes new files)."""
        from .fsio import check_output

        target = Path(_path("path", path))  # type: ignore[arg-type]
        ref = self._ref(output)
        frame = _frame(frame)
        check_output(target)
        return write.write_frame(self._run([ref], frame).values[ref], target, lambda: self.session.gl)

    def _repr_png_(self) -> bytes:
        """Jupyter shows a pipeline as its first output."""
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            path = self.write(Path(tmp) / "image.png")
            return path.read_bytes()

    def __repr__(self) -> str:
        w, h = self.size
        return f"<Pipe {self.name!r} {w}x{h}, {len(self.pipeline.nodes)} nodes, outputs: {', '.join(self.outputs)}>"


def _frame_source(frames: Any) -> Iterator[int]:
    """The frames of `Pipe.frames` as a lazy iterator of checked ints: a 'START:END[:STEP]' text is parsed now
    (at most MAX_FRAMES); anything else is checked frame by frame as it is taken (a range's first frame now)."""
    if isinstance(frames, str):
        try:
            return iter(write.parse_frames(frames))
        except SketchgraphError as exc:
            raise ArgumentValueError(f"frames={_shown(frames)}: {_strip_flag(str(exc), '--frames')}") from None
    if isinstance(frames, (bytes, bytearray, Mapping)) or not isinstance(frames, Iterable):
        raise _type_error("frames", frames, "an iterable of ints (a range, a list) or 'START:END[:STEP]'")
    if isinstance(frames, range) and frames and not -MAX_FRAME <= frames[0] <= MAX_FRAME:
        raise _value_error("frames", frames, f"frame numbers between {-MAX_FRAME} and {MAX_FRAME}")
    try:
        it = iter(frames)
    except TypeError:
        raise _type_error("frames", frames, "an iterable of ints (a range, a list) or 'START:END[:STEP]'") from None
    return (_frame(f, f"frames[{i}]") for i, f in enumerate(it))


def _one_line_errors(it: Iterator[Any]) -> Iterator[Any]:
    """`it`, with a SketchgraphError raised while iterating made one line (as `_api` does for calls)."""
    try:
        yield from it
    except SketchgraphError as exc:
        _one_line(exc)
        raise


@_api
def to_array(value: Any, dtype: str = "float32") -> np.ndarray:
    """A node value as an image array, row 0 at the top: float32 values, or uint8 as an 8-bit file holds them."""
    from .values import Strokes, Tex, TexArray

    dtype = _dtype(dtype)
    if isinstance(value, np.ndarray):
        if value.ndim != 3 or not (np.issubdtype(value.dtype, np.floating) or np.issubdtype(value.dtype, np.integer)):
            raise _value_error("value", value, "an (H, W, C) array of numbers")
    elif not isinstance(value, (Tex, TexArray, Strokes)):
        raise _type_error("value", value, "a texture, Strokes or an (H, W, C) array (a node value)")
    arr = write.to_image(value)[::-1]
    if dtype == "uint8":
        from .output.imageio import to_uint8

        return to_uint8(arr)
    return np.ascontiguousarray(arr, dtype=np.float32)


def _overrides(values: Mapping[str, Any] | Iterable[str] | None, arg: str = "set") -> list[str]:
    """{"node.param": value} as the command line's NODE.PARAM=VALUE strings (JSON is valid YAML)."""
    if values is None:
        return []
    if isinstance(values, Mapping):
        out = []
        for k, v in values.items():
            if not isinstance(k, str):
                raise _type_error(arg, values, "a mapping with 'node.param' str keys")
            try:
                text = json.dumps(_plain(v), allow_nan=False)
            except ValueError:
                raise _value_error(arg, values, f"finite numbers (no nan or inf) for {k!r}") from None
            except (TypeError, RecursionError):
                raise _type_error(arg, values, f"values YAML can hold (numbers, str, bool, None, lists, dicts) for "
                                  f"{k!r}") from None
            out.append(f"{k}={text}")
        return out
    if isinstance(values, str):
        return [values]
    out = []
    for v in values:
        if not isinstance(v, str):
            raise _type_error(arg, v, "'node.param=value' strings")
        out.append(v)
    return out


def _plain(v: Any) -> Any:
    """A value as JSON can hold it: NumPy values as Python's; non-finite floats (YAML's .nan, .inf) are refused
    by json.dumps(allow_nan=False) and reported as a type the pipeline cannot take."""
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, (np.floating, np.integer, np.bool_)):
        return v.item()
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    if isinstance(v, list):
        return [_plain(x) for x in v]
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, float) and not math.isfinite(v):
        raise ValueError("non-finite")
    return v
