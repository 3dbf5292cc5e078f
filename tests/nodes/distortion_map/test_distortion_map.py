"""distortion_map: bounded per-layer offsets a cos(b u + c), a sin(b v + c) from the node seed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from nodegraph.node import HashContext, derive_seed
from tests.helpers import assert_outputs_as_planned, run_minimal

TEXT = """\
pipeline: t
size: [96, 64]
scene: builtin:box
seed: 21
nodes:
  dist: {type: distortion_map, params: {layers: 4, amplitude: 0.01}}
outputs:
  out: dist.out
"""


def load(overrides: list[str] = (), seed: int | None = None) -> pl.Pipeline:
    text = TEXT if seed is None else TEXT.replace("seed: 21", f"seed: {seed}")
    return pl.loads(text, "t.yaml", overrides=list(overrides), load_scene=False)


def gpu_offsets(gl, pipe: pl.Pipeline, frame: int = 0) -> np.ndarray:
    value = Executor(pipe, None, gl=gl).run(frame).values[("dist", "out")]
    assert value.fmt == "RG16F" and value.layers == pipe.nodes["dist"].params.layers
    assert value.size == pipe.size
    return value.read()


def analytic(a: float, b: float, c: float, w: int, h: int) -> np.ndarray:
    """float64, written from the formula: offsets at pixel centres, (H, W, 2)."""
    out = np.zeros((h, w, 2))
    for x in range(w):
        out[:, x, 0] = a * math.cos(b * (x + 0.5) / w + c)
    for y in range(h):
        out[y, :, 1] = a * math.sin(b * (y + 0.5) / h + c)
    return out


def test_matches_the_formula(gl):
    pipe = load()
    node = pipe.nodes["dist"]
    got = gpu_offsets(gl, pipe)
    coef = node.coefficients(derive_seed(pipe.seed, "dist", 0), pipe.size[1])
    assert coef.shape == (4, 3)
    w, h = pipe.size
    for k, (a, b, c) in enumerate(coef):
        # a in pixels within [amplitude_min, 1] x amplitude x height, b = 2 pi f with f in the range
        assert 0.4 * 0.01 * h - 1e-9 <= a <= 0.01 * h + 1e-9
        assert 2 * math.pi * 0.5 - 1e-9 <= b <= 2 * math.pi * 2.0 + 1e-9
        assert 0.0 <= c < 2 * math.pi
        np.testing.assert_allclose(got[k], analytic(a, b, c, w, h), atol=2e-3)  # half precision


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 99])
def test_bounded(gl, seed: int):
    pipe = load(["dist.amplitude=0.02", "dist.frequency=[3, 9]"], seed=seed)
    got = gpu_offsets(gl, pipe)
    bound = 0.02 * pipe.size[1]
    assert np.abs(got).max() <= bound * (1 + 1e-3)
    assert np.abs(got).max() > 0.3 * bound  # and not degenerate


def test_same_seed_same_bytes_other_seed_differs(gl):
    a = gpu_offsets(gl, load())
    b = gpu_offsets(gl, load())
    assert a.tobytes() == b.tobytes()
    assert gpu_offsets(gl, load(seed=22)).tobytes() != a.tobytes()
    # still by default, boiling when animated
    assert gpu_offsets(gl, load(), frame=3).tobytes() == a.tobytes()
    anim = load(["dist.animate=true"])
    assert gpu_offsets(gl, anim, 0).tobytes() != gpu_offsets(gl, anim, 3).tobytes()


def test_key_reads_size_and_seed_not_frame():
    pipe = load()
    node = pipe.nodes["dist"]
    k = node.key(HashContext((96, 64), 0, 21, None), {})
    assert k == node.key(HashContext((96, 64), 7, 21, None), {})
    assert k != node.key(HashContext((97, 64), 0, 21, None), {})
    assert k != node.key(HashContext((96, 64), 0, 22, None), {})


@pytest.mark.parametrize("override, match", [
    ("dist.amplitude=0.5", "amplitude"),
    ("dist.layers=0", "layers"),
    ("dist.frequency=[2, 1]", "frequency"),
])
def test_bad_params(override: str, match: str):
    with pytest.raises(PipelineError, match=match):
        load([override])


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  d: {type: distortion_map, params: {layers: 3}}
"""
    ex, res = run_minimal(gl, nodes, {"out": "d.out"})
    assert assert_outputs_as_planned(ex, res, "d") == ["out"]
