"""float64 NumPy versions of GPU texture reads, for reference implementations of GPU nodes.

Arrays are (H, W[, C]) with row 0 = bottom, as textures are. Coordinates follow OpenGL: texture
coordinate u covers [0, 1] across the width; texel i has its centre at (i + 0.5) / W.
"""

from __future__ import annotations

import numpy as np


def bilinear(img: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """GL_LINEAR with CLAMP_TO_EDGE at texture coordinates (u, v)."""
    h, w = img.shape[:2]
    x = np.asarray(u, dtype=np.float64) * w - 0.5
    y = np.asarray(v, dtype=np.float64) * h - 0.5
    x0 = np.floor(x)
    y0 = np.floor(y)
    fx = x - x0
    fy = y - y0
    x0i = np.clip(x0.astype(np.int64), 0, w - 1)
    x1i = np.clip(x0.astype(np.int64) + 1, 0, w - 1)
    y0i = np.clip(y0.astype(np.int64), 0, h - 1)
    y1i = np.clip(y0.astype(np.int64) + 1, 0, h - 1)
    a = img.astype(np.float64)
    if a.ndim == 3:
        fx = fx[..., None]
        fy = fy[..., None]
    top = a[y0i, x0i] * (1 - fx) + a[y0i, x1i] * fx
    bot = a[y1i, x0i] * (1 - fx) + a[y1i, x1i] * fx
    return top * (1 - fy) + bot * fy


def nearest(img: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """texelFetch at floor(uv * size), clamped to the texture."""
    h, w = img.shape[:2]
    x = np.clip(np.floor(np.asarray(u, dtype=np.float64) * w), 0, w - 1).astype(np.int64)
    y = np.clip(np.floor(np.asarray(v, dtype=np.float64) * h), 0, h - 1).astype(np.int64)
    return img[y, x].astype(np.float64)


def pixel_uv(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Texture coordinates of every pixel centre, (H, W) each."""
    u = (np.arange(width, dtype=np.float64) + 0.5) / width
    v = (np.arange(height, dtype=np.float64) + 0.5) / height
    return np.meshgrid(u, v)


def shifted(img: np.ndarray, dx: int, dy: int) -> np.ndarray:
    """img[y + dy, x + dx] with indices clamped to the edge (texelFetch of a clamped coordinate)."""
    h, w = img.shape[:2]
    ys = np.clip(np.arange(h) + dy, 0, h - 1)
    xs = np.clip(np.arange(w) + dx, 0, w - 1)
    return img[ys][:, xs]


def smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)
