"""distortion_map: the shaken drawing planes of multiple contour drawing (Lee et al. 2006, §4.1.1)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import Field, model_validator

from nodegraph.node import Node, NodeParams, Output, RunContext
from nodegraph.types import TextureArray

from .._shared.pencil import MAX_AMPLITUDE


class DistortionMap(Node):
    """`layers` screen-space offset maps, one per attempt at drawing the contours. Layer k shifts the pixel
    at texture coordinates (u, v) by (a_k cos(b_k u + c_k), a_k sin(b_k v + c_k)) pixels, with amplitude
    a_k drawn uniformly from [amplitude_min, 1] x amplitude x image height, frequency b_k = 2 pi f with f
    uniform in `frequency` (cycles per image) and phase c_k uniform in [0, 2 pi), all from the node seed.
    Every offset component is bounded by amplitude x height, so the strokes stay on the shape. The maps
    are smooth and low-frequency: locally each layer is a small shift and stretch, so contours come out
    as several slightly different, roughly parallel attempts (the paper finds 3 to 5 layers best). The
    coefficients stay for the whole sequence by default; `hold: N` draws new ones every N frames."""

    version = "1"
    persist = "never"  # ~10 ms to compute, cheaper than a disk read of 3 x 800 x 800 x 2 halves
    outputs = {"out": Output(TextureArray("RG16F"), "Offsets in pixels (x, y), one layer per attempt.")}

    class Params(NodeParams):
        layers: int = Field(3, ge=1, le=8, description="Number of offset maps (drawing attempts); 3 to 5 read "
                            "best.")
        amplitude: float = Field(0.004, ge=0, le=MAX_AMPLITUDE, description="Largest offset of any component, "
                                 "as a fraction of the image height (the bound; at most 0.02 keeps lines on "
                                 "the shape).")
        amplitude_min: float = Field(0.4, ge=0, le=1, description="Smallest layer amplitude as a fraction of "
                                     "`amplitude`.")
        frequency: tuple[float, float] = Field((0.5, 2.0), description="Range of frequencies in cycles per "
                                               "image width (u) or height (v).")
        animate: bool = Field(False, description="Draw new coefficients every frame (boiling lines); the older "
                              "spelling of `hold: 1`.")
        hold: int | None = Field(None, ge=0, le=100_000, description="Frames per change of the coefficients (the "
                                 "boil rate of the lines): 0 keeps them for the whole sequence, N draws new ones "
                                 "every N frames (frame // N * N). Default: 0, or 1 with `animate: true`.")

        @model_validator(mode="after")
        def _check(self) -> DistortionMap.Params:
            lo, hi = self.frequency
            if not 0.0 <= lo <= hi <= 64.0:
                raise ValueError(f"frequency needs 0 <= lo <= hi <= 64, got {list(self.frequency)}")
            return self

    key_omits = frozenset({"hold"})  # covered by the held frame in the key

    @property
    def hold(self) -> int:  # type: ignore[override]
        p = self.params
        return p.hold if p.hold is not None else (1 if p.animate else 0)

    @property
    def context_keys(self) -> frozenset[str]:  # type: ignore[override]
        return frozenset({"size", "seed", "frame"}) if self.hold != 0 else frozenset({"size", "seed"})

    def coefficients(self, seed: int, height: int) -> np.ndarray:
        """(layers, 3) float64 rows (a in pixels, b in radians per texture unit, c in radians)."""
        p = self.params
        u = np.random.default_rng(seed).random((p.layers, 3))
        a = p.amplitude * height * (p.amplitude_min + (1.0 - p.amplitude_min) * u[:, 0])
        lo, hi = p.frequency
        b = 2.0 * math.pi * (lo + (hi - lo) * u[:, 1])
        c = 2.0 * math.pi * u[:, 2]
        return np.stack([a, b, c], axis=1)

    def offsets(self, seed: int, size: tuple[int, int]) -> np.ndarray:
        """(layers, H, W, 2) float32 offsets in pixels at the pixel centres (row 0 = bottom)."""
        w, h = size
        coef = self.coefficients(seed, h)
        u = (np.arange(w) + 0.5) / w
        v = (np.arange(h) + 0.5) / h
        a, b, c = (coef[:, k, None] for k in range(3))
        ox = (a * np.cos(b * u[None, :] + c)).astype(np.float32)  # (layers, W)
        oy = (a * np.sin(b * v[None, :] + c)).astype(np.float32)  # (layers, H)
        out = np.empty((len(coef), h, w, 2), dtype=np.float32)
        out[..., 0] = ox[:, None, :]
        out[..., 1] = oy[:, :, None]
        return out

    def output_shape(self, port: str, size: tuple[int, int]) -> tuple[int, int, int]:
        return (size[0], size[1], self.params.layers)

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        data = self.offsets(ctx.seed, ctx.size)
        return {"out": ctx.gl.texture_array(ctx.size, data.shape[0], "RG16F", data, repeat=False, mipmaps=False)}


NODE = DistortionMap
