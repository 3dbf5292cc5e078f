"""feature_lines' cleaning of noisy curvature: chains of segments joined across mesh edges (hand-built
zero sets on a grid), the chain filter (length and hysteresis), and the curvature diffusion (its kernel's
RMS radius against the one it is asked for, on two mesh densities; noise on a sphere, which has no lines)."""

from __future__ import annotations

import numpy as np
from nodegraph_nodes._shared import feature_lines as L

from tests.nodes.feature_lines.test_feature_lines import icosphere, ops_of


def grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The unit square in n x n cells, two triangles each, z = 0."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    V = np.stack([i.ravel() / n, j.ravel() / n, np.zeros(i.size)], 1)

    def idx(a, b):
        return a * (n + 1) + b

    a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    q = [idx(a, b), idx(a + 1, b), idx(a + 1, b + 1), idx(a, b + 1)]
    F = np.concatenate([np.stack([q[0], q[1], q[2]], -1).reshape(-1, 3),
                        np.stack([q[0], q[2], q[3]], -1).reshape(-1, 3)])
    return V, F


def zero_set(V: np.ndarray, F: np.ndarray, f: np.ndarray, intensity: np.ndarray | None = None) -> L.Segments:
    faces, pts, edges = L.zero_crossings(F, V, f[F])
    inten = np.ones((len(faces), 2)) if intensity is None else intensity[faces]
    return L.Segments(pts, inten, faces, L._edge_vertices(F, faces, edges))


def line_and_loop(n: int = 60) -> tuple[np.ndarray, np.ndarray, L.Segments, np.ndarray]:
    """The zeros of min(|x - 0.31| ..., ...): the line x = 0.31 across the square (length 1) and a circle of
    radius 0.06 about (0.7, 0.5) (length 2 pi 0.06 = 0.377), as one zero set; per segment whether it is on
    the circle."""
    V, F = grid(n)
    x, y = V[:, 0], V[:, 1]
    circle = (x - 0.7) ** 2 + (y - 0.5) ** 2 - 0.06 ** 2
    f = np.where(x < 0.5, x - 0.31, circle)
    seg = zero_set(V, F, f)
    on_circle = seg.points.mean(axis=1)[:, 0] > 0.5
    return V, F, seg, on_circle


def test_a_line_and_a_loop_are_two_chains_of_the_right_lengths() -> None:
    _, _, seg, on_circle = line_and_loop()
    lab, count = L.chains(seg)
    assert count == 2
    assert len(np.unique(lab[on_circle])) == 1 and len(np.unique(lab[~on_circle])) == 1
    length = np.linalg.norm(seg.points[:, 1] - seg.points[:, 0], axis=1)
    assert abs(length[~on_circle].sum() - 1.0) < 1e-9  # a straight line is exact on a linear interpolant
    assert abs(length[on_circle].sum() - 2 * np.pi * 0.06) < 0.02  # the inscribed polygon, a little short


def test_chains_follow_welded_seams() -> None:
    """The grid cut along x = 0.5 with the vertices there duplicated: the line crossing the cut is two
    chains by vertex id and one once the copies are welded."""
    V, F = grid(40)
    on_cut = np.flatnonzero(np.isclose(V[:, 0], 0.5))
    copies = len(V) + np.arange(len(on_cut))
    remap = np.arange(len(V))
    V2 = np.concatenate([V, V[on_cut]])
    right = V[F].mean(axis=1)[:, 0] > 0.5
    remap_right = remap.copy()
    remap_right[on_cut] = copies
    F2 = np.where(right[:, None], remap_right[F], F)
    weld = np.concatenate([np.arange(len(V)), on_cut])
    seg = zero_set(V2, F2, V2[:, 1] - 0.43)  # the line y = 0.43, across the cut
    assert L.chains(seg)[1] == 2
    assert L.chains(seg, weld)[1] == 1


def test_filter_drops_short_chains_and_keeps_weak_parts_of_strong_ones() -> None:
    V, F, seg, on_circle = line_and_loop()
    kept = L.filter_chains(seg, 0.5, None)
    assert len(kept) == int((~on_circle).sum())  # the loop (0.38 long) goes, the line (1.0) stays whole
    assert L.filter_chains(seg, 0.3, None).length() == seg.length()
    # hysteresis: the line is weak (0.2) except near y = 0.5 (0.9); the loop is uniformly 0.4
    y = V[:, 1]
    inten = np.where(V[:, 0] < 0.5, np.where(np.abs(y - 0.5) < 0.05, 0.9, 0.2), 0.4)
    seg2 = zero_set(V, F, np.where(V[:, 0] < 0.5, V[:, 0] - 0.31, (V[:, 0] - 0.7) ** 2 + (y - 0.5) ** 2 - 0.06 ** 2),
                    np.stack([inten[F].max(axis=1)] * 2, axis=1))
    strong = L.filter_chains(seg2, 0.0, None, strong=0.5)
    assert abs(strong.length() - 1.0) < 1e-9  # all of the line, weak parts included; none of the loop
    assert strong.intensity.min() < 0.5


def _kernel_rms(level: int, length: float) -> float:
    V, F = icosphere(level)
    ops = ops_of(V, F)
    from dataclasses import replace

    impulse = np.zeros(len(V))
    impulse[0] = 1.0
    sm = L.smooth_curvature(replace(ops, k1=impulse, k2=impulse), length)
    w = sm.k1 / sm.k1.sum()
    d = np.arccos(np.clip(V @ V[0], -1, 1))  # geodesic distance on the unit sphere
    return float(np.sqrt(np.sum(w * d ** 2)))


def test_smoothing_radius_is_the_length_asked_for_on_any_density() -> None:
    for level in (4, 5):
        rms = _kernel_rms(level, 0.15)
        assert 0.7 * 0.15 < rms < 1.3 * 0.15, (level, rms)


def test_smoothing_keeps_constants_and_the_order_of_k1_k2() -> None:
    V, F = icosphere(4)
    ops = ops_of(V, F)
    from dataclasses import replace

    const = replace(ops, k1=np.full(len(V), 2.0), k2=np.full(len(V), -1.0))
    sm = L.smooth_curvature(const, 0.1)
    assert np.allclose(sm.k1, 2.0) and np.allclose(sm.k2, -1.0)
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=len(V)), rng.normal(size=len(V))
    sm = L.smooth_curvature(replace(ops, k1=np.maximum(a, b), k2=np.minimum(a, b)), 0.1)
    assert np.all(sm.k1 >= sm.k2)
    assert L.smooth_curvature(ops, 0.0) is ops


def test_cleaning_removes_the_lines_of_a_noisy_sphere() -> None:
    """A sphere has no lines (test_feature_lines); with its vertices jittered radially by 0.3% (a scan's
    noise) the measured curvature gives lines everywhere. Smoothing over 2% of the diagonal and dropping
    chains under 3% of it (the node's defaults) removes at least 90% of their length."""
    V, F = icosphere(5)
    rng = np.random.default_rng(11)
    V = V * (1 + 0.003 * rng.standard_normal(len(V)))[:, None]
    ops = ops_of(V, F)
    eye = np.array([3.0, 2.0, 4.0])
    raw = L.suggestive_contours(ops, eye, 2.0, 25.0).length() + L.ridges(ops, L.extrema_data(ops), 20.0).length()
    assert raw > 1.0  # the noise does give lines
    sm = L.smooth_curvature(ops, 0.01 * ops.diag)
    min_len = 0.03 * ops.diag
    clean = (L.filter_chains(L.suggestive_contours(sm, eye, 2.0, 25.0), min_len, strong=0.5).length()
             + L.filter_chains(L.ridges(sm, L.extrema_data(sm), 20.0), min_len, strong=0.5).length())
    assert clean < 0.1 * raw, (raw, clean)
