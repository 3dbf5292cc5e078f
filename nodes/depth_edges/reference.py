"""float64 NumPy version of depth_edges.glsl (through the shared filters, `nodes/_shared/filters.py`)."""

from __future__ import annotations

import numpy as np

from .._shared import filters
from .._shared import scaled_kernels as kernels


def normalised_depth(depth: np.ndarray, mode: str = "window", near: float = 0.0, far: float = 1.0) -> np.ndarray:
    """Depth in [0, 1] with 1 = background, as pass 0 of the shader reads it."""
    d = np.asarray(depth, np.float64)
    if mode == "window":
        return d
    return np.where(d > 0.0, np.clip((d - near) / (far - near), 0.0, 1.0), 1.0)


def depth_edges(depth: np.ndarray, threshold: float = 0.03, mode: str = "window", near: float = 0.0,
                far: float = 1.0, reference_height: int | None = None) -> dict[str, np.ndarray]:
    """edges (bool), gradient (H, W, 2: Curtis' gx, gy, times H / reference_height if given) and magnitude
    of a (H, W) depth map."""
    scale = 1.0 if reference_height is None else np.shape(depth)[0] / reference_height
    gx, gy = (scale * g for g in filters.sobel(filters.tent3(normalised_depth(depth, mode, near, far))))
    mag = np.sqrt(gx * gx + gy * gy)
    return {"edges": mag >= threshold, "gradient": np.stack([gx, gy], axis=-1), "magnitude": mag}


def depth_edges_scaled(depth: np.ndarray, threshold: float = 0.03, px_scale: float = 1.0, mode: str = "window",
                       near: float = 0.0, far: float = 1.0) -> dict[str, np.ndarray]:
    """As `depth_edges` with reference_height `pipeline`: the tent and Sobel pair with their footprint in
    reference pixels at px_scale (nodes/_shared/scaled_kernels.py), float64."""
    gx, gy = kernels.tent_sobel(normalised_depth(depth, mode, near, far), kernels.kernels(2.0, px_scale))
    mag = np.sqrt(gx * gx + gy * gy)
    return {"edges": mag >= threshold, "gradient": np.stack([gx, gy], axis=-1), "magnitude": mag}
