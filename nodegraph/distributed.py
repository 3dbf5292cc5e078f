"""Frame sequences (and, through the tools, wedges and gallery entries) on a Dask cluster.

- `connect("local:N" | "tcp://host:port" | "tls://host:port" | Client)`: a `distributed.LocalCluster` of N
  spawned worker processes (one thread each, llvmpipe limited to cores // N threads), a running scheduler, or
  a client the caller made. The address is checked before anything connects (`parse_scheduler`); a running
  scheduler must accept a TCP connection at once (refused: one line, no retries) and answer within
  `CONNECT_TIMEOUT`.
- One thread per worker: a worker process holds one GL context, which one thread may use. A cluster with a
  worker of more threads is refused before anything renders (`check_workers`, from the scheduler's
  `Client.nthreads()`), and a task on such a worker (one that joined later) fails before it touches GL
  (`worker_threads`: `Worker.state.nthreads`).
- A cluster with no live worker for `NO_WORKERS_TIMEOUT` seconds fails the run with one line (`completed`,
  `result`: the scheduler itself would keep the tasks waiting forever).
- Each worker process keeps one headless GL context (texture pool, compiled programs) and its last executor
  (in-memory values) across tasks: `SketchgraphPlugin` / `WorkerState`.
- The disk cache is shared (`SKETCHGRAPH_CACHE_DIR` on a filesystem every worker sees) and namespaced by the
  GL renderer (`renderer_namespace`: a subfolder of the cache root; node keys are unchanged), so an entry
  made by llvmpipe is never read where another renderer renders. Workers never prune; the client does.
- Nodes whose key is the same for every requested frame are computed once, in one task, persisted, and
  reach the other tasks through the cache.
- Workers write frames straight to the output pattern and return small metadata (frame, digest, SHA-256,
  timings). A task's `SketchgraphError` comes back as a value and is raised on the client as the same class
  with the same one-line message (deterministic errors are not retried); a killed worker costs only its
  chunk, which the scheduler runs again.

See docs/distributed.md for the measured overheads and the throughput model.
"""

from __future__ import annotations

import contextlib
import importlib
import ipaddress
import logging
import math
import os
import re
import shutil
import sys
import tempfile
import time
import uuid
from collections import Counter, OrderedDict
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from distributed import WorkerPlugin

from . import render
from .cache import Cache, default_root
from .errors import SketchgraphError, one_line
from .fsio import sync_written
from .output import write
from .output.frames_manifest import FramesManifest, file_sha256, frame_digest
from .values import Tex

PLUGIN_NAME = "sketchgraph"
VIDEO_SUFFIXES = (".mp4", ".gif", ".webm")  # the film writer's formats (output.film.FILM_FORMATS)
RETRIES = 2
"""`retries=` of every task: unexpected exceptions (an OS error on the shared filesystem) are tried again.
A dead worker's tasks are rescheduled by the scheduler (`distributed.scheduler.allowed-failures`)."""
MIN_CHUNK = 4
"""The smallest default chunk. Measured (`sketchgraph bench distributed`, docs/distributed.md): 1.6-3 ms per
task when tasks are queued, 10-12 ms for a lone round trip; a frame costs 10 ms (96x96) to 100+ ms (800x800),
so 4 frames a task keep the overhead under ~7% even at the smallest sizes."""
MAX_CHUNK = 32
"""The largest default chunk: past it, a lost worker costs more and the last chunks balance worse."""


# -- the renderer namespace of the shared cache ----------------------------------------------------------


class WorkerCache(Cache):
    """A worker's view of the shared cache: it never prunes (only the client does)."""

    def prune(self, limit: int | None = None) -> tuple[int, int]:
        return 0, 0


def namespaced_cache(root: str | Path | None, renderer: str, cls: type[Cache] = Cache) -> Cache:
    return cls(Path(root) if root else default_root(), renderer=renderer)


# -- what a task renders ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class PipeSpec:
    """A pipeline as every process can open it: a path every worker sees (or a shipped name), the
    overrides, size and scene, and the output (a name or NODE.PORT; None: the first)."""

    source: str
    overrides: tuple[str, ...] = ()
    size: str | None = None
    scene: str | None = None
    output: str | None = None
    view: str | None = None  # --view, --up: how a mesh-file scene is framed
    up: str | None = None
    fill: float | None = None  # --fill
    # --camera-type, --fov, --zoom as given where the spec was made (scene.views.LENS): workers apply them too
    lens: tuple[str | None, float | None, float | None] = (None, None, None)
    # --animation, --animation-end as given where the spec was made (scene.views.ANIMATION, ANIMATION_END)
    play: tuple[str | None, str | None] = (None, None)
    # --front as given where the spec was made (scene.views.FRONT: an axis, or the benchmarks' sides by file as
    # sorted (path, axis) pairs)
    facing: str | tuple[tuple[str, str], ...] | None = None
    camera: str | None = None  # --camera: a glTF (or scene YAML) camera by name or index
    fps: float | None = None  # --fps: the animation sampled at this rate

    @classmethod
    def make(cls, source: str | Path, overrides: Sequence[str] = (), size: str | None = None,
             scene: str | None = None, output: str | None = None, view: str | None = None,
             up: str | None = None, fill: float | None = None, camera: str | None = None,
             fps: float | None = None) -> PipeSpec:
        src = str(source)
        if Path(src).exists():
            src = str(Path(src).resolve())
        if scene is not None and not scene.startswith("builtin:") and Path(scene).exists():
            scene = str(Path(scene).resolve())
        from .scene.views import ANIMATION, ANIMATION_END, FRONT, LENS

        front = FRONT.get()
        return cls(src, tuple(overrides), size, scene, output, view, up, fill, lens=LENS.get(),
                   play=(ANIMATION.get(), ANIMATION_END.get()), facing=front if isinstance(front, (str, type(None)))
                   else tuple(sorted(front.items())), camera=camera, fps=fps)

    def open(self) -> Any:
        from .scene.animation import with_fps
        from .scene.scene import select_camera
        from .scene.views import facing, lens, playing

        sides = dict(self.facing) if isinstance(self.facing, tuple) else self.facing
        with lens(*self.lens), playing(*self.play), facing(sides):
            pipe = render.open_pipeline(self.source, self.overrides, self.size, self.scene, view=self.view,
                                        up=self.up, fill=self.fill)
            if pipe.scene is not None and (self.camera is not None or self.fps is not None):
                pipe.scene = with_fps(select_camera(pipe.scene, self.camera), self.fps)
            return pipe


def ref_of(pipe: Any, output: str | None) -> tuple[str, str]:
    if output is None:
        return next(iter(pipe.outputs.values()))
    if output in pipe.outputs:
        return pipe.outputs[output]
    if "." in output:
        return pipe.parse_ref(output)
    raise SketchgraphError(f"pipeline has no output '{output}'; outputs: {', '.join(pipe.outputs)}")


# -- errors across processes -----------------------------------------------------------------------------
@dataclass
class TaskFailure:
    """A task's SketchgraphError as plain data: its class (module:qualname), its one-line message and its
    attributes (only those that pickle)."""

    cls: str
    message: str
    attrs: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, exc: SketchgraphError) -> TaskFailure:
        import pickle

        attrs = {}
        for k, v in vars(exc).items():
            try:
                pickle.dumps(v)
            except Exception:  # noqa: BLE001 - what does not pickle stays behind
                continue
            attrs[k] = v
        return cls(f"{type(exc).__module__}:{type(exc).__qualname__}", str(exc), attrs)

    def error(self) -> SketchgraphError:
        mod, _, name = self.cls.partition(":")
        try:
            klass: Any = importlib.import_module(mod)
            for part in name.split("."):
                klass = getattr(klass, part)
            if not (isinstance(klass, type) and issubclass(klass, SketchgraphError)):
                raise TypeError(name)
        except Exception:  # noqa: BLE001 - an unknown class: the base class, same message
            klass = SketchgraphError
        exc = klass.__new__(klass)
        Exception.__init__(exc, self.message)
        exc.__dict__.update(self.attrs)
        return exc


def remote_error(exc: BaseException) -> SketchgraphError:
    """An exception a future raised on the client, as the one line a local run prints."""
    if isinstance(exc, SketchgraphError):
        return exc
    name = type(exc).__name__
    if name == "KilledWorker":
        return SketchgraphError(f"a task failed on every worker it was tried on (workers died: out of memory, "
                                f"killed or crashed): {one_line(exc)}")
    return SketchgraphError(one_line(exc))


# -- the worker side -------------------------------------------------------------------------------------
class WorkerState:
    """What one worker process keeps between tasks: its GL context (created on first use), the shared cache
    in its renderer's namespace, opened pipelines, and the last executor with its in-memory values."""

    def __init__(self, cache_root: str | None | bool = None, address: str = "") -> None:
        self.cache_root = cache_root
        self.address = address
        self._caches: dict[str | None, Cache] = {}
        self._pipes: OrderedDict[PipeSpec, Any] = OrderedDict()
        self._executor: Any = None
        self.tasks = 0

    @property
    def gl(self) -> Any:
        from .gpu import gl as glmod

        return glmod.get()

    @property
    def renderer(self) -> str:
        return self.gl.renderer

    @property
    def cache(self) -> Cache | None:
        return self.cache_for(self.cache_root)

    def cache_for(self, root: str | Path | None | bool) -> Cache | None:
        """The shared cache at `root` (None: the default root; False: none), in this renderer's namespace."""
        if root is False:
            return None
        name = None if root in (None, True) else str(root)
        cache = self._caches.get(name)
        if cache is None:
            cache = self._caches[name] = namespaced_cache(name, self.renderer, WorkerCache)
        return cache

    def pipeline(self, spec: PipeSpec, cache_root: str | Path | None | bool = None) -> Any:
        """`spec` opened (kept for later tasks); a mesh file another process parsed before is read from the
        shared cache at `cache_root` (nodegraph/scene/meshstore.py; False: no cache, parsed here)."""
        pipe = self._pipes.get(spec)
        if pipe is None:
            from .scene import meshstore

            meshstore.use_cache(None if cache_root is False else
                                Cache(None if cache_root in (None, True) else Path(str(cache_root))))
            pipe = self._pipes[spec] = spec.open()
            while len(self._pipes) > 8:
                self._pipes.popitem(last=False)
        else:
            self._pipes.move_to_end(spec)
        return pipe

    def executor(self, pipe: Any, refs: list[tuple[str, str]], mode: str, frame: int, like: Any = None,
                 cache: Any = ...) -> Any:
        """The executor of the last task when it ran the same pipeline and outputs, else a new one that
        adopts its in-memory values (content-addressed: only unchanged keys are reused)."""
        from .executor import Executor

        cache = self.cache if cache is ... else cache
        old = self._executor
        if (old is not None and like is None and old.pipeline is pipe and old.mode == mode and old.cache is cache
                and list(old.plan.requested) == refs):
            return old
        ex = Executor(pipe, cache, mode=mode, requested=refs, like=like)
        ex.adopt_memory(old, frame)
        if old is not None:
            old.close()
        self._executor = ex
        return ex

    def close(self) -> None:
        if self._executor is not None:
            self._executor.clear_memory()
            self._executor.close()
            self._executor = None


class SketchgraphPlugin(WorkerPlugin):
    """Registered on every worker (also those that join or restart later): sets llvmpipe's thread count
    before the GL context exists and keeps the `WorkerState`."""

    name = PLUGIN_NAME

    def __init__(self, cache_root: str | None | bool = None, lp_threads: int | None = None) -> None:
        self.cache_root = cache_root
        self.lp_threads = lp_threads
        self.state: WorkerState | None = None

    def setup(self, worker: Any) -> None:
        if self.lp_threads and "LP_NUM_THREADS" not in os.environ:
            os.environ["LP_NUM_THREADS"] = str(self.lp_threads)
        self.state = WorkerState(self.cache_root, getattr(worker, "address", ""))

    def teardown(self, worker: Any) -> None:
        if self.state is not None:
            self.state.close()


_LOCAL_STATE: WorkerState | None = None


def worker_threads(worker: Any) -> int:
    """How many threads run tasks on `worker` (a `distributed.Worker`): `worker.state.nthreads` (the worker state
    machine, distributed >= 2022.11; `Worker.nthreads` is gone there), else the older `worker.nthreads`, else the
    size of its default executor's pool."""
    n = getattr(getattr(worker, "state", None), "nthreads", None)
    if n is None:
        n = getattr(worker, "nthreads", None)
    if n is None:
        n = getattr(getattr(worker, "executors", {}).get("default"), "_max_workers", 1)
    return int(n)


def threads_message(scheduler: str, worker: str, threads: int) -> str:
    return (f"{scheduler}: worker {worker} has {threads} threads; sketchgraph needs --nthreads 1 per worker "
            "(one GL context each)")


def worker_state() -> WorkerState:
    """This worker's state (the plugin's); outside a worker, one for the process. A worker must run one
    thread: its GL context is current in one thread only."""
    global _LOCAL_STATE
    try:
        from distributed import get_worker

        worker = get_worker()
    except ValueError:
        worker = None
    if worker is not None:
        threads = worker_threads(worker)
        if threads != 1:  # refused before this task touches GL: nothing is rendered by a worker of 2+ threads
            scheduler = getattr(getattr(worker, "scheduler", None), "address", None) or "the scheduler"
            raise SketchgraphError(threads_message(scheduler, worker.address, threads))
        plugin = worker.plugins.get(PLUGIN_NAME)
        if plugin is not None and getattr(plugin, "state", None) is not None:
            return plugin.state
    if _LOCAL_STATE is None:
        _LOCAL_STATE = WorkerState()
    return _LOCAL_STATE


def worker_renderer() -> str:
    return worker_state().renderer


def _disk_hits(result: Any) -> int:
    return sum(1 for s in result.stats.values() if s.status == "disk")


def render_frames_task(spec: PipeSpec, frames: list[int], pattern: str, many: bool,
                       cache_root: str | None | bool = None) -> dict[str, Any]:
    """Render `frames` and write each to `pattern`; returns metadata only (or the error as a value)."""
    t0 = time.perf_counter()
    try:
        state = worker_state()
        fresh = state.tasks == 0
        state.tasks += 1
        pipe = state.pipeline(spec, cache_root)
        ref = ref_of(pipe, spec.output)
        ex = state.executor(pipe, [ref], "loop" if many else "single", frames[0], cache=state.cache_for(cache_root))
        out = []
        # each frame is written during the next one's run, once that run's first pass is issued, as
        # `film.render_frames` does: a PNG frame's 8-bit pass is issued then and read back, compressed and
        # written at the hand-over after (`GL.pack_png`: the read does not wait); a frame's `ms` is its own run
        # and its own conversion and write, not the overlap
        pending: list[tuple[int, Any, float]] = []
        packed: list[tuple[int, Any, float, Path, Any]] = []  # (frame, result, ms so far, path, pack)
        handed_ms = 0.0  # time the current run spent writing the frames before it
        unsynced: list[Path] = []  # PNG frames written unsynced: synced together before the task reports them
        from .gpu.gl import PngRowsBuffer

        rows = PngRowsBuffer()  # the frames' rows, laid out one after another in one buffer

        def record(frame: int, result: Any, ms: float, path: Path) -> None:
            out.append({"frame": frame, "digest": frame_digest(result.stats[ref[0]].key, ref[1], path.suffix),
                        "sha256": file_sha256(path), "path": str(path), "hits": _disk_hits(result), "ms": ms})

        def hand_over(last: bool = False) -> None:
            nonlocal handed_ms
            t2 = time.perf_counter()
            while packed:
                frame, result, ms, target, pack = packed.pop(0)
                t3 = time.perf_counter()
                path = write.PngRows(pack.read()).write(target, sync=False, rows_buffer=rows)
                unsynced.append(path)
                record(frame, result, ms + (time.perf_counter() - t3) * 1000, path)
            while pending:
                frame, result, run_ms = pending.pop(0)
                t3 = time.perf_counter()
                target = write.frame_path(pattern, frame, many)
                value = result.values[ref]
                if target.suffix.lower() == ".png" and isinstance(value, Tex):
                    pack = ex.gl.pack_png(value)
                    packed.append((frame, result, run_ms + (time.perf_counter() - t3) * 1000, target, pack))
                else:
                    path = write.write_frame(value, target, lambda: ex.gl)
                    record(frame, result, run_ms + (time.perf_counter() - t3) * 1000, path)
            if last and packed:
                hand_over()
            handed_ms += (time.perf_counter() - t2) * 1000

        for frame in frames:
            t1 = time.perf_counter()
            handed_ms = 0.0
            result = ex.run(frame, before_wait=hand_over)
            pending.append((frame, result, (time.perf_counter() - t1) * 1000 - handed_ms))
        hand_over(last=True)
        sync_written(unsynced)
        if ex.cache is not None:
            ex.cache.flush()
    except SketchgraphError as exc:
        return {"error": TaskFailure.of(exc)}
    return {"worker": state.address, "pid": os.getpid(), "fresh": fresh, "frames": out, "renderer": state.renderer,
            "ms": (time.perf_counter() - t0) * 1000}


def prepare_task(spec: PipeSpec, refs: list[tuple[str, str]], frame: int,
                 cache_root: str | None | bool = None) -> dict[str, Any]:
    """Compute the given (frame-independent) ports once and persist them to the shared cache, in the formats
    the full render plans for them (so that its tasks find the entries)."""
    from .plan import plan

    t0 = time.perf_counter()
    try:
        state = worker_state()
        pipe = state.pipeline(spec, cache_root)
        ex = state.executor(pipe, refs, "loop", frame, like=plan(pipe, [ref_of(pipe, spec.output)]),
                            cache=state.cache_for(cache_root))
        result = ex.run(frame)
        stored = 0
        if ex.cache is not None:
            for nid, port in refs:
                node = pipe.nodes[nid]
                key = result.stats[nid].key
                if node.persist != "never" and not node.side_effect and not ex.is_stored(nid, port, key):
                    ex.store(nid, port, key, result.values[(nid, port)])
                    stored += 1
            ex.cache.flush()
    except SketchgraphError as exc:
        return {"error": TaskFailure.of(exc)}
    return {"worker": state.address, "stored": stored, "computed": result.computed(), "renderer": state.renderer,
            "ms": (time.perf_counter() - t0) * 1000}


def noop_task(x: Any = None) -> Any:
    """For measuring the per-task overhead."""
    return x


# -- frame-independent nodes -----------------------------------------------------------------------------
def shared_frontier(pipe: Any, ref: tuple[str, str], key_sets: Sequence[dict[str, str]]) -> list[tuple[str, str]]:
    """The ports of nodes whose key is the same in every key set (frames, wedge cells) that feed a node whose
    key changes: computing these once makes every other unchanged node unnecessary downstream."""
    from .plan import plan

    if len(key_sets) < 2:
        return []
    first = key_sets[0]
    same = {nid for nid, k in first.items() if all(ks.get(nid) == k for ks in key_sets[1:])}
    p = plan(pipe, [ref])

    def source(nid: str, port: str) -> tuple[str, str]:
        seen = 0
        while (nid, port) in p.aliases and seen < 1000:
            nid, port = p.aliases[(nid, port)]
            seen += 1
        return nid, port

    out: list[tuple[str, str]] = []
    for nid in p.order:
        if nid in same:
            continue
        for _port, (src, sport) in sorted(p.read_connections(nid).items()):
            s = source(src, sport)
            node = pipe.nodes[s[0]]
            if s[0] in same and s not in out and node.persist != "never" and not node.side_effect:
                out.append(s)
    return out


# -- connecting ------------------------------------------------------------------------------------------
def lp_threads_for(n_workers: int, cores: int | None = None) -> int:
    return max(1, (cores or os.cpu_count() or 1) // max(1, n_workers))


LOCAL_MAX_WORKERS = 256
"""`local:N` accepts N from 1 to this."""
ADDRESS_MAX_CHARS = 300
"""The longest `--scheduler` address accepted (a host name is at most 253 characters)."""
SCHEMES = ("tcp", "tls")
"""The schemes of a running scheduler's address (`tcp://HOST:PORT`, `tls://HOST:PORT`)."""
CONNECT_TIMEOUT = 10.0
"""Seconds to reach a running scheduler: the TCP connection (a refused one fails at once, without waiting),
then the Dask handshake (`Client(timeout=)`)."""
NO_WORKERS_TIMEOUT = 60.0
"""A run fails with one line once the cluster has had no live worker for this many seconds (a tcp cluster that
lost its workers, or never had any, would otherwise wait forever). Tests lower it."""
WATCH_INTERVAL = 1.0
"""While no task finishes, the client asks the scheduler for its workers this often (one small request)."""

_LABEL = r"[A-Za-z0-9_]([A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?"
_HOST = re.compile(rf"{_LABEL}(\.{_LABEL})*\.?")  # a host name (labels of up to 63 characters) or an IPv4 address
_EXPECTED = f"expected local:N (N from 1 to {LOCAL_MAX_WORKERS}), tcp://HOST:PORT or tls://HOST:PORT"


@dataclass(frozen=True)
class SchedulerAddress:
    """A parsed `--scheduler`: `local:N` (scheme 'local', workers N) or SCHEME://HOST:PORT."""

    scheme: str
    host: str = ""
    port: int = 0
    workers: int = 0

    @property
    def address(self) -> str:
        if self.scheme == "local":
            return f"local:{self.workers}"
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{self.scheme}://{host}:{self.port}"


def _show(text: str, limit: int = 60) -> str:
    """`text` for an error line: at most `limit` characters, control characters and whitespace other than a
    space escaped."""
    cut = text[:limit]
    shown = "".join(c if c.isprintable() else repr(c)[1:-1] for c in cut)
    return shown + ("…" if len(text) > limit else "")


def parse_scheduler(text: str) -> SchedulerAddress:
    """`--scheduler` checked before anything connects: `local:N`, `tcp://HOST:PORT` or `tls://HOST:PORT` (HOST a
    name, an IPv4 address or a bracketed IPv6 address; PORT 1 to 65535); else one line saying what is wrong."""

    def bad(problem: str) -> SketchgraphError:
        return SketchgraphError(f"--scheduler '{_show(text)}': {problem}; {_EXPECTED}")

    if len(text) > ADDRESS_MAX_CHARS:
        raise SketchgraphError(f"--scheduler '{_show(text)}': address too long ({len(text)} characters, at most "
                               f"{ADDRESS_MAX_CHARS}); {_EXPECTED}")
    stripped = text.strip()
    if not stripped:
        raise SketchgraphError(f"--scheduler: empty address; {_EXPECTED}")
    if any(c.isspace() or not c.isprintable() for c in stripped):
        raise bad("whitespace or control characters inside the address")
    if stripped.lower().startswith("local:"):
        n = stripped[6:]
        if not n.isascii() or not n.isdigit() or not 1 <= int(n) <= LOCAL_MAX_WORKERS:
            raise bad(f"N must be a whole number from 1 to {LOCAL_MAX_WORKERS}")
        return SchedulerAddress("local", workers=int(n))
    scheme, sep, rest = stripped.partition("://")
    if not sep:
        hint = f" (did you mean tcp://{stripped}?)" if re.fullmatch(r"[^:/]+:\d+", stripped) else ""
        raise bad(f"no scheme{hint}")
    scheme = scheme.lower()
    if scheme not in SCHEMES:
        raise bad(f"unsupported scheme '{_show(scheme, 20)}'")
    if not rest:
        raise bad("no host and port")
    for c in "/?#@":
        if c in rest:
            raise bad(f"unexpected '{c}' after the scheme (give HOST:PORT only)")
    if rest.startswith("["):
        host, close, port = rest[1:].partition("]")
        if not close:
            raise bad("an IPv6 host needs its closing ']'")
        try:
            ipaddress.IPv6Address(host)
        except ValueError:
            raise bad(f"'{_show(host, 40)}' is not an IPv6 address") from None
        if not port.startswith(":"):
            raise bad("no port (give [HOST]:PORT)")
        port = port[1:]
    else:
        host, colon, port = rest.rpartition(":")
        if not colon:
            raise bad("no port (give HOST:PORT)")
        if not host:
            raise bad("no host")
        if ":" in host:
            raise bad("an IPv6 host goes in brackets: [HOST]:PORT")
        if len(host) > 253 or not _HOST.fullmatch(host):
            raise bad(f"'{_show(host, 40)}' is not a host name or address")
    if not port:
        raise bad("no port")
    if not port.isascii() or not port.isdigit() or len(port) > 5 or not 1 <= int(port) <= 65535:
        raise bad(f"port '{_show(port, 20)}' is not a number from 1 to 65535")
    return SchedulerAddress(scheme, host, int(port))


def probe(addr: SchedulerAddress, timeout: float | None = None) -> None:
    """Open (and close) a TCP connection to a scheduler's address: a refused connection, a host that does not
    resolve or one that does not answer within `timeout` (`CONNECT_TIMEOUT`) fail here with one line instead
    of inside `distributed.Client`, which retries a refused connection until its own timeout."""
    import socket

    timeout = CONNECT_TIMEOUT if timeout is None else timeout
    hint = f"start one with `dask scheduler --host {addr.host} --port {addr.port}` (docs/distributed.md)"
    try:
        with socket.create_connection((addr.host, addr.port), timeout=timeout):
            pass
    except socket.gaierror as exc:
        raise SketchgraphError(f"--scheduler {addr.address}: cannot resolve host '{_show(addr.host, 60)}' "
                               f"({exc.strerror})") from None
    except ConnectionRefusedError:
        raise SketchgraphError(f"--scheduler {addr.address}: connection refused (no scheduler listens there); "
                               f"{hint}") from None
    except TimeoutError:
        raise SketchgraphError(f"--scheduler {addr.address}: no answer within {timeout:g} s (connect timeout)") \
            from None
    except OSError as exc:
        raise SketchgraphError(f"--scheduler {addr.address}: cannot connect ({exc.strerror or one_line(exc)})") \
            from None


@contextlib.contextmanager
def connect(scheduler: Any, *, cache_root: str | Path | None | bool = None) -> Iterator[Any]:
    """A `distributed.Client` for `local:N`, `tcp://host:port`, `tls://host:port` or a Client (used as it is, not
    closed), with the sketchgraph plugin registered on every worker. The address is checked before anything
    connects (`parse_scheduler`); a running scheduler must accept the connection within `CONNECT_TIMEOUT`; a
    worker of more than one thread is refused (`check_workers`)."""
    import dask
    from distributed import Client, LocalCluster

    root: str | None | bool = str(cache_root) if isinstance(cache_root, (str, Path)) else cache_root
    if not isinstance(scheduler, str):
        ensure_plugin(scheduler, root)
        yield scheduler
        return
    addr = parse_scheduler(scheduler)
    config = {"distributed.worker.multiprocessing-method": "spawn",  # never fork a process holding GL
              "distributed.scheduler.allowed-failures": 3,
              "distributed.worker.daemon": True}
    if addr.scheme == "local":
        n = addr.workers
        lp = lp_threads_for(n)
        env = {"LP_NUM_THREADS": str(lp)}
        if isinstance(root, str):
            env["SKETCHGRAPH_CACHE_DIR"] = root
        with dask.config.set(config):
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=None, silence_logs=logging.ERROR, env=env,
                                   worker_dashboard_address=None)
            try:
                client = Client(cluster)
                try:
                    ensure_plugin(client, root, lp)
                    yield client
                finally:
                    client.close()
            finally:
                cluster.close()
        return
    probe(addr)
    with dask.config.set(config):
        try:
            client = Client(addr.address, timeout=f"{CONNECT_TIMEOUT}s")
        except Exception as exc:  # noqa: BLE001 - refused, timed out, a TLS or handshake failure: one line
            raise SketchgraphError(f"--scheduler {addr.address}: no Dask scheduler answered within "
                                   f"{CONNECT_TIMEOUT:g} s ({one_line(exc)})") from None
        try:
            ensure_plugin(client, root)
            yield client
        finally:
            client.close()


def scheduler_address(client: Any) -> str:
    return str(getattr(getattr(client, "scheduler", None), "address", None) or "the scheduler")


def worker_threads_of(client: Any) -> dict[str, int]:
    """Each live worker's thread count, as the scheduler knows it (`Client.nthreads`)."""
    try:
        return {str(w): int(n) for w, n in client.nthreads().items()}
    except Exception as exc:  # noqa: BLE001 - the scheduler went away: one line
        raise SketchgraphError(f"{scheduler_address(client)}: lost the scheduler ({one_line(exc)})") from None


def check_workers(client: Any, threads: dict[str, int] | None = None) -> None:
    """Refuse a cluster with a worker of more than one thread, before anything renders there: a worker process
    holds one GL context, which one thread may use (two threads render garbage or crash the process)."""
    threads = worker_threads_of(client) if threads is None else threads
    bad = sorted((w, n) for w, n in threads.items() if n != 1)
    if bad:
        more = f" (and {len(bad) - 1} more such workers)" if len(bad) > 1 else ""
        raise SketchgraphError(threads_message(scheduler_address(client), bad[0][0], bad[0][1]) + more)


class WorkerWatch:
    """Called while no task finishes: fails with one line once the cluster has had no live worker for
    `timeout` seconds (`NO_WORKERS_TIMEOUT`), or as soon as a worker of more than one thread joined."""

    def __init__(self, client: Any, timeout: float | None = None, left: Callable[[], str] | None = None) -> None:
        self.client = client
        self.timeout = NO_WORKERS_TIMEOUT if timeout is None else timeout
        self.left = left
        self.since: float | None = None

    def check(self) -> None:
        threads = worker_threads_of(self.client)
        check_workers(self.client, threads)
        now = time.monotonic()
        if threads:
            self.since = None
            return
        if self.since is None:
            self.since = now
        if now - self.since >= self.timeout:
            addr = scheduler_address(self.client)
            left = f"; {self.left()}" if self.left is not None else ""
            raise SketchgraphError(f"{addr}: no live workers for {self.timeout:g} s (all lost, or none joined)"
                                   f"{left}; start workers with `dask worker {addr} --nthreads 1`")


def completed(client: Any, futures: Sequence[Any], timeout: float | None = None,
              left: Callable[[], str] | None = None, watch: WorkerWatch | None = None) -> Iterator[Any]:
    """`futures` as they finish (like `distributed.as_completed`), failing with one line once the cluster has
    had no live worker for `timeout` seconds (`NO_WORKERS_TIMEOUT`): a scheduler keeps tasks that no worker can
    run waiting forever. `watch`: the WorkerWatch to check (its time without workers shared with the caller's
    `watched_result` waits); else one of its own."""
    import queue

    done: queue.SimpleQueue[Any] = queue.SimpleQueue()
    for fut in futures:
        fut.add_done_callback(done.put)
    watch = watch or WorkerWatch(client, timeout, left)
    for _ in range(len(futures)):
        while True:
            try:
                fut = done.get(timeout=WATCH_INTERVAL)
                break
            except queue.Empty:
                watch.check()
        watch.since = None
        yield fut


def watched_result(fut: Any, watch: WorkerWatch) -> Any:
    """`fut.result()`, with `watch.check()` every WATCH_INTERVAL while it waits. A finished task whose result
    lived on a worker lost before the client gathered it is scheduled again ("Couldn't gather ... rescheduling"),
    and with no worker left `result()` would wait forever."""
    while True:
        try:
            return fut.result(timeout=WATCH_INTERVAL)
        except TimeoutError:
            if getattr(fut, "status", None) in ("error", "cancelled"):
                raise  # the task's own error, not the wait
            watch.check()


def result(client: Any, future: Any, timeout: float | None = None) -> Any:
    """`future.result()`, failing with one line once the cluster has had no live worker for `timeout` s."""
    watch = WorkerWatch(client, timeout)
    for fut in completed(client, [future], watch=watch):
        return watched_result(fut, watch)
    raise AssertionError("unreachable")


def ensure_plugin(client: Any, cache_root: str | None | bool = None, lp_threads: int | None = None) -> None:
    """Check the workers' threads (`check_workers`), and register the plugin once per client (workers that
    join later get it too)."""
    check_workers(client)
    done = getattr(client, "_sketchgraph_plugin", None)
    if done == (cache_root, lp_threads):
        return
    client.register_plugin(SketchgraphPlugin(cache_root, lp_threads), name=PLUGIN_NAME)
    client._sketchgraph_plugin = (cache_root, lp_threads)


def n_workers(client: Any) -> int:
    return max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))


def default_chunk(frames: int, workers: int) -> int:
    """At least four chunks per worker (balance, and a lost worker costs little), at least `MIN_CHUNK` frames
    each (the per-task overhead), at most `MAX_CHUNK`."""
    return max(1, min(frames, max(MIN_CHUNK, min(MAX_CHUNK, math.ceil(frames / (4 * max(1, workers)))))))


def chunks(items: Sequence[int], size: int) -> list[list[int]]:
    return [list(items[i:i + size]) for i in range(0, len(items), size)]


def task_attempts(client: Any, keys: list[str], retries: int) -> int:
    """How many times tasks were run again: retries used plus reschedules after a worker died."""

    def count(dask_scheduler: Any, keys: list[str], retries: int) -> int:
        total = 0
        for k in keys:
            ts = dask_scheduler.tasks.get(k)
            if ts is not None:
                total += int(getattr(ts, "suspicious", 0)) + max(0, retries - int(getattr(ts, "retries", retries)))
        return total

    try:
        return int(client.run_on_scheduler(count, keys=keys, retries=retries))
    except Exception:  # noqa: BLE001 - a figure for the summary only
        return 0


# -- sinks for video outputs -----------------------------------------------------------------------------
class FrameSink(Protocol):
    """What a video encoder offers the client: frames in order, then close."""

    def add(self, frame: int, rgb: Any) -> None: ...

    def close(self) -> None: ...


class _FilmSink:
    """`nodegraph.output.film.FilmWriter` behind the sink protocol: frames arrive in order; `abort` on a failure
    removes the partial film, so the output is a complete film or nothing."""

    def __init__(self, path: Path, fps: float, size: tuple[int, int], crf: int | None = None) -> None:
        from .output.film import FilmWriter

        self._film = FilmWriter(path, fps, size, crf)

    def add(self, frame: int, rgb: Any) -> None:
        self._film.write(rgb)

    def close(self) -> None:
        self._film.close()

    def abort(self) -> None:
        self._film.abort()


def open_sink(path: Path, fps: float, size: tuple[int, int], crf: int | None = None) -> FrameSink:
    """The film encoder (`nodegraph.output.film`) for a video path."""
    return _FilmSink(path, fps, size, crf)


def video_frames_dir(path: str | Path) -> Path:
    p = Path(path)
    return p.parent / f".{p.name}.frames"


# -- the client side -------------------------------------------------------------------------------------
@dataclass
class RunReport:
    frames: int = 0
    rendered: int = 0
    skipped: int = 0  # finished by an earlier run (--resume)
    chunk: int = 0
    tasks: int = 0
    retries: int = 0
    cache_hits: int = 0
    per_worker: Counter[str] = field(default_factory=Counter)
    prepared: list[str] = field(default_factory=list)  # NODE.PORT computed once, first
    prepare_s: float = 0.0
    wall_s: float = 0.0
    task_ms: list[float] = field(default_factory=list)
    frame_ms: list[float] = field(default_factory=list)

    def fps(self) -> float:
        return self.rendered / self.wall_s if self.wall_s > 0 else 0.0

    def format(self) -> str:
        workers = ", ".join(f"{w.rsplit('/', 1)[-1] or w}: {n}" for w, n in sorted(self.per_worker.items()))
        lines = [f"{self.rendered} frames rendered in {self.wall_s:.1f} s ({self.fps():.1f} frames/s) in "
                 f"{self.tasks} tasks of up to {self.chunk} frames; {self.skipped} already done",
                 f"frames per worker: {workers or 'none'}; retries: {self.retries}; cache hits: {self.cache_hits}"]
        if self.prepared:
            lines.append(f"frame-independent, computed once first ({self.prepare_s:.1f} s): "
                         + ", ".join(self.prepared))
        return "\n".join(lines)


class FrameRun:
    """Render frames on a cluster; iterating yields (frame, path) in frame order as frames arrive (frames a
    resumed run skips included). `report` holds the summary once the iteration is over."""

    def __init__(self, client: Any, spec: PipeSpec, frames: Sequence[int], pattern: str | Path, *,
                 chunk: int | None = None, resume: bool = False, retries: int = RETRIES, progress: bool = False,
                 cache_root: str | Path | None | bool = None, resources: dict[str, float] | None = None,
                 many: bool | None = None, manifest: bool = True) -> None:
        self.client = client
        self.spec = spec
        self.frames = [int(f) for f in frames]
        if len(set(self.frames)) != len(self.frames):
            raise SketchgraphError("frames: each frame may be named once")
        self.pattern = str(pattern)
        self.many = len(self.frames) > 1 if many is None else many
        self.chunk = chunk
        if chunk is not None and chunk < 1:
            raise SketchgraphError(f"--chunk: expected at least 1 frame, found {chunk}")
        self.resume = resume
        self.retries = retries
        self.progress = progress
        self.cache_root = cache_root
        self.resources = resources
        self.use_manifest = manifest
        self.report = RunReport(frames=len(self.frames))
        self.renderers: set[str] = set()
        self.pipe = spec.open()  # every load-time error here, before any task
        self.ref = ref_of(self.pipe, spec.output)

    def path(self, frame: int) -> Path:
        return write.frame_path(self.pattern, frame, self.many)

    def __iter__(self) -> Iterator[tuple[int, Path]]:
        from .executor import Executor

        t0 = time.perf_counter()
        rep = self.report
        root = _root_arg(self.cache_root)
        ensure_plugin(self.client, root)
        planner = Executor(self.pipe, None, requested=[self.ref])
        keysets = {f: planner.keys(f) for f in self.frames}
        suffix = Path(self.pattern).suffix
        digests = {f: frame_digest(keysets[f][self.ref[0]], self.ref[1], suffix) for f in self.frames}
        manifest = FramesManifest.load(self.pattern) if self.use_manifest else None
        done: dict[int, Path] = {}
        if manifest is not None and self.resume:
            for f in self.frames:
                if manifest.done(f, digests[f], self.path(f)):
                    done[f] = self.path(f)
        todo = [f for f in self.frames if f not in done]
        rep.skipped = len(done)
        if manifest is not None:
            for f in todo:
                manifest.forget(f)
        bar = _bar(len(self.frames), len(done), not self.progress)
        order = iter(self.frames)
        next_frame = next(order, None)
        futures: list[Any] = []
        others: list[Any] = []  # the prepare task's
        try:
            while next_frame is not None and next_frame in done:  # what a resumed run finished already
                yield next_frame, done[next_frame]
                next_frame = next(order, None)
            if not todo:
                return
            workers = n_workers(self.client)
            # with one worker there is nothing to share: its executor keeps those values in memory
            refs = shared_frontier(self.pipe, self.ref, [keysets[f] for f in todo]) if workers > 1 else []
            if refs and len(todo) > 1:
                t1 = time.perf_counter()
                fut = self.client.submit(prepare_task, self.spec, refs, todo[0], root, retries=self.retries, pure=False,
                                         key=f"sketchgraph-prepare-{uuid.uuid4().hex[:12]}", resources=self.resources)
                others.append(fut)
                try:
                    res = result(self.client, fut)
                except SketchgraphError:
                    raise
                except Exception as exc:  # noqa: BLE001 - one line, as a local run prints
                    raise remote_error(exc) from None
                _raise_failure(res)
                rep.prepared = [f"{n}.{p}" for n, p in refs]
                rep.prepare_s = time.perf_counter() - t1
            size = self.chunk or default_chunk(len(todo), workers)
            rep.chunk = size
            token = uuid.uuid4().hex[:12]
            for i, part in enumerate(chunks(todo, size)):
                futures.append(self.client.submit(render_frames_task, self.spec, part, self.pattern, self.many, root,
                                                  key=f"sketchgraph-frames-{token}-{i:05d}", retries=self.retries,
                                                  pure=False, resources=self.resources))
            rep.tasks = len(futures)

            def left() -> str:
                return f"{len(self.frames) - len(done)} of {len(self.frames)} frames not rendered (--resume goes on)"

            watch = WorkerWatch(self.client, left=left)
            for fut in completed(self.client, futures, watch=watch):
                try:
                    res = watched_result(fut, watch)
                except SketchgraphError:
                    raise
                except Exception as exc:  # noqa: BLE001 - one line, as a local run prints
                    raise remote_error(exc) from None
                _raise_failure(res)
                self.renderers.add(res["renderer"])
                rep.task_ms.append(res["ms"])
                for rec in res["frames"]:
                    f = rec["frame"]
                    done[f] = Path(rec["path"])
                    rep.rendered += 1
                    rep.cache_hits += rec["hits"]
                    rep.frame_ms.append(rec["ms"])
                    rep.per_worker[res["worker"]] += 1
                    if manifest is not None:
                        manifest.record(f, rec["digest"], rec["sha256"])
                if manifest is not None:
                    manifest.save(every=1.0)
                bar.update(len(res["frames"]))
                while next_frame is not None and next_frame in done:
                    yield next_frame, done[next_frame]
                    next_frame = next(order, None)
            rep.retries = task_attempts(self.client, [f.key for f in futures], self.retries)
        finally:
            for fut in futures + others:
                if not fut.done():
                    fut.cancel()
            if manifest is not None:
                manifest.save()
            bar.close()
            rep.wall_s = time.perf_counter() - t0
            self._prune()

    def _prune(self) -> None:
        """Only the client prunes the shared cache (each renderer's namespace the workers wrote into)."""
        if self.cache_root is False:
            return
        prune_shared(self.cache_root, self.renderers)


def prune_shared(cache_root: Any, renderers: set[str]) -> None:
    """Prune the shared cache after the workers wrote into it (the client's job; workers never prune). One
    prune covers every renderer's namespace under the root (`Cache.prune` scans them all)."""
    if cache_root is False or not renderers:
        return
    root = _root_arg(cache_root)
    with contextlib.suppress(Exception):
        Cache(Path(root) if isinstance(root, str) else None).prune()


def worker_renderers(client: Any) -> dict[str, str]:
    """Each worker's GL renderer, asked through a task on that worker (so the context is made in the thread
    that renders, never in the worker's event loop as `client.run` would)."""
    addrs = list(client.scheduler_info(n_workers=-1).get("workers", {}))
    futs = {a: client.submit(worker_renderer, key=f"sketchgraph-renderer-{uuid.uuid4().hex[:12]}", workers=[a],
                             allow_other_workers=False, pure=False) for a in addrs}
    out = {}
    for a, f in futs.items():
        try:
            out[a] = result(client, f)
        except SketchgraphError:
            raise
        except Exception as exc:  # noqa: BLE001
            raise remote_error(exc) from None
    return out


def _root_arg(cache_root: Any) -> str | None | bool:
    if isinstance(cache_root, (str, Path)):
        return str(cache_root)
    return cache_root


def _raise_failure(res: Any) -> None:
    if isinstance(res, dict) and isinstance(res.get("error"), TaskFailure):
        raise res["error"].error()


def _bar(total: int, initial: int, disable: bool) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, disable=disable or not sys.stderr.isatty(), unit="frame",
                file=sys.stderr, leave=False, dynamic_ncols=True, smoothing=0.1)


def render_frames(client: Any, spec: PipeSpec, frames: Sequence[int], out: str | Path, *,
                  chunk: int | None = None, resume: bool = False, progress: bool = False,
                  cache_root: str | Path | None | bool = None, retries: int = RETRIES,
                  on_frame: Callable[[int, Path], None] | None = None, sink: FrameSink | None = None,
                  fps: float = 24.0, resources: dict[str, float] | None = None, crf: int | None = None) -> RunReport:
    """Render `frames` of `spec` to `out` (a frame pattern, or a video file through `sink`, encoded at `fps` with
    `crf`), on the cluster behind `client`. `on_frame(frame, path)` is called in frame order as frames arrive."""
    out = Path(out)
    if out.suffix.lower() in VIDEO_SUFFIXES:
        tmp = video_frames_dir(out)
        run = FrameRun(client, spec, frames, tmp / "f_########.png", chunk=chunk, resume=resume, progress=progress,
                       cache_root=cache_root, retries=retries, resources=resources, many=True)
        if sink is None:
            sink = open_sink(out, fps, run.pipe.size, crf)
        from .output.imageio import read, to_uint8

        try:
            for frame, path in run:
                rgb = to_uint8(read(path)[::-1][:, :, :3])  # files are top-down; read() gives bottom-up
                sink.add(frame, rgb)
                if on_frame is not None:
                    on_frame(frame, path)
        except BaseException:
            with contextlib.suppress(Exception):
                (getattr(sink, "abort", None) or sink.close)()
            raise
        sink.close()
        shutil.rmtree(tmp, ignore_errors=True)  # kept after a failure: --resume picks up from it
        return run.report
    run = FrameRun(client, spec, frames, out, chunk=chunk, resume=resume, progress=progress, cache_root=cache_root,
                   retries=retries, resources=resources)
    for frame, path in run:
        if on_frame is not None:
            on_frame(frame, path)
    return run.report


def scratch_dir(cache_root: str | Path | None | bool, prefix: str) -> Path:
    """A temporary folder every worker sees: under the shared cache root (two levels down, so the cache never
    takes its files for entries), else the system's temporary folder."""
    base = (Path(cache_root) if isinstance(cache_root, (str, Path)) else default_root()) / ".tmp"
    if cache_root is False:
        base = Path(tempfile.gettempdir())
    base.mkdir(parents=True, exist_ok=True)
    return Path(tempfile.mkdtemp(prefix=prefix, dir=base))
