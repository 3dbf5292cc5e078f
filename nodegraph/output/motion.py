"""Frames compared along rasterize's exact screen-space motion (docs/animation.md, Making films).

Arrays are (H, W[, C]) with row 0 at the top, as `Pipe.render` and `Pipe.inspect` give them: pixel (r, c) has
its centre at window (c + 0.5, H - r - 0.5), in the gl_FragCoord convention (origin lower-left) of
`rasterize.motion` (xy: where the pixel's surface point was in the previous frame, z its window depth then,
w = 1 where covered). All arithmetic is float64.
"""

from __future__ import annotations

import numpy as np

DEPTH_TOL = 0.01
"""visible_both's default: the previous depth buffer may differ from the point's previous depth by 1% of its view
depth (window depth z = A - B / d: |dz| = (1 - z) |dd| / d where far >> near)."""
DEPTH_JUMP = 0.05
"""motion_boundaries' default: two neighbouring covered pixels lie on different surfaces (an occluding contour
between them) where their view depths differ by more than 5% of the nearer one's. A surface between them would
have to be within about 3 degrees of edge-on at 256 px across a 45-degree view (less at larger sizes)."""


def _corners(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """The four texels around window position (x, y) (texel centres at +0.5, clamped at the edges) and the
    bilinear weights along x and y."""
    h, w = img.shape[:2]
    tx, ty = x - 0.5, h - 0.5 - y  # continuous column and row
    x0, y0 = np.floor(tx), np.floor(ty)
    fx, fy = tx - x0, ty - y0
    x0i = np.clip(x0.astype(np.int64), 0, w - 1)
    y0i = np.clip(y0.astype(np.int64), 0, h - 1)
    x1i = np.clip(x0.astype(np.int64) + 1, 0, w - 1)
    y1i = np.clip(y0.astype(np.int64) + 1, 0, h - 1)
    return [img[y0i, x0i], img[y0i, x1i], img[y1i, x0i], img[y1i, x1i]], fx, fy


def _centres(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's own window position (x, y)."""
    rows, cols = np.mgrid[0:h, 0:w].astype(np.float64)
    return cols + 0.5, h - rows - 0.5


def _source(motion: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Window position to read the previous frame at (background pixels: the pixel itself, the sheet does not
    move), and the coverage mask."""
    m = np.asarray(motion, dtype=np.float64)
    covered = m[..., 3] > 0.5
    xx, yy = _centres(*m.shape[:2])
    x = np.where(covered, m[..., 0], xx)
    y = np.where(covered, m[..., 1], yy)
    return x, y, covered


def displacement(motion: np.ndarray) -> np.ndarray:
    """(H, W, 2): how far each pixel's surface point was from the pixel in the previous frame, in pixels (window
    axes; 0 on the background, where the sheet does not move)."""
    x, y, _ = _source(motion)
    xx, yy = _centres(*x.shape)
    return np.stack([x - xx, y - yy], axis=-1)


def sample(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """img (h, w) or (h, w, c) read bilinearly at window positions (x, y) (pixel centres at +0.5; edges clamped)."""
    a = np.asarray(img, dtype=np.float64)
    (c00, c10, c01, c11), fx, fy = _corners(a, x, y)
    if a.ndim == 3:
        fx, fy = fx[..., None], fy[..., None]
    return (c00 * (1 - fx) + c10 * fx) * (1 - fy) + (c01 * (1 - fx) + c11 * fx) * fy


def warp(prev_img: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """The previous frame's image brought to this frame: prev_img read bilinearly at motion.xy where covered, at
    the pixel itself on the background."""
    x, y, _ = _source(motion)
    return sample(prev_img, x, y)


def visible_both(motion: np.ndarray, prev_depth: np.ndarray, tol: float = DEPTH_TOL) -> np.ndarray:
    """(h, w) bool: pixels that show the same thing in both frames. A covered pixel counts where its point lay
    inside the previous image, the previous texels that motion.xy reads (bilinear weight over 1e-3) are all
    surface (depth < 1), and the previous depth buffer read bilinearly there matches the point's previous depth
    motion.z within `tol` relative view depth (|dz| <= tol * (1 - z)); otherwise it was hidden (disocclusion) or
    off screen. A background pixel counts where the previous frame's pixel was background too (the sheet stays
    put)."""
    d = np.asarray(prev_depth, dtype=np.float64)
    if d.ndim == 3:
        d = d[..., 0]
    h, w = d.shape
    x, y, covered = _source(motion)
    z = np.asarray(motion, dtype=np.float64)[..., 2]
    corners, fx, fy = _corners(d, x, y)
    weights = [(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy]
    # texels that take part (weight over 1e-3: a point on a pixel centre reads that texel alone)
    all_surface = np.logical_and.reduce([(c < 1.0) | (wt <= 1e-3) for c, wt in zip(corners, weights, strict=True)])
    read = sum(c * wt for c, wt in zip(corners, weights, strict=True))
    inside = (x >= 0) & (x <= w) & (y >= 0) & (y <= h)
    match = np.abs(read - z) <= tol * np.maximum(1.0 - z, 0.0)
    surface_ok = covered & inside & all_surface & match & (z <= 1.0)
    background_ok = ~covered & (d >= 1.0)
    return surface_ok | background_ok


def motion_boundaries(motion: np.ndarray, depth: np.ndarray, jump: float = DEPTH_JUMP) -> np.ndarray:
    """(h, w) bool: the pixels on either side of an occluding contour in this frame, where the motion is
    discontinuous: a pixel and one of its four neighbours differ in coverage (an outline over the sheet), or are
    both covered at view depths (`depth`, rasterize.linear_depth) more than `jump` of the nearer one apart (a
    part in front of another). A pixel there straddles two surfaces that move apart, and its one motion vector
    follows one of them (an antialiased outline mixes both; a line drawn along the contour moves with the contour,
    not with either surface), so the warping error leaves it out. This is the exact-geometry counterpart of the
    motion-boundary test in the non-occlusion mask of Ruder et al. 2016 that Lai et al. 2018 measure over (a large
    gradient of optical flow); smooth motion, however sheared, is never a boundary here."""
    covered = np.asarray(motion, dtype=np.float64)[..., 3] > 0.5
    d = np.asarray(depth, dtype=np.float64)
    if d.ndim == 3:
        d = d[..., 0]
    out = np.zeros(covered.shape, bool)
    for axis in (0, 1):
        a = [slice(None), slice(None)]
        b = [slice(None), slice(None)]
        a[axis], b[axis] = slice(None, -1), slice(1, None)
        ca, cb, da, db = covered[tuple(a)], covered[tuple(b)], d[tuple(a)], d[tuple(b)]
        edge = (ca != cb) | (ca & cb & (np.abs(da - db) > jump * np.minimum(da, db)))
        out[tuple(a)] |= edge
        out[tuple(b)] |= edge
    return out


def reliable(motion: np.ndarray, prev_depth: np.ndarray, depth: np.ndarray, tol: float = DEPTH_TOL) -> np.ndarray:
    """(h, w) bool: the pixels the warping error is measured over: visible in both frames (`visible_both`) and
    off this frame's motion boundaries (`motion_boundaries`, from its linear `depth`)."""
    return visible_both(motion, prev_depth, tol) & ~motion_boundaries(motion, depth)


def warping_error(frame: np.ndarray, prev_frame: np.ndarray, motion: np.ndarray, prev_depth: np.ndarray,
                  depth: np.ndarray | None = None, tol: float = DEPTH_TOL) -> float:
    """Mean of |frame - warp(prev_frame, motion)| over the pixels visible in both frames, and off the motion
    boundaries where this frame's linear `depth` is given (`reliable`), averaged over the channels given (Lai et
    al. 2018 after Bonneel et al. 2015, with the exact motion instead of optical flow); NaN where no pixel
    counts."""
    mask = visible_both(motion, prev_depth, tol) if depth is None else reliable(motion, prev_depth, depth, tol)
    if not mask.any():
        return float("nan")
    diff = np.abs(np.asarray(frame, dtype=np.float64) - warp(prev_frame, motion))
    if diff.ndim == 3:
        diff = diff.mean(axis=2)
    return float(diff[mask].mean())
