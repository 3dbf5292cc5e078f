"""float64 NumPy version of posterize.glsl, for tests."""

from __future__ import annotations

import numpy as np


def posterize(rgba: np.ndarray, levels: int, alpha: bool = False) -> np.ndarray:
    """rgba (H, W, 4) -> (H, W, 4) float64: each channel (alpha only when `alpha`) to `levels` values."""
    c = np.asarray(rgba, dtype=np.float64)
    q = np.minimum(np.floor(np.clip(c, 0.0, 1.0) * levels), levels - 1) / (levels - 1)
    if not alpha:
        q[..., 3] = c[..., 3]
    return q
