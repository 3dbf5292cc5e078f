"""Planning, compute counts, the disk cache and its recovery, with small test nodes."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import Field

from nodegraph import pipeline as pl
from nodegraph.cache import Cache, CacheWarning
from nodegraph.executor import Executor
from nodegraph.node import Input, Node, NodeParams, Output
from nodegraph.plan import plan
from nodegraph.registry import Registry
from nodegraph.types import Texture

COUNTS: dict[str, int] = {}


class Fill(Node):
    """A constant texture."""

    outputs = {"out": Output(Texture("RGBA32F"))}

    class Params(NodeParams):
        value: float = Field(0.5, description="fill value")

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        COUNTS[self.id] = COUNTS.get(self.id, 0) + 1
        w, h = ctx.size
        return {"out": ctx.gl.upload(np.full((h, w, 4), self.params.value, np.float32), ctx.format("out"))}


class Add(Node):
    """a + b + offset (computed on the CPU to keep the test independent of shaders)."""

    inputs = {"a": Input(Texture("RGBA16F")), "b": Input(Texture("RGBA16F"))}
    outputs = {"out": Output(Texture("RGBA32F")), "half": Output(Texture("R16F"))}

    class Params(NodeParams):
        offset: float = Field(0.0, description="added")

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        COUNTS[self.id] = COUNTS.get(self.id, 0) + 1
        s = inputs["a"].read() + inputs["b"].read() + self.params.offset
        out = {"out": ctx.gl.upload(s, ctx.format("out"))}
        if "half" in needed:
            out["half"] = ctx.gl.upload(s[..., :1] * 0.5, ctx.format("half"))
        return out


REG = Registry()
REG.add(Fill, "fill")
REG.add(Add, "add")

TEXT = """\
pipeline: t
size: [8, 4]
nodes:
  a: {type: fill, params: {value: 0.25}}
  b: {type: fill, params: {value: 0.5}}
  c: {type: fill, params: {value: 1.0}}
  ab: {type: add, in: {a: a.out, b: b.out}}
  abc: {type: add, in: {a: ab.out, b: c.out}, params: {offset: 1.0}}
outputs:
  image: abc.out
  partial: ab.out
"""


def load(overrides: list[str] = ()) -> pl.Pipeline:
    return pl.loads(TEXT, "t.yaml", registry=REG, load_scene=False, overrides=list(overrides))


@pytest.fixture(autouse=True)
def _reset():
    COUNTS.clear()


def test_only_ancestors_of_the_requested_output_run(gl):
    pipe = load()
    ex = Executor(pipe, None, requested=[("ab", "out")], gl=gl)
    res = ex.run()
    assert COUNTS == {"a": 1, "b": 1, "ab": 1}
    np.testing.assert_allclose(res.values[("ab", "out")].read(), 0.75)
    assert set(res.stats) == {"a", "b", "ab"}


def test_full_run_values_and_formats(gl):
    pipe = load()
    p = plan(pipe)
    # a, b, c feed RGBA16F inputs only: the engine allocates them at half precision
    assert p.formats[("a", "out")] == "RGBA16F"
    # ab.out feeds abc (RGBA16F) and is a requested output (full precision)
    assert p.formats[("ab", "out")] == "RGBA32F"
    assert ("ab", "half") not in p.formats
    ex = Executor(pipe, None, gl=gl)
    res = ex.run()
    np.testing.assert_allclose(res.values[("abc", "out")].read(), 2.75)
    assert res.values[("a", "out")].fmt if ("a", "out") in res.values else True


def test_second_run_computes_nothing_and_a_param_change_recomputes_downstream_only(gl, tmp_path: Path):
    cache = Cache(tmp_path / "c")
    Executor(load(), cache, gl=gl).run()
    assert COUNTS == {"a": 1, "b": 1, "c": 1, "ab": 1, "abc": 1}
    COUNTS.clear()
    ex = Executor(load(), cache, gl=gl)  # a new executor: nothing in memory, everything on disk
    res = ex.run()
    assert COUNTS == {}
    np.testing.assert_allclose(res.values[("abc", "out")].read(), 2.75)
    # a and b were not even loaded: ab's cached output was enough
    assert {n: s.status for n, s in res.stats.items()} == {"a": "skipped", "b": "skipped", "c": "skipped",
                                                           "ab": "disk", "abc": "disk"}
    COUNTS.clear()
    res = Executor(load(["c.value=2.0"]), cache, gl=gl).run()
    assert COUNTS == {"c": 1, "abc": 1}
    np.testing.assert_allclose(res.values[("abc", "out")].read(), 3.75)


def test_memory_cache_within_one_executor(gl):
    ex = Executor(load(), None, gl=gl)
    ex.run(0)
    ex.run(1)  # no node reads the frame: everything comes from memory
    assert COUNTS == {"a": 1, "b": 1, "c": 1, "ab": 1, "abc": 1}


def test_corrupt_cache_entry_is_recomputed_with_a_warning(gl, tmp_path: Path):
    cache = Cache(tmp_path / "c")
    ex = Executor(load(), cache, gl=gl)
    keys = ex.keys()
    ex.run()
    path = cache.find(keys["abc"], ex._entry("abc", "out"))
    assert path is not None and path.suffix == ".exr"
    path.write_bytes(b"not an exr at all")
    COUNTS.clear()
    with pytest.warns(CacheWarning, match="unusable"):
        res = Executor(load(), Cache(tmp_path / "c"), gl=gl).run()
    assert COUNTS == {"abc": 1}
    np.testing.assert_allclose(res.values[("abc", "out")].read(), 2.75)


def test_mismatched_header_key_is_recomputed(gl, tmp_path: Path):
    cache = Cache(tmp_path / "c")
    ex = Executor(load(), cache, gl=gl)
    keys = ex.keys()
    ex.run()
    # put ab's entry where abc's should be: a readable EXR whose header names another key
    src, dst = cache.find(keys["ab"], ex._entry("ab", "out")), cache.find(keys["abc"], ex._entry("abc", "out"))
    dst.write_bytes(src.read_bytes())
    COUNTS.clear()
    with pytest.warns(CacheWarning, match="does not match"):
        res = Executor(load(), Cache(tmp_path / "c"), gl=gl).run()
    assert COUNTS == {"abc": 1}
    np.testing.assert_allclose(res.values[("abc", "out")].read(), 2.75)


def test_exr_header_explains_the_entry(gl, tmp_path: Path):
    import OpenImageIO as oiio

    cache = Cache(tmp_path / "c")
    ex = Executor(load(), cache, gl=gl)
    keys = ex.keys()
    ex.run()
    spec = oiio.ImageInput.open(str(cache.find(keys["abc"], ex._entry("abc", "out")))).spec()
    assert spec.get_string_attribute("sketchgraph:key") == keys["abc"]
    assert spec.get_string_attribute("sketchgraph:type") == "add"
    assert '"offset": 1.0' in spec.get_string_attribute("sketchgraph:params")


def test_lru_prune(gl, tmp_path: Path):
    import os
    import time

    cache = Cache(tmp_path / "c")
    Executor(load(), cache, gl=gl).run()
    entries = sorted(cache.entries(), key=lambda e: e.path.name)
    assert len(entries) == 5  # a, b, c, ab, abc: one per planned output port, nothing for unplanned ports
    oldest = entries[0].path
    past = time.time() - 3600
    os.utime(oldest, (past, past))
    total = sum(e.size for e in entries)
    files, freed = cache.prune(total - 1)
    assert files == 1 and not oldest.exists()
    assert cache.prune(0)[0] == 4
    assert cache.entries() == []


def test_loop_mode_does_not_write_auto_nodes(gl, tmp_path: Path):
    cache = Cache(tmp_path / "c")
    ex = Executor(load(), cache, gl=gl, mode="loop")
    ex.run(0)
    ex.close()
    assert cache.entries() == []


def test_cache_writes_are_atomic_names(gl, tmp_path: Path):
    cache = Cache(tmp_path / "c")
    Executor(load(), cache, gl=gl).run()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        names = [p.name for p in (tmp_path / "c").rglob("*") if p.is_file()]
    assert not any(n.startswith(".tmp") for n in names)


def test_a_lower_precision_cache_entry_is_not_read_where_more_is_planned(gl, tmp_path: Path):
    cache = Cache(tmp_path / "c")
    first = Executor(load(), cache, requested=[("abc", "out")], gl=gl)
    assert first.plan.formats[("ab", "out")] == "RGBA16F"  # only abc reads it, at half precision
    first.run()
    COUNTS.clear()
    second = Executor(load(), cache, requested=[("ab", "out")], gl=gl)
    assert second.plan.formats[("ab", "out")] == "RGBA32F"  # requested: full precision
    second.run()
    assert COUNTS == {"ab": 1}  # recomputed from a and b (read from disk), not read at half precision


@pytest.mark.parametrize("first", ["disk", "memory"])
def test_a_recompute_for_a_missing_port_leaves_the_values_already_handed_out_intact(gl, tmp_path: Path, first):
    """ab.out is stored (on disk, or in memory from an earlier frame) but ab.half is not: the run hands
    out ab.out, then computes ab for its half. The value handed out must stay valid: its texture may not
    go back to the pool while the result (or a later node's inputs) still holds it. (It did: a later
    upload of the same shape reused it, and the intermediates sheet of a gallery entry showed another
    node's buffer.)"""
    cache = Cache(tmp_path / "c") if first == "disk" else None
    ex = Executor(load(), cache, gl=gl, requested=[("ab", "out")])
    ex.run()
    if first == "disk":
        ex = Executor(load(), cache, gl=gl, requested=[("ab", "out"), ("ab", "half"), ("abc", "out")])
    else:  # the same executor's memory, asked for more
        ex.plan = plan(load(), [("ab", "out"), ("ab", "half"), ("abc", "out")])
    COUNTS.clear()
    res = ex.run()
    assert COUNTS.get("ab") == 1  # computed once, for its half
    np.testing.assert_allclose(res.values[("ab", "out")].read(), 0.75)
    np.testing.assert_allclose(res.values[("ab", "half")].read(), 0.375)
    np.testing.assert_allclose(res.values[("abc", "out")].read(), 2.75)


def test_before_wait_runs_once_before_the_first_node_that_reads_inputs(gl):
    pipe = load()
    order: list[str] = []
    for nid, node in pipe.nodes.items():
        def traced(ctx: Any, inputs: dict[str, Any], needed: frozenset[str], _c=node.compute, _n=nid) -> Any:
            order.append(_n)
            return _c(ctx, inputs, needed)
        node.compute = traced
    ex = Executor(pipe, None, requested=[("abc", "out")], gl=gl, mode="loop")
    ex.run(0, before_wait=lambda: order.append("hook"))
    first_reader = min(order.index("ab"), order.index("abc"))
    assert order.count("hook") == 1 and order.index("hook") == first_reader - 1
    assert set(order[:first_reader - 1]) <= {"a", "b", "c"}  # only nodes without inputs before it


def test_before_wait_runs_at_the_end_when_nothing_reads_inputs_and_sees_the_last_frames_values(gl):
    pipe = load()
    ex = Executor(pipe, None, requested=[("abc", "out")], gl=gl, mode="loop")
    last = ex.run(0).values[("abc", "out")]
    seen: list[Any] = []
    # the same key: every value comes from memory, nothing is computed, the hook runs at the run's end, and
    # the previous run's value it reads back is still the one handed out (not yet back in the pool)
    ex.run(1, before_wait=lambda: seen.append(last.read()))
    assert len(seen) == 1
    np.testing.assert_allclose(seen[0], 2.75)


def test_before_wait_is_not_called_when_the_run_fails(gl):
    pipe = load()

    def broken(ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> Any:
        raise RuntimeError("boom")

    pipe.nodes["a"].compute = broken
    calls: list[int] = []
    ex = Executor(pipe, None, requested=[("abc", "out")], gl=gl, mode="loop")
    with pytest.raises(Exception, match="boom"):
        ex.run(0, before_wait=lambda: calls.append(1))
    assert calls == []
    ex2 = Executor(load(), None, requested=[("abc", "out")], gl=gl, mode="loop")
    ex2.run(0)  # and a later run without a hook does not call an old one
    ex2.run(1, before_wait=lambda: calls.append(2))
    ex2.run(2)
    assert calls == [2]
