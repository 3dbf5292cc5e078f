"""hatching_synthesis: a tonal art map of nested, tileable pencil-hatching tones (Lee et al. 2006, §4.1.2).

The synthesis itself is in ``tam`` (CPU, float64, exact per-pixel stroke order); this node wraps it as a
``TextureArray[R8]`` with mipmaps and wrap-around addressing, computed once per parameter set.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field, model_validator

from nodegraph.errors import NodeError
from nodegraph.node import Node, NodeParams, Output, RunContext
from nodegraph.types import TextureArray

from .tam import synthesize_tam


class HatchingSynthesis(Node):
    """Tonal art map: `tones` hatching textures, tone 0 the lightest (blank paper) and the last at
    `max_darkness` mean darkness. Strokes have seeded random positions, lengths, slopes and a gentle
    sinusoidal wobble; each stroke darkens a pixel by c_t' = c_t - mu_b c_a with c_a = c_t (1 - c_s) times
    its coverage, scaled by mu_w while the pixel is still white (white preservation). Tones are nested
    (every tone holds all strokes of the lighter ones), so blending neighbouring tones shows no seams, and
    every tone tiles seamlessly. The key covers the params and the seed only (never the frame, size or
    camera): a frame loop and later runs reuse it, and it is persisted to the disk cache."""

    version = "1"
    persist = "always"
    outputs = {"tones": Output(TextureArray("R8"), "The tones, layer 0 lightest; value 1 = white paper. "
                               "Mipmapped, wrap-around addressing.")}

    class Params(NodeParams):
        size: int = Field(256, ge=8, le=2048, description="Tile width and height in texels.")
        tones: int = Field(32, ge=2, le=256, description="Number of tones (texture layers).")
        strokes: int = Field(20000, ge=1, le=1_000_000, description="Most strokes drawn for the darkest tone "
                             "(an error names the darkness reached if max_darkness needs more).")
        mu_b: float = Field(0.6, gt=0, le=1, description="Darkening factor: a stroke darkens a pixel by "
                            "mu_b * c_a, c_a = c_t * (1 - c_s) times its coverage.")
        mu_w: float = Field(0.5, gt=0, le=1, description="White preservation: the darkening of a still-white "
                            "pixel (value above white_threshold) is scaled by mu_w, keeping gaps open.")
        c_s: float = Field(0.1, ge=0, lt=1, description="Stroke colour (0 = black graphite).")
        max_darkness: float = Field(0.8, gt=0, lt=1, description="Mean darkness (1 - mean value) of the "
                                    "darkest tone; tones are spaced evenly from 0 to this.")
        wobble_amplitude: float = Field(1.0, ge=0, le=16, description="Amplitude of each stroke's sinusoidal "
                                        "wobble, in texels.")
        wobble_frequency: float = Field(2.0, ge=0, le=32, description="Wobble cycles per tile width "
                                        "(each stroke draws from 0.75x to 1.25x this).")
        stroke_width: float = Field(1.1, gt=0, le=8, description="Stroke thickness in texels.")
        stroke_length: tuple[float, float] = Field((0.2, 0.6), description="Range of stroke lengths as "
                                                   "fractions of the tile width (at most 0.98).")
        max_angle: float = Field(4.0, ge=0, lt=45, description="Strokes tilt by up to this many degrees.")
        pressure_jitter: float = Field(0.35, ge=0, lt=1, description="Per-stroke pressure varies in "
                                       "[1 - pressure_jitter, 1].")
        taper: float = Field(0.15, ge=0, le=0.5, description="Opacity ramps over this fraction of a stroke's "
                             "length at both ends.")
        grain: float = Field(0.35, ge=0, lt=1, description="Paper grain inside strokes: opacity times a fixed "
                             "noise in [1 - grain, 1].")
        seed: int | None = Field(None, ge=0, description="Stroke seed; default: derived from the pipeline seed "
                                 "and the node id.")

        @model_validator(mode="after")
        def _check(self) -> HatchingSynthesis.Params:
            lo, hi = self.stroke_length
            if not 0.0 < lo <= hi <= 0.98:
                raise ValueError(f"stroke_length needs 0 < lo <= hi <= 0.98, got {list(self.stroke_length)}")
            if self.stroke_width > self.size / 4:
                raise ValueError(f"stroke_width {self.stroke_width} is more than a quarter of the tile ({self.size})")
            if self.mu_b == 1.0 and self.c_s == 0.0:
                raise ValueError("mu_b = 1 with c_s = 0 paints pixels black in one stroke; lower one of them")
            return self

    @property
    def context_keys(self) -> frozenset[str]:  # type: ignore[override]
        return frozenset() if self.params.seed is not None else frozenset({"seed"})

    def synthesize(self, seed: int) -> Any:
        """The (tones, size, size) float32 stack, 1 = white."""
        p = self.params
        try:
            return synthesize_tam(
                size=p.size, tones=p.tones, strokes=p.strokes, mu_b=p.mu_b, mu_w=p.mu_w, c_s=p.c_s,
                max_darkness=p.max_darkness, wobble_amplitude=p.wobble_amplitude,
                wobble_frequency=p.wobble_frequency, stroke_width=p.stroke_width, seed=seed,
                stroke_length=p.stroke_length, max_angle=p.max_angle, pressure_jitter=p.pressure_jitter,
                taper=p.taper, grain=p.grain,
            )
        except ValueError as exc:
            raise NodeError(str(exc), self.id, self.type_name) from None

    def output_shape(self, port: str, size: tuple[int, int]) -> tuple[int, int, int]:
        return (self.params.size, self.params.size, self.params.tones)

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        seed = self.params.seed if self.params.seed is not None else ctx.seed
        tam = self.synthesize(seed)
        size = (tam.shape[2], tam.shape[1])
        return {"tones": ctx.gl.texture_array(size, tam.shape[0], "R8", tam, repeat=True, mipmaps=True)}


NODE = HatchingSynthesis
