"""What the pencil nodes (Lee et al. 2006) agree on: paper and graphite colours, the light in view space,
and the bound on the distortion maps' offsets."""

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
