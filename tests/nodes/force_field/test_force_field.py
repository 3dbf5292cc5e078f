"""force_field on the GPU: float64 references, and the field of a depth disc circulating around its rim."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.depth_edges import DepthEdges
from nodegraph_nodes.force_field import ForceField
from nodegraph_nodes.force_field.reference import force_field as force_field_ref
from nodegraph_nodes.particle_sketch import core, synthetic
from pydantic import ValidationError
from scipy import ndimage

from tests.helpers import assert_outputs_as_planned, run_minimal, run_node

SEED_GX = np.array([[-1, -2, -1], [0, 0, 0], [1, 2, 1]], float)
SEED_GY = np.array([[1, 0, -1], [2, 0, -2], [1, 0, -1]], float)
TENT9 = np.array([1, 2, 3, 4, 5, 4, 3, 2, 1], float)


def _field(gl, depth: np.ndarray, **params) -> tuple[np.ndarray, np.ndarray]:
    """(gradient, force) of a depth map in [0, 1] through depth_edges and force_field on the GPU."""
    h, w = depth.shape
    de = run_node(gl, DepthEdges("de", DepthEdges.Params(mode="window", reference_height=None)),
                  {"depth": gl.upload(depth.astype(np.float32), "R32F")}, (w, h), needed=frozenset({"gradient"}))
    out = run_node(gl, ForceField("ff", ForceField.Params(**params)), {"gradient": de["gradient"]}, (w, h))
    assert out["out"].fmt == "RG32F"
    return de["gradient"].read().astype(np.float64), out["out"].read().astype(np.float64)


def _disc_frame(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    y, x = np.mgrid[0:size, 0:size] + 0.5
    dx, dy = x - size / 2, y - size / 2
    r = np.hypot(dx, dy)
    return r, dx / r, dy / r


def test_matches_the_pseudocode_in_float64(gl):
    d = synthetic.ellipsoids_depth((64, 90), [(30, 36, 22, 15, 20, 0.5, 0.1), (62, 22, 18, 24, -30, 0.3, 0.05)])
    g, raw = _field(gl, d, saturate=0.0, clamp=0.3)
    # ff1 - ff2 written out with SciPy from the (GPU) gradient: magnitude, clamp, 9x9 tent, Sobel, rotations
    gx, gy = g[..., 0], g[..., 1]
    b = ndimage.convolve(np.minimum(np.hypot(gx, gy), 0.3), np.outer(TENT9, TENT9) / 625.0, mode="nearest")
    hx = ndimage.convolve(b, np.flipud(SEED_GX.T), mode="nearest")
    hy = ndimage.convolve(b, np.flipud(SEED_GY.T), mode="nearest")
    ff1 = np.stack([-1.0 * gy, 1.0 * gx], -1)
    ff2 = np.stack([-1.0 * hy, 1.0 * hx], -1)
    np.testing.assert_allclose(raw, ff1 - ff2, rtol=0, atol=1e-5)
    # and against the particle core's float64 force field of the same depth
    np.testing.assert_allclose(raw, core.force_field(d, clamp=0.3), rtol=0, atol=1e-5)
    for restoring in ("rotated", "gradient"):
        _, sat = _field(gl, d, saturate=0.03, restoring=restoring)
        np.testing.assert_allclose(sat, force_field_ref(g, 1.0, 0.03, restoring), rtol=0, atol=1e-5)
        assert np.hypot(sat[..., 0], sat[..., 1]).max() <= 1.0 + 1e-6


@pytest.mark.parametrize("shape", [(31, 26), (6, 11), (2, 3)])
def test_white_noise_gradient_borders_and_tiny_images_match(gl, shape):
    """A noise gradient fed straight in, so every border texel matters: the separable passes clamp at
    both stages (9x9 tent, then Sobel) as the two clamped convolutions do; images down to 2 px."""
    h, w = shape
    g = np.random.default_rng(4).normal(0.0, 0.4, (h, w, 2)).astype(np.float32)
    out = run_node(gl, ForceField("ff", ForceField.Params(saturate=0.0, clamp=0.5)),
                   {"gradient": gl.upload(g, "RG32F", filter="nearest")}, (w, h))["out"].read()
    np.testing.assert_allclose(out, force_field_ref(g.astype(np.float64), 0.5, 0.0, "rotated"), rtol=0, atol=2e-6)


def test_a_depth_disc_circulates_tangentially_around_its_rim(gl):
    size, radius = 128, 40.0
    _, ff = _field(gl, synthetic.disc_depth(size, radius, 0.5), saturate=0.0)
    r, ux, uy = _disc_frame(size)
    radial = ff[..., 0] * ux + ff[..., 1] * uy
    tangential = ff[..., 0] * -uy + ff[..., 1] * ux  # counter-clockwise positive
    rim = np.abs(r - (radius + 1.0)) <= 1.0  # the rim and the ring just outside it
    assert rim.sum() > 500
    assert (tangential[rim] < 0).all()  # clockwise all the way round
    assert np.abs(radial[rim]).mean() < 0.1 * np.abs(tangential[rim]).mean()
    far = (r < radius - 12) | (r > radius + 12)
    assert np.abs(ff[far]).max() < 1e-6  # no force away from edges


def test_restoring_gradient_pulls_towards_the_rim(gl):
    size, radius = 128, 40.0
    _, ff = _field(gl, synthetic.disc_depth(size, radius, 0.5), restoring="gradient")
    r, ux, uy = _disc_frame(size)
    radial = ff[..., 0] * ux + ff[..., 1] * uy
    inside = np.abs(r - (radius - 4.0)) <= 0.5
    outside = np.abs(r - (radius + 5.0)) <= 0.5
    assert (radial[inside] > 0).all() and (radial[outside] < 0).all()  # both sides point at the ridge
    _, rot = _field(gl, synthetic.disc_depth(size, radius, 0.5), restoring="rotated")
    rot_radial = rot[..., 0] * ux + rot[..., 1] * uy
    assert np.abs(rot_radial[inside | outside]).mean() < 0.1 * np.abs(radial[inside | outside]).mean()


def test_params_are_validated():
    with pytest.raises(ValidationError):
        ForceField.Params(clamp=0.0)
    with pytest.raises(ValidationError):
        ForceField.Params(saturate=-1.0)
    with pytest.raises(ValidationError):
        ForceField.Params(restoring="normal")


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  g: {type: rasterize}
  e: {type: depth_edges, in: {depth: g.linear_depth}}
  f: {type: force_field, in: {gradient: e.gradient}}
"""
    ex, res = run_minimal(gl, nodes, {"out": "f.out"})
    assert assert_outputs_as_planned(ex, res, "f") == ["out"]


@pytest.mark.parametrize("shape,reference", [((40, 52), 20), ((40, 52), 80), ((33, 45), 22)])
def test_scaled_tent_and_sobel_match_float64(gl, shape, reference):
    """px_scale 2, 0.5 and 1.5: the 9x9 tent and the Sobel pair with their footprint in reference pixels
    (half-width 5 px_scale, difference at +-px_scale, linearly interpolated) against the float64 NumPy
    reference, on a noise gradient so that every weight and border texel matters."""
    from nodegraph_nodes._shared import scaled_kernels as kernels

    h, w = shape
    s = min(w, h) / reference
    g = np.random.default_rng(reference).normal(0.0, 0.4, (h, w, 2)).astype(np.float32)
    for saturate in (0.0, 0.03):
        out = run_node(gl, ForceField("ff", ForceField.Params(saturate=saturate, clamp=0.5)),
                       {"gradient": gl.upload(g, "RG32F", filter="nearest")}, (w, h),
                       reference_size=reference)["out"].read()
        ref = force_field_ref(g.astype(np.float64), 0.5, saturate, "rotated", px_scale=s)
        # saturated: divided by max(|ff|, 0.03), which magnifies the float32 rounding up to 33 times
        np.testing.assert_allclose(out, ref, rtol=0, atol=3e-6 if saturate == 0 else 3e-5)
    k = kernels.kernels(5.0, s)
    assert k.tent_r == int(np.ceil(5 * s)) - 1 and k.tent_sum == pytest.approx((5 * s) ** 2, rel=0.1)
    # and the reference at scale 1 is the seed's (tent9, Sobel)
    np.testing.assert_allclose(force_field_ref(g, 0.5, 0.0, px_scale=1.0), force_field_ref(g, 0.5, 0.0),
                               rtol=0, atol=1e-12)


def _ff2_in_the_picture(gl, size: int, reference: int) -> np.ndarray:
    """ff2 of a disc at one place in the picture, size x size px, area-averaged to 64 px."""
    d = synthetic.disc_depth(size, 0.3 * size, 0.5)
    de = run_node(gl, DepthEdges("de", DepthEdges.Params(mode="window")),
                  {"depth": gl.upload(d.astype(np.float32), "R32F")}, (size, size),
                  needed=frozenset({"gradient"}), reference_size=reference)
    ff = run_node(gl, ForceField("ff", ForceField.Params(saturate=0.0)), {"gradient": de["gradient"]},
                  (size, size), reference_size=reference)["out"].read().astype(np.float64)
    g = de["gradient"].read().astype(np.float64)
    ff2 = np.stack([-g[..., 1], g[..., 0]], -1) - ff  # ff = ff1 - ff2
    f = size // 64
    return ff2.reshape(64, f, 64, f, 2).mean(axis=(1, 3))


@pytest.mark.slow  # 1.9 s
def test_ff2_keeps_its_shape_in_the_picture_at_every_size(gl):
    """A disc at the same place in the picture at 64, 128 and 256 px, reference 128: the restoring part of
    the field, area-averaged to 64 px, is close to the reference size's (per reference pixel); with the
    per-pixel filters (every size its own reference) it is twice or half as wide and much further off."""
    ref = _ff2_in_the_picture(gl, 128, 128)
    for size in (64, 256):
        scaled = np.linalg.norm(_ff2_in_the_picture(gl, size, 128) - ref) / np.linalg.norm(ref)
        per_pixel = np.linalg.norm(_ff2_in_the_picture(gl, size, size) - ref) / np.linalg.norm(ref)
        # measured 0.16 / 1.04 at 64 px (a step spans a pixel of the coarser image) and 0.09 / 0.69 at 256
        assert scaled < 0.2 and scaled < per_pixel / 4, (size, scaled, per_pixel)
