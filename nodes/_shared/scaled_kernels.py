"""The tent blurs and the Sobel pair of Curtis' method (Curtis, "Loose and Sketchy Animation", 1998) with
a footprint in pixels at the pipeline's reference size (docs/sizes.md): the 1-D weights at px_scale s, for
the GPU passes of depth_edges and force_field (uniform arrays) and for their float64 NumPy references.

Each kernel is a continuous function of the offset in *reference* pixels, x / s, sampled at the integer
pixel offsets x of this image:

* tent of half-width a (3x3: a = 2, 9x9: a = 5): w(x) = a s - |x| where positive, divided by its sum, so
  at s = 1 the weights are Curtis' [1 2 1] / 4 and [1 2 3 4 5 4 3 2 1] / 25 exactly;
* Sobel smoothing: the tent of half-width 2, scaled to sum 4 (Curtis' unnormalised [1 2 1]);
* Sobel difference: I(x + s) - I(x - s), the image linearly interpolated between its pixels, i.e. the
  weights hat(x - s) - hat(x + s), hat(t) = max(0, 1 - |t|): [-1 0 1] at s = 1.

So a slope of the same steepness per reference pixel gives the same gradient at every size (the difference
of a linear interpolant of a linear function is exact), and a depth step gives the same peak at s >= 1
(3 x the step, as at the reference size); below the reference size a step spans a pixel of the coarser
image and peaks at 2 x the step at s = 0.5 (the per-pixel filters times s gave 1.5 x). The weights at s = 1
are small integers (and their sums), so the GPU computes Curtis' filters bit for bit as before.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np


class Kernels(NamedTuple):
    """1-D weights at offsets -r .. r (index k + r): tent (unnormalised, divide by `tent_sum`), Sobel smoothing
    and difference (both of radius `sobel_r`)."""

    tent: np.ndarray
    tent_sum: float
    smooth: np.ndarray
    diff: np.ndarray

    @property
    def tent_r(self) -> int:
        return len(self.tent) // 2

    @property
    def sobel_r(self) -> int:
        return len(self.smooth) // 2


def _hat(t: np.ndarray) -> np.ndarray:
    return np.maximum(0.0, 1.0 - np.abs(t))


def tent_weights(half_width: float, s: float) -> np.ndarray:
    """Unnormalised tent a s - |x| at the integers x where it is positive (at least the centre)."""
    a = half_width * s
    r = max(0, math.ceil(a) - 1)
    x = np.arange(-r, r + 1, dtype=np.float64)
    return a - np.abs(x)


def kernels(tent_half_width: float, s: float = 1.0) -> Kernels:
    """The weights of a tent of `tent_half_width` reference pixels followed by Curtis' Sobel pair, at px_scale s."""
    if not s > 0:
        raise ValueError(f"px_scale must be positive, got {s}")
    tent = tent_weights(tent_half_width, s)
    smooth = tent_weights(2.0, s)
    if s != 1.0:
        smooth = smooth * (4.0 / smooth.sum())
    r = max(len(smooth) // 2, math.ceil(s))
    smooth = np.pad(smooth, r - len(smooth) // 2)
    x = np.arange(-r, r + 1, dtype=np.float64)
    diff = _hat(x - s) - _hat(x + s)
    return Kernels(tent, float(tent.sum()), smooth, diff)


def correlate1d(img: np.ndarray, weights: np.ndarray, axis: int) -> np.ndarray:
    """sum_k w[k] img[clamp(i + k - r)] along `axis` (edge-clamped), float64."""
    a = np.asarray(img, np.float64)
    r = len(weights) // 2
    n = a.shape[axis]
    idx = np.arange(n)
    out = np.zeros(a.shape, np.float64)
    for k, wk in enumerate(weights):
        if wk != 0.0:
            out += wk * np.take(a, np.clip(idx + k - r, 0, n - 1), axis=axis)
    return out


def tent_sobel(img: np.ndarray, k: Kernels) -> tuple[np.ndarray, np.ndarray]:
    """float64 reference: Curtis' (gx, gy) (= -8 x the gradient per reference pixel) of `img` blurred by the
    tent, both stages edge-clamped ([row (y up), col (x)] arrays, as nodes/_shared/filters.py)."""
    t = correlate1d(correlate1d(img, k.tent, 0), k.tent, 1) / (k.tent_sum * k.tent_sum)
    gx = -correlate1d(correlate1d(t, k.smooth, 0), k.diff, 1)
    gy = -correlate1d(correlate1d(t, k.diff, 0), k.smooth, 1)
    return gx, gy


def uniforms(k: Kernels) -> dict[str, object]:
    """The shader's uniform arrays (tent_sobel.glsl)."""
    return {"u_tent": k.tent.astype(np.float32), "u_smooth": k.smooth.astype(np.float32),
            "u_diff": k.diff.astype(np.float32), "u_tent_norm": k.tent_sum * k.tent_sum}


def defines(k: Kernels) -> dict[str, int]:
    return {"TENT_R": k.tent_r, "SOBEL_R": k.sobel_r}


# Above this many multiply-adds a pixel for the tents at every Sobel tap ((2 tent_r + 1) x (2 sobel_r + 1)), the
# nodes split each axis into a tent pass and a Sobel pass (tent_sobel.glsl: the same bits, two more passes): at the
# reference size (force_field 27, depth_edges 9) and below it the two passes stay.
SPLIT_ABOVE = 40


def split(k: Kernels) -> bool:
    """Whether tent_sobel.glsl's split passes (2, 3, 4, 5) are the cheaper way to apply `k`."""
    return len(k.tent) * len(k.smooth) > SPLIT_ABOVE


def pass_rects(rect: tuple[int, int, int, int], k: Kernels, size: tuple[int, int]
               ) -> tuple[tuple[int, int, int, int], ...]:
    """Where the passes of tent_sobel.glsl can differ from their value on a constant input, given the rectangle
    outside which their input is constant (`nodegraph.gpu.footprint`): the x pass's window reaches tent_r + sobel_r
    pixels along x, the y pass's as far along y; split (`split`), each of the four passes reaches its own kernel's
    radius along its axis."""
    from nodegraph.gpu import footprint

    if split(k):  # the four split passes: the tent, then the Sobel pair, along x, then along y
        rects = [footprint.grow(rect, k.tent_r, 0, size)]
        rects.append(footprint.grow(rects[-1], k.sobel_r, 0, size))
        rects.append(footprint.grow(rects[-1], 0, k.tent_r, size))
        rects.append(footprint.grow(rects[-1], 0, k.sobel_r, size))
        return tuple(rects)  # type: ignore[arg-type]
    win = k.tent_r + k.sobel_r
    across = footprint.grow(rect, win, 0, size)
    return across, footprint.grow(across, 0, win, size)  # type: ignore[return-value]


def draw(ctx: object, shader: str, k: Kernels, size: tuple[int, int], x_pass: tuple[dict, dict, dict],
         y_pass: tuple[dict, dict, dict, list], rects: tuple | None = None, blanks: list | None = None,
         keep: bool = False) -> list:
    """Run tent_sobel.glsl's passes of a node's `shader`: the x pass over the node's input (`x_pass`: its defines,
    textures and uniforms) and the y pass into the node's targets (`y_pass`: defines, textures besides `t_x`,
    uniforms, targets), or, where `split(k)`, the four split passes (2 and 5 the node's, 3 and 4 generic). `rects`
    and `blanks` as `pass_rects` and `footprint.blank_results` give them, one per pass (the last pass's blanks,
    one per target). Returns the targets; with `keep`, the intermediate textures first (for blank_results)."""
    gl = ctx.gl  # type: ignore[attr-defined]
    weights, defs = uniforms(k), defines(k)
    x_defines, x_textures, x_uniforms = x_pass
    y_defines, y_textures, y_uniforms, targets = y_pass
    passes = (2, 3, 4, 5) if split(k) else (0, 1)
    made: list = []
    try:
        source = None
        for i, n in enumerate(passes):
            last = i == len(passes) - 1
            if i == 0:
                extra, textures, unis = x_defines, x_textures, x_uniforms
            elif last:
                extra, textures, unis = y_defines, {**y_textures, "t_x": source}, y_uniforms
            else:
                extra, textures, unis = {}, {"t_t": source}, {}
            out = targets if last else [gl.texture(size, "RG32F", filter="nearest")]
            if not last:
                made.append(out[0])
            gl.fullscreen(ctx.program(shader, {"PASS": n, **defs, **extra}), out,  # type: ignore[attr-defined]
                          textures=textures, uniforms={**unis, **weights}, rect=rects[i] if rects else None,
                          blanks=(blanks[i:] if last else blanks[i:i + 1]) if blanks else None)
            source = out[0]
    except BaseException:
        for tex in made:
            gl.release(tex)
        raise
    if keep:
        return [*made, *targets]
    for tex in made:
        gl.release(tex)
    return list(targets)
