"""float64 NumPy twin of the contour pass (multiple shaken attempts, pencil tone, light, grain, overlaps).

Inputs are read-back textures, (H, W[, C]) with row 0 = bottom: the edge map (bilinear, clamped), the
per-layer offsets (layers, H, W, 2) in pixels, normal_depth (nearest) and optionally the paper (wrapped).
"""

from __future__ import annotations

import numpy as np

from nodegraph.gpu import sampling


def light_contribution(normal: np.ndarray, light: np.ndarray) -> np.ndarray:
    """sqrt((N.L) x 0.5 + 0.5) for unit normals (..., 3) (the report's light contribution)."""
    n = normal / np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-30)
    return np.sqrt(np.clip(np.sum(n * np.asarray(light, dtype=np.float64), axis=-1) * 0.5 + 0.5, 0.0, 1.0))


def contour(edges: np.ndarray, offsets: np.ndarray, normal_depth: np.ndarray, light: np.ndarray,
            pressures: np.ndarray, *, tone: float, light_weight: float, grain: float = 0.0,
            paper: np.ndarray | None = None) -> np.ndarray:
    """(H, W) paper value: prod over attempts k of (1 - darkness_k). The light and the stroke direction
    come from the surface under the pixel, or, off the surface, under the first attempt's edge sample."""
    edges = edges[..., 0] if edges.ndim == 3 else edges
    h, w = edges.shape
    ys, xs = np.mgrid[0:h, 0:w]
    here = normal_depth.astype(np.float64)
    px0 = xs + 0.5 + offsets[0, ..., 0].astype(np.float64)
    py0 = ys + 0.5 + offsets[0, ..., 1].astype(np.float64)
    qx = np.clip(np.floor(px0).astype(np.int64), 0, w - 1)
    qy = np.clip(np.floor(py0).astype(np.int64), 0, h - 1)
    nd = np.where((here[..., 3] > 0.0)[..., None], here, here[qy, qx])
    on = nd[..., 3] > 0.0
    lit = np.where(on, light_contribution(np.where(on[..., None], nd[..., :3], 1.0), light), np.sqrt(0.5))
    stroke = tone * (1.0 - light_weight * lit)
    if paper is not None:
        g = paper[ys % paper.shape[0], xs % paper.shape[1], :2].astype(np.float64)
        nxy = nd[..., :2]
        length = np.linalg.norm(nxy, axis=-1)
        across = np.stack([-nxy[..., 1], nxy[..., 0]], axis=-1) / np.maximum(length, 1e-30)[..., None]
        direction = np.where(length[..., None] > 1e-4, across, [1.0, 0.0])  # across the projected normal
        stroke = stroke * np.clip(1.0 + grain * 2.5 * np.sum(g * direction, axis=-1), 0.0, 2.0)
    value = np.ones((h, w))
    for k in range(offsets.shape[0]):
        px = xs + 0.5 + offsets[k, ..., 0].astype(np.float64)
        py = ys + 0.5 + offsets[k, ..., 1].astype(np.float64)
        e = sampling.bilinear(edges, px / w, py / h)
        value *= 1.0 - np.clip(stroke * pressures[k] * np.clip(e, 0.0, 1.0), 0.0, 1.0)
    return value
