"""float64 NumPy version of sketch.glsl."""

from __future__ import annotations

import numpy as np

from nodegraph.gpu.sampling import bilinear, nearest, pixel_uv

from .._shared.noise import turn_pairs


def sketch(edges: np.ndarray, shade: np.ndarray, offset: np.ndarray, shade_matrix: np.ndarray,
           layers: list[tuple[np.ndarray, tuple[float, float, float]]], edge_strength: float = 1.0,
           use_shade: bool = True, paper: tuple[float, float, float] = (0.98, 0.97, 0.94),
           depth: np.ndarray | None = None, line_contrast: float = 0.1,
           spin: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """edges (H, W), shade (H, W, 4), offset (H, W, 2); layers: [(2x2 matrix, colour)]; depth (H, W)
    optional: adds the "depth" output (minimum of the depth map over every perturbed lookup); spin (H, W, 2)
    optional: (cos, sin) turning every shift, after its matrix, in pixels ((0, 0): not turned)."""
    h, w = shade.shape[:2]
    u, v = pixel_uv(w, h)
    off = bilinear(offset, u, v)

    def turn(o: np.ndarray) -> np.ndarray:
        return o if spin is None else turn_pairs(o, spin, (w, h))

    sm = np.asarray(shade_matrix, dtype=np.float64)
    s_off = turn(off @ sm.T)
    sh = bilinear(shade, u + s_off[..., 0], v + s_off[..., 1]) * float(use_shade)
    color = np.asarray(paper, dtype=np.float64) * (1 - sh[..., 3:4]) + sh[..., :3] * sh[..., 3:4]
    cover = sh[..., 3]
    luma = np.array([0.2126, 0.7152, 0.0722])
    fill_luma = color @ luma  # the fill under the lines: an ink it comes close to turns towards the paper
    z = np.ones((h, w))
    if depth is not None and use_shade:
        z = nearest(depth, u + s_off[..., 0], v + s_off[..., 1])
    first = None
    for matrix, edge_color in layers:
        e_off = turn(off @ np.asarray(matrix, dtype=np.float64).T)
        first = e_off if first is None else first
        e = np.clip(bilinear(edges, u + e_off[..., 0], v + e_off[..., 1]) * edge_strength, 0, 1)
        ink = np.asarray(edge_color, dtype=np.float64)
        light = (np.clip((ink @ luma + line_contrast - fill_luma) / line_contrast, 0, 1) if line_contrast > 0
                 else np.zeros((h, w)))[..., None]
        ink = ink * (1 - light) + np.asarray(paper, dtype=np.float64) * light
        color = color * (1 - e[..., None]) + ink * e[..., None]
        cover = np.maximum(cover, e)
        if depth is not None:
            z = np.minimum(z, nearest(depth, u + e_off[..., 0], v + e_off[..., 1]))
    assert first is not None
    if depth is not None:  # no surface behind the pixel: paper (what the depth sprite shows)
        far = z >= 1.0
        color = np.where(far[..., None], np.asarray(paper, dtype=np.float64), color)
        cover = np.where(far, 0.0, cover)
    out = {"color": np.concatenate([color, cover[..., None]], axis=-1),
           "offsets": np.concatenate([first, s_off], axis=-1)}
    if depth is not None:
        out["depth"] = z
    return out

