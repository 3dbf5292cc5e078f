"""depth_edges on the GPU against a float64 SciPy computation of the seed's pseudocode."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.depth_edges import DepthEdges
from nodegraph_nodes.depth_edges.reference import depth_edges as depth_edges_ref
from nodegraph_nodes.particle_sketch import synthetic
from pydantic import ValidationError
from scipy import ndimage

from nodegraph.errors import NodeError
from tests.helpers import assert_outputs_as_planned, run_minimal, run_node

# The seed's kernels exactly as printed; k[x][y] with y down the image (see nodes/particle_sketch/core.py).
SEED_TENT = np.array([[1, 2, 1], [2, 4, 2], [1, 2, 1]], float)
SEED_GX = np.array([[-1, -2, -1], [0, 0, 0], [1, 2, 1]], float)
SEED_GY = np.array([[1, 0, -1], [2, 0, -2], [1, 0, -1]], float)


def _weights(k: np.ndarray) -> np.ndarray:
    """k[x][y] (y down) as a weight array over [row (y up), col (x)] for scipy.ndimage.convolve."""
    return np.flipud(k.T)


def _pseudocode(depth: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """blur with the tent, convolve with the Sobel pair, magnitude, threshold; float64, borders clamped."""
    blur = ndimage.convolve(depth.astype(np.float64), SEED_TENT / 16.0, mode="nearest")
    gx = ndimage.convolve(blur, _weights(SEED_GX), mode="nearest")
    gy = ndimage.convolve(blur, _weights(SEED_GY), mode="nearest")
    mag = np.sqrt(gx * gx + gy * gy)
    return gx, gy, mag, mag >= threshold


@pytest.fixture(scope="module")
def depth() -> np.ndarray:
    """Non-square and asymmetric: a tilted ramp under two ellipsoids of different depths."""
    d = synthetic.ellipsoids_depth((70, 96), [(30, 40, 22, 15, 20, 0.5, 0.1), (64, 25, 18, 24, -30, 0.6, 0.05)])
    y, x = np.mgrid[0:70, 0:96]
    return np.where(d < 1.0, d, 0.95 - 0.001 * x + 0.0007 * y).astype(np.float32)


def _run(gl, depth: np.ndarray, scene=None, **params) -> dict[str, np.ndarray]:
    params.setdefault("reference_height", None)  # per pixel, as the seed
    node = DepthEdges("de", DepthEdges.Params(**params))
    h, w = depth.shape
    out = run_node(gl, node, {"depth": gl.upload(depth.astype(np.float32), "R32F")}, (w, h), scene=scene)
    return {port: tex.read() for port, tex in out.items()} | {"fmt": {p: t.fmt for p, t in out.items()}}


def test_tent_and_sobel_match_the_pseudocode_in_float64(gl, depth):
    thr = 0.03
    gx, gy, mag, edges = _pseudocode(depth, thr)
    got = _run(gl, depth, mode="window", threshold=thr)
    assert got["fmt"] == {"edges": "R8", "gradient": "RG32F", "magnitude": "R32F"}
    assert got["gradient"].shape == depth.shape + (2,) and got["edges"].shape == depth.shape + (1,)
    np.testing.assert_allclose(got["gradient"][..., 0], gx, rtol=0, atol=2e-6)
    np.testing.assert_allclose(got["gradient"][..., 1], gy, rtol=0, atol=2e-6)
    np.testing.assert_allclose(got["magnitude"][..., 0], mag, rtol=0, atol=2e-6)
    e = got["edges"][..., 0]
    assert set(np.unique(e)) <= {0.0, 1.0}
    differ = (e > 0.5) != edges
    assert not (differ & (np.abs(mag - thr) > 1e-5)).any()  # only where float32 rounding decides
    assert 0.02 < edges.mean() < 0.5
    # the node's reference (the particle core's filters) is the same computation
    ref = depth_edges_ref(depth, thr)
    np.testing.assert_allclose(ref["gradient"], np.stack([gx, gy], -1), rtol=0, atol=1e-13)


@pytest.mark.parametrize("shape", [(23, 17), (5, 9), (2, 3)])
def test_white_noise_borders_and_tiny_images_match(gl, shape):
    """Noise everywhere, borders included: the separable passes clamp at both stages as the two clamped
    convolutions of the pseudocode do (a single clamp of the combined 5x5 kernel differs on the outer
    two rows and columns); images down to 2 px."""
    depth = np.random.default_rng(3).random(shape).astype(np.float32)
    gx, gy, mag, _ = _pseudocode(depth, 0.03)
    got = _run(gl, depth, mode="window", threshold=0.03)
    np.testing.assert_allclose(got["gradient"][..., 0], gx, rtol=0, atol=2e-6)
    np.testing.assert_allclose(got["gradient"][..., 1], gy, rtol=0, atol=2e-6)
    np.testing.assert_allclose(got["magnitude"][..., 0], mag, rtol=0, atol=2e-6)


def test_orientation_on_a_ramp(gl):
    """(gx, gy) = -8 x the gradient with x = column, y = row, row 0 at the bottom (GL)."""
    y, x = np.mgrid[0:24, 0:32]
    got = _run(gl, (0.2 + 0.01 * x + 0.02 * y).astype(np.float32), mode="window")["gradient"]
    np.testing.assert_allclose(got[2:-2, 2:-2, 0], -0.08, atol=1e-5)
    np.testing.assert_allclose(got[2:-2, 2:-2, 1], -0.16, atol=1e-5)


def test_linear_depth_is_mapped_by_the_range(gl, depth):
    near, far = 2.0, 6.0
    lin = np.where(depth < 0.95 - 0.2, near + depth * (far - near), 0.0).astype(np.float32)  # 0 = background
    got = _run(gl, lin, mode="linear", range=(near, far), threshold=0.05)
    ref = depth_edges_ref(lin, 0.05, mode="linear", near=near, far=far)
    np.testing.assert_allclose(got["gradient"], ref["gradient"], rtol=0, atol=1e-5)
    assert ((got["edges"][..., 0] > 0.5) == ref["edges"]).mean() > 0.999


def test_reference_height_keeps_a_slope_the_same_at_every_size(gl):
    """A plane seen at the same angle: twice the pixels, half the depth change per pixel."""
    got = {}
    for h in (200, 400, 800):
        y, x = np.mgrid[0:h, 0:8]
        plane = (0.2 + 0.5 * (y + 0.5) / h).astype(np.float32)  # 0.5 across the image height
        got[h] = _run(gl, plane, mode="window", reference_height=800, threshold=0.004)
        np.testing.assert_allclose(got[h]["gradient"][2:-2, 2:-2, 1], -8 * 0.5 / 800, rtol=1e-3)
        assert (got[h]["edges"][2:-2] > 0.5).all()  # 0.005 >= 0.004 at every size
    per_pixel = _run(gl, plane[::4], mode="window", reference_height=None)["gradient"]  # 200 px, the seed's
    np.testing.assert_allclose(per_pixel[2:-2, 2:-2, 1], -8 * 0.5 / 200, rtol=1e-3)
    ref = depth_edges_ref(plane[::4], 0.004, reference_height=800)
    np.testing.assert_allclose(got[200]["gradient"], ref["gradient"], rtol=0, atol=1e-6)


def test_linear_depth_needs_a_camera_or_a_range(gl, depth):
    with pytest.raises(NodeError, match="needs the scene's camera or an explicit `range`"):
        _run(gl, depth, mode="linear")


def test_params_are_validated():
    with pytest.raises(ValidationError, match="far > near"):
        DepthEdges.Params(range=(5.0, 2.0))
    with pytest.raises(ValidationError):
        DepthEdges.Params(threshold=0.0)
    with pytest.raises(ValidationError):
        DepthEdges.Params(mode="log")


_PIPE = """pipeline: t
size: [{w}, {h}]
scene: builtin:sphere
nodes:
  g: {{type: rasterize}}
  d: {{type: depth_edges, in: {{depth: g.linear_depth}}}}
outputs: {{image: d.edges}}
"""


@pytest.mark.parametrize(("w", "h", "bad"), [(1, 1, True), (1, 8, True), (8, 1, True), (2, 2, False)])
def test_images_below_2x2_are_load_errors(w, h, bad):
    from nodegraph import pipeline as pl
    from nodegraph.errors import PipelineError

    if not bad:
        pl.loads(_PIPE.format(w=w, h=h), "t.yaml", load_scene=False)
        return
    with pytest.raises(PipelineError, match=rf"t.yaml:6:3: node 'd' \(depth_edges\): needs a depth image of at "
                                            rf"least 2x2 pixels .*got {w}x{h}"):
        pl.loads(_PIPE.format(w=w, h=h), "t.yaml", load_scene=False)


def test_size_override_below_2x2_is_a_load_error():
    from nodegraph import pipeline as pl
    from nodegraph.errors import PipelineError

    with pytest.raises(PipelineError, match=r"got 1x5"):
        pl.loads(_PIPE.format(w=64, h=64), "t.yaml", load_scene=False, size=(1, 5))


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  g: {type: rasterize}
  e: {type: depth_edges, in: {depth: g.linear_depth}}
"""
    ex, res = run_minimal(gl, nodes, {"edges": "e.edges", "gradient": "e.gradient", "magnitude": "e.magnitude"})
    assert assert_outputs_as_planned(ex, res, "e") == ["edges", "gradient", "magnitude"]


# --- footprint in reference pixels (reference_height: pipeline, nodes/_shared/scaled_kernels.py) ---

def _run_scaled(gl, depth: np.ndarray, reference_size: int, **params) -> dict[str, np.ndarray]:
    node = DepthEdges("de", DepthEdges.Params(mode="window", **params))  # reference_height: pipeline
    h, w = depth.shape
    out = run_node(gl, node, {"depth": gl.upload(depth.astype(np.float32), "R32F")}, (w, h),
                   reference_size=reference_size)
    return {port: tex.read().astype(np.float64) for port, tex in out.items()}


def _seed_filters(img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The seed's tent and Sobel pair, written out with SciPy (as `_pseudocode`)."""
    blur = ndimage.convolve(img, SEED_TENT / 16.0, mode="nearest")
    return (ndimage.convolve(blur, _weights(SEED_GX), mode="nearest"),
            ndimage.convolve(blur, _weights(SEED_GY), mode="nearest"))


def test_scaled_kernels_at_scale_one_are_the_seeds():
    from nodegraph_nodes._shared import scaled_kernels as kernels

    k = kernels.kernels(2.0, 1.0)
    assert k.tent.tolist() == [1, 2, 1] and k.tent_sum == 4 and k.smooth.tolist() == [1, 2, 1]
    assert k.diff.tolist() == [-1, 0, 1]
    assert kernels.kernels(5.0, 1.0).tent.tolist() == [1, 2, 3, 4, 5, 4, 3, 2, 1]
    img = np.random.default_rng(5).random((13, 17))
    for got, want in zip(kernels.tent_sobel(img, k), _seed_filters(img), strict=True):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-13)


@pytest.mark.parametrize("s", [0.5, 1.5, 2.0, 0.3])
def test_scaled_kernels_by_hand(s):
    """The weights are the continuous kernels sampled at the pixels: a ramp of slope a per reference pixel
    gives -8 a at every scale; the difference is I(x + s) - I(x - s), linearly interpolated."""
    from nodegraph_nodes._shared import scaled_kernels as kernels

    k = kernels.kernels(2.0, s)
    x = np.arange(-k.sobel_r, k.sobel_r + 1, dtype=np.float64)
    assert k.smooth.sum() == pytest.approx(4.0)
    assert (k.diff * x).sum() == pytest.approx(2 * s)  # a linear function's difference over 2 s px
    assert k.diff.sum() == pytest.approx(0.0)
    a = 0.01  # depth per reference pixel, so a / s per pixel here
    y, xx = np.mgrid[0:40, 0:48]
    gx, gy = kernels.tent_sobel(0.2 + (a / s) * xx + 0 * y, k)
    r = k.tent_r + k.sobel_r
    np.testing.assert_allclose(gx[r:-r, r:-r], -8 * a, rtol=1e-12)
    np.testing.assert_allclose(gy[r:-r, r:-r], 0.0, atol=1e-15)


def test_a_depth_step_peaks_the_same_above_the_reference_size():
    """A step of 0.1 across columns: the seed's ridge 0.1 x [1, 3, 3, 1] at 800; at 1600 the same ridge on
    twice the pixels (hand computation: the difference at +-2 px is 0.1 on four columns, the tent of
    half-width 4 px, [1 2 3 4 3 2 1] / 16, sums three of them, (3 + 4 + 3 + 2) / 16 x 4 = 3 at its peak);
    at 400 it spans one pixel of the coarser image: 0.1 x 2 on two columns (the difference at +-0.5 px)."""
    from nodegraph_nodes._shared import scaled_kernels as kernels

    step = np.where(np.arange(32) >= 16, 0.6, 0.5)[None, :].repeat(12, 0)
    ridge = {s: -kernels.tent_sobel(step, kernels.kernels(2.0, s))[0][6] for s in (0.5, 1.0, 2.0)}
    np.testing.assert_allclose(ridge[1.0][13:19], 0.1 * np.array([0, 1, 3, 3, 1, 0]), atol=1e-12)
    assert ridge[2.0].max() == pytest.approx(0.3)
    np.testing.assert_allclose(ridge[2.0][11:21], 0.1 * np.array([1, 3, 6, 10, 12, 12, 10, 6, 3, 1]) / 4, atol=1e-12)
    np.testing.assert_allclose(ridge[0.5][14:18], [0, 0.2, 0.2, 0], atol=1e-12)


@pytest.mark.parametrize("side,reference", [(96, 48), (48, 96), (72, 48), (60, 200)])
def test_scaled_filters_match_float64(gl, depth, side, reference):
    """The GPU's scaled tent and Sobel (px_scale 2, 0.5, 1.5, 0.3) against the float64 NumPy reference,
    borders included (the depth resampled to `side` rows)."""
    from nodegraph_nodes.depth_edges.reference import depth_edges_scaled

    h, w = depth.shape
    rows = np.minimum((np.arange(side) * h) // side, h - 1)
    cols = np.minimum((np.arange(side * w // h) * h) // side, w - 1)
    d = depth[rows][:, cols]
    noisy = d + np.random.default_rng(side).normal(0, 0.002, d.shape)  # every weight matters
    s = min(d.shape) / reference
    got = _run_scaled(gl, noisy, reference, threshold=0.03)
    ref = depth_edges_scaled(noisy.astype(np.float32), 0.03, s)
    np.testing.assert_allclose(got["gradient"], ref["gradient"], rtol=0, atol=3e-6)
    np.testing.assert_allclose(got["magnitude"][..., 0], ref["magnitude"], rtol=0, atol=3e-6)
    differ = (got["edges"][..., 0] > 0.5) != ref["edges"]
    assert not (differ & (np.abs(ref["magnitude"] - 0.03) > 1e-5)).any()


def test_pipeline_reference_keeps_slopes_and_steps_at_every_size(gl):
    """A plane at the same angle and a depth step, rendered at 200, 400 and 800 rows with reference 400: the
    slope gives the same gradient per reference pixel, the step is found at every size (its ridge 0.036
    plus the slope's 0.01 at and above the reference, 0.024 + 0.01 at half of it) and its edge band is as
    tall in the picture at and above the reference (2 reference px: 0.012 x [.., 3, 3, ..] at 400,
    0.012 x [.., 10, 12, 12, 10, ..] / 4 at 800); at 200 one pixel spans 2 reference px, so 2 px, 4."""
    band = {}
    for h in (200, 400, 800):
        y = (np.mgrid[0:h, 0:h][0] + 0.5) / h  # square: px_scale = h / 400
        plane = 0.2 + 0.5 * y + np.where(y >= 0.5, 0.012, 0.0)
        got = _run_scaled(gl, plane, 400, threshold=0.03)
        g = got["gradient"][..., 1][:, h // 2]
        far = np.abs(y[:, 0] - 0.5) > 8 / 400
        inner = far & (np.minimum(y[:, 0], 1 - y[:, 0]) > 8 / 400)  # the footprint off the borders
        np.testing.assert_allclose(g[inner], -8 * 0.5 / 400, rtol=1e-3)
        e = got["edges"][..., 0][:, h // 2] > 0.5
        assert e.any() and not e[far].any()
        band[h] = e.sum() * 400 / h
    assert band == {200: 4.0, 400: 2.0, 800: 2.0}


@pytest.mark.parametrize("reference", [64, 32, 24])  # px_scale 1 (the two passes), 2 and 2.67 (split by default)
def test_split_passes_give_the_same_bits_as_the_two_passes(gl, monkeypatch, reference):
    """Wide kernels run each axis as a tent pass and a Sobel pass (`scaled_kernels.split`, tent_sobel.glsl's PASS
    2-5) instead of forming the tent at every Sobel tap: the same sums in the same order, so depth_edges' outputs
    and force_field's field are the same bytes either way, borders included (a noisy depth, 64 x 48)."""
    from nodegraph_nodes._shared import scaled_kernels as kernels
    from nodegraph_nodes.force_field import ForceField

    depth = np.random.default_rng(reference).uniform(0.3, 0.7, (48, 64)).astype(np.float32)

    def both() -> list[np.ndarray]:
        de = run_node(gl, DepthEdges("de", DepthEdges.Params(mode="window")),
                      {"depth": gl.upload(depth, "R32F")}, (64, 48), reference_size=reference)
        ff = run_node(gl, ForceField("ff", ForceField.Params()), {"gradient": de["gradient"]}, (64, 48),
                      reference_size=reference)
        return [de["gradient"].read(), de["magnitude"].read(), de["edges"].read(), ff["out"].read()]

    s = 48 / reference
    monkeypatch.setattr(kernels, "SPLIT_ABOVE", 10**9)
    assert not kernels.split(kernels.kernels(5.0, s))
    two = both()
    monkeypatch.setattr(kernels, "SPLIT_ABOVE", 0)
    assert kernels.split(kernels.kernels(5.0, s)) and kernels.split(kernels.kernels(2.0, s))
    split = both()
    for a, b in zip(two, split, strict=True):
        assert a.tobytes() == b.tobytes()
    assert np.abs(two[3]).max() > 0  # a field, not zeros
