"""Variations in style (Nienhaus & Döllner §3.4): repeated edges and roughened (chalk) profiles."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from nodegraph_nodes.depth_sprite import DepthSprite
from nodegraph_nodes.perlin_noise import PerlinNoise
from nodegraph_nodes.sketch import Sketch
from nodegraph_nodes.sketch.reference import sketch as sketch_ref

from nodegraph import pipeline as pl
from nodegraph.errors import NodeError
from nodegraph.executor import Executor
from nodegraph.node import derive_seed
from tests.helpers import run_node

ROOT = Path(__file__).resolve().parents[2]


def _synthetic_edges(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """Short horizontal and vertical strokes at random places: a sharp, aperiodic autocorrelation."""
    e = np.zeros((h, w), np.float32)
    for _ in range(120):
        y, x = rng.integers(12, h - 12), rng.integers(12, w - 12)
        if rng.random() < 0.5:
            e[y, x - 2:x + 3] = 1.0
        else:
            e[y - 2:y + 3, x] = 1.0
    return e


def _ncc(a: np.ndarray, b: np.ndarray) -> float:
    a = a - a.mean()
    b = b - b.mean()
    return float((a * b).sum() / np.sqrt((a * a).sum() * (b * b).sum()))


def test_repeated_edges_give_n_distinct_shifted_copies(gl, rng):
    h, w = 128, 128
    edges = _synthetic_edges(rng, h, w)
    shade = np.zeros((h, w, 4), np.float32)
    offset = np.ones((h, w, 2), np.float32)  # constant uncertainty: each layer is a pure translation
    shifts = [(6, 2), (-4, 7), (3, -8)]  # pixels each layer reads ahead (x right, y up)
    layers = tuple({"matrix": ((sx / w, 0.0), (0.0, sy / h)), "color": (0.1 * i, 0.1, 0.1)}
                   for i, (sx, sy) in enumerate(shifts))
    node = Sketch("s", Sketch.Params(edge_layers=layers, use_shade=False))
    out = run_node(gl, node, {"edges": gl.upload(edges[..., None], "R16F"), "shade": gl.upload(shade, "RGBA8"),
                              "offset": gl.upload(offset, "RG16F")}, (w, h), needed=frozenset({"color"}))
    ink = out["color"].read()[..., 3]
    m = 10  # compare away from the clamped image border
    core = ink[m:-m, m:-m]
    corr = {}
    for dy in range(-9, 10):
        for dx in range(-9, 10):
            # the drawing at x shows the edge map at x + shift: a copy displaced by -shift
            corr[(dx, dy)] = _ncc(core, edges[m - dy:h - m - dy, m - dx:w - m - dx])
    expected = {(-sx, -sy) for sx, sy in shifts}
    for d in expected:
        assert corr[d] > 0.45, (d, corr[d])  # one of three equal copies: ~1/sqrt(3)
    # away from the expected offsets (strokes are 5 px long: 3 px along one still overlaps) nothing matches
    others = [c for d, c in corr.items() if min(max(abs(d[0] - e[0]), abs(d[1] - e[1])) for e in expected) > 3]
    assert max(others) < 0.2
    top3 = sorted(corr, key=corr.get, reverse=True)[:3]
    assert set(top3) == expected
    # one layer gives one copy
    one = Sketch("s1", Sketch.Params(edge_layers=layers[:1], use_shade=False))
    ink1 = run_node(gl, one, {"edges": gl.upload(edges[..., None], "R16F"), "shade": gl.upload(shade, "RGBA8"),
                              "offset": gl.upload(offset, "RG16F")}, (w, h), needed=frozenset({"color"}))
    ink1 = ink1["color"].read()[..., 3][m:-m, m:-m]
    assert _ncc(ink1, edges[m + 2:h - m + 2, m + 6:w - m + 6]) > 0.95


@pytest.mark.parametrize("use_shade", [False, True])
def test_sketch_depth_is_min_over_every_layer(gl, rng, use_shade):
    """Depth is read once per edge layer (and for the shade map when used): paper §3.4."""
    h, w = 48, 64
    ys, xs = np.mgrid[0:h, 0:w]
    depth = np.where((xs - 32) ** 2 + (ys - 24) ** 2 < 10**2, 0.3 + 0.004 * xs, 1.0).astype(np.float32)
    offset = rng.random((h, w, 2)).astype(np.float32)
    layers = tuple({"matrix": m, "color": (0.1, 0.1, 0.1)} for m in
                   (((0.12, 0.0), (0.0, 0.02)), ((-0.1, 0.03), (0.0, 0.0)), ((0.0, 0.0), (0.04, -0.15))))
    params = Sketch.Params(edge_layers=layers, shade_matrix=((0.0, -0.2), (0.1, 0.0)), use_shade=use_shade)
    inputs = {"edges": gl.upload(np.zeros((h, w, 1), np.float32), "R16F"),
              "shade": gl.upload(np.zeros((h, w, 4), np.float32), "RGBA8"),
              "offset": gl.upload(offset, "RG16F"), "depth": gl.upload(depth[..., None], "R32F")}
    node = Sketch("s", params)
    got = run_node(gl, node, inputs, (w, h), needed=frozenset({"color", "offsets", "depth"}))
    z = got["depth"].read()[..., 0]
    ref = sketch_ref(np.zeros((h, w)), np.zeros((h, w, 4)), inputs["offset"].read(), np.asarray(params.shade_matrix),
                     [(np.asarray(la.matrix), la.color) for la in node.layers()], use_shade=use_shade,
                     depth=depth)["depth"]
    # nearest lookups: a coordinate within float rounding of a texel border may pick the neighbour
    assert np.mean(np.abs(z - ref) > 1e-6) < 0.003
    # every layer contributes: the covered area is larger than any single layer's
    first = node.layers()[0]
    single = sketch_ref(np.zeros((h, w)), np.zeros((h, w, 4)), inputs["offset"].read(),
                        np.asarray(params.shade_matrix), [(np.asarray(first.matrix), first.color)],
                        use_shade=False, depth=depth)["depth"]
    assert (z < 1).sum() > (single < 1).sum() + 50
    # the depth sprite takes it as the perturbed depth
    sprite = run_node(gl, DepthSprite("d"), {"color": got["color"], "offsets": got["offsets"],
                                             "depth": inputs["depth"], "sketch_depth": got["depth"]}, (w, h))
    sz = sprite["depth"].read()[..., 0]
    assert np.array_equal(sz < 1, z < 1)
    assert np.abs(sz[z < 1] - z[z < 1]).max() < 1e-6


def test_sketch_depth_output_needs_depth_input(gl):
    h, w = 8, 8
    inputs = {"edges": gl.upload(np.zeros((h, w, 1), np.float32), "R16F"),
              "shade": gl.upload(np.zeros((h, w, 4), np.float32), "RGBA8"),
              "offset": gl.upload(np.zeros((h, w, 2), np.float32), "RG16F")}
    with pytest.raises(NodeError, match="needs input 'depth'"):
        run_node(gl, Sketch("s"), inputs, (w, h), needed=frozenset({"depth"}))


# -- chalk: white vs Perlin noise ----------------------------------------------------------------
def _lag1(a: np.ndarray, axis: int) -> float:
    a = a - a.mean()
    x = np.moveaxis(a, axis, 0)
    return float((x[1:] * x[:-1]).mean() / (a * a).mean())


def test_white_noise_is_uncorrelated_and_perlin_correlated(gl):
    size = (256, 256)
    perlin = run_node(gl, PerlinNoise("n", PerlinNoise.Params(kind="perlin", scale=0.01)), {}, size, seed=3)
    white = run_node(gl, PerlinNoise("n", PerlinNoise.Params(kind="white")), {}, size, seed=3)
    p, wn = perlin["out"].read(), white["out"].read()
    for c in range(2):
        for axis in (0, 1):
            assert _lag1(p[..., c], axis) > 0.9
            # 65k samples: the estimate's standard deviation is ~0.004
            assert abs(_lag1(wn[..., c], axis)) < 0.02
    # the two channels of the white noise are independent too, and uniform on [0, 1)
    assert abs(np.corrcoef(wn[..., 0].ravel(), wn[..., 1].ravel())[0, 1]) < 0.02
    assert wn.min() >= 0.0 and wn.max() < 1.0 and abs(wn.mean() - 0.5) < 0.01


def test_white_noise_pattern_follows_the_seed(gl):
    size = (64, 64)
    node = PerlinNoise("n", PerlinNoise.Params(kind="white"))
    a = run_node(gl, node, {}, size, seed=1)["out"].read()
    b = run_node(gl, node, {}, size, seed=1)["out"].read()
    c = run_node(gl, node, {}, size, seed=2)["out"].read()
    assert np.array_equal(a, b)
    assert np.mean(a == c) < 0.01
    assert np.array_equal(a, node.reference(64, 64, derive_seed(1, "n", 0)).astype(np.float32))


def _roughness(img: np.ndarray) -> tuple[float, int]:
    """(changes of the dark-ink mask along rows and columns per dark pixel, colour changes > 0.05 between
    neighbours): both grow when edges and colour borders fray."""
    rgb = img[..., :3]
    dark = rgb.mean(axis=-1) < 0.4
    changes = np.count_nonzero(dark[:, 1:] != dark[:, :-1]) + np.count_nonzero(dark[1:] != dark[:-1])
    borders = (np.count_nonzero(np.abs(np.diff(rgb, axis=1)).max(axis=-1) > 0.05)
               + np.count_nonzero(np.abs(np.diff(rgb, axis=0)).max(axis=-1) > 0.05))
    return changes / max(int(dark.sum()), 1), borders


def test_chalk_roughens_profiles_and_colour_borders(gl):
    """Same scene and matrices (a few pixels of spread at the pipeline's own size): white noise frays the
    edges and colour borders that Perlin noise keeps smooth."""
    path = ROOT / "pipelines" / "chalk.yaml"
    chalk = Executor(pl.load(path), None, gl=gl).run().values[("sprite", "color")].read()
    smooth = Executor(pl.load(path, overrides=["noise.kind=perlin"]), None, gl=gl).run()
    rough_edges, rough_borders = _roughness(chalk)
    smooth_edges, smooth_borders = _roughness(smooth.values[("sprite", "color")].read())
    assert rough_edges > 1.8 * smooth_edges  # measured 1.36 vs 0.63 transitions per dark pixel
    assert rough_borders > 1.4 * smooth_borders  # measured 116k vs 65k


@pytest.mark.parametrize("name", ["repeated_edges", "chalk", "object_space_uncertainty"])
def test_variation_pipelines_render(gl, name):
    pipe = pl.load(ROOT / "pipelines" / f"{name}.yaml", size=(96, 96))
    img = Executor(pipe, None, gl=gl).run().values[pipe.outputs["image"]].read()
    assert img.shape == (96, 96, 4) and np.isfinite(img).all()
    paper = np.asarray((0.98, 0.97, 0.94), np.float32)
    drawn = np.abs(img[..., :3] - paper).max(axis=-1) > 0.05
    assert 0.02 < drawn.mean() < 0.98
