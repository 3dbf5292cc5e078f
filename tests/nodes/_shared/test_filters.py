"""The shared float64 filters (tent blurs, the seed's Sobel pair) against scipy and the seed's kernels."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes._shared import filters
from nodegraph_nodes.particle_sketch import synthetic
from scipy import ndimage

from tests.helpers import SEED_GX, SEED_GY, SEED_TENT, seed_weights


@pytest.fixture(scope="module")
def depth() -> np.ndarray:
    """Non-square, so a transposed axis cannot pass; a ramp plus ellipsoids, so nothing is symmetric."""
    d = synthetic.ellipsoids_depth((70, 90), [(30, 40, 22, 15, 20, 0.5, 0.1), (60, 25, 18, 24, -30, 0.6, 0.05)])
    y, x = np.mgrid[0:70, 0:90]
    return (d - 0.001 * x + 0.0007 * y).astype(np.float32)


def test_tent3_and_tent9_match_scipy(depth):
    d = depth.astype(np.float64)
    ref3 = ndimage.convolve(d, SEED_TENT / 16.0, mode="nearest")
    np.testing.assert_allclose(filters.tent3(depth), ref3, rtol=0, atol=1e-14)
    t = np.array([1, 2, 3, 4, 5, 4, 3, 2, 1], float)
    ref9 = ndimage.correlate(d, np.outer(t, t) / 625.0, mode="nearest")  # symmetric: no flip issue
    np.testing.assert_allclose(filters.tent9(depth), ref9, rtol=0, atol=1e-14)
    assert filters.tent3(depth).dtype == np.float64


def test_sobel_is_the_seeds_convolution(depth):
    d = depth.astype(np.float64)
    gx, gy = filters.sobel(depth)
    wx, wy = seed_weights(SEED_GX), seed_weights(SEED_GY)
    np.testing.assert_allclose(gx, ndimage.convolve(d, wx, mode="nearest"), rtol=0, atol=1e-13)
    np.testing.assert_allclose(gy, ndimage.convolve(d, wy, mode="nearest"), rtol=0, atol=1e-13)
    # convolution = correlation with the kernel turned 180 degrees; unturned it is the opposite sign
    np.testing.assert_allclose(gx, ndimage.correlate(d, wx[::-1, ::-1], mode="nearest"), atol=1e-13)
    np.testing.assert_allclose(gx, -ndimage.correlate(d, wx, mode="nearest"), atol=1e-13)
    # orientation: on a ramp the seed's pair is -8 x the gradient (x = col, y = row, row 0 at the bottom)
    y, x = np.mgrid[0:20, 0:30]
    rx, ry = filters.sobel(0.01 * x + 0.02 * y)
    np.testing.assert_allclose(rx[1:-1, 1:-1], -0.08, atol=1e-12)
    np.testing.assert_allclose(ry[1:-1, 1:-1], -0.16, atol=1e-12)


def test_filters_take_2d_images_only():
    with pytest.raises(ValueError, match="2D"):
        filters.tent3(np.zeros((2, 3, 4)))
