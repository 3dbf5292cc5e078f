"""float64 NumPy version of force_field.glsl (through the shared filters, `nodes/_shared/filters.py`)."""

from __future__ import annotations

import numpy as np

from .._shared import filters
from .._shared import scaled_kernels as kernels


def force_field(gradient: np.ndarray, clamp: float = 1.0, saturate: float = 0.03,
                restoring: str = "rotated", px_scale: float | None = None) -> np.ndarray:
    """(H, W, 2) field from Curtis' Sobel pair (H, W, 2) of the blurred depth (depth_edges.gradient);
    with px_scale, the tent and Sobel pair with their footprint in reference pixels
    (nodes/_shared/scaled_kernels.py)."""
    g = np.asarray(gradient, np.float64)
    gx, gy = g[..., 0], g[..., 1]
    mag = np.minimum(np.sqrt(gx * gx + gy * gy), clamp)
    if px_scale is None:
        hx, hy = filters.sobel(filters.tent9(mag))
    else:
        hx, hy = kernels.tent_sobel(mag, kernels.kernels(5.0, px_scale))
    ff2 = (hx, hy) if restoring == "gradient" else (-hy, hx)  # unrotated, or rotated by 90 degrees
    ff = np.stack([-gy - ff2[0], gx - ff2[1]], axis=-1)
    if saturate > 0:
        ff /= np.maximum(np.sqrt(ff[..., 0] ** 2 + ff[..., 1] ** 2), saturate)[..., None]
    return ff
