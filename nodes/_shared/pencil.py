"""What the pencil nodes (Lee et al. 2006) agree on: paper and graphite colours, the light in view space, the
lightness a surface colour is measured by (`albedo_lightness`, the GLSL in nodegraph/gpu/shaders/albedo.glsl),
the bound on the distortion maps' offsets, and the pixel box of the objects (`screen_bounds`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from nodegraph.gpu import footprint
from nodegraph.scene.scene import DEFAULT_MESH_COLOR

from .params import Color  # RGB in [0, 1], finite: checked when the pipeline loads

PAPER_COLOR: Color = (0.97, 0.96, 0.93)
GRAPHITE_COLOR: Color = (0.17, 0.17, 0.19)

# the largest distortion_map `amplitude` accepted: consumers (contour) may rely on
# |offset| <= MAX_AMPLITUDE x height per component
MAX_AMPLITUDE = 0.02


def albedo_lightness(color: tuple[float, float, float]) -> float:
    """CIE lightness L* (0..100) of a display colour as an RGBA8 texel holds it: Rec. 709 luminance of its linear
    values, then L* = 116 Y^(1/3) - 16 (903.3 Y below 0.008856)."""
    c = np.round(np.asarray(color, dtype=np.float64) * 255.0) / 255.0
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    y = float(lin @ np.array([0.2126, 0.7152, 0.0722]))
    return 116.0 * y ** (1.0 / 3.0) - 16.0 if y > 0.008856 else 903.3 * y


ALBEDO_REF = albedo_lightness(DEFAULT_MESH_COLOR)  # L* 81.8: the default mesh colour hatches as N.L alone


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
