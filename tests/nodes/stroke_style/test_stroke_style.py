"""stroke_style against hand computations: the uncertainty offset of every vertex equals float64 improved noise
(Perlin's Java reference transcribed line by line) at its surface point; the same surface point gets the same
offset whatever the camera or pose; repeats, overshoot, width by depth and taper; the SVG of stylised strokes."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from nodegraph_nodes._shared import noise
from nodegraph_nodes.stroke_style import style as st

from nodegraph.output.svg import layered_svg, read_layers
from nodegraph.values import LINE_KINDS, Strokes

PLAIN = dict(repeats=1, amplitude=0.0, shake=0.0, pressure=0.0, repeat_tone=1.0, overshoot=0.0, width_by="none",
             taper=0.0)


def ref_fbm(p: np.ndarray, octaves: int) -> float:
    return sum(noise._scalar_reference_noise(*(2.0 ** i * p)) / 2.0 ** i for i in range(octaves))


def line(n: int = 41, y: float = 100.0, pos: np.ndarray | None = None, depth: np.ndarray | None = None,
         kind: int = 1) -> Strokes:
    xy = np.c_[np.arange(n, dtype=np.float64) + 10.0, np.full(n, y)]
    attrs = {"kind": np.full(n, kind, np.uint8)}
    if pos is not None:
        attrs["pos"] = pos
    if depth is not None:
        attrs["depth"] = depth
    return Strokes.from_arrays(xy, np.array([0, n]), (200, 200), 1.5, attrs=attrs)


def test_uncertainty_offsets_equal_hand_evaluated_noise():
    rng = np.random.default_rng(1)
    pos = rng.uniform(-2, 2, (41, 3))
    s = line(pos=pos)
    sty = st.Style(**{**PLAIN, "amplitude": 5.0, "frequency": 0.7, "octaves": 3})
    out = st.stylise(s, st.surface_points(s, {}), sty, seed=1234)
    o = noise.seed_offset(st.sub_seed(1234, 0, "uncertainty"))
    want = np.array([5.0 * ref_fbm(p.astype(np.float32).astype(np.float64) * 0.7 + o, 3) for p in pos])
    # a stroke running +x: its left normal is +y, so x stays and y moves by the noise
    np.testing.assert_allclose(out.xy[:, 0], s.xy[:, 0], atol=1e-5)
    np.testing.assert_allclose(out.xy[:, 1] - 100.0, want, atol=2e-4)
    assert np.abs(want).max() > 0.5  # the test sees real offsets


def test_same_surface_point_same_offset_under_other_camera_and_pose():
    # a rest mesh of two triangles; the stroke's vertices lie on it at fixed (face, bary)
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.5]], float)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    n = 30
    rng = np.random.default_rng(2)
    face = rng.integers(0, 2, n).astype(np.int32)
    bary = rng.dirichlet([1, 1, 1], n)
    rest_pts = np.einsum("nk,nkd->nd", bary, V[F[face]])
    sty = st.Style(**{**PLAIN, "amplitude": 6.0, "frequency": 3.0, "shake": 2.0, "shake_frequency": 0.5})
    offsets = []
    for angle, shift, bend in ((0.0, (20.0, 30.0), 0.0), (0.9, (120.0, 60.0), 0.3)):  # two cameras, two poses
        t = np.linspace(0, 60, n)
        d = np.array([np.cos(angle), np.sin(angle)])
        xy = np.asarray(shift) + t[:, None] * d
        posed = rest_pts + bend * rest_pts[:, :1] ** 2  # a deformed (posed) surface: pos differs per frame
        s = Strokes.from_arrays(xy, np.array([0, n]), (300, 300), 1.0, attrs={
            "obj": np.zeros(n, np.int32), "face": face, "bary": bary, "pos": posed})
        out = st.stylise(s, st.surface_points(s, {0: (V, F)}), sty, seed=99)
        normal = np.array([-d[1], d[0]])
        delta = out.xy.astype(np.float64) - xy
        shake = 2.0 * noise.noise3_at(rest_pts, 1, st.sub_seed(99, 0, "shake"), "fbm", 0.5)
        offsets.append(((delta - shake) @ normal, shake))
        np.testing.assert_allclose((delta - shake) @ d, 0.0, atol=2e-4)  # only across the stroke
    np.testing.assert_allclose(offsets[0][0], offsets[1][0], atol=3e-4)
    o = noise.seed_offset(st.sub_seed(99, 0, "uncertainty"))
    want = [6.0 * ref_fbm(p * 3.0 + o, sty.octaves) for p in rest_pts]
    np.testing.assert_allclose(offsets[0][0], want, atol=3e-4)


def test_repeats_count_and_spread():
    rng = np.random.default_rng(3)
    s = Strokes.from_arrays(np.c_[np.arange(60.0), np.full(60, 50.0)], np.array([0, 25, 60]), (100, 100),
                            attrs={"pos": rng.uniform(0, 3, (60, 3))})
    sty = st.Style(**{**PLAIN, "repeats": 3, "amplitude": 4.0, "frequency": 1.0, "repeat_tone": 0.5})
    out = st.stylise(s, st.surface_points(s, {}), sty, seed=5)
    assert len(out) == 6 and out.n_vertices == 180
    ys = out.xy[:, 1].reshape(3, 60) - 50.0
    bound = 4.0 * noise.octaves_bound(sty.octaves)
    assert np.abs(ys).max() <= bound
    for a in range(3):
        for b in range(a + 1, 3):
            assert np.abs(ys[a] - ys[b]).max() > 0.3  # each copy has its own noise
    np.testing.assert_allclose(out["tone"].reshape(3, 60)[:, 0], [1.0, 0.5, 0.25])


def test_overshoot_extends_open_strokes_only():
    s_open = line(n=21)
    t = np.linspace(0, 2 * np.pi, 41)
    ring = np.c_[100 + 30 * np.cos(t), 100 + 30 * np.sin(t)]
    ring[-1] = ring[0]
    s = Strokes.from_arrays(np.r_[s_open.xy, ring], np.array([0, 21, 62]), (200, 200))
    sty = st.Style(**{**PLAIN, "overshoot": 6.5, "overshoot_jitter": 0.0, "spacing": 1.0})
    out = st.stylise(s, st.surface_points(s, {}), sty, seed=0)
    lens = out.lengths()
    assert lens[0] == pytest.approx(20.0 + 2 * 6.5, abs=1e-4)
    assert lens[1] == pytest.approx(s.lengths()[1], abs=1e-4)  # closed: unchanged
    a = out.polylines[0]
    np.testing.assert_allclose(a[0], [10.0 - 6.5, 100.0], atol=1e-4)
    np.testing.assert_allclose(a[-1], [30.0 + 6.5, 100.0], atol=1e-4)
    assert len(a) == 21 + 2 * 7 and np.hypot(*np.diff(a, axis=0).T).max() <= 1.0 + 1e-5


def test_width_by_depth_nearer_is_thicker_and_taper():
    depth = np.linspace(2.0, 8.0, 41)
    s = line(depth=depth)
    sty = st.Style(**{**PLAIN, "width_by": "depth", "width_range": (0.5, 2.0)})
    w = st.stylise(s, st.surface_points(s, {}), sty, seed=0, z_ref=4.0)["width"]
    np.testing.assert_allclose(w, 1.5 * np.clip(4.0 / depth, 0.5, 2.0), rtol=1e-6)
    assert (np.diff(w) <= 0).all() and w[0] > w[-1]
    sty = st.Style(**{**PLAIN, "taper": 10.0, "taper_floor": 0.2})
    w = st.stylise(s, st.surface_points(s, {}), sty, seed=0)["width"]
    u = np.clip(np.minimum(np.arange(41.0), 40.0 - np.arange(41.0)) / 10.0, 0, 1)
    np.testing.assert_allclose(w, 1.5 * (0.2 + 0.8 * u * u * (3 - 2 * u)), rtol=1e-6)


def test_width_by_curvature_thicker_in_bends():
    t = np.linspace(0, np.pi, 60)
    arc = np.c_[100 + 10 * np.cos(t), 100 + 10 * np.sin(t)]  # radius 10 px
    straight = np.c_[np.linspace(0, 60, 60), np.full(60, 20.0)]
    s = Strokes.from_arrays(np.r_[arc, straight], np.array([0, 60, 120]), (200, 200), 1.0)
    sty = st.Style(**{**PLAIN, "width_by": "curvature", "width_range": (0.6, 1.6), "curvature_radius": 20.0})
    w = st.stylise(s, st.surface_points(s, {}), sty, seed=0)["width"]
    np.testing.assert_allclose(w[10:50], 1.6, rtol=1e-3)  # curvature 1/10 px x 20 px >= 1
    np.testing.assert_allclose(w[70:110], 0.6, rtol=1e-6)


def test_svg_of_stylised_strokes_is_valid():
    rng = np.random.default_rng(4)
    s = line(pos=rng.uniform(0, 1, (41, 3)), kind=LINE_KINDS.index("contour"))
    out = st.stylise(s, st.surface_points(s, {}), st.Style(repeats=3), seed=8, z_ref=1.0)
    text = layered_svg(out)
    root = ET.fromstring(text)
    assert root.tag.endswith("svg")
    layers = read_layers(text)
    assert list(layers) == ["contour"] and len(layers["contour"]) == 3
    for poly, want in zip(layers["contour"], out.polylines, strict=True):
        np.testing.assert_allclose(poly[:, 0], want[:, 0], atol=0.006)
        np.testing.assert_allclose(poly[:, 1], 200 - want[:, 1], atol=0.006)


def test_pipeline_draws_two_copies_of_every_line():
    import nodegraph as ng

    pipe = ng.load("sketchy_strokes", scene="builtin:torus", size=(160, 160))
    lines = pipe.value("lines.strokes")
    styled = pipe.value("strokes")
    assert len(styled) == 2 * len(lines) > 0
    assert np.isfinite(styled.xy).all() and np.isfinite(styled["width"]).all()
