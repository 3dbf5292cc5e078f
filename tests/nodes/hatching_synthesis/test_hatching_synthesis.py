"""hatching_synthesis node: the tonal art map on the GPU, its key, its caching and its errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from nodegraph_nodes.hatching_synthesis.tam import measured_darkness, synthesize_tam, tone_targets

from nodegraph import pipeline as pl
from nodegraph.cache import Cache
from nodegraph.errors import NodeError, PipelineError
from nodegraph.executor import Executor
from nodegraph.node import HashContext
from tests.helpers import assert_outputs_as_planned, run_minimal

TEXT = """\
pipeline: t
size: [64, 48]
scene: builtin:box
seed: 3
nodes:
  tam: {type: hatching_synthesis, params: {size: 64, tones: 8, max_darkness: 0.6}}
outputs:
  tones: tam.tones
"""


def load(overrides: list[str] = (), size: tuple[int, int] | None = None) -> pl.Pipeline:
    return pl.loads(TEXT, "t.yaml", overrides=list(overrides), size=size)


def read_tones(value) -> np.ndarray:
    return value.read()[..., 0]


def test_shape_dtype_and_matches_the_core(gl):
    pipe = load()
    res = Executor(pipe, None, gl=gl).run()
    tex = res.values[("tam", "tones")]
    assert tex.fmt == "R8" and tex.layers == 8 and tex.size == (64, 64)
    got = read_tones(tex)
    expected = synthesize_tam(size=64, tones=8, max_darkness=0.6, seed=node_seed(pipe, "tam"))
    # the texture holds the float tones rounded to 8 bits
    np.testing.assert_allclose(got, np.round(expected * 255) / 255, atol=1e-6)


def node_seed(pipe: pl.Pipeline, node_id: str) -> int:
    from nodegraph.node import derive_seed

    return derive_seed(pipe.seed, node_id, 0)


def test_gpu_tones_monotonic_nested_and_tileable(gl):
    got = read_tones(Executor(load(), None, gl=gl).run().values[("tam", "tones")])
    d = measured_darkness(got)
    assert np.all(np.diff(d) > 0)
    np.testing.assert_allclose(d, tone_targets(8, 0.6), atol=0.01)
    # nested: a pixel never gets lighter in a darker tone, so every stroke pixel of tone k is one of k + 1
    assert np.all(got[1:] <= got[:-1])
    # wrap-around: the step across the tile border is like a step inside the tile
    inner = np.abs(np.diff(got[-1], axis=1)).mean()
    border = np.abs(got[-1][:, 0] - got[-1][:, -1]).mean()
    assert border < 1.5 * inner


def test_key_ignores_frame_size_and_camera():
    a, b = load(), load(size=(200, 100))
    node = a.nodes["tam"]
    k0 = node.key(HashContext(a.size, 0, a.seed, a.scene), {})
    k1 = node.key(HashContext(b.size, 17, b.seed, b.scene), {})
    assert k0 == k1
    other_seed = node.key(HashContext(a.size, 0, a.seed + 1, a.scene), {})
    assert other_seed != k0
    fixed = load(["tam.seed=5"]).nodes["tam"]
    assert fixed.key(HashContext(a.size, 0, 1, a.scene), {}) == fixed.key(HashContext(a.size, 0, 2, a.scene), {})


def test_computed_once_then_from_memory_then_from_disk(gl, tmp_path: Path):
    cache = Cache(tmp_path / "c")
    ex = Executor(load(), cache, mode="loop", gl=gl)
    for frame in range(3):
        ex.run(frame)
    assert ex.compute_counts == {"tam": 1}
    cache.flush()
    ex2 = Executor(load(), cache, mode="loop", gl=gl)
    res = ex2.run(5)
    assert ex2.compute_counts == {} and res.stats["tam"].status == "disk"
    np.testing.assert_array_equal(read_tones(res.values[("tam", "tones")]),
                                  read_tones(ex.run(0).values[("tam", "tones")]))


def test_unreachable_darkness_is_a_one_line_error(gl):
    ex = Executor(load(["tam.strokes=5"]), None, gl=gl)
    with pytest.raises(NodeError, match=r"node 'tam' \(hatching_synthesis\): max_darkness 0.6 not reached"):
        ex.run()


@pytest.mark.parametrize("override, match", [
    ("tam.stroke_length=[0.5, 0.2]", "stroke_length"),
    ("tam.stroke_width=40", "stroke_width"),
    ("tam.mu_b=0", "mu_b"),
])
def test_bad_params_fail_at_load(override: str, match: str):
    with pytest.raises(PipelineError, match=match):
        load([override])


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  t: {type: hatching_synthesis, params: {size: 64, tones: 8, max_darkness: 0.6}}
"""
    ex, res = run_minimal(gl, nodes, {"tones": "t.tones"})
    assert assert_outputs_as_planned(ex, res, "t") == ["tones"]
