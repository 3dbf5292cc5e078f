"""Tonal art map synthesis (hatching_synthesis): tones, nesting, tiling, determinism, float64 reference."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.hatching_synthesis import tam as tam_mod
from nodegraph_nodes.hatching_synthesis.tam import measured_darkness, synthesize_tam, tone_targets

EPS = 1e-4


@pytest.fixture(scope="module")
def default_tam() -> np.ndarray:
    return synthesize_tam()


def test_shape_dtype_range(default_tam: np.ndarray) -> None:
    assert default_tam.shape == (32, 256, 256)
    assert default_tam.dtype == np.float32
    assert np.isfinite(default_tam).all()
    assert default_tam.min() >= 0.0 and default_tam.max() <= 1.0
    assert (default_tam[0] == 1.0).all()  # the lightest tone is blank paper (target darkness 0)


def test_darkness_monotonic_and_spans_range(default_tam: np.ndarray) -> None:
    d = measured_darkness(default_tam)
    assert np.all(np.diff(d) > 0.0)
    assert d[0] <= 0.05
    assert abs(d[-1] - 0.8) <= 0.05
    # Each tone stops at the first stroke that reaches its target: overshoot is at most a stroke or so.
    assert np.all(d >= tone_targets(32, 0.8) - 1e-6)
    assert np.abs(d - tone_targets(32, 0.8)).max() < 0.01


@pytest.mark.parametrize("max_darkness", [0.3, 0.6])
def test_configured_max_darkness(max_darkness: float) -> None:
    d = measured_darkness(synthesize_tam(size=128, tones=16, max_darkness=max_darkness, seed=3))
    assert np.all(np.diff(d) > 0.0)
    assert d[0] <= 0.05 and abs(d[-1] - max_darkness) <= 0.05


def test_tones_are_nested(default_tam: np.ndarray) -> None:
    lighter, darker = default_tam[:-1], default_tam[1:]
    marked = lighter < 1.0 - EPS
    assert np.all(darker[marked] < 1.0 - EPS)  # stroke pixels of tone k are stroke pixels of tone k+1
    assert np.all(darker <= lighter)  # and no pixel gets lighter


def _seam_ratio(tile: np.ndarray, axis: int) -> float:
    """Mean |difference| across the wrap boundary (moved to the middle by a half roll) / interior median."""
    size = tile.shape[axis]
    rolled = np.roll(tile, size // 2, axis=axis)
    steps = np.abs(np.diff(rolled, axis=axis)).mean(axis=1 - axis)  # one value per boundary
    seam = steps[size // 2 - 1]  # between old index size-1 and old index 0
    interior = np.delete(steps, size // 2 - 1)
    return float(seam / np.median(interior))


@pytest.mark.parametrize("tone", [4, 12, 24, 31])
def test_seamless_tiling(default_tam: np.ndarray, tone: int) -> None:
    tile = default_tam[tone].astype(np.float64)
    for axis in (0, 1):
        assert 0.5 < _seam_ratio(tile, axis) < 1.5


def test_seam_measure_detects_a_real_seam(default_tam: np.ndarray) -> None:
    # Control for the measure: half of another seed's tile glued on breaks strokes at the wrap column.
    other = synthesize_tam(seed=99)
    for tone in (12, 24):
        glued = np.concatenate([default_tam[tone][:, :128], other[tone][:, 128:]], axis=1).astype(np.float64)
        assert _seam_ratio(glued, 1) > 2.0 * _seam_ratio(default_tam[tone].astype(np.float64), 1)


def test_same_seed_same_bytes_other_seed_differs() -> None:
    a = synthesize_tam(size=96, tones=8, seed=5)
    b = synthesize_tam(size=96, tones=8, seed=5)
    c = synthesize_tam(size=96, tones=8, seed=6)
    assert a.tobytes() == b.tobytes()
    assert a.tobytes() != c.tobytes()


def _reference_step(
    c_t: np.ndarray, alpha: np.ndarray, mu_b: float, mu_w: float, c_s: float, white: float
) -> np.ndarray:
    """The paper's rule, written out: c_a = c_t (1 - c_s') with the stroke pixel colour c_s' = 1-a(1-c_s)."""
    stroke_colour = 1.0 - alpha * (1.0 - c_s)
    c_a = c_t * (1.0 - stroke_colour)
    c_a = np.where(c_t > white, mu_w * c_a, c_a)
    return c_t - mu_b * c_a


def test_reference_step_hand_computed() -> None:
    # Defaults mu_b = 0.6, mu_w = 0.5, c_s = 0.1, full coverage: white paper, then an already marked pixel.
    first = _reference_step(np.array([1.0]), np.array([1.0]), 0.6, 0.5, 0.1, 0.9)
    assert first[0] == pytest.approx(1.0 - 0.6 * 0.5 * 0.9)  # 0.73
    second = _reference_step(first, np.array([1.0]), 0.6, 0.5, 0.1, 0.9)
    assert second[0] == pytest.approx(0.73 - 0.6 * 0.73 * 0.9)  # 0.3358


@pytest.mark.parametrize("seed", [0, 11])
def test_matches_sequential_float64_reference(seed: int) -> None:
    size, tones, max_darkness = 48, 7, 0.7
    kw = dict(mu_b=0.6, mu_w=0.5, c_s=0.1, white_threshold=0.9)
    geometry = dict(
        stroke_width=1.1, stroke_length=(0.2, 0.6), max_angle=4.0, y_jitter=0.25,
        wobble_amplitude=1.0, wobble_frequency=2.0, pressure_jitter=0.35, taper=0.15, grain=0.35,
    )  # fmt: skip
    got = synthesize_tam(size=size, tones=tones, max_darkness=max_darkness, seed=seed, **kw, **geometry)

    # One stroke at a time, every pixel it touches, in order; snapshot when a target is reached.
    chunks = tam_mod._stroke_chunks(size, seed, **geometry)
    value = np.ones(size * size)
    goals = tone_targets(tones, max_darkness) * value.size
    total, snaps = 0.0, []
    while len(snaps) < tones and total >= goals[len(snaps)]:
        snaps.append(value.copy())
    while len(snaps) < tones:
        pix, sid, alpha = next(chunks)
        for s in np.unique(sid):
            on = sid == s
            p = pix[on]
            assert np.unique(p).size == p.size  # a stroke touches a pixel once
            new = _reference_step(value[p], alpha[on], kw["mu_b"], kw["mu_w"], kw["c_s"], kw["white_threshold"])
            total += float(np.sum(value[p] - new))
            value[p] = new
            while len(snaps) < tones and total >= goals[len(snaps)]:
                snaps.append(value.copy())
            if len(snaps) == tones:
                break
    want = np.stack(snaps).reshape(tones, size, size)
    np.testing.assert_allclose(got, want, atol=2e-6, rtol=0)


def test_tone_targets_and_measured_darkness() -> None:
    np.testing.assert_allclose(tone_targets(5, 0.8), [0.0, 0.2, 0.4, 0.6, 0.8])
    stack = np.stack([np.full((4, 4), v) for v in (1.0, 0.75, 0.25)])
    np.testing.assert_allclose(measured_darkness(stack), [0.0, 0.25, 0.75])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(tones=1), "tones"),
        (dict(max_darkness=1.0), "max_darkness"),
        (dict(mu_b=0.0), "mu_b"),
        (dict(c_s=1.0), "c_s"),
        (dict(stroke_length=(0.5, 1.0)), "stroke_length"),
        (dict(strokes=50), "not reached within 50 strokes"),
    ],
)
def test_bad_params_raise(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        synthesize_tam(**{"size": 64, "tones": 8, **kwargs})


def test_measured_darkness_rejects_2d() -> None:
    with pytest.raises(ValueError, match="tones, height, width"):
        measured_darkness(np.ones((4, 4)))
