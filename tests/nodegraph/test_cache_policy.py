"""Cost-aware persistence of single renders (`Cache.worth_writing`, driven by `Executor`): an output is written
when recomputing it (its node and the unstored nodes it needs, as measured in the run) costs at least its
estimated write and read; small entries are always written. The cost model is set per test so that tiny
textures stand for big ones."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import Field

from nodegraph import pipeline as pl
from nodegraph.cache import Cache
from nodegraph.executor import Executor
from nodegraph.node import Input, Node, NodeParams, Output
from nodegraph.registry import Registry
from nodegraph.types import Texture

COUNTS: dict[str, int] = {}
SIZE = (8, 4)
ENTRY_MS = 200.0  # what every 8x4 RGBA32F entry is made to cost (write + read)


class Fill(Node):
    """A constant texture, after `sleep_ms` (standing for an expensive computation)."""

    outputs = {"out": Output(Texture("RGBA32F"))}

    class Params(NodeParams):
        value: float = Field(0.5, description="fill value")
        sleep_ms: float = Field(0.0, description="time the node takes")

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        COUNTS[self.id] = COUNTS.get(self.id, 0) + 1
        time.sleep(self.params.sleep_ms / 1000)
        w, h = ctx.size
        return {"out": ctx.gl.upload(np.full((h, w, 4), self.params.value, np.float32), ctx.format("out"))}


class Add(Node):
    """a + b, on the CPU."""

    inputs = {"a": Input(Texture("RGBA32F")), "b": Input(Texture("RGBA32F"))}
    outputs = {"out": Output(Texture("RGBA32F"))}

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        COUNTS[self.id] = COUNTS.get(self.id, 0) + 1
        return {"out": ctx.gl.upload(inputs["a"].read() + inputs["b"].read(), ctx.format("out"))}


class Fail(Node):
    """Fails, after its input was computed."""

    inputs = {"a": Input(Texture("RGBA32F"))}
    outputs = {"out": Output(Texture("RGBA32F"))}

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        raise RuntimeError("this node always fails")


REG = Registry()
REG.add(Fill, "fill")
REG.add(Add, "add")
REG.add(Fail, "fail")


def _load(text: str) -> pl.Pipeline:
    return pl.loads(f"pipeline: t\nsize: [{SIZE[0]}, {SIZE[1]}]\n{text}", "t.yaml", registry=REG, load_scene=False)


def _cache(root: Path) -> Cache:
    cache = Cache(root)
    cache.always_write_ms = 0.0
    cache.ms_per_mb = ENTRY_MS / (SIZE[0] * SIZE[1] * 4 * 4 / 1e6)  # RGBA32F: stored as float
    return cache


def _stored(ex: Executor, res: Any) -> set[str]:
    return {nid for nid, st in res.stats.items() if ex.is_stored(nid, "out", st.key)}


@pytest.fixture(autouse=True)
def _reset():
    COUNTS.clear()


def test_entry_cost_is_the_stored_bytes_at_the_rate(gl, tmp_path):
    cache = Cache(tmp_path / "c")
    cache.ms_per_mb = 10.0
    for fmt, per_pixel in (("RGBA8", 4 * 2), ("RGBA16F", 4 * 2), ("R32F", 4), ("RG32F", 2 * 4)):
        tex = gl.texture((800, 600), fmt)
        assert cache.entry_cost_ms(tex) == pytest.approx(800 * 600 * per_pixel / 1e6 * 10.0)
        gl.release(tex)
    assert cache.worth_writing(object(), None)  # unknown recompute cost: written


def test_cheap_outputs_are_recomputed_and_an_expensive_one_is_stored(gl, tmp_path):
    text = """\
nodes:
  cheap: {type: fill, params: {value: 0.25}}
  slow: {type: fill, params: {value: 0.5, sleep_ms: 400}}
  mix: {type: add, in: {a: cheap.out, b: slow.out}}
outputs:
  image: mix.out
"""
    cache = _cache(tmp_path / "c")
    ex = Executor(_load(text), cache, gl=gl)
    first = ex.run()
    ex.close()
    assert _stored(ex, first) == {"slow"}  # cheap (and mix, needing only cheap again) cost less than 200 ms
    assert cache.skipped == 2
    COUNTS.clear()
    ex2 = Executor(_load(text), cache, gl=gl)
    second = ex2.run()
    assert COUNTS == {"cheap": 1, "mix": 1}
    assert second.stats["slow"].status == "disk"
    np.testing.assert_array_equal(second.values[("mix", "out")].read(), np.full((4, 8, 4), 0.75, np.float32))


def test_the_recompute_cost_counts_the_unstored_nodes_it_needs(gl, tmp_path):
    # each slow node alone costs less than its entry; the sum node would need both again, which costs more
    text = """\
nodes:
  a: {type: fill, params: {value: 0.25, sleep_ms: 120}}
  b: {type: fill, params: {value: 0.5, sleep_ms: 120}}
  ab: {type: add, in: {a: a.out, b: b.out}}
outputs:
  image: ab.out
"""
    cache = _cache(tmp_path / "c")
    ex = Executor(_load(text), cache, gl=gl)
    first = ex.run()
    ex.close()
    assert _stored(ex, first) == {"ab"}
    COUNTS.clear()
    second = Executor(_load(text), cache, gl=gl).run()
    assert COUNTS == {} and second.stats["ab"].status == "disk"
    np.testing.assert_array_equal(second.values[("ab", "out")].read(), np.full((4, 8, 4), 0.75, np.float32))


def test_small_entries_and_persist_all_are_always_written(gl, tmp_path):
    text = """\
nodes:
  cheap: {type: fill, params: {value: 0.25}}
  other: {type: fill, params: {value: 0.5}}
  mix: {type: add, in: {a: cheap.out, b: other.out}}
outputs:
  image: mix.out
"""
    default = Cache(tmp_path / "default")  # 512-byte entries are far below ALWAYS_WRITE_MS
    ex = Executor(_load(text), default, gl=gl)
    assert _stored(ex, ex.run()) == {"cheap", "other", "mix"} and default.skipped == 0
    costly = _cache(tmp_path / "costly")
    ex = Executor(_load(text), costly, gl=gl, persist_all=True)  # inspecting: everything is written
    assert _stored(ex, ex.run()) == {"cheap", "other", "mix"} and costly.skipped == 0


def test_entries_are_written_after_the_runs_nodes_and_kept_when_a_later_node_fails(gl, tmp_path, monkeypatch):
    from nodegraph.errors import NodeError

    text = """\
nodes:
  a: {type: fill, params: {value: 0.25}}
  b: {type: fill, params: {value: 0.5}}
  ab: {type: add, in: {a: a.out, b: b.out}}
  bad: {type: fail, in: {a: ab.out}}
outputs:
  image: ab.out
  broken: bad.out
"""
    cache = Cache(tmp_path / "c")  # default cost model: these small entries are all written
    events: list[dict[str, int]] = []  # the computes done when each entry is stored
    store = cache.store_value

    def recording(*args: Any, **kwargs: Any) -> bool:
        events.append(dict(COUNTS))
        return store(*args, **kwargs)

    monkeypatch.setattr(cache, "store_value", recording)
    ex = Executor(_load(text), cache, gl=gl, requested=[("ab", "out")])
    ex.run()
    assert events == [{"a": 1, "b": 1, "ab": 1}] * 3  # every node had run before the first write
    COUNTS.clear()
    events.clear()
    failing = Executor(_load(text.replace("0.25", "0.125")), cache, gl=gl, requested=[("bad", "out")])
    with pytest.raises(NodeError, match="always fails"):
        failing.run()
    assert events == [{"a": 1, "ab": 1}] * 2  # a and ab are kept although bad failed; b was on disk
    COUNTS.clear()
    again = Executor(_load(text.replace("0.25", "0.125")), cache, gl=gl, requested=[("ab", "out")]).run()
    assert COUNTS == {} and again.stats["ab"].status == "disk"
    np.testing.assert_array_equal(again.values[("ab", "out")].read(), np.full((4, 8, 4), 0.625, np.float32))
