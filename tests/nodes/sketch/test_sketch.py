"""sketch against float64 NumPy: perturbed edges times perturbed shade, repeated edges (§3.4), depth over layers."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.depth_sprite import DepthSprite
from nodegraph_nodes.sketch import Sketch
from nodegraph_nodes.sketch.reference import sketch as sketch_ref

from nodegraph.errors import NodeError
from tests.helpers import assert_outputs_as_planned, run_minimal, run_node


# -- against float64 NumPy on small images ----------------------------------------------------
def _smooth(rng, shape, scale=6):
    base = rng.random((shape[0] // scale + 2, shape[1] // scale + 2) + shape[2:])
    return np.kron(base, np.ones((scale, scale) + (1,) * (len(shape) - 2)))[: shape[0], : shape[1]]


@pytest.mark.parametrize("spin", [False, True], ids=["screen-axes", "spin"])
def test_sketch_matches_float64_reference(gl, rng, spin):
    """With `spin`, each pixel's shifts turned (after their matrices, in pixels: the image is not square) by a
    random angle, (0, 0) (not turned) on a quarter of the pixels."""
    h, w = 64, 96
    edges = gl.upload(_smooth(rng, (h, w)).astype(np.float32)[..., None], "R16F")
    shade_arr = _smooth(rng, (h, w, 4)).astype(np.float32)
    shade_arr[..., 3] = (shade_arr[..., 3] > 0.4).astype(np.float32)
    shade = gl.upload(shade_arr, "RGBA8")
    offset = gl.upload(rng.random((h, w, 2)).astype(np.float32), "RG16F")
    layers = ({"matrix": ((0.05, 0.01), (-0.02, 0.04)), "color": (0.1, 0.2, 0.3)},
              {"matrix": ((-0.03, 0.0), (0.0, 0.06)), "color": (0.6, 0.1, 0.1)})
    params = Sketch.Params(shade_matrix=((-0.04, 0.02), (0.01, -0.05)), edge_layers=layers, edge_strength=1.3)
    node = Sketch("s", params)
    inputs = {"edges": edges, "shade": shade, "offset": offset}
    turn = None
    if spin:
        a = rng.uniform(-np.pi, np.pi, (h, w))
        turn = np.stack([np.cos(a), np.sin(a)], axis=-1).astype(np.float32) * rng.uniform(0.5, 2.0, (h, w, 1))
        turn[rng.random((h, w)) < 0.25] = 0.0
        inputs["spin"] = gl.upload(turn, "RG32F")
    got = run_node(gl, node, inputs, (w, h), needed=frozenset({"color", "offsets"}))
    # the reference reads exactly what the GPU holds (after 8-bit / half quantisation)
    ref = sketch_ref(edges.read()[..., 0], shade.read(), offset.read(), np.asarray(params.shade_matrix),
                     [(np.asarray(lay.matrix), lay.color) for lay in node.layers()], params.edge_strength,
                     params.use_shade, params.paper, spin=turn)
    # the shifts themselves, to half precision (|shift| < 0.1)
    np.testing.assert_allclose(got["offsets"].read(), ref["offsets"], atol=1e-4)
    if spin:  # turned: a shift keeps its length in pixels, and differs from the unturned one where turned
        px = ref["offsets"][..., :2] * [w, h]
        plain = sketch_ref(edges.read()[..., 0], shade.read(), offset.read(), np.asarray(params.shade_matrix),
                           [(np.asarray(lay.matrix), lay.color) for lay in node.layers()])["offsets"][..., :2] * [w, h]
        np.testing.assert_allclose(np.linalg.norm(px, axis=-1), np.linalg.norm(plain, axis=-1), rtol=1e-9)
        turned = np.linalg.norm(turn, axis=-1) > 0
        assert np.abs(px - plain)[turned].max() > 1.0 and np.abs(px - plain)[~turned].max() < 1e-9
    for port in ("color", "offsets"):
        err = np.abs(got[port].read() - ref[port])
        # bilinear weights are quantised to 8 bits in llvmpipe's sampler; outputs are half floats
        assert np.percentile(err, 99) < 1e-2 and err.max() < 5e-2, (port, err.max())


@pytest.mark.parametrize("name", ["offset", "spin"])
def test_an_offset_or_spin_of_another_size_is_one_line_error(gl, name):
    """Both are read texel for texel on the output's grid."""
    sizes = {"offset": 16, "spin": 16, name: 8}
    tex = {"edges": gl.upload(np.zeros((16, 16, 1), np.float32), "R16F"),
           "shade": gl.upload(np.zeros((16, 16, 4), np.float32), "RGBA8"),
           "offset": gl.upload(np.zeros((sizes["offset"],) * 2 + (2,), np.float32), "RG16F"),
           "spin": gl.upload(np.zeros((sizes["spin"],) * 2 + (2,), np.float32), "RG32F")}
    with pytest.raises(NodeError, match=f"{name} is 8x8 but shade is 16x16"):
        run_node(gl, Sketch("s", Sketch.Params()), tex, (16, 16), needed=frozenset({"color"}))


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


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  g: {type: rasterize}
  e: {type: edge_detect, in: {normal_depth: g.normal_depth}}
  n: {type: perlin_noise}
  s: {type: sketch, in: {edges: e.out, shade: g.color, offset: n.out, depth: g.depth}}
"""
    ex, res = run_minimal(gl, nodes, {"image": "s.color", "offsets": "s.offsets", "depth": "s.depth"})
    assert assert_outputs_as_planned(ex, res, "s") == ["color", "depth", "offsets"]


def test_a_line_over_a_black_fill_stays_visible(gl):
    """A dark texture under a line: the ink turns to the paper colour where the fill is as dark as the ink, and a
    light fill keeps the ink colour (hand-computed: contrast 0.1, ink luminance ~0.1)."""
    h, w = 16, 32
    edges = np.zeros((h, w, 1), np.float32)
    edges[:, 8] = edges[:, 24] = 1.0  # one line over each half
    shade = np.zeros((h, w, 4), np.float32)
    shade[..., 3] = 1.0
    shade[:, 16:, :3] = 0.8  # left half black, right half light grey
    zero = gl.upload(np.zeros((h, w, 2), np.float32), "RG16F")
    node = Sketch("s", Sketch.Params(edge_matrix=((0.0, 0.0), (0.0, 0.0)), shade_matrix=((0.0, 0.0), (0.0, 0.0))))
    out = run_node(gl, node, {"edges": gl.upload(edges, "R16F"), "shade": gl.upload(shade, "RGBA8"), "offset": zero},
                   (w, h), needed=frozenset({"color"}))["color"].read()
    paper, ink = np.array(node.params.paper), np.array(node.params.edge_color)
    assert np.abs(out[4, 8, :3] - paper).max() < 0.01  # over black: a light line
    assert np.abs(out[4, 4, :3]).max() < 0.01  # the black fill beside it
    assert np.abs(out[4, 24, :3] - ink).max() < 0.01  # over the light fill: the ink as before
    off = run_node(gl, Sketch("s", Sketch.Params(edge_matrix=((0.0, 0.0), (0.0, 0.0)), line_contrast=0.0,
                                                 shade_matrix=((0.0, 0.0), (0.0, 0.0)))),
                   {"edges": gl.upload(edges, "R16F"), "shade": gl.upload(shade, "RGBA8"), "offset": zero},
                   (w, h), needed=frozenset({"color"}))["color"].read()
    assert np.abs(off[4, 8, :3] - ink).max() < 0.01  # line_contrast 0: the ink, lost in the black
