"""Synthetic depth maps for tests and benchmarks until the rasterize node feeds real ones.

Depth is float32 in [0, 1], 1.0 = background; arrays are [row, col] with row 0 = the bottom row.
Each shape is the front surface of an ellipsoid seen along -z: inside the ellipse of semi-axes
(a, b) rotated by `angle`, depth = z0 - c * sqrt(1 - r^2) with r the normalised elliptic radius.
"""

from __future__ import annotations

import math

import numpy as np

# (cx, cy, a, b, angle_deg, z0, c): pixel units on an 800 x 800 canvas (scaled to other sizes).
# A cow seen from its left side, facing left: near legs in front of the body, far legs behind it,
# the head in front of the neck, so there are silhouettes and inner depth edges of several strengths.
_COW = [
    (430, 440, 230, 120, 0, 0.60, 0.14),  # body
    (250, 490, 90, 62, 35, 0.56, 0.08),  # neck
    (165, 540, 72, 50, -25, 0.48, 0.07),  # head
    (115, 500, 38, 32, -10, 0.45, 0.05),  # muzzle
    (205, 602, 34, 11, 25, 0.47, 0.02),  # ear
    (150, 612, 30, 10, -20, 0.50, 0.02),  # far ear
    (300, 215, 28, 135, 3, 0.52, 0.04),  # near front leg
    (355, 228, 25, 125, -4, 0.70, 0.04),  # far front leg
    (555, 215, 32, 135, -3, 0.52, 0.04),  # near back leg
    (610, 228, 27, 125, 5, 0.70, 0.04),  # far back leg
    (505, 318, 42, 30, 0, 0.58, 0.04),  # udder
    (672, 395, 9, 115, 12, 0.66, 0.02),  # tail
    (648, 518, 80, 68, 0, 0.58, 0.06),  # haunch
]


def ellipsoids_depth(shape: tuple[int, int], blobs: list[tuple[float, ...]],
                     scale: float = 1.0) -> np.ndarray:
    """Nearest front surface of rotated ellipsoids; `scale` multiplies every pixel quantity."""
    h, w = shape
    y, x = np.mgrid[0:h, 0:w].astype(np.float64) + 0.5
    depth = np.ones(shape, np.float64)
    for cx, cy, a, b, ang, z0, c in blobs:
        ca, sa = math.cos(math.radians(ang)), math.sin(math.radians(ang))
        dx, dy = x - cx * scale, y - cy * scale
        u = (ca * dx + sa * dy) / (a * scale)
        v = (-sa * dx + ca * dy) / (b * scale)
        r2 = u * u + v * v
        inside = r2 < 1.0
        z = z0 - c * np.sqrt(np.clip(1.0 - r2, 0.0, None))
        depth = np.where(inside, np.minimum(depth, z), depth)
    return depth.astype(np.float32)


def cow_depth(size: int = 800) -> np.ndarray:
    """A cow-like union of ellipsoids, size x size, depth 0.4-0.7 on a 1.0 background."""
    return ellipsoids_depth((size, size), _COW, scale=size / 800.0)


def herd_depth(size: int = 800) -> np.ndarray:
    """Four smaller cows, overlapping and at different depths: about twice the cow's edge length."""
    blobs = []
    for ox, oy, k, dz, flip in ((0, 400, 0.5, 0.0, 1), (400, 430, 0.48, 0.1, -1), (40, 20, 0.55, -0.1, -1),
                                (380, 40, 0.5, 0.05, 1)):
        for cx, cy, a, b, ang, z0, c in _COW:
            x = cx if flip > 0 else 800 - cx
            blobs.append((ox + x * k, oy + cy * k, a * k, b * k, ang * flip, z0 + dz, c))
    return ellipsoids_depth((size, size), blobs, scale=size / 800.0)


def disc_depth(size: int, radius: float, depth: float = 0.5, center: tuple[float, float] | None = None
               ) -> np.ndarray:
    """A flat disc at `depth` on a 1.0 background (a pure step edge along a circle)."""
    cx, cy = center if center is not None else (size / 2.0, size / 2.0)
    y, x = np.mgrid[0:size, 0:size].astype(np.float64) + 0.5
    inside = (x - cx) ** 2 + (y - cy) ** 2 < radius * radius
    return np.where(inside, depth, 1.0).astype(np.float32)
