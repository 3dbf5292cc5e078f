"""Evenly spaced streamlines of a line field on the screen (Jobard and Lefer, "Creating evenly-spaced
streamlines of arbitrary density", 1997): a streamline grows both ways from a seed in steps of `step` pixels
and stops where it comes closer than d_test = stop_ratio x d_sep(p) to another streamline (or to its own
earlier part), leaves the region, or turns back; new seeds are taken d_sep(p) to either side of every accepted
streamline's samples, then from a grid. d_sep varies over the image (by tone). Pure Python and NumPy: the
reference for the compiled loop that `hatch` runs (jit.py), which gives the same streamlines."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

Field = Callable[[float, float], tuple[float, float] | None]


EMPTY = 1e-9  # a cell whose tensor's trace is at most this has no direction


def tensor_field(points: np.ndarray, dirs: np.ndarray, weights: np.ndarray, size: tuple[int, int], cell: float,
                 sigma: float, fill: np.ndarray | None = None) -> np.ndarray:
    """(rows, cols, 3) smoothed structure tensor (xx, xy, yy) of unsigned screen directions on a grid of `cell`
    pixels: each direction d adds weight x d d^T to its cell; a Gaussian of `sigma` pixels smooths the sums
    (sign-free, so opposite directions agree). `fill` (rows, cols) bool: the cells to give a direction wherever
    there are points at all (those an object covers): the ones the Gaussian leaves empty (more than about four
    sigma from every point: the middle of a large flat face, whose only vertices are its corners) take the sums
    smoothed by a Gaussian twice as wide, and so on, up to the whole grid."""
    from scipy.ndimage import gaussian_filter

    w, h = size
    cols, rows = int(math.ceil(w / cell)), int(math.ceil(h / cell))
    t = np.zeros((rows, cols, 3))
    if len(points):
        ci = np.clip((points[:, 0] / cell).astype(int), 0, cols - 1)
        ri = np.clip((points[:, 1] / cell).astype(int), 0, rows - 1)
        for k, v in enumerate((dirs[:, 0] ** 2, dirs[:, 0] * dirs[:, 1], dirs[:, 1] ** 2)):
            np.add.at(t[..., k], (ri, ci), weights * v)
    s = max(sigma / cell, 0.0)

    def smooth(width: float) -> np.ndarray:
        return np.stack([gaussian_filter(t[..., k], width, mode="nearest") for k in range(3)], axis=-1)

    out = smooth(s) if s > 0 else t.copy()
    if fill is not None and (t[..., 0] + t[..., 2]).max() > EMPTY:
        width = max(s, 1.0)
        while True:
            empty = (out[..., 0] + out[..., 2] <= EMPTY) & fill
            if not empty.any() or width > 2.0 * max(rows, cols):
                break
            width *= 2.0
            out[empty] = smooth(width)[empty]
    return out


def principal(t: np.ndarray) -> np.ndarray:
    """(..., 2) unit eigenvector of the larger eigenvalue of tensors (..., 3) = (xx, xy, yy)."""
    angle = 0.5 * np.arctan2(2.0 * t[..., 1], t[..., 0] - t[..., 2])
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)


class Hatcher:
    """Grows the streamlines of one family. `field(x, y)` gives a unit direction or None off the region,
    `dsep(x, y)` the separation there (pixels)."""

    def __init__(self, size: tuple[int, int], field: Field, dsep: Callable[[float, float], float],
                 max_sep: float, stop_ratio: float = 0.5, step: float = 1.0, min_length: float = 0.0,
                 max_steps: int = 4000):
        self.size = size
        self.field = field
        self.dsep = dsep
        self.stop_ratio = stop_ratio
        self.step = step
        self.min_length = min_length
        self.max_steps = max_steps
        self.cell = max(max_sep * stop_ratio, step)  # the largest d_test: neighbours are in the 3 x 3 cells
        self.cols = int(self.size[0] / self.cell) + 1
        self.rows = int(self.size[1] / self.cell) + 1
        self.grid: dict[int, list[tuple[float, float, int, int]]] = {}
        self.lines: list[np.ndarray] = []

    def _free(self, x: float, y: float, line: int, index: int) -> bool:
        """No other streamline's sample (nor this one's, more than 3 d_test back along it) within d_test."""
        dt = self.stop_ratio * self.dsep(x, y)
        dt2 = dt * dt
        ci, ri = int(x / self.cell), int(y / self.cell)
        guard = 3.0 * dt / self.step
        for r in (ri - 1, ri, ri + 1):
            for c in (ci - 1, ci, ci + 1):
                for px, py, ln, ix in self.grid.get(r * self.cols + c, ()):
                    if ln == line and abs(ix - index) <= guard:
                        continue
                    if (px - x) ** 2 + (py - y) ** 2 < dt2:
                        return False
        return True

    def _inside(self, x: float, y: float) -> bool:
        return 0.0 <= x < self.size[0] and 0.0 <= y < self.size[1]

    def _grow(self, x: float, y: float, d: tuple[float, float], line: int, sign: int) -> list[tuple[float, float]]:
        out: list[tuple[float, float]] = []
        dx, dy = d[0] * sign, d[1] * sign
        for k in range(1, self.max_steps):
            # midpoint (RK2) step along the line field, the sign kept from the last step
            f = self.field(x + 0.5 * self.step * dx, y + 0.5 * self.step * dy)
            if f is None:
                break
            fx, fy = f if f[0] * dx + f[1] * dy >= 0 else (-f[0], -f[1])
            if fx * dx + fy * dy < 0.5:  # a turn over 60 degrees in one step: a singularity
                break
            nx, ny = x + self.step * fx, y + self.step * fy
            if not self._inside(nx, ny) or self.field(nx, ny) is None or not self._free(nx, ny, line, sign * k):
                break
            out.append((nx, ny))
            x, y, dx, dy = nx, ny, fx, fy
            # own samples enter the grid as they are made (self-approach, a loop closing, stops it)
            self._add(nx, ny, line, sign * k)
        return out

    def _add(self, x: float, y: float, line: int, index: int) -> None:
        key = int(y / self.cell) * self.cols + int(x / self.cell)
        self.grid.setdefault(key, []).append((x, y, line, index))

    def _remove(self, pts: list[tuple[float, float]], line: int) -> None:
        for x, y in pts:
            key = int(y / self.cell) * self.cols + int(x / self.cell)
            self.grid[key] = [q for q in self.grid[key] if q[2] != line]

    def streamline(self, x: float, y: float) -> np.ndarray | None:
        """Grow one streamline from a seed; keep it (and return it) if it is long enough."""
        d = self.field(x, y)
        line = len(self.lines)
        if d is None or not self._inside(x, y) or not self._free(x, y, line, 0):
            return None
        self._add(x, y, line, 0)
        fwd = self._grow(x, y, d, line, 1)
        back = self._grow(x, y, d, line, -1)
        pts = back[::-1] + [(x, y)] + fwd
        length = self.step * (len(pts) - 1)
        if length < self.min_length or len(pts) < 2:
            self._remove(pts, line)
            return None
        arr = np.array(pts, dtype=np.float64)
        self.lines.append(arr)
        return arr

    def run_fixed(self, seeds: np.ndarray) -> list[np.ndarray]:
        """Every seed in the order given, no queue of neighbour seeds: the streamlines depend only on the seeds'
        order and the field, so seeds that move with a surface give much the same streamlines frame to frame."""
        for x, y in seeds:
            self.streamline(float(x), float(y))
        return self.lines

    def run(self, seeds: np.ndarray) -> list[np.ndarray]:
        """Jobard and Lefer's loop: seeds d_sep to either side of each new streamline's samples first (a queue),
        then the next of `seeds` (grid candidates) when the queue is empty."""
        queue: list[np.ndarray] = []
        nxt = 0
        while True:
            if queue:
                line = queue.pop(0)
            else:
                line = None
                while nxt < len(seeds) and line is None:
                    line = self.streamline(float(seeds[nxt, 0]), float(seeds[nxt, 1]))
                    nxt += 1
                if line is None:
                    return self.lines
                queue.append(line)
                continue
            tang = np.gradient(line, axis=0)
            tang /= np.maximum(np.linalg.norm(tang, axis=1, keepdims=True), 1e-12)
            normal = np.stack([-tang[:, 1], tang[:, 0]], axis=1)
            for k in range(0, len(line), 2):
                x, y = line[k]
                ds = self.dsep(float(x), float(y))
                for s in (1.0, -1.0):
                    new = self.streamline(float(x + s * ds * normal[k, 0]), float(y + s * ds * normal[k, 1]))
                    if new is not None:
                        queue.append(new)
