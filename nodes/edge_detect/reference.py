"""float64 NumPy version of edge_detect.glsl, for tests and the speed comparison."""

from __future__ import annotations

import numpy as np

from nodegraph.gpu.sampling import shifted, smoothstep


def edge_detect(normal_depth: np.ndarray, operator: str = "four_neighbour", mode: str = "normal_depth",
                normal_threshold: float = 0.4, depth_threshold: float = 0.03, width: float = 1,
                profile_intensity: float = 1.0, inner_intensity: float = 1.0) -> dict[str, np.ndarray]:
    """normal_depth (H, W, 4): view-space normal in xyz, linear depth in w with 0 = background. `width` is
    the stencil radius in image pixels (already scaled); not whole, the stencils at floor(width) and
    floor(width) + 1 are blended by the fraction (radius 0: nothing)."""
    whole = int(np.floor(width + 1e-9))
    frac = width - whole
    frac = 0.0 if frac < 1e-9 else frac
    zero = np.zeros(normal_depth.shape[:2])
    profile, inner = (_measures(normal_depth, operator, mode, normal_threshold, depth_threshold, whole)
                      if whole > 0 else (zero, zero))
    if frac > 0.0:
        p1, i1 = _measures(normal_depth, operator, mode, normal_threshold, depth_threshold, whole + 1)
        profile = profile * (1.0 - frac) + p1 * frac
        inner = inner * (1.0 - frac) + i1 * frac
    return {"out": np.maximum(profile * profile_intensity, inner * inner_intensity), "profile": profile,
            "inner": inner}


def _measures(normal_depth: np.ndarray, operator: str, mode: str, normal_threshold: float,
              depth_threshold: float, r: int) -> tuple[np.ndarray, np.ndarray]:
    """(profile, inner) with the stencil at distance r."""
    n = normal_depth[..., :3].astype(np.float64)
    d = normal_depth[..., 3].astype(np.float64)
    cov = d > 0
    dc = d
    inside = dc > 0

    def depth_at(dx: int, dy: int) -> np.ndarray:
        s = shifted(d, dx, dy)
        return np.where(s > 0, s, dc * 4.0)

    def normal_at(dx: int, dy: int) -> np.ndarray:
        s = shifted(n, dx, dy)
        c = shifted(cov, dx, dy)
        return np.where(c[..., None], s, n)

    def chord(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.linalg.norm(a - b, axis=-1)

    safe = np.where(inside, dc, 1.0)
    if operator == "four_neighbour":
        sx = (depth_at(-r, 0) + depth_at(r, 0) - 2 * dc) / safe
        sy = (depth_at(0, -r) + depth_at(0, r) - 2 * dc) / safe
        depth_measure = np.maximum(sx, sy)
        normal_measure = np.max([chord(n, normal_at(dx, dy)) for dx, dy in ((-r, 0), (r, 0), (0, -r), (0, r))], axis=0)
    else:
        dd = {(i, j): depth_at(i * r, j * r) for i in (-1, 0, 1) for j in (-1, 0, 1)}
        nn = {(i, j): normal_at(i * r, j * r) for i in (-1, 0, 1) for j in (-1, 0, 1)}
        gx = (dd[1, -1] + 2 * dd[1, 0] + dd[1, 1]) - (dd[-1, -1] + 2 * dd[-1, 0] + dd[-1, 1])
        gy = (dd[-1, 1] + 2 * dd[0, 1] + dd[1, 1]) - (dd[-1, -1] + 2 * dd[0, -1] + dd[1, -1])
        depth_measure = np.hypot(gx, gy) / (4 * safe)
        nx = chord(nn[-1, -1], nn[1, -1]) + 2 * chord(nn[-1, 0], nn[1, 0]) + chord(nn[-1, 1], nn[1, 1])
        ny = chord(nn[-1, -1], nn[-1, 1]) + 2 * chord(nn[0, -1], nn[0, 1]) + chord(nn[1, -1], nn[1, 1])
        normal_measure = np.hypot(nx, ny) / 4
    profile = np.zeros_like(dc)
    inner = np.zeros_like(dc)
    if mode in ("normal_depth", "depth"):
        profile = smoothstep(depth_threshold, 1.5 * depth_threshold, depth_measure)
    if mode in ("normal_depth", "normal"):
        inner = smoothstep(normal_threshold, 1.25 * normal_threshold, normal_measure)
    profile = np.where(inside, profile, 0.0)
    inner = np.where(inside, inner, 0.0)
    return profile, inner
