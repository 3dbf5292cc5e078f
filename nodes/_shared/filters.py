"""Float64 references of the separable filters of the method of Curtis, "Loose and Sketchy Animation", 1998: the tent
blurs and the Sobel pair that `depth_edges`, `force_field` and `particle_sketch` compute on the GPU or
the CPU. Images are [row, col] arrays with row 0 = the bottom row (GL textures), x = col, y = row (up).

* `tent3` is Curtis' [1 2 1; 2 4 2; 1 2 1], divided by 16 so a blur keeps the depth scale (Curtis
  gives no divisor); `tent9` is the outer product of [1 2 3 4 5 4 3 2 1], / 625. Borders clamp to the
  edge pixel (GL CLAMP_TO_EDGE, scipy mode='nearest').
* `sobel` uses Curtis' kernels unnormalised and, as Curtis says, as *convolutions*. They only make
  sense - ff1 = (-gy, gx) must be tangent to edges, so gx and gy must be derivatives along x and y with
  the same sign - when read as C arrays k[x][y] (first index the x offset -1, 0, 1, second the y offset
  with y pointing *down* Curtis' 8-bit images, row 0 on top). On our [row (y up), col (x)] arrays
  that is the weight array W = flipud(K.T) for scipy.ndimage.convolve (W's row 0 = the y-1 neighbour):

      seed gx kernel K = [-1 -2 -1; 0 0 0; 1 2 1]  ->  W_gx = [-1 0 1; -2 0 2; -1 0 1]
      seed gy kernel K = [ 1 0 -1; 2 0 -2; 1 0 -1]  ->  W_gy = [-1 -2 -1; 0 0 0; 1 2 1]

  Convolution flips W, so gx = -8 dI/dx and gy = -8 dI/dy (central differences smoothed by [1 2 1]):
  Curtis' (gx, gy) is -8 x the gradient. Magnitudes do not care; the sign picks the direction of
  circulation: ff1 = (-gy, gx) = 8 (dI/dy, -dI/dx) is the gradient turned clockwise, so particles run
  clockwise along the rim of a near object on a far background.
"""

from __future__ import annotations

import numpy as np

_TENT3 = np.array([1.0, 2.0, 1.0]) / 4.0
_TENT9 = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 4.0, 3.0, 2.0, 1.0]) / 25.0
_SMOOTH = np.array([1.0, 2.0, 1.0])
_DIFF = np.array([-1.0, 0.0, 1.0])  # correlation weights: I(+1) - I(-1)

def _correlate1d(img: np.ndarray, weights: np.ndarray, axis: int) -> np.ndarray:
    """sum_k w[k] * img[i + k - r] along `axis`, edge-clamped borders."""
    r = len(weights) // 2
    pad = [(0, 0), (0, 0)]
    pad[axis] = (r, r)
    p = np.pad(img, pad, mode="edge")
    n = img.shape[axis]
    out = np.zeros(img.shape, np.float64)
    for k, wk in enumerate(weights):
        if wk != 0.0:
            out += wk * (p[k:k + n] if axis == 0 else p[:, k:k + n])
    return out


def _as_image(img: np.ndarray) -> np.ndarray:
    a = np.asarray(img, dtype=np.float64)
    if a.ndim != 2:
        raise ValueError(f"expected a 2D image [row, col], got shape {a.shape}")
    return a


def tent3(img: np.ndarray) -> np.ndarray:
    """Curtis' 3x3 tent [1 2 1; 2 4 2; 1 2 1] / 16, edge-clamped, float64."""
    a = _as_image(img)
    return _correlate1d(_correlate1d(a, _TENT3, 0), _TENT3, 1)


def tent9(img: np.ndarray) -> np.ndarray:
    """9x9 tent, the outer product of [1 2 3 4 5 4 3 2 1] / 625, edge-clamped, float64."""
    a = _as_image(img)
    return _correlate1d(_correlate1d(a, _TENT9, 0), _TENT9, 1)


def sobel(img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Curtis' Sobel pair, as convolutions: (gx, gy) = -8 x the gradient in our x-right, y-up frame.

    See the module docstring for how Curtis' kernels map onto [row, col]; borders edge-clamped.
    """
    a = _as_image(img)
    gx = -_correlate1d(_correlate1d(a, _SMOOTH, 0), _DIFF, 1)
    gy = -_correlate1d(_correlate1d(a, _DIFF, 0), _SMOOTH, 1)
    return gx, gy
