"""What the pencil nodes (Lee et al. 2006) agree on: paper and graphite colours, the light in view space,
the bound on the distortion maps' offsets, and the pixel box of the objects (`screen_bounds`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from nodegraph.gpu import footprint

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
    vp = camera.projection_matrix(w / h) @ camera.view_matrix()
    return footprint.union(footprint.project_box(vp, *obj.world_bounds(), size, margin) for obj in scene.objects)
