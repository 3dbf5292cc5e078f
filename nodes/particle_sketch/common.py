"""What the particle sketcher's engines share: parameters, result, the line level and the disc geometry.

`core` (pure-Python reference and NumPy lanes) and `jit` (compiled sequential engine) both import this
module and `rng`; `core` imports `jit` (lazily), never the other way round.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

LINE_LEVEL = 0.5
"""Ink at or above this is a line pixel for the start test (`m`)."""


@dataclass(frozen=True)
class ParticleParams:
    """Particle system parameters; distances in pixels, time in units of the (saturated) force field."""

    strokes: int = 2000  # particles to launch at most
    n: float = 2.0  # a start, and every position, must be within n px of a remaining edge pixel
    m: float = 2.0  # a start must not be within m px of a line pixel
    mass: float = 6.0
    drag: float = 1.0
    randomness: float = 0.35  # amplitude of the random force, per component
    step: float = 3.0  # time step; with the saturated field about `step` px per step at full speed
    max_steps: int = 25
    line_width: float = 1.2  # ink line width in px (antialiased)
    erase_width: float | None = None  # width erased from the edge map; None = line_width
    integrator: Literal["rk4", "euler"] = "rk4"
    retries: int = 5000  # random start positions tried per stroke before the run ends
    batch: int = 1  # 1: strictly sequential (compiled); B > 1: B lanes in lock-step (NumPy)

    def __post_init__(self) -> None:
        erase = self.erase_width if self.erase_width is not None else 0.0
        checks = [
            (self.strokes >= 0, "strokes >= 0"), (self.n >= 0, "n >= 0"), (self.m >= 0, "m >= 0"),
            (self.mass > 0, "mass > 0"), (self.drag >= 0, "drag >= 0"),
            (self.randomness >= 0, "randomness >= 0"), (self.step > 0, "step > 0"),
            (self.max_steps >= 1, "max_steps >= 1"), (self.line_width > 0, "line_width > 0"),
            (erase >= 0, "erase_width >= 0 or None"),
            (self.integrator in ("rk4", "euler"), "integrator in {'rk4', 'euler'}"),
            (self.retries >= 1, "retries >= 1"), (self.batch >= 1, "batch >= 1"),
        ]
        for ok, what in checks:
            if not ok:
                raise ValueError(f"ParticleParams: expected {what}, got {self!r}")
        for name in ("n", "m", "mass", "drag", "randomness", "step", "line_width"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"ParticleParams: expected a finite {name}, got {getattr(self, name)}")
        if not math.isfinite(erase):
            raise ValueError(f"ParticleParams: expected a finite erase_width, got {self.erase_width}")

    @property
    def erase(self) -> float:
        """The erase width in effect."""
        return self.erase_width if self.erase_width is not None else self.line_width


@dataclass
class SketchResult:
    sketch: np.ndarray  # (H, W) float32 ink coverage in [0, 1]
    edges: np.ndarray  # (H, W) bool, the edge pixels left after erasing
    strokes: list[np.ndarray] = field(default_factory=list)  # (k, 2) float32 (x, y), k >= 2
    launched: int = 0  # particles started
    steps: int = 0  # segments drawn
    exhausted: bool = False  # the run ended because a stroke found no valid start


@dataclass(frozen=True)
class Sites:
    """Given starts, tried in order instead of random positions: stroke k starts at the next site (after the last
    one tried) that is valid then, and its random forces are drawn from its site's key instead of from k. Sites
    fixed on a surface (`nodegraph_nodes._shared.surface_points`) keep their keys from frame to frame, so the
    same surface point starts a stroke with the same forces, and the drawing follows its objects."""

    xy: np.ndarray  # (S, 2) float64 window positions (x right, y up), inside the image
    key: np.ndarray  # (S,) uint64 keys

    def __post_init__(self) -> None:
        xy = np.ascontiguousarray(self.xy, np.float64).reshape(-1, 2)
        key = np.ascontiguousarray(self.key, np.uint64).reshape(-1)
        if len(xy) != len(key):
            raise ValueError(f"sites: {len(xy)} positions but {len(key)} keys")
        if not np.isfinite(xy).all():
            raise ValueError("sites: positions must be finite")
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "key", key)


def disc_offsets(r: float) -> list[tuple[int, int]]:
    """Integer (dx, dy) with dx^2 + dy^2 <= r^2, in a fixed order."""
    k = int(math.floor(r))
    return [(dx, dy) for dy in range(-k, k + 1) for dx in range(-k, k + 1) if dx * dx + dy * dy <= r * r]


def pad_for(params: ParticleParams) -> int:
    reach = max(params.n, params.m, params.erase / 2.0, params.line_width / 2.0 + 0.5)
    return int(math.ceil(reach)) + 2
