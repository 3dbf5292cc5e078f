"""Execution of a plan (`nodegraph.plan`).

`Executor.run()` computes each planned node's key (cheap, no GPU), then
materialises values backwards from the requested outputs: from the in-memory cache (GPU textures
kept across frames), else from the disk cache, else by `compute()`, whose inputs are materialised
the same way. So a node whose output is cached never causes its ancestors to load or run.
"""

from __future__ import annotations

import time
import warnings
from collections import OrderedDict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import Any

from . import types
from .cache import Cache, CacheWarning, Expect, kind_of_port, value_mismatch
from .errors import NodeError, PipelineError, SketchgraphError, one_line
from .node import HashContext, Node, RunContext
from .pipeline import Pipeline, PortRef
from .plan import Plan, plan
from .values import Tex, TexArray, nbytes


@dataclass
class NodeStat:
    node: str
    type: str
    key: str
    status: str = "skipped"  # computed | memory | disk | skipped
    ms: float = 0.0
    outputs: dict[str, str] = field(default_factory=dict)  # port -> format / kind


@dataclass
class RunResult:
    values: dict[PortRef, Any]
    stats: dict[str, NodeStat]
    frame: int

    def computed(self) -> list[str]:
        return [s.node for s in self.stats.values() if s.status == "computed"]


ON_COMPUTE: ContextVar[Callable[[str, str], None] | None] = ContextVar("on_compute", default=None)
"""Told `(node id, node type)` before any executor in this context computes a node (progress lines)."""


@contextmanager
def on_compute(callback: Callable[[str, str], None] | None) -> Iterator[None]:
    """Within the block, every node any executor computes is first reported to `callback` (None: nothing)."""
    token = ON_COMPUTE.set(callback)
    try:
        yield
    finally:
        ON_COMPUTE.reset(token)

class Executor:
    """Runs a pipeline. `mode='single'` persists outputs for later runs; `mode='loop'` (frame
    sequences, benchmarks) persists only nodes marked `persist = "always"` and writes in the background."""

    def __init__(self, pipeline: Pipeline, cache: Cache | None = None, *, mode: str = "single",
                 requested: list[PortRef] | None = None, gl: Any = None, timing: bool = False,
                 memory_limit: int = 1024**3, persist_all: bool = False, like: Plan | None = None,
                 background_writes: bool | None = None, keep_host: bool = False):
        """`like`: allocate every texture as that plan does (inspecting intermediates must not raise their
        precision and so change what the next node sees). `background_writes`: disk-cache writes happen on the
        cache's writer thread and `close` waits for them (default: in frame loops only; a single run's entries
        are then on disk when `run` returns). `keep_host`: textures loaded from the disk cache keep the host
        copy they were uploaded from (`host_copy`), so a tool that looks at them needs no read-back."""
        self.background_writes = mode == "loop" if background_writes is None else background_writes
        self.pipeline = pipeline
        self._cache = cache
        self.mode = mode
        self.timing = timing
        self.persist_all = persist_all
        self.plan = plan(pipeline, requested)
        if like is not None:
            self.plan.formats.clear()
            self.plan.formats.update(like.formats)
            self.plan.reasons = like.reasons
        self._gl = gl
        self._memory: OrderedDict[tuple[str, str], Any] = OrderedDict()
        self._memory_bytes = 0
        self.memory_limit = memory_limit
        self.compute_counts: dict[str, int] = {}
        self._unstorable: set[tuple[str, str]] = set()  # outputs already reported as not cacheable
        self.keep_host = keep_host
        self._host: dict[int, tuple[Any, Any]] = {}  # id(value) -> (value, its host copy), with keep_host
        # cost-aware persistence (single renders): each node's measured compute ms by key, and for each output
        # (key, port) the keys of the nodes a later run would have to compute to get it back (empty: on disk)
        self._own_ms: dict[str, float] = {}
        self._recompute: dict[tuple[str, str], frozenset[str]] = {}
        self._deferred: list[tuple[Node, str, str, Any]] = []  # entries to write when the run's nodes are done
        self._before_wait: Callable[[], None] | None = None  # see `run`

    @property
    def cache(self) -> Cache | None:
        """The disk cache, bound to this executor's GL renderer before its first use (entries of different
        renderers never mix; see `Cache.bind`). Binding creates the GL context."""
        c = self._cache
        if c is not None and c.namespace is None:
            c.bind(self.gl.renderer)
        return c

    @property
    def gl(self) -> Any:
        if self._gl is None:
            from .gpu import gl as glmod

            self._gl = glmod.get()
            self._gl.check_size(self.pipeline.size, f"pipeline '{self.pipeline.name}' size")
        return self._gl

    # -- keys ------------------------------------------------------------------------------
    def keys(self, frame: int = 0) -> dict[str, str]:
        hctx = HashContext(self.pipeline.size, frame, self.pipeline.seed, self.pipeline.scene,
                           self.pipeline.reference_size)
        keys: dict[str, str] = {}
        for nid in self.plan.order:
            node = self.pipeline.nodes[nid]
            ins = {p: f"{keys[s]}.{sp}" for p, (s, sp) in sorted(self.pipeline.connections[nid].items())}
            keys[nid] = node.key(hctx, ins)
        return keys

    # -- run -------------------------------------------------------------------------------
    def run(self, frame: int = 0, before_wait: Callable[[], None] | None = None) -> RunResult:
        """Compute the requested outputs of `frame`. `before_wait` is called once, at the first point where this
        run may have to wait for its own GPU work: just before the first node that reads inputs is computed,
        or at the end of the run if none is. A frame loop reads the previous frame back there: llvmpipe
        rasterises a pass while the next one is issued unless that one reads its output, so the previous
        frame's last pass runs while this frame's first, geometry pass is issued (docs/performance.md, "Back
        to back"). The previous frame's values are still held then; they go back to the pool at this run's
        end."""
        self._host.clear()
        self._before_wait = before_wait
        keys = self.keys(frame)
        stats = {nid: NodeStat(nid, self.pipeline.nodes[nid].type_name, keys[nid]) for nid in self.plan.order}
        pinned: set[tuple[str, str]] = set()
        values: dict[PortRef, Any] = {}
        try:
            for ref in self.plan.requested:
                values[ref] = self._get(ref[0], ref[1], keys, stats, pinned, frame)
        finally:  # what was computed is kept even when a later node fails
            self._store_deferred()
            hook, self._before_wait = self._before_wait, None
        if hook is not None:
            hook()
        self._evict(pinned)
        if self._cache is not None and self.mode == "loop":
            self._cache.report_write_errors()
            self._cache.maybe_prune()  # a long frame loop stays within the limit, not only at its end
        return RunResult(values, stats, frame)

    def _get(self, nid: str, port: str, keys: dict[str, str], stats: dict[str, NodeStat],
             pinned: set[tuple[str, str]], frame: int) -> Any:
        src = self.plan.aliases.get((nid, port))
        if src is not None:  # a pass-through: the value is its source's
            if stats[nid].status == "skipped":
                stats[nid].status = "pass-through"
            return self._get(src[0], src[1], keys, stats, pinned, frame)
        mkey = (keys[nid], port)
        if self.pipeline.nodes[nid].side_effect and stats[nid].status != "computed":
            self._compute(nid, keys, stats, pinned, frame)
            return self._memory[mkey]
        if mkey in self._memory:
            self._memory.move_to_end(mkey)
            pinned.add(mkey)
            if stats[nid].status == "skipped":
                stats[nid].status = "memory"
            return self._memory[mkey]
        node = self.pipeline.nodes[nid]
        if self.cache is not None and node.persist != "never" and not node.side_effect:
            t0 = time.perf_counter()
            loaded = self.cache.load(keys[nid], self._entry(nid, port), f"node '{nid}' port '{port}'",
                                     self._expect(nid, port))
            if loaded is not None:
                value = self._upload(loaded, nid, port)
                if self.keep_host and isinstance(value, (Tex, TexArray)):
                    self._host[id(value)] = (value, as_read(loaded.data, value.fmt))
                self._remember(mkey, value, pinned)
                self._recompute[mkey] = frozenset()
                if stats[nid].status in ("skipped", "memory"):
                    stats[nid].status = "disk"
                stats[nid].ms += (time.perf_counter() - t0) * 1000
                stats[nid].outputs[port] = describe(value)
                return value
        self._compute(nid, keys, stats, pinned, frame)
        return self._memory[mkey]

    def _compute(self, nid: str, keys: dict[str, str], stats: dict[str, NodeStat], pinned: set[tuple[str, str]],
                 frame: int) -> None:
        node = self.pipeline.nodes[nid]
        # a connected input the plan found unread for the needed outputs is given as None (not computed)
        inputs = {p: None for p in self.plan.unread.get(nid, ())}
        inputs.update({p: self._get(s, sp, keys, stats, pinned, frame)
                       for p, (s, sp) in self.plan.read_connections(nid).items()})
        needed = self.plan.needed[nid]
        ctx = RunContext(node, gl=lambda: self.gl, size=self.pipeline.size, frame=frame,
                         pipeline_seed=self.pipeline.seed, scene=self.pipeline.scene,
                         formats={p: f for (n, p), f in self.plan.formats.items() if n == nid},
                         reference_size=self.pipeline.reference_size)
        weigh = self._weighing()
        if self._before_wait is not None and self.plan.read_connections(nid):
            hook, self._before_wait = self._before_wait, None
            hook()
        report = ON_COMPUTE.get()
        if report is not None:
            report(nid, node.type_name)
        t0 = time.perf_counter()
        try:
            outs = node.compute(ctx, inputs, needed)
        except NodeError as exc:
            if exc.node_id is None:
                raise NodeError(exc.message, nid, node.type_name) from exc
            raise
        except SketchgraphError:
            raise
        except Exception as exc:  # a bug or an unforeseen input inside a node: one line naming it
            raise NodeError(one_line(exc), nid, node.type_name) from exc
        if (self.timing or weigh) and self._gl is not None:
            self.gl.finish()  # the GPU's share of the node's time counts too
        ms = (time.perf_counter() - t0) * 1000
        self.compute_counts[nid] = self.compute_counts.get(nid, 0) + 1
        missing = needed - set(outs)
        if missing:
            raise NodeError(f"did not produce {sorted(missing)}", nid, node.type_name)
        st = stats[nid]
        st.status, st.ms = "computed", st.ms + ms
        self._own_ms[keys[nid]] = ms
        persist = self.cache is not None and (
            node.persist == "always" or self.persist_all or (node.persist == "auto" and self.mode == "single"))
        chain = self._chain(nid, keys) if weigh else None
        for port, value in outs.items():
            mkey = (keys[nid], port)
            held = self._memory.get(mkey)
            if held is not None and held is not value and mkey in pinned:
                # this run already handed that port out (from disk or memory, before another port of the
                # node had to be computed): keep it, so no texture this run holds goes back to the pool;
                # the key is the same, so is the content
                self._release(value)
                st.outputs[port] = describe(held)
                continue
            self._remember(mkey, value, pinned)
            st.outputs[port] = describe(value)
            if persist and port in needed:
                if self.cache.find(keys[nid], self._entry(nid, port)) is not None:
                    self._recompute[mkey] = frozenset()
                    continue
                if chain is None or node.persist == "always" or self.cache.worth_writing(value, chain[1]):
                    if weigh:  # written once the run's nodes are done: no write competes with them
                        self._deferred.append((node, keys[nid], port, value))
                    else:
                        self._persist(node, keys[nid], port, value)
                    self._recompute[mkey] = frozenset()
                    continue
            if chain is not None:  # not on disk (not worth it, or never persisted): a later run recomputes it
                self._recompute[mkey] = chain[0]

    def _store_deferred(self) -> None:
        """Write the entries chosen during this run (their values are still pinned: nothing was evicted yet)."""
        deferred, self._deferred = self._deferred, []
        for node, key, port, value in deferred:
            self._persist(node, key, port, value)

    def _weighing(self) -> bool:
        """Whether outputs are persisted by cost (`Cache.worth_writing`; nodes marked `persist = "always"`
        are persisted all the same): single renders with a disk cache, unless everything is to be persisted.
        Each node's compute time is then measured to the end of its GPU work, and the chosen entries are
        written when the run's nodes are done (`_store_deferred`), so no write slows a node it measures."""
        return self._cache is not None and self.mode == "single" and not self.persist_all

    def _chain(self, nid: str, keys: dict[str, str]) -> tuple[frozenset[str], float | None]:
        """What recomputing `nid`'s outputs would take in a later run: the keys of the nodes it needs computed
        (itself, and the inputs that are not on disk, transitively) and their measured ms this run; the ms is
        None when an input's cost is not known (a value kept in memory from before this executor saw it)."""
        need = {keys[nid]}
        for s, sp in self.plan.read_connections(nid).values():
            while (s, sp) in self.plan.aliases:
                s, sp = self.plan.aliases[(s, sp)]
            up = self._recompute.get((keys[s], sp))
            if up is None:
                return frozenset(need), None
            need |= up
        own = [self._own_ms.get(k) for k in need]
        return frozenset(need), None if any(m is None for m in own) else sum(m for m in own if m is not None)

    # -- memory cache ----------------------------------------------------------------------
    def _remember(self, mkey: tuple[str, str], value: Any, pinned: set[tuple[str, str]]) -> None:
        old = self._memory.pop(mkey, None)
        if old is not None and old is not value:
            self._memory_bytes -= nbytes(old)
            self._release(old)
        self._memory[mkey] = value
        self._memory_bytes += nbytes(value)
        pinned.add(mkey)

    def _evict(self, pinned: set[tuple[str, str]]) -> None:
        """Past the memory limit, drop least-recently-used entries. In a frame loop, whatever this frame
        did not use (last frame's buffers) goes back to the texture pool at once: reallocating an 800x800
        texture costs more than a full-screen pass on llvmpipe."""
        loop = self.mode == "loop"
        for mkey in list(self._memory):
            if not loop and self._memory_bytes <= self.memory_limit:
                break
            if mkey in pinned:
                continue
            value = self._memory.pop(mkey)
            self._memory_bytes -= nbytes(value)
            self._release(value)

    def _release(self, value: Any) -> None:
        in_use = any(v is value for v in self._memory.values())
        if isinstance(value, (Tex, TexArray)) and self._gl is not None and not in_use:
            self.gl.release(value)

    def adopt_memory(self, old: Executor | None, frame: int = 0) -> int:
        """Take over `old`'s in-memory values (same GL context). Values are content-addressed, so one is
        reused only where a node's key is unchanged; a texture whose planned format differs here is
        released instead. Returns the number adopted."""
        if old is None or old is self:
            return 0
        formats: dict[tuple[str, str], str] = {}
        for nid, key in self.keys(frame).items():
            for port in self.plan.needed.get(nid, ()):
                fmt = self.plan.formats.get((nid, port))
                if fmt:
                    formats[(key, port)] = fmt
        adopted = 0
        for mkey, value in old._memory.items():
            want = formats.get(mkey)
            if isinstance(value, Tex) and want is not None and value.fmt != want:
                old._release(value)
                continue
            if isinstance(value, (Tex, TexArray)) and self._gl is None:
                self._gl = old._gl
            self._memory[mkey] = value
            self._memory_bytes += nbytes(value)
            adopted += 1
        old._memory.clear()
        old._memory_bytes = 0
        for k, v in old._recompute.items():  # what it knew of those values' cost (same keys, same nodes)
            self._recompute.setdefault(k, v)
        for k, ms in old._own_ms.items():
            self._own_ms.setdefault(k, ms)
        return adopted

    def host_copy(self, value: Any) -> Any:
        """What `value.read()` gives, without reading back: the host copy of a texture loaded from the disk
        cache (`keep_host`), else None."""
        held = self._host.get(id(value))
        return held[1] if held is not None and held[0] is value else None

    def clear_memory(self) -> None:
        self._host.clear()
        for value in self._memory.values():
            self._release(value)
        self._memory.clear()
        self._memory_bytes = 0

    def _entry(self, nid: str, port: str) -> str:
        """A cache entry's name within its key: the port, and for textures the planned format, so an
        entry of lower precision is never read where more is planned."""
        fmt = self.plan.formats.get((nid, port))
        return f"{port}.{fmt}" if fmt else port

    # -- disk cache ------------------------------------------------------------------------
    def is_stored(self, nid: str, port: str, key: str) -> bool:
        """Whether the disk cache holds output `port` of node `nid` under `key`, in the planned format."""
        return self.cache is not None and self.cache.find(key, self._entry(nid, port)) is not None

    def store(self, nid: str, port: str, key: str, value: Any) -> None:
        """Persist one output to the disk cache (checked against the plan like any computed value)."""
        self._persist(self.pipeline.nodes[nid], key, port, value)

    def _expect(self, nid: str, port: str) -> Expect | None:
        """What a cache entry of this output must be: its kind from the port type, the planned format, and for
        textures the size from `output_shape` (the image size unless the node says otherwise)."""
        node = self.pipeline.nodes[nid]
        kind = kind_of_port(node.outputs[port].type)
        if kind is None:
            return None
        fmt = self.plan.formats.get((nid, port))
        if kind not in ("texture", "texture_array"):
            return Expect(kind, fmt)
        w, h, layers = node.output_shape(port, self.pipeline.size)
        return Expect(kind, fmt, int(w), int(h), int(layers))

    def _persist(self, node: Node, key: str, port: str, value: Any) -> None:
        assert self.cache is not None
        from . import __version__

        expect = self._expect(node.id, port)
        diff = value_mismatch(value, expect) if expect is not None else None
        if diff:  # every later load would discard it: say so once, write nothing
            if (node.id, port) not in self._unstorable:
                self._unstorable.add((node.id, port))
                warnings.warn(f"node '{node.id}' port '{port}' is not cached: its value differs from what the "
                              f"plan expects ({diff}); check the node's output_shape() and formats",
                              CacheWarning, stacklevel=2)
            return
        meta = {"node": node.id, "type": node.type_name, "version": node.version,
                "params": node.params.model_dump(mode="json"), "package": __version__}
        # the cache decides how (and whether: scenes and meshes are sources) a value is stored
        # with background_writes, written on the cache's writer thread (bounded), so the image is written
        # as soon as it is ready; `close` waits for the writes
        self.cache.store_value(key, self._entry(node.id, port), value, meta, background=self.background_writes)

    def _upload(self, loaded: Any, nid: str, port: str) -> Any:
        """A value from a cache entry (`Cache.load`: host data and its stored kind): textures go to the GPU."""
        if loaded.kind == "texture":
            fmt = self.plan.formats.get((nid, port)) or loaded.fmt or "RGBA32F"
            arr = loaded.data
            if arr.shape[2] != types.components(fmt):
                raise PipelineError(f"cache entry for {nid}.{port} has {arr.shape[2]} channels, expected {fmt}")
            tex = self.gl.upload(arr, fmt)
            if fmt == loaded.fmt:  # the stored values, so the stored blank, exactly
                tex.footprint, tex.absmax = loaded.footprint, loaded.absmax
            return tex
        if loaded.kind == "texture_array":
            data = loaded.data
            fmt = loaded.fmt or "R8"
            return self.gl.texture_array((data.shape[2], data.shape[1]), data.shape[0], fmt, data)
        return loaded.data

    def close(self, progress: Any = None) -> None:
        """Finish the background writes (reporting a failed one; `progress(text)` is told if that takes over
        a second), prune the cache if anything was written or discarded (frame loops too), and start the
        cache's next run."""
        if self._cache is not None:
            self._cache.flush(progress)
            if self._cache.writes or self._cache.recovered:
                self._cache.prune()
            self._cache.new_run()


def as_read(data: Any, fmt: str) -> Any:
    """Host data as a texture of `fmt` made from it reads back (`Tex.read`): converted to the format's dtype
    the way an upload converts it (`gl._to_bytes`), then to float32 the way a read-back does."""
    import numpy as np

    dt = types.numpy_dtype(fmt)
    arr = np.asarray(data)
    if dt == np.uint8 and arr.dtype != np.uint8:
        arr = np.clip(np.rint(np.asarray(arr, np.float32) * 255.0), 0, 255)  # half entries scaled in float32
    raw = arr.astype(dt, copy=False)
    if dt == np.float32:
        return np.ascontiguousarray(raw)
    out = raw.astype(np.float32)
    if dt == np.uint8:
        out /= 255.0
    return out


def describe(value: Any) -> str:
    """A value's format for listings: 'RGBA16F', 'R8x32' for texture arrays, else its type name."""
    if isinstance(value, Tex):
        return value.fmt
    if isinstance(value, TexArray):
        return f"{value.fmt}x{value.layers}"
    return type(value).__name__
