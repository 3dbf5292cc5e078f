"""float64 NumPy twin of the pencil_shade fragment stage (tone mapping, layers, 3-way blending, grain).

Arrays follow OpenGL: the tonal art map is (tones, H, W) with row 0 = bottom, sampled with wrap-around
bilinear filtering at mip level 0; pixel centres are at (x + 0.5, y + 0.5).
"""

from __future__ import annotations

import math

import numpy as np

# texture-space shift of each hatching layer, so layers do not reuse the same strokes
LAYER_SHIFTS = np.array([[0.0, 0.0], [0.371, 0.613], [0.719, 0.283]])


def project_to_pixels(point: np.ndarray, view: np.ndarray, proj: np.ndarray,
                      size: tuple[int, int]) -> tuple[float, float]:
    """World point -> window pixel coordinates (x right, y up, origin at the bottom-left corner)."""
    clip = proj @ view @ np.append(np.asarray(point, dtype=np.float64), 1.0)
    ndc = clip[:3] / clip[3]
    return (float((ndc[0] + 1.0) * 0.5 * size[0]), float((ndc[1] + 1.0) * 0.5 * size[1]))


def view_rays_to_eye(size: tuple[int, int], proj: np.ndarray) -> np.ndarray:
    """(H, W, 3) unit view-space directions from each pixel centre's surface point towards the eye (rows in
    OpenGL order, row 0 at the bottom), for the projection `proj`: the view axis everywhere for an orthographic
    one (w = 1)."""
    w, h = size
    if proj[3, 3] == 1.0 and proj[3, 2] == 0.0:
        return np.broadcast_to(np.array([0.0, 0.0, 1.0]), (h, w, 3)).copy()
    x = 1.0 - 2.0 * (np.arange(w) + 0.5) / w
    y = 1.0 - 2.0 * (np.arange(h) + 0.5) / h
    d = np.stack(np.broadcast_arrays(x[None, :] / proj[0, 0], y[:, None] / proj[1, 1], np.ones((h, w))), axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def brightness(n_dot_l: np.ndarray, facing: np.ndarray, grazing_floor: float = 0.0,
               grazing_angle: float = 20.0) -> np.ndarray:
    """max(N.L, 0), lifted where the surface is seen nearly edge-on: at least grazing_floor x (1 - N.V / sin
    grazing_angle) (N.V = `facing`, clamped at 0), a lift that is the whole floor edge-on and nothing from
    grazing_angle on."""
    lit = np.maximum(np.asarray(n_dot_l, dtype=np.float64), 0.0)
    v = np.maximum(np.asarray(facing, dtype=np.float64), 0.0)
    lift = grazing_floor * np.clip(1.0 - v / max(math.sin(math.radians(grazing_angle)), 1e-6), 0.0, 1.0)
    return np.maximum(lit, lift)


def darkness(brightness: np.ndarray, light_intensity: float = 1.0) -> np.ndarray:
    """1 - sqrt(clamp(b x intensity, 0, 1)): 0 fully lit, 1 unlit."""
    return 1.0 - np.sqrt(np.clip(np.asarray(brightness, dtype=np.float64) * light_intensity, 0.0, 1.0))


def tone_index(brightness: np.ndarray, light_intensity: float, max_tone: float) -> np.ndarray:
    """Continuous tone index of the first layer: max_tone x darkness (the report's maxDarkness mapping)."""
    return max_tone * darkness(brightness, light_intensity)


def layer_shares(dark: np.ndarray, layers: int, layer_offset: float) -> np.ndarray:
    """(layers, ...) share of the darkest tone each layer draws: layer k starts at k x layer_offset."""
    dark = np.asarray(dark, dtype=np.float64)
    out = []
    for k in range(layers):
        start = k * layer_offset
        out.append(np.clip((dark - start) / max(1.0 - start, 1e-6), 0.0, 1.0))
    return np.stack(out)


def blend_weights(bary: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (..., 3) normalised to sum 1: the 3-way blending weights."""
    bary = np.asarray(bary, dtype=np.float64)
    return bary / bary.sum(axis=-1, keepdims=True)


def sample_tam(tam: np.ndarray, u: np.ndarray, v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Wrap-around bilinear reads of the two tones around the continuous index t, mixed linearly."""
    tones, h, w = tam.shape
    a = tam.astype(np.float64)
    x = np.asarray(u, dtype=np.float64) * w - 0.5
    y = np.asarray(v, dtype=np.float64) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    xi0, yi0 = x0.astype(np.int64) % w, y0.astype(np.int64) % h
    xi1, yi1 = (xi0 + 1) % w, (yi0 + 1) % h
    t = np.asarray(t, dtype=np.float64)
    t0 = np.floor(t)
    ft = t - t0
    l0 = np.clip(t0.astype(np.int64), 0, tones - 1)
    l1 = np.clip(l0 + 1, 0, tones - 1)

    def read(layer: np.ndarray) -> np.ndarray:
        top = a[layer, yi0, xi0] * (1 - fx) + a[layer, yi0, xi1] * fx
        bot = a[layer, yi1, xi0] * (1 - fx) + a[layer, yi1, xi1] * fx
        return top * (1 - fy) + bot * fy

    return read(l0) * (1 - ft) + read(l1) * ft


def canonical(dirs: np.ndarray) -> np.ndarray:
    """Directions are lines; the GPU holds each as the unit vector at angle in (-90, 90] degrees (the half
    angle of the doubled-angle form), and that sign decides how the hatching texture is laid."""
    d = np.asarray(dirs, dtype=np.float64)
    flip = (d[..., 0] < 0.0) | ((d[..., 0] == 0.0) & (d[..., 1] < 0.0))
    return np.where(flip[..., None], -d, d)


def shade(px: np.ndarray, py: np.ndarray, dirs: np.ndarray, weights: np.ndarray, dark: np.ndarray,
          tam: np.ndarray, *, max_tone: float, layers: int, layer_offset: float, layer_angle_deg: float,
          texel_scale: float = 1.0, anchor: tuple[float, float] = (0.0, 0.0), grain: float = 0.0,
          paper: np.ndarray | None = None) -> np.ndarray:
    """Hatching value (1 = paper) at pixel centres (px, py) (N,), for per-pixel vertex directions dirs
    (N, 3, 2) (unit screen-space lines, see `canonical`), blending weights (N, 3) and darkness (N,)."""
    px = np.asarray(px, dtype=np.float64)
    py = np.asarray(py, dtype=np.float64)
    dirs = canonical(dirs)
    _, th, tw = tam.shape
    p = np.stack([(px - anchor[0]) * texel_scale / tw, (py - anchor[1]) * texel_scale / th], axis=-1)
    a = math.radians(layer_angle_deg)
    angles = [0.0, a, -a][:layers]
    shares = layer_shares(dark, layers, layer_offset)
    strongest = np.argmax(weights, axis=-1)
    value = np.ones_like(px)
    for k in range(layers):
        c, s = math.cos(angles[k]), math.sin(angles[k])
        d = np.stack([c * dirs[..., 0] - s * dirs[..., 1], s * dirs[..., 0] + c * dirs[..., 1]], axis=-1)
        t = shares[k] * max_tone
        layer = np.zeros_like(px)
        for i in range(3):
            di = d[:, i]
            u = p[:, 0] * di[:, 0] + p[:, 1] * di[:, 1] + LAYER_SHIFTS[k, 0]
            v = -p[:, 0] * di[:, 1] + p[:, 1] * di[:, 0] + LAYER_SHIFTS[k, 1]
            layer += weights[:, i] * sample_tam(tam, u, v, t)
        dk = 1.0 - layer
        if paper is not None and grain > 0.0:
            ph, pw = paper.shape[:2]
            g = paper[py.astype(np.int64) % ph, px.astype(np.int64) % pw, :2].astype(np.float64)
            ds = d[np.arange(len(px)), strongest]
            dk *= np.clip(1.0 + grain * 2.5 * np.sum(g * ds, axis=-1), 0.0, 2.0)
        value *= np.where(shares[k] > 0.0, 1.0 - np.clip(dk, 0.0, 1.0), 1.0)
    return value
