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


OBJECT_NODES = """\
  gbuf: {type: rasterize}
  dist:
    type: distortion_map
    in: {position: gbuf.position}
    params: {layers: 3, amplitude: 0.01, space: object}
"""


def test_object_space_matches_the_formula_by_hand(gl):
    """space: object: every pixel's offsets written from the docstring's formula in float64 at the object-space
    position under it; off the box, at the position of a nearest covered pixel (brute force)."""
    ex, res = run_minimal(gl, OBJECT_NODES, {"out": "dist.out", "pos": "gbuf.position"}, size=(40, 32),
                          scene="builtin:box")
    node = ex.pipeline.nodes["dist"]
    got = res.values[("dist", "out")].read()
    pos = res.values[("gbuf", "position")].read().astype(np.float64)
    seed = derive_seed(ex.pipeline.seed, "dist", 0)
    coef = node.coefficients(seed, 32)
    axes = node.axes(seed)
    assert np.allclose(np.linalg.norm(axes, axis=-1), 1.0)
    lo, hi = ex.pipeline.scene.scale_bounds()
    diag = math.dist(lo, hi)
    covered = pos[..., 3] > 0
    assert 0.1 < covered.mean() < 0.9  # the box and the sheet around it
    cy, cx = np.nonzero(covered)

    def expected(g: np.ndarray, k: int) -> tuple[float, float]:
        a, b, c = coef[k]
        return (a * math.cos(b * float(g @ axes[k, 0]) / diag + c), a * math.sin(b * float(g @ axes[k, 1]) / diag + c))

    worst = 0.0
    for y in range(32):
        for x in range(40):
            if covered[y, x]:
                cands = [pos[y, x, :3]]
            else:  # any nearest covered pixel may be the one taken
                d2 = (cy - y) ** 2 + (cx - x) ** 2
                cands = [pos[j, i, :3] for j, i in zip(cy[d2 == d2.min()], cx[d2 == d2.min()], strict=True)]
            for k in range(3):
                err = min(max(abs(got[k, y, x, 0] - e[0]), abs(got[k, y, x, 1] - e[1]))
                          for e in (expected(g, k) for g in cands))
                worst = max(worst, err)
    assert worst < 2e-3 * 0.01 * 32 + 1e-3  # RG16F: a few half-float ulps of offsets up to 0.32 px
    assert np.abs(got).max() <= 0.01 * 32 * (1 + 1e-3)  # the bound holds as in screen space


def test_object_space_keys_and_errors(gl):
    """The screen-space key is as before (space is keyed only where it is object); object space needs
    `position` in one line."""
    screen = load()
    ctx = HashContext(screen.size, 0, screen.seed, None)
    assert "space" not in screen.nodes["dist"].key_parts(ctx, {})["params"]
    assert screen.nodes["dist"].hash_extra(ctx) is None
    with pytest.raises(Exception, match=r"space: object.*needs `position` connected"):
        run_minimal(gl, "  dist: {type: distortion_map, params: {space: object}}\n", {"out": "dist.out"})
