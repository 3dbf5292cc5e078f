"""The render thread of `sketchgraph serve`: it alone owns the GL context.

Everything the page asks for is queued to it. Parameter changes coalesce: while the thread is busy, later
values of a parameter replace earlier ones, so a slider drag renders the latest value only. After a change the
pipeline is loaded again with the edited values as overrides and run by a new executor that adopts the previous
one's in-memory values (content addressed: only the nodes whose key changed compute again). The executor keeps
every planned port (as `inspect --all` does, in the formats the ordinary run gives them), so looking at any
buffer costs one read-back, kept for pixel probes until the buffer changes. A view is drawn in 8 bits (fast
paths per kind for a buffer shown whole) and sent as a PNG, which is kept with the view's settings until the
buffer changes. Between requests the thread polls the pipeline and scene files and reloads when one changes.

Idle prefetch: a change plans only the ports the ordinary run makes (planning every port would make each change
compute them all). Once the result is delivered and no message has come for `QUIET_S`, the thread plans the
remaining output ports of the planned nodes, one node per step (a new executor adopting the previous one's
values: only that node computes), looking for messages between steps, until every port is held; a port that
cannot be made here is skipped. Then, a step at a time, each held texture port is drawn and encoded as the pages
would ask for it on a click (their box, mode, exposure and range), and kept with the drawn views (the read-back is
not kept): a later click sends the kept PNG. The next change keeps the
prefetched ports whose node's key it leaves unchanged (memory hits), so only what it reaches is prefetched
again. Prefetch computes are counted apart from the page's compute counts. Pipelines with side-effect nodes
(files written) are not prefetched: every run would write again.
"""

from __future__ import annotations

import contextvars
import json
import secrets
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

from ...errors import PipelineError, SketchgraphError, one_line
from ...pipeline import Pipeline
from .. import viz
from ..inspect_all import all_ports, box_area, box_sum, reduce_and_colour
from ..watch import _stamp, scene_files
from . import yamledit

MODES = ("auto", "rgb", "r", "g", "b", "a")
MAX_BOX = 8192
VIEW_CACHE_BYTES = 64 << 20  # drawn views kept (their PNG bytes), the least recently looked at dropped first
# the quiet period before an idle prefetch: longer than the gaps between a drag's messages (16 to 50 ms; a change
# renders in 70 to 100 ms here, so a drag keeps the thread busy throughout), short against the seconds before a
# user clicks a port after a change
QUIET_S = 0.2


@dataclass
class View:
    """What one page looks at: a port, the box it is shown in (device pixels) and how it is drawn."""

    port: str | None = None  # NODE.PORT; None: the pipeline's first output
    width: int = 800
    height: int = 800
    mode: str = "auto"  # auto (the port's own visualisation), rgb (with exposure), or one channel
    exposure: float = 0.0  # stops, for colour
    lo: float | None = None  # value range of one channel (None: its finite min and max)
    hi: float | None = None


@dataclass
class Client:
    """A page's connection: `send(message)` is called on the render thread (it must be thread safe)."""

    send: Callable[[Any], None]
    view: View = field(default_factory=View)
    wants_image: bool = True
    probe: tuple[int, int] | None = None
    stats_for: tuple[tuple[str, str], str] | None = None  # the port whose statistics are sent when idle
    have: frozenset[str] = frozenset()  # the drawn views (`vid`) the page says it still holds, decoded
    asked: float = 0.0  # when the last view request arrived (perf_counter), for the header's `wait_ms`


class Engine:
    """Loads, runs and shows one pipeline; `start()` runs the render thread."""

    def __init__(self, pipeline: str | Path, *, open_pipeline: Callable[[tuple[str, ...]], Pipeline],
                 cache: Any = None, roots: list[Path] | None = None, poll: float = 0.25, frame: int = 0,
                 prefetch: bool = True):
        self.path = Path(pipeline).resolve()
        self._open = open_pipeline
        self.cache = cache
        self.roots = [Path(r).resolve() for r in (roots or [self.path.parent])]
        self.poll = poll
        self.frame = frame
        self.edits: dict[str, dict[str, Any]] = {}  # node -> param -> value, applied as overrides
        self.pipe: Pipeline | None = None
        self.error: str | None = None  # the located one-line error of the last load or run, if any
        self.notice: str | None = None  # a refused edit, for one message
        self.result: Any = None
        self.counts: dict[str, int] = {}  # node -> computes since the server started
        self.last_ms: dict[str, float] = {}  # node -> its last compute's time
        self.run_ms = 0.0
        self.seq = 0  # the last change the page sent that has been applied
        self._ex: Any = None
        self._lock = threading.Condition()
        self._pending: dict[tuple[str, str], Any] = {}
        self._pending_seq = 0
        self._pending_frame: int | None = None
        self._save = False
        self._reload = True
        self._clients: dict[int, Client] = {}
        self._stamps: dict[Path, Any] = {}
        self._host: dict[tuple[str, str], tuple[str, np.ndarray]] = {}  # port -> (value key, GL-order data)
        self._views: OrderedDict[tuple[Any, ...], tuple[dict[str, Any], bytes]] = OrderedDict()  # drawn views
        self._views_bytes = 0
        self._vids = 0  # drawn views so far: each gets an id (`vid`) the page keeps its decoded picture under
        self._vid_prefix = f"{secrets.token_hex(4)}-"  # a page reconnected to another server holds none of its
        self._stats_key: Any = None
        self._stats_val: list[dict[str, Any]] = []
        self._extra: set[tuple[str, str]] = set()  # ports looked at that the ordinary run does not produce
        # idle prefetch (see the module's docstring)
        self.prefetch = prefetch
        self._base: Any = None  # the ordinary run's plan
        self._made: list[tuple[str, str]] = []  # the ports the ordinary run makes
        self._full: set[tuple[str, str]] = set()  # ports prefetched (kept requested while their values are held)
        self._failed: set[tuple[str, str, str]] = set()  # (node, port, key): could not be prefetched
        self._undrawable: set[tuple[str, str]] = set()  # held ports the idle drawing leaves to a click
        self._single: set[tuple[str, str]] = set()  # (node, key): a step failed; its ports go one at a time
        self._bad: set[tuple[str, str]] = set()  # ports that failed under some key: tried alone, after the rest
        self._shown: tuple[set[str], dict[str, Any]] = (set(), {})  # the ordinary run's plan order and stats
        self._last_msg = 0.0  # monotonic time of the last message (probes aside) or the last work done
        self._prefetching = False
        self._arrived: float | None = None  # perf_counter when a message first arrived during a prefetch step
        self.prefetch_counts: dict[str, int] = {}  # node -> computes by prefetch steps
        self.prefetch_steps: list[float] = []  # each step's ms (the last 200)
        self.prefetch_delays: list[float] = []  # ms a message waited for the step in progress (the last 200)
        self._stop = False
        self._thread: threading.Thread | None = None
        self.ready = threading.Event()

    # -- called from any thread -----------------------------------------------------------------------
    def start(self) -> None:
        # the render thread opens the pipeline in the starting command's context: --front, --animation, the lens
        # and --allow-outside-scene-dir are context variables (nodegraph/scene/views.py) a new thread would not see
        self._thread = threading.Thread(target=contextvars.copy_context().run, args=(self._loop,),
                                        name="sketchgraph-render", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        with self._lock:
            self._stop = True
            self._lock.notify_all()
        if self._thread is not None:
            self._thread.join(timeout=10)

    def add_client(self, cid: int, send: Callable[[Any], None]) -> None:
        with self._lock:
            self._clients[cid] = Client(send)
            self._lock.notify_all()

    def remove_client(self, cid: int) -> None:
        with self._lock:
            self._clients.pop(cid, None)

    def submit(self, cid: int, msg: dict[str, Any]) -> None:
        """A message from a page (already parsed JSON); applied by the render thread, latest values first."""
        op = msg.get("op")
        with self._lock:
            client = self._clients.get(cid)
            if op != "probe":  # the cursor over the picture does not put off the prefetch
                self._last_msg = time.monotonic()
                if self._prefetching and self._arrived is None:
                    self._arrived = time.perf_counter()
            if op == "set":
                node, param = str(msg.get("node")), str(msg.get("param"))
                self._pending[(node, param)] = msg.get("value")
                self._pending_seq = max(self._pending_seq, int(msg.get("seq") or 0))
            elif op == "reset":
                self._pending[(str(msg.get("node")), str(msg.get("param")))] = _RESET
            elif op == "frame":
                self._pending_frame = int(msg.get("frame") or 0)
            elif op == "view" and client is not None:
                client.view = _view(msg, client.view)
                have = msg.get("have")
                client.have = frozenset(str(v) for v in have[:64]) if isinstance(have, list) else frozenset()
                client.wants_image = True
                client.asked = time.perf_counter()
            elif op == "probe" and client is not None:
                client.probe = (int(msg.get("x", -1)), int(msg.get("y", -1)))
            elif op == "save":
                self._save = True
            elif op == "state" and client is not None:
                client.wants_image = True
            self._lock.notify_all()

    # -- the render thread ----------------------------------------------------------------------------
    def _loop(self) -> None:
        from ...gpu import gl as glmod

        try:
            self._gl = glmod.create()  # a context of its own, made (and current) on this thread, which owns it
        except SketchgraphError as exc:
            self.error = _line(exc)
            self._gl = None
        next_poll = 0.0
        while True:
            with self._lock:
                while True:
                    due = min(next_poll, self._prefetch_due())
                    if self._stop or self._has_work() or time.monotonic() >= due:
                        break
                    self._lock.wait(timeout=max(0.0, due - time.monotonic()))
                if self._stop:
                    break
                prefetch = not self._has_work() and time.monotonic() < next_poll
                if prefetch:
                    self._prefetching, self._arrived = True, None
            if prefetch:
                self._prefetch_step()
                continue
            with self._lock:
                work = self._has_work()
                pending, self._pending = self._pending, {}
                seq = self._pending_seq
                frame, self._pending_frame = self._pending_frame, None
                save, self._save = self._save, False
                reload, self._reload = self._reload, False
            if time.monotonic() >= next_poll:
                reload = reload or self._files_changed()
                next_poll = time.monotonic() + self.poll
            try:
                self._step(pending, seq, frame, save, reload)
            except Exception as exc:  # noqa: BLE001 - the server stays up; the page shows the error
                self.error = _line(exc)
                self._broadcast_state()
            if work or reload:
                with self._lock:
                    self._last_msg = max(self._last_msg, time.monotonic())
            self.ready.set()
        self._close()

    def _has_work(self) -> bool:
        return bool(self._pending or self._pending_frame is not None or self._save or self._reload
                    or any(c.wants_image or c.probe for c in self._clients.values()))

    def _files_changed(self) -> bool:
        files = [self.path] if self.pipe is None else list(self._stamps)
        return any(_stamp(p) != self._stamps.get(p) for p in files) or not self._stamps

    def _step(self, pending: dict[tuple[str, str], Any], seq: int, frame: int | None, save: bool,
              reload: bool) -> None:
        changed = reload
        if pending:
            changed = self._apply(pending) or changed
        if frame is not None and frame != self.frame:
            self.frame, changed = frame, True
        if save:
            self._write_back()
        tell = False
        if changed:
            self._load_and_run()
            for c in list(self._clients.values()):
                c.wants_image = True
        if changed or pending or save:
            self.seq = max(self.seq, seq)
            tell = True
        for c in list(self._clients.values()):
            if c.wants_image:
                c.wants_image = False
                self._send_image(c)
            if c.probe is not None:
                x, y = c.probe
                c.probe = None
                c.send({"type": "probe", **self.probe(c.view.port, x, y)})
        if tell:  # after the pictures: the graph's news is not on the way to the screen
            self._broadcast_state()
        for c in list(self._clients.values()):
            if c.stats_for is not None and not self._pending:
                ref, port = c.stats_for
                c.stats_for = None
                _, host = self._host_of(ref)
                if host is not None:
                    c.send({"type": "stats", "port": port, "stats": _finite(self._stats(ref, host))})

    def _apply(self, pending: dict[tuple[str, str], Any]) -> bool:
        """Merge edits; an edit the node's parameters refuse is dropped and reported (one line)."""
        before = json.loads(json.dumps(self.edits))
        for (node, param), value in pending.items():
            if value is _RESET:
                self.edits.get(node, {}).pop(param, None)
            else:
                self.edits.setdefault(node, {})[param] = value
        self.edits = {n: p for n, p in self.edits.items() if p}
        if self.error is None:
            try:
                self._open(self._overrides())
            except SketchgraphError as exc:
                self.edits = before
                self.notice = _line(exc)
                return False
        return self.edits != before

    def _overrides(self) -> tuple[str, ...]:
        return tuple(f"{n}.{p}={json.dumps(v)}" for n, ps in self.edits.items() for p, v in ps.items())

    def _load_and_run(self) -> None:
        from ...executor import Executor
        from ...plan import plan

        t0 = time.perf_counter()
        self._stamps = {self.path: _stamp(self.path)}
        try:
            pipe = self._open(self._overrides())
        except SketchgraphError as exc:
            # the file changed under edits it no longer takes: keep those it does
            found = self._drop_stale_edits() if self.edits else None
            if found is None:
                self.error = _line(exc)
                return
            pipe = found
        scene_base = self.path.parent
        for f in scene_files(pipe.scene_spec, scene_base):
            self._stamps[f] = _stamp(f)
        base = plan(pipe)
        made = all_ports(pipe)
        ports = made + sorted(r for r in self._extra if r not in made and r[0] in pipe.nodes
                              and r[1] in pipe.nodes[r[0]].outputs)
        ex = Executor(pipe, self.cache, mode="loop", requested=ports, gl=self._gl, like=base)
        kept = self._kept_ports(ex, pipe, ports)
        if kept:  # prefetched ports the change leaves as they were: held, so planning them costs nothing
            ex = Executor(pipe, self.cache, mode="loop", requested=ports + kept, gl=self._gl, like=base)
        ex.adopt_memory(self._ex, self.frame)
        if self._ex is not None:
            self._ex.close()
        self._ex, self.pipe, self._base, self._made, self._full = ex, pipe, base, made, set(kept)
        try:
            result = ex.run(self.frame)
        except SketchgraphError as exc:
            self.error = _line(exc)
            self.result = None
            return
        self.error = None
        self.result = result
        self._shown = (set(ex.plan.order), result.stats)
        for nid in result.computed():
            self.counts[nid] = self.counts.get(nid, 0) + 1
            self.last_ms[nid] = result.stats[nid].ms
        self.run_ms = (time.perf_counter() - t0) * 1000

    def _kept_ports(self, ex: Any, pipe: Pipeline, ports: list[tuple[str, str]]) -> list[tuple[str, str]]:
        """The prefetched ports whose values the previous executor holds under the keys `ex` gives them (a
        pass-through port: its source's value)."""
        old = self._ex
        if old is None or not self._full:
            return []
        keys = ex.keys(self.frame)
        have = set(ports)

        def held(ref: tuple[str, str]) -> bool:
            for _ in range(64):
                src = old.plan.aliases.get(ref)
                if src is None:
                    break
                ref = src
            return ref[0] in keys and (keys[ref[0]], ref[1]) in old._memory

        return sorted(r for r in self._full if r not in have and r[0] in keys and r[1] in pipe.nodes[r[0]].outputs
                      and held(r))

    # -- idle prefetch ----------------------------------------------------------------------------------
    def _prefetch_next(self) -> tuple[str, list[tuple[str, str]]] | None:
        """The next planned node (topological order) with output ports not held, and those ports (one, where a
        step with all of them failed); None when every port is held or was found not to be makeable."""
        pipe, result, base = self.pipe, self.result, self._base
        if not self.prefetch or pipe is None or result is None or base is None or self._ex is None \
                or self.error is not None:
            return None
        if any(pipe.nodes[nid].side_effect for nid in self._ex.plan.order):
            return None
        for nid in base.order:
            st = result.stats.get(nid)
            if st is None:
                continue
            want = [(nid, p) for p in pipe.nodes[nid].outputs
                    if (nid, p) not in result.values and (nid, p, st.key) not in self._failed]
            if want:
                good = [r for r in want if r not in self._bad]
                return nid, want[:1] if (nid, st.key) in self._single or not good else good
        return None

    def _predraw_next(self) -> tuple[tuple[str, str], View] | None:
        """Once every port is held: the next held texture port not yet drawn as a page would ask for it on a click
        (its current box, mode, exposure and range with that port), and that view; None when all are drawn."""
        if not self.prefetch or self.result is None or self.pipe is None or self.error is not None:
            return None
        if self._prefetch_next() is not None:
            return None
        from ...values import Tex

        views = {(c.view.width, c.view.height, c.view.mode, c.view.exposure, c.view.lo, c.view.hi)
                 for c in list(self._clients.values())}
        for ref, value in self.result.values.items():
            # textures only: their drawing takes milliseconds (a texture array's montage or a chart can take a
            # second or two at 800x800, and a change arriving meanwhile would wait for it)
            if not isinstance(value, Tex) or ref in self._undrawable:
                continue
            vkey = self._value_key(ref)
            for w, h, mode, exposure, lo, hi in sorted(views, key=str):
                shown = _fit(value.size[1], value.size[0], w, h)
                if (ref, vkey, mode, exposure, lo, hi, shown) not in self._views:
                    return ref, View(f"{ref[0]}.{ref[1]}", w, h, mode, exposure, lo, hi)
        return None

    def _prefetch_due(self) -> float:
        """When (monotonic) the next prefetch step may run: inf when there is nothing to prefetch or draw."""
        if self._prefetch_next() is None and self._predraw_next() is None:
            return float("inf")
        return self._last_msg + QUIET_S

    def _predraw_step(self) -> bool:
        """Draw and keep one held port's view (`_predraw_next`) so that clicking it sends the kept PNG; the
        read-back is not kept unless a page shows that port (the probe and statistics read it again). False
        when there was nothing to draw."""
        nxt = self._predraw_next()
        if nxt is None:
            return False
        ref, view = nxt
        shown = {self._ref(c.view.port) for c in list(self._clients.values())}
        try:
            header, _ = self.image(ref, view)
            if header.get("empty"):
                self._undrawable.add(ref)
        except Exception:  # noqa: BLE001 - a view that cannot be drawn here is drawn (and explained) on a click
            self._undrawable.add(ref)
        if ref not in shown:
            self._host.pop(ref, None)
        return True

    def _prefetch_step(self) -> None:
        """Plan the next node's ports not held (`_prefetch_next`) and run: only that node computes. Where that
        fails, the node's ports go one at a time, and a port that cannot be made here is remembered under the
        node's key and left out; the run goes back to the ports held before."""
        from ...executor import Executor

        t0 = time.perf_counter()
        step = self._prefetch_next()
        nid = step[0] if step is not None else None
        try:
            if step is None:
                if self._predraw_step():
                    nid = "(draw)"
                return
            pipe, old = self.pipe, self._ex
            ports = list(old.plan.requested)
            key = self.result.stats[nid].key
            want = [r for r in step[1] if r not in ports]
            if not want:  # (cannot happen: a requested port is held) never the same step again
                self._failed.update((n, p, key) for n, p in step[1])
                return
            ex = Executor(pipe, self.cache, mode="loop", requested=ports + want, gl=self._gl, like=self._base)
            ex.adopt_memory(old, self.frame)
            old.close()
            self._ex = ex
            try:
                result = ex.run(self.frame)
            except Exception:  # noqa: BLE001 - a port that cannot be made here: skipped quietly
                if len(want) > 1:
                    self._single.add((nid, key))  # which one: each alone from now on
                else:
                    self._failed.add((*want[0], key))
                    self._bad.add(want[0])
                back = Executor(pipe, self.cache, mode="loop", requested=ports, gl=self._gl, like=self._base)
                back.adopt_memory(ex, self.frame)
                ex.close()
                self._ex = back
                try:
                    self.result = back.run(self.frame)  # what was held: memory hits
                except SketchgraphError as exc:
                    self.error, self.result = _line(exc), None
                return
            if self._gl is not None:
                self._gl.finish()  # the step's GPU work inside the step: a change after it does not wait for it
            self.result = result
            self._full.update(want)
            for n in result.computed():
                self.prefetch_counts[n] = self.prefetch_counts.get(n, 0) + 1
        finally:
            with self._lock:
                self._prefetching = False
                end = time.perf_counter()
                if nid is not None:
                    self.prefetch_steps = [*self.prefetch_steps[-199:], round((end - t0) * 1000, 2)]
                if self._arrived is not None:
                    self.prefetch_delays = [*self.prefetch_delays[-199:], round((end - self._arrived) * 1000, 2)]
                    self._arrived = None

    def _drop_stale_edits(self) -> Pipeline | None:
        kept: dict[str, dict[str, Any]] = {}
        for node, params in self.edits.items():
            for param, value in params.items():
                trial = {**kept, node: {**kept.get(node, {}), param: value}}
                overrides = tuple(f"{n}.{p}={json.dumps(v)}" for n, ps in trial.items() for p, v in ps.items())
                try:
                    self._open(overrides)
                except SketchgraphError:
                    continue
                kept = trial
        self.edits = kept
        try:
            return self._open(self._overrides())
        except SketchgraphError:
            return None

    def _write_back(self) -> None:
        from ...fsio import atomic_write_text

        if not self.edits:
            self.notice = "nothing to save: no parameter was changed"
            return
        target = self.path
        if not _inside(target, self.roots):
            self.notice = f"refusing to write {target}: outside the folders this server may write"
            return
        try:
            text = yamledit.set_params(target.read_text(encoding="utf-8"), self.edits)
        except (PipelineError, OSError) as exc:
            self.notice = _line(exc)
            return
        atomic_write_text(target, text)
        self.notice = f"saved {sum(len(p) for p in self.edits.values())} parameter(s) to {target.name}"
        self.edits = {}
        self._reload = False
        # the file now holds the values the overrides held: the same keys, nothing recomputes
        self._load_and_run()

    def _close(self) -> None:
        if self._ex is not None:
            self._ex.clear_memory()
            self._ex.close()
            self._ex = None
        if self._gl is not None:  # the thread's own context (`glmod.create`), with everything made in it
            self._gl.ctx.release()
            self._gl = None

    # -- what the page is told ------------------------------------------------------------------------
    def _broadcast_state(self) -> None:
        state = self.state()
        for c in list(self._clients.values()):
            c.send(state)
        self.notice = None

    def state(self) -> dict[str, Any]:
        """The graph, laid out, with each node's type, ports, cache state, last compute time, parameters and
        their schemas; the error and the notice, if any."""
        pipe = self.pipe
        out: dict[str, Any] = {"type": "state", "file": self.path.name, "error": self.error, "notice": self.notice,
                               "seq": self.seq, "frame": self.frame, "frames": _frames(pipe),
                               "edits": self.edits, "run_ms": round(self.run_ms, 2), "nodes": [], "edges": [],
                               "outputs": {}}
        if pipe is None:
            return out
        g = pipe.graph()
        # as the ordinary run left them: prefetch steps change neither the statuses nor the counts shown
        planned = self._shown[0] if self._ex is not None else set()
        stats = self._shown[1] if self.result is not None else {}
        for col, gen in enumerate(nx.topological_generations(g)):
            for row, nid in enumerate(sorted(gen)):
                node = pipe.nodes[nid]
                st = stats.get(nid)
                out["nodes"].append({
                    "id": nid, "type": node.type_name, "col": col, "row": row,
                    "inputs": {p: {"type": str(spec.type), "from": ".".join(pipe.connections[nid][p])
                                   if p in pipe.connections[nid] else None} for p, spec in node.inputs.items()},
                    "outputs": {p: {"type": str(spec.type), "doc": spec.doc} for p, spec in node.outputs.items()},
                    "status": (st.status if st is not None else "not run") if nid in planned else "not planned",
                    "ms": round(self.last_ms.get(nid, 0.0), 3), "computes": self.counts.get(nid, 0),
                    "prefetch_computes": self.prefetch_counts.get(nid, 0),
                    "params": node.params.model_dump(mode="json"),
                    "schema": _schema(type(node.params)),
                    "doc": " ".join((getattr(node, "doc", None) or type(node).__doc__ or "").split())[:400],
                })
        out["edges"] = [{"from": f"{s}.{sp}", "to": f"{n}.{p}"} for n, conns in pipe.connections.items()
                        for p, (s, sp) in conns.items()]
        out["outputs"] = {name: ".".join(ref) for name, ref in pipe.outputs.items()}
        out["made"] = [f"{n}.{p}" for n, p in self._made]  # the ports the ordinary run makes
        out["prefetch"] = {"pending": self._prefetch_next() is not None, "quiet_ms": QUIET_S * 1000,
                           "steps_ms": list(self.prefetch_steps), "delays_ms": list(self.prefetch_delays),
                           "memory_run_bytes": self._held_bytes(self._made),
                           "memory_bytes": self._held_bytes(list(self.result.values) if self.result else [])}
        return out

    def _held_bytes(self, refs: list[tuple[str, str]]) -> int:
        """The bytes of the distinct values these ports hold (a pass-through port holds its source's)."""
        from ...values import nbytes

        values = self.result.values if self.result is not None else {}
        seen = {id(values[r]): values[r] for r in refs if r in values}
        return sum(nbytes(v) for v in seen.values())

    def _ref(self, port: str | None) -> tuple[str, str] | None:
        pipe = self.pipe
        if pipe is None:
            return None
        if port is None:
            return next(iter(pipe.outputs.values()), None)
        if port in pipe.outputs:
            return pipe.outputs[port]
        node, _, name = port.partition(".")
        return (node, name) if node in pipe.nodes and name in pipe.nodes[node].outputs else None

    def _host_of(self, ref: tuple[str, str]) -> tuple[Any, np.ndarray | None]:
        """A port's value and, for a texture, its data read back once (kept until its key changes)."""
        from ...values import Tex, TexArray

        if self.result is None or ref not in self.result.values:
            return None, None
        value = self.result.values[ref]
        if not isinstance(value, (Tex, TexArray)):
            return value, None
        key = self._value_key(ref)
        hit = self._host.get(ref)
        if hit is not None and hit[0] == key:
            return value, hit[1]
        host = self._ex.host_copy(value) if self._ex is not None else None
        data = np.asarray(host if host is not None else value.read(), np.float32)
        self._host[ref] = (key, data)
        return value, data

    def _send_image(self, client: Client) -> None:
        ref = self._ref(client.view.port)
        if ref is None or self.result is None:
            client.send({"type": "image", "port": client.view.port, "seq": self.seq, "empty": True,
                         "note": "nothing to show" if self.error is None else self.error})
            return
        ran = False
        if ref not in self.result.values and ref not in self._extra:  # a port nothing reads: run it too
            ran = True
            self._extra.add(ref)
            self._load_and_run()
            if self.result is None:  # that port cannot be made here: say why, and run without it
                why = self.error
                self._extra.discard(ref)
                self._load_and_run()
                self._broadcast_state()
                client.send({"type": "image", "port": f"{ref[0]}.{ref[1]}", "seq": self.seq, "empty": True,
                             "note": f"cannot show {ref[0]}.{ref[1]}: {why}"})
                return
            self._broadcast_state()
        wait = (time.perf_counter() - client.asked) * 1000 if client.asked else 0.0
        client.asked = 0.0
        header, pixels = self.image(ref, client.view, client.have)
        header["seq"] = self.seq
        header["wait_ms"] = round(wait, 2)  # from the view request's arrival to its drawing starting
        if ran:
            header["ran"] = True  # the port was computed for this view (its node ran again, with it planned)
        client.send(header if header.get("empty") else (header, pixels))
        if header.get("stats") is None and not header.get("empty"):
            client.stats_for = (ref, header["port"])

    def image(self, ref: tuple[str, str], view: View, have: frozenset[str] = frozenset()) \
            -> tuple[dict[str, Any], bytes]:
        """A port drawn at the size it is shown: (header, a PNG of 8-bit RGB or grey, row 0 at the top). Drawn
        views are kept (`VIEW_CACHE_BYTES`) until the port's value changes: looking again sends at once, and
        where the page says it holds that view (`have`, the headers' `vid`) the header alone goes (`reuse`)."""
        from ...values import Tex

        t0 = time.perf_counter()
        vkey = self._value_key(ref)
        value = self.result.values.get(ref) if self.result is not None else None
        # a texture is drawn at its size fitted to the box (never enlarged): zooming in past 1:1 is the same view
        shown = _fit(value.size[1], value.size[0], view.width, view.height) if isinstance(value, Tex) \
            else (view.height, view.width)
        ckey = (ref, vkey, view.mode, view.exposure, view.lo, view.hi, shown)
        hit = self._views.get(ckey) if vkey is not None else None
        if hit is not None:
            self._views.move_to_end(ckey)
            reuse = hit[0].get("vid") in have
            return {**hit[0], "read_ms": 0.0, "draw_ms": round((time.perf_counter() - t0) * 1000, 2),
                    "encode_ms": 0.0, "cached": True, "reuse": reuse}, b"" if reuse else hit[1]
        header, pixels, t1 = self._draw_view(ref, view)
        t2 = time.perf_counter()
        header["read_ms"] = round((t1 - t0) * 1000, 2)
        header["draw_ms"] = round((t2 - t1) * 1000, 2)
        if header.get("empty"):
            return header, b""
        payload = encode_png(pixels)
        header["format"] = "png"
        header["bytes"] = len(payload)
        header["encode_ms"] = round((time.perf_counter() - t2) * 1000, 2)
        if vkey is not None:
            self._vids += 1
            header["vid"] = f"{self._vid_prefix}{self._vids}"
            self._keep_view(ckey, dict(header), payload)  # a copy: the sent header gains seq, wait_ms
        return header, payload

    def _value_key(self, ref: tuple[str, str]) -> str | None:
        """What identifies a port's current value: its node's cache key and the frame (None: no value)."""
        if self.result is None or ref not in self.result.values or ref[0] not in self.result.stats:
            return None
        return f"{self.result.stats[ref[0]].key}:{self.frame}"

    def _keep_view(self, ckey: tuple[Any, ...], header: dict[str, Any], payload: bytes) -> None:
        for k in [k for k in self._views if k[0] == ckey[0] and k[1] != ckey[1]]:  # that port's older values
            self._views_bytes -= len(self._views.pop(k)[1])
        self._views[ckey] = (header, payload)
        self._views_bytes += len(payload)
        while self._views_bytes > VIEW_CACHE_BYTES and len(self._views) > 1:
            self._views_bytes -= len(self._views.popitem(last=False)[1][1])

    def _draw_view(self, ref: tuple[str, str], view: View) -> tuple[dict[str, Any], np.ndarray, float]:
        """(header, (H, W, 3) or (H, W) uint8 display picture, when the read-back ended)."""
        from ...values import Tex, TexArray

        value, host = self._host_of(ref)
        t1 = time.perf_counter()
        doc = self.pipe.nodes[ref[0]].outputs[ref[1]].doc if self.pipe is not None else ""
        port = f"{ref[0]}.{ref[1]}"
        fast = None
        whole = host is not None and _fit(host.shape[0], host.shape[1], view.width, view.height) == host.shape[:2]
        if isinstance(value, Tex) and whole and view.mode == "auto" and not view.exposure and host.shape[2] == 4 \
                and viz.classify(ref[1], 4, doc) == "color":  # (an exposure goes `draw`'s way)
            fast = _fast_rgba8(host)
        if fast is not None:  # the usual final image, shown whole
            h, w = host.shape[:2]
            header = {"type": "image", "port": port, "width": w, "height": h, "full": (w, h), "note": "rgb",
                      "kind": "color", "stats": None, "frame": self.frame}
            return header, fast, t1
        strip = draw_array(host, ref[1], doc, view) if isinstance(value, TexArray) and host is not None \
            and host.ndim == 4 else None
        layout = None
        if isinstance(value, Tex) and host is not None:
            rgb, note, kind = draw(host, ref[1], doc, view)
            n, gap = panels(host.shape[1], kind, view.mode)
            full = (n * host.shape[1] + (n - 1) * gap, host.shape[0])  # the picture's size in buffer pixels
            layout = [n, host.shape[1], gap] if n > 1 else None
            stats = None  # sent after the picture (`stats_message`): they are not on the way to the screen
        elif strip is not None:
            rgb, note, kind, full = strip
            stats = []
        else:
            panel = viz.visualize(host if host is not None else value, ref[1], doc)
            if panel.image is None:
                return ({"type": "image", "port": port, "empty": True, "note": panel.note, "kind": panel.kind},
                        np.zeros((0, 0, 3), np.uint8), t1)
            img = panel.image
            full = (img.shape[1], img.shape[0])
            h, w = _fit(img.shape[0], img.shape[1], view.width, view.height)
            rgb = img if (h, w) == img.shape[:2] else (box_sum(img, h, w) / box_area(*img.shape[:2], h, w)[:, :, None])
            note, kind, stats = panel.note, panel.kind, []
        h, w = rgb.shape[:2]
        header = {"type": "image", "port": port, "width": w, "height": h, "full": full, "note": note, "kind": kind,
                  "stats": None if stats is None else _finite(stats), "frame": self.frame}
        if layout is not None:  # [panels, panel width, gap]: the page maps a point of panel i onto the buffer
            header["panels"] = layout
        return header, to_uint8(rgb, grey=kind == "grey"), t1

    def _stats(self, ref: tuple[str, str], host: np.ndarray) -> list[dict[str, Any]]:
        key = (ref, id(host))
        if self._stats_key != key:
            self._stats_key, self._stats_val = key, channel_stats(host)
        return self._stats_val

    def probe(self, port: str | None, x: int, y: int) -> dict[str, Any]:
        """The values of a texture at pixel (x, y), row 0 at the top, from the data the view read back."""
        ref = self._ref(port)
        if ref is None:
            return {"x": x, "y": y, "values": None}
        _, host = self._host_of(ref)
        if host is None or host.ndim != 3 or not (0 <= x < host.shape[1] and 0 <= y < host.shape[0]):
            return {"x": x, "y": y, "values": None}
        vals = host[host.shape[0] - 1 - y, x]
        return {"x": x, "y": y, "port": f"{ref[0]}.{ref[1]}",
                "values": [float(v) if np.isfinite(v) else str(v) for v in vals.tolist()]}


def _line(exc: BaseException) -> str:
    """The one-line message the command line prints: a located error as `file:line:col: message`."""
    if isinstance(exc, SketchgraphError):
        return " ".join(str(exc).split())
    return one_line(exc)


class _Reset:
    def __repr__(self) -> str:
        return "<reset>"


_RESET = _Reset()


def _inside(path: Path, roots: list[Path]) -> bool:
    p = path.resolve()
    return any(p == r or r in p.parents for r in roots)


def _view(msg: dict[str, Any], old: View) -> View:
    def num(name: str, default: Any) -> Any:
        v = msg.get(name, default)
        if v is None or v == "":
            return None
        v = float(v)
        return v if np.isfinite(v) else None

    mode = str(msg.get("mode", old.mode))
    return View(port=msg.get("port", old.port) or None,
                width=int(min(MAX_BOX, max(1, int(msg.get("width", old.width))))),
                height=int(min(MAX_BOX, max(1, int(msg.get("height", old.height))))),
                mode=mode if mode in MODES else "auto", exposure=num("exposure", old.exposure) or 0.0,
                lo=num("lo", old.lo), hi=num("hi", old.hi))


def _fit(h: int, w: int, box_w: int, box_h: int) -> tuple[int, int]:
    """(height, width) of an h x w picture shrunk to fit the box (never enlarged)."""
    s = min(1.0, box_w / w, box_h / h)
    return max(1, round(h * s)), max(1, round(w * s))


def panels(w: int, kind: str, mode: str = "auto") -> tuple[int, int]:
    """(panels side by side, the gap between them in buffer pixels) of a `w`-wide texture's picture: two for
    two 2D vectors per pixel (the sketch's offsets: viz's `vector2`, a gap of w // 100, at least 1) drawn in
    `auto` mode, else one."""
    if kind == "vector2" and mode == "auto":
        return 2, max(1, w // 100)
    return 1, 0


def draw(host: np.ndarray, port: str, doc: str, view: View) -> tuple[np.ndarray, str, str]:
    """A texture (GL order) drawn at the size of `view`'s box: (RGB float image, or an 8-bit picture (RGB or
    grey) where a fast path drew it, note, kind). A picture of several panels (`panels`) fits the box as a
    whole: each panel is drawn at the size that leaves room for the others."""
    a = host[::-1]
    h, w, c = a.shape
    kind = viz.classify(port, c, doc)
    n, gap = panels(w, kind, view.mode)
    s = min(1.0, view.width / (n * w + (n - 1) * gap), view.height / h)
    height, width = (h, w) if s >= 1.0 else (max(1, round(h * s)), max(1, round(w * s)))
    if view.mode == "auto":
        fast = _fast_color(a, height, width) if kind == "color" else None
        if fast is None and (height, width) == (h, w) and kind in _FAST_WHOLE:
            fast = _FAST_WHOLE[kind](a)
        if fast is not None:
            img, note = fast
        elif (height, width) == (h, w):  # shown whole: the port's own visualisation, nothing to average
            img, note = viz._DRAW[kind](a)
        else:
            img, note = reduce_and_colour(a, kind, height, width)
        if kind == "color" and view.exposure:
            img = np.clip(img * np.float32(2.0 ** view.exposure), 0.0, 1.0)
            note += f", exposure {view.exposure:+g}"
        return img, note, kind
    area = box_area(h, w, height, width)[:, :, None]
    if view.mode == "rgb":
        src = a[:, :, :3] if c >= 3 else np.repeat(a[:, :, :1], 3, axis=2)
        mean = box_sum(np.nan_to_num(src, nan=0.0, posinf=0.0, neginf=0.0), height, width) / area
        img = np.clip(mean * 2.0 ** view.exposure, 0.0, 1.0).astype(np.float32)
        return img, f"RGB, exposure {view.exposure:+g}", "rgb"
    k = "rgba".index(view.mode)
    if k >= c:
        return np.zeros((height, width, 3), np.float32), f"no channel {view.mode.upper()} ({c} channels)", "grey"
    ch = a[:, :, k]
    finite = np.isfinite(ch)
    vals = ch[finite]
    lo = view.lo if view.lo is not None else (float(vals.min()) if vals.size else 0.0)
    hi = view.hi if view.hi is not None else (float(vals.max()) if vals.size else 1.0)
    mean = box_sum(np.where(finite, ch, np.float32(lo))[:, :, None], height, width) / area
    g = np.clip((mean - lo) / (hi - lo), 0.0, 1.0) if hi > lo else (mean > lo).astype(np.float64)
    img = np.repeat(g, 3, axis=2).astype(np.float32)
    return img, f"channel {view.mode.upper()}, {lo:.4g}..{hi:.4g}", "grey"


def draw_array(host: np.ndarray, port: str, doc: str, view: View, per_row: int = 16,
               gap: int = 2) -> tuple[np.ndarray, str, str, tuple[int, int]] | None:
    """A texture array (L, H, W, C; GL order) as `viz.visualize_array`'s strip of layers, shrunk to fit `view`'s
    box: each layer reduced to its tile's size first and then coloured (`reduce_and_colour`, as a shrunk texture
    is), instead of colouring every layer whole. (RGB float image, note, kind, the whole strip's (W, H)); None
    where the strip is shown whole or the view is not `auto` (the exact path draws it)."""
    n, h, w, c = host.shape
    cols, rows = min(n, per_row), -(-n // per_row)
    full_w, full_h = cols * (w + gap) - gap, rows * (h + gap) - gap
    shown_h, shown_w = _fit(full_h, full_w, view.width, view.height)
    if view.mode != "auto" or view.exposure or (shown_h, shown_w) == (full_h, full_w) or n == 0:
        return None
    s = min(shown_h / full_h, shown_w / full_w)
    th, tw, g = max(1, int(h * s)), max(1, int(w * s)), max(1, round(gap * s))
    while tw > 1 and cols * (tw + g) - g > shown_w:  # (a gap is at least a pixel: the tiles give way)
        tw -= 1
    while th > 1 and rows * (th + g) - g > shown_h:
        th -= 1
    kind = viz.classify(port, c, doc)
    out = np.empty((rows * (th + g) - g, cols * (tw + g) - g, 3), np.float32)
    out[:] = viz.SHEET_BG
    for i in range(n):
        r, k = divmod(i, per_row)
        tile, _ = reduce_and_colour(np.asarray(host[i][::-1], np.float32), kind, th, tw)
        out[r * (th + g):r * (th + g) + th, k * (tw + g):k * (tw + g) + tw] = tile
    return out, f"{n} layers ({kind})", "strip", (full_w, full_h)


def _box_mean32(a: np.ndarray, height: int, width: int) -> np.ndarray:
    """The area average of (H, W, C) over a (height, width) grid, summed in float32 (for display only)."""
    h, w = a.shape[:2]
    s = np.add.reduceat(a, (np.arange(height) * h // height), axis=0) if height < h else a
    s = np.add.reduceat(s, (np.arange(width) * w // width), axis=1) if width < w else s
    return s / box_area(h, w, height, width).astype(np.float32)[:, :, None]


def _fast_color(a: np.ndarray, height: int, width: int) -> tuple[np.ndarray, str] | None:
    """`reduce_and_colour` for a colour buffer whose values are all finite and within 0..1 (the usual final
    image), in float32 and without the masks; None for anything else (the exact path draws it)."""
    rgb = a[:, :, :3] if a.shape[2] >= 3 else None
    if rgb is None or not np.isfinite(rgb).all():
        return None
    if float(rgb.min()) < -1e-3 or float(rgb.max()) > 1.0 + 1e-3:
        return None
    mean = rgb if (height, width) == rgb.shape[:2] else _box_mean32(rgb, height, width)
    return np.clip(mean, 0.0, 1.0), "rgb"


def _u8(x: np.ndarray, own: bool = False) -> np.ndarray:
    """Float display values as 8-bit ones, as `to_uint8` makes them (clipped to 0..1, x 255, rounded); `own`:
    x is a float32 scratch array that may be worked in place."""
    scaled = np.clip(x, np.float32(0.0), np.float32(1.0), out=x if own else None, dtype=np.float32)
    scaled *= np.float32(255.0)
    scaled += np.float32(0.5)
    return scaled.astype(np.uint8)  # truncation after +0.5: rounded


# `viz`'s drawings of a buffer shown whole whose values are all finite, with its float32 operations in its order
# (so the same 8-bit values), without its masks and copies, as 8-bit pictures (grey where viz's is grey); None
# for anything else (viz draws it)
def _fast_grey(a: np.ndarray) -> tuple[np.ndarray, str] | None:
    ch = a[:, :, 0]
    if not np.isfinite(ch).all():
        return None
    lo, hi = float(ch.min()), float(ch.max())
    if lo >= -1e-3 and hi <= 1.0 + 1e-3:
        return _u8(ch), "grey, 0..1"
    return _u8(viz._normalize(ch, lo, hi)), f"grey, normalized {lo:.4g}..{hi:.4g}"


def _fast_depth(a: np.ndarray) -> tuple[np.ndarray, str] | None:
    d = a[:, :, 0]
    if not np.isfinite(d).all():
        return None
    background = (d == np.float32(0.0)) | (d == np.float32(1.0))  # no surface
    if background.all():
        background[:] = False
    vals = d[~background]  # a masked reduction (`where=`) is slower than the copy
    lo, hi = float(vals.min()), float(vals.max())
    v = 1.0 - viz._normalize(d, lo, hi)  # near is bright; the background's values are replaced below
    g = _u8(0.12 + 0.88 * v)
    note = f"depth {lo:.4g}..{hi:.4g}, near bright"
    if not background.any():
        return g, note
    g[background] = 0  # the surface's grey is 0.12 or more (31 or more): 0 is free for the background colour
    return Indexed(g, _DEPTH_PALETTE), note


def _fast_normals(a: np.ndarray) -> tuple[np.ndarray, str] | None:
    if not np.isfinite(a).all():
        return None
    # all channels in whole-array passes (slicing three of four makes NumPy's inner loops three long), in place;
    # a fourth channel is then made opaque: sent as RGBA
    t = a * np.float32(0.5)
    t += np.float32(0.5)
    out = _u8(t, own=True)
    if a.shape[2] == 4:
        out[:, :, 3] = 255
    return out, "normal xyz as rgb = n/2 + 1/2"


@dataclass
class Indexed:
    """An 8-bit picture as indices into a palette ((N, 3) uint8): sent as a paletted PNG."""

    index: np.ndarray
    palette: np.ndarray

    @property
    def shape(self) -> tuple[int, int, int]:
        return (*self.index.shape, 3)

    dtype = np.dtype(np.uint8)

    def rgb(self) -> np.ndarray:
        return self.palette[self.index]


_DEPTH_PALETTE = np.repeat(np.arange(256, dtype=np.uint8)[:, None], 3, axis=1)
_DEPTH_PALETTE[0] = np.clip(viz.BACKGROUND * np.float32(255.0) + np.float32(0.5), 0, 255).astype(np.uint8)


_HUE_STEPS = 1 << 16  # the wheel's colours at this many hues a turn: one step moves a channel by 6/65536 of v


def _hue_table() -> np.ndarray:
    """(steps + 1, 3) float32: 255 (1 - ramp) of red, green and blue (`viz.hsv_to_rgb`, saturation 1) at the
    hue of each step, the first at -1/2 turn (arctan2's -pi)."""
    h6 = (np.arange(_HUE_STEPS + 1, dtype=np.float64) / _HUE_STEPS - 0.5) * 6.0
    table = np.empty((_HUE_STEPS + 1, 3), np.float64)
    for c, offset in enumerate((5.0, 3.0, 1.0)):
        k = np.mod(offset + h6, 6.0)
        table[:, c] = 1.0 - np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0)
    return (table * 255.0).astype(np.float32)


_HUE = _hue_table()


def _wheel8(x: np.ndarray, y: np.ndarray, mag: np.ndarray, peak: float, out: np.ndarray) -> None:
    """`viz.wheel` (hue = direction, brightness = |v| / peak, full saturation) in float32 into 8-bit `out`
    (H, W, 3), its colours looked up at `_HUE_STEPS` hues a turn: a value moves by one step in a few pixels in
    ten thousand. `mag` is |v| (float32), used up."""
    if peak > 0:
        mag *= np.float32(1.0 / peak)
        np.minimum(mag, np.float32(1.0), out=mag)
    else:
        mag[:] = 0.0
    hue = np.arctan2(y, x)  # -pi..pi
    hue *= np.float32(_HUE_STEPS / (2.0 * np.pi))
    hue += np.float32(_HUE_STEPS / 2.0 + 0.5)  # the nearest step
    rgb = _HUE[hue.astype(np.intp)]  # (H, W, 3): 255 (1 - ramp)
    rgb *= mag[:, :, None]
    rgb += np.float32(0.5)
    out[:] = rgb  # truncation after +0.5: rounded


def _peak_mag(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    mag = np.hypot(x, y, dtype=np.float32)
    return mag, float(mag.max()) if mag.size else 0.0


def _fast_vector(a: np.ndarray) -> tuple[np.ndarray, str] | None:
    x, y = a[:, :, 0], a[:, :, 1]
    if not np.isfinite(a[:, :, :2]).all():
        return None
    mag, peak = _peak_mag(x, y)
    out = np.empty(a.shape[:2] + (3,), np.uint8)
    _wheel8(x, y, mag, peak, out)
    return out, f"direction as hue, |v| as brightness (max {peak:.4g})"


def _fast_vector2(a: np.ndarray) -> tuple[np.ndarray, str] | None:
    if a.shape[2] < 4 or not np.isfinite(a).all():
        return None
    (m1, p1), (m2, p2) = _peak_mag(a[:, :, 0], a[:, :, 1]), _peak_mag(a[:, :, 2], a[:, :, 3])
    peak = max(p1, p2)
    h, w = a.shape[:2]
    gap = max(1, w // 100)
    out = np.empty((h, 2 * w + gap, 3), np.uint8)
    out[:, w:w + gap] = _u8(viz.SHEET_BG)
    _wheel8(a[:, :, 0], a[:, :, 1], m1, peak, out[:, :w])
    _wheel8(a[:, :, 2], a[:, :, 3], m2, peak, out[:, w + gap:])
    return out, f"xy | zw: direction as hue, |v| as brightness (max {peak:.4g})"


def _fast_ids(a: np.ndarray) -> tuple[np.ndarray, str] | None:
    """Object ids: each id's colour made once (viz's own arithmetic on a table of the ids 0..max), then looked
    up per pixel; the same colours as `viz._ids`."""
    ch = a[:, :, 0]
    if not np.isfinite(ch).all():
        return None
    ids = np.rint(ch).astype(np.intp)
    top = int(ids.max()) if ids.size else 0
    if ids.size and (int(ids.min()) < 0 or top > 1 << 16):
        return None
    table, _ = viz._ids(np.arange(top + 1, dtype=np.float32)[None, :, None])
    n = int(np.count_nonzero(np.bincount(ids.ravel(), minlength=top + 1)[1:]))
    return _u8(table[0])[ids], f"{n} ids as colours, 0 black"


def _fast_position(a: np.ndarray) -> tuple[np.ndarray, str] | None:
    """Each of x, y, z normalised over the covered pixels (alpha > 0; all where there are 3 channels), the
    uncovered black, as `viz._position`, one channel at a time."""
    if not np.isfinite(a).all():
        return None
    planes = np.ascontiguousarray(np.moveaxis(a, 2, 0))  # one channel after another: contiguous passes
    covered = planes[3] > 0 if a.shape[2] == 4 else None
    out = np.empty(a.shape[:2] + (3,), np.uint8)
    for c in range(3):
        ch = planes[c]
        if covered is None:
            lo, hi = float(ch.min()), float(ch.max())
        else:
            vals = ch[covered]  # a masked reduction (`where=`) is slower than the copy
            lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (0.0, 1.0)
        g = _u8(viz._normalize(ch, lo, hi))
        out[:, :, c] = g if covered is None else np.where(covered, g, np.uint8(0))
    return out, "xyz normalized per channel over covered pixels"


_FAST_WHOLE = {"grey": _fast_grey, "depth": _fast_depth, "normals": _fast_normals, "vector": _fast_vector,
               "vector2": _fast_vector2, "ids": _fast_ids, "position": _fast_position}


def _fast_rgba8(host: np.ndarray) -> np.ndarray | None:
    """An RGBA texture (GL order) whose values are all finite and whose colour lies within 0..1 as the RGBA8
    picture `viz`'s colour drawing gives (opaque, row 0 at the top), in a few whole-array passes; None for
    anything else (the exact path draws it)."""
    h, w, c = host.shape
    rows = np.ascontiguousarray(host).reshape(h, w * c)
    if not np.isfinite(rows).all():
        return None
    lo = float(rows.min(axis=0).reshape(w, c)[:, :3].min())
    hi = float(rows.max(axis=0).reshape(w, c)[:, :3].max())
    if lo < -1e-3 or hi > 1.0 + 1e-3:
        return None
    out = _u8(host[::-1])
    out[:, :, 3] = 255
    return out


def to_uint8(rgb: np.ndarray, grey: bool = False) -> np.ndarray:
    """A float display picture (H, W, 3) in 0..1 as 8-bit values (rounded); (H, W) where `grey` is asked and
    the three channels agree everywhere (a grey picture sent as one channel). An 8-bit picture is kept."""
    if isinstance(rgb, Indexed) or rgb.dtype == np.uint8:  # drawn as 8-bit values already
        return rgb
    out = _u8(rgb)
    if grey and np.array_equal(out[:, :, 0], out[:, :, 1]) and np.array_equal(out[:, :, 1], out[:, :, 2]):
        return np.ascontiguousarray(out[:, :, 0])
    return out


def encode_png(img: np.ndarray | Indexed) -> bytes:
    """An 8-bit picture, (H, W) grey, (H, W, 3) RGB, (H, W, 4) RGBA or `Indexed`, row 0 at the top, as PNG
    bytes: each row stored as its difference from the row above (PNG's "up" filter: flat and vertically smooth
    areas become zeros) and deflated by ISA-L's level 1 (`output.imageio.png_bytes`). A view of 800x800 takes
    about 1 ms here and mostly 6 to 60 KB, which the page decodes off its main thread; the raw 2.5 MB of RGBA
    took 27 to 100 ms to cross the websocket into Chromium (docs/serve.md "Latency")."""
    from ...output.imageio import png_bytes

    palette = None
    if isinstance(img, Indexed):
        img, palette = img.index, img.palette
    a = img if img.ndim == 3 else img[:, :, None]
    h, w, c = a.shape
    flat = np.ascontiguousarray(a).reshape(h, w * c)
    rows = np.empty((h, 1 + w * c), np.uint8)
    rows[:, 0] = 2  # filter type "up"; the first row's row above is zeros
    rows[0, 1:] = flat[0]
    np.subtract(flat[1:], flat[:-1], out=rows[1:, 1:])  # modulo 256, as PNG defines it
    return png_bytes(rows, w, h, c, level=1, name="view", palette=palette)


def channel_stats(host: np.ndarray) -> list[dict[str, Any]]:
    """Per-channel min, max and mean (float64 sums) of a texture; NumPy's nan-aware path only where needed."""
    c = host.shape[-1]
    if not np.isfinite(host).all():
        return [s.as_dict() for s in viz.channel_stats(host)]
    # reduced over rows first (a contiguous inner axis is several times faster than reducing (N, C) on axis 0)
    rows = np.ascontiguousarray(host).reshape(host.shape[0], -1)
    lo = rows.min(axis=0).reshape(-1, c).min(axis=0)
    hi = rows.max(axis=0).reshape(-1, c).max(axis=0)
    mean = rows.sum(axis=0, dtype=np.float64).reshape(-1, c).sum(axis=0) / (host.size // c)
    names = "RGBA" if c <= 4 else [str(i) for i in range(c)]
    return [{"channel": names[k], "min": float(lo[k]), "max": float(hi[k]), "mean": float(mean[k]), "nan": 0,
             "inf": 0} for k in range(c)]


def _finite(stats: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: (v if not isinstance(v, float) or np.isfinite(v) else str(v)) for k, v in s.items()} for s in stats]


def _frames(pipe: Pipeline | None) -> dict[str, Any] | None:
    """The frame slider's range: an animated scene's frames, or one turn of its orbit; None for a still."""
    scene = getattr(pipe, "scene", None)
    if scene is None:
        return None
    anim = getattr(scene, "animation", None)
    if anim is not None:
        r = anim.frame_range()
        return {"start": r.start, "end": max(r.start, r.stop - 1), "fps": anim.fps, "kind": "animation"}
    orbit = getattr(scene, "orbit", None)
    if orbit is not None and orbit.degrees_per_frame:
        n = max(1, round(360.0 / abs(orbit.degrees_per_frame)))
        return {"start": 0, "end": n - 1, "fps": 24.0, "kind": "orbit"}
    return None


_SCHEMAS: dict[type, dict[str, Any]] = {}


def _schema(model: type) -> dict[str, Any]:
    """A node's parameter schema (pydantic's JSON schema, `$ref`s resolved), memoised per class."""
    hit = _SCHEMAS.get(model)
    if hit is None:
        raw = model.model_json_schema()  # type: ignore[attr-defined]
        defs = raw.get("$defs", {})

        def resolve(node: Any, depth: int = 0) -> Any:
            if depth > 20:
                return {}
            if isinstance(node, dict):
                if "$ref" in node:
                    target = defs.get(node["$ref"].rsplit("/", 1)[-1], {})
                    return resolve({**target, **{k: v for k, v in node.items() if k != "$ref"}}, depth + 1)
                return {k: resolve(v, depth + 1) for k, v in node.items() if k != "$defs"}
            if isinstance(node, list):
                return [resolve(v, depth + 1) for v in node]
            return node

        hit = _SCHEMAS[model] = resolve(raw)
    return hit
