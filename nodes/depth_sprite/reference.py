"""float64 NumPy version of the two depth-sprite passes."""

from __future__ import annotations

import numpy as np

from nodegraph.gpu.sampling import bilinear, nearest, pixel_uv


def depth_sprite(color: np.ndarray, offsets: np.ndarray, depth: np.ndarray, under_color: np.ndarray | None = None,
                 under_depth: np.ndarray | None = None,
                 paper: tuple[float, float, float] = (0.98, 0.97, 0.94),
                 sketch_depth: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """sketch_depth (H, W), when given, is the perturbed depth (sketch.depth) instead of the lookups."""
    h, w = depth.shape[:2]
    u, v = pixel_uv(w, h)
    paper_rgb = np.broadcast_to(np.asarray(paper, dtype=np.float64), (h, w, 3))
    if under_color is not None and under_depth is not None:
        uc = bilinear(under_color, u, v)
        out_rgb = paper_rgb * (1 - uc[..., 3:4]) + uc[..., :3] * uc[..., 3:4]
        out_z = under_depth.astype(np.float64).copy()
    else:
        out_rgb = paper_rgb.copy()
        out_z = np.ones((h, w))
    off = offsets.astype(np.float64)
    if sketch_depth is not None:
        z = np.asarray(sketch_depth, dtype=np.float64)
    else:
        z = np.minimum(nearest(depth, u + off[..., 0], v + off[..., 1]),
                       nearest(depth, u + off[..., 2], v + off[..., 3]))
    draw = (z < 1.0) & (z < out_z)
    out_rgb = np.where(draw[..., None], bilinear(color, u, v)[..., :3], out_rgb)
    out_z = np.where(draw, z, out_z)
    return {"color": np.concatenate([out_rgb, np.ones((h, w, 1))], axis=-1), "depth": out_z}
