"""What the pencil nodes (Lee et al. 2006) agree on: paper and graphite colours, the light in view space,
the bound on the distortion maps' offsets, and the pixel box of the objects (`screen_bounds`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from .params import Color  # RGB in [0, 1], finite: checked when the pipeline loads

PAPER_COLOR: Color = (0.97, 0.96, 0.93)
GRAPHITE_COLOR: Color = (0.17, 0.17, 0.19)

# the largest distortion_map `amplitude` accepted: consumers (contour) may rely on
# |offset| <= MAX_AMPLITUDE x height per component
MAX_AMPLITUDE = 0.02


def view_light(scene: Any, camera: Any) -> np.ndarray:
    """The scene light as a unit view-space direction towards the light (float64)."""
    light = np.asarray(scene.light_direction, dtype=np.float64)
    if scene.light_space == "world":
        light = camera.view_matrix()[:3, :3] @ light
    return light / max(float(np.linalg.norm(light)), 1e-12)


def screen_bounds(scene: Any, camera: Any, size: tuple[int, int], margin: int) -> tuple[int, int, int, int] | None:
    """Pixel rectangle (x, y, w, h) holding every object's projected bounding box grown by `margin` pixels,
    clipped to the image; None when a box reaches behind the camera (then the whole image)."""
    w, h = size
    if not scene.objects:
        return (0, 0, 0, 0)
    vp = camera.projection_matrix(w / h) @ camera.view_matrix()
    lo = np.array([np.inf, np.inf])
    hi = -lo
    for obj in scene.objects:
        bmin, bmax = obj.world_bounds()
        corners = np.array([[x, y, z, 1.0] for x in (bmin[0], bmax[0]) for y in (bmin[1], bmax[1])
                            for z in (bmin[2], bmax[2])])
        clip = corners @ vp.T
        if (clip[:, 3] <= 1e-9).any():
            return None
        ndc = clip[:, :2] / clip[:, 3:4]
        px = (ndc + 1.0) * 0.5 * np.array([w, h])
        lo, hi = np.minimum(lo, px.min(axis=0)), np.maximum(hi, px.max(axis=0))
    x0 = int(np.clip(np.floor(lo[0]) - margin, 0, w))
    y0 = int(np.clip(np.floor(lo[1]) - margin, 0, h))
    x1 = int(np.clip(np.ceil(hi[0]) + margin, 0, w))
    y1 = int(np.clip(np.ceil(hi[1]) + margin, 0, h))
    return (x0, y0, max(x1 - x0, 0), max(y1 - y0, 0))
