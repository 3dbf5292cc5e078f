"""perlin_noise: uncertainty values for the sketch (Nienhaus & Döllner 2004, §3.2, §3.4)."""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field

from nodegraph.node import Node, NodeParams, Output, RunContext
from nodegraph.types import Texture

from .._shared import noise


class PerlinNoise(Node):
    """Screen-space uncertainty values (off_s, off_t). `kind: perlin` uses Ken Perlin's improved noise (2002: his
    permutation table, quintic fade, 12 gradients) summed over octaves, with the paper's off_s = turbulence(s,
    t) and off_t = turbulence(1 - s, 1 - t); neighbouring values are correlated, so the drawing is coherent from
    frame to frame. `kind: white` gives uncorrelated values in [0, 1) for roughened, chalk-like profiles (paper
    §3.4), one per pixel of the reference size (a grain cell of 1 / px_scale pixels above it; per pixel at or
    below it), so chalk frays alike at every size. The seed (from the pipeline seed and the node id) shifts the
    noise domain; Perlin's table stays untouched. Noise coordinates are pixel centres times `scale` / px_scale:
    `scale` is in cycles per pixel at the pipeline's reference size (docs/sizes.md), so the noise has the same
    features at every image size. The paper creates the noise texture once, so by default the values do not
    change with the frame (`hold: 0`); `hold: N` draws new noise every N frames (the boil rate: `hold: 1`
    reseeds every frame, no coherence, the classic boil; `animate: true` is its older spelling). Turbulence is
    non-negative (mean about 0.43), so each 2x2 matrix also shifts its map by a constant; `mode: fbm` gives
    signed values with mean 0 instead. A float64 CPU version of the same function is in
    `nodes/_shared/noise.py`; the GPU output matches it to about 1e-6. On the GPU each octave's lattice z is the
    same for every pixel, so the eight corner hashes of a lattice cell come from one fetch of a 256 x 256 table
    made for that z (`noise.gradient_table`) instead of twelve permutation lookups: the same bits, in 0.55-0.6
    of the time on llvmpipe (4 octaves at 3840x2160: 0.50-0.55 s -> 0.28-0.37 s)."""

    version = "1"
    shaders = ("perlin_noise.glsl",)  # includes improved_noise.glsl: hashed with it
    outputs = {"out": Output(Texture("RG32F"), "Uncertainty values (off_s, off_t).")}

    class Params(NodeParams):
        kind: Literal["perlin", "white"] = Field("perlin", description="perlin: correlated improved noise; "
                                                 "white: uncorrelated values, one per pixel of the reference size "
                                                 "(chalk, paper §3.4).")
        mode: Literal["turbulence", "fbm"] = Field("turbulence", description="turbulence: sum of |noise| over "
                                                   "octaves (the paper's); fbm: signed sum.")
        scale: float = Field(0.01, gt=0, le=1, description="Noise frequency in cycles per pixel at the reference "
                             "size (perlin).")
        octaves: int = Field(4, ge=1, le=12, description="Octaves summed, each at twice the frequency and half "
                                                         "the amplitude (perlin).")
        animate: bool = Field(False, description="Reseed every frame (no frame-to-frame coherence); the older "
                              "spelling of `hold: 1`.")
        hold: int | None = Field(None, ge=0, le=100_000, description="Frames per change of the noise (the boil "
                                 "rate): 0 keeps it for the whole sequence, N draws new noise every N frames "
                                 "(frame // N * N). Default: 0, or 1 with `animate: true`.")

    key_omits = frozenset({"hold"})  # covered by the held frame in the key

    @property
    def hold(self) -> int:  # type: ignore[override]
        p = self.params
        return p.hold if p.hold is not None else (1 if p.animate else 0)

    @property
    def context_keys(self) -> frozenset[str]:  # type: ignore[override]
        keys = {"size", "seed", "px_scale"}
        if self.hold != 0:
            keys.add("frame")
        return frozenset(keys)

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        perlin = p.kind == "perlin"
        prog = ctx.program("perlin_noise.glsl", {"KIND": 0, "NOISE_GRAD_TABLE": 1} if perlin else {"KIND": 1})
        seed = ctx.seed
        cell, frac = noise.seed_offset_parts(seed)
        out = ctx.target("out")
        w, h = ctx.size
        tables = {}
        if perlin:
            tables["t_noise_grad"] = gradient_tables(ctx.gl, noise.screen_lattice_z(cell, frac, p.octaves))
        ctx.gl.fullscreen(prog, [out], textures=tables,
                          uniforms={"u_scale_split": noise.split_scale(self.frequency(ctx.px_scale)),
                                    "u_seed_cell": tuple(int(c) for c in cell),
                                    "u_seed_frac": tuple(float(f) for f in frac),
                                    "u_octaves": p.octaves, "u_mode": 0 if p.mode == "turbulence" else 1,
                                    "u_seed": seed & 0xFFFFFFFF,
                                    "u_frame": ctx.noise_frame & 0xFFFFFFFF,
                                    "u_size": (float(w), float(h)),
                                    "u_cell_ratio": self.cell_ratio(ctx.size, ctx.reference_size)})
        out.absmax = self.absmax(out)
        return {"out": out}

    def absmax(self, out: Any) -> tuple[float, float]:
        """A bound on |value| of each channel, for consumers that shift lookups by the noise (sketch draws only
        near the objects). Noise kept for the whole sequence (`hold` 0, the default: made once a run) is read
        back once and measured, exactly (4-octave turbulence reaches about 1.3-1.6 of the bound below); noise
        that changes is not read back (a read-back waits for the GPU) and gets the analytic bound: white noise
        lies in [0, 1), turbulence and fbm within `noise.octaves_bound`."""
        if self.params.kind == "white":
            return (1.0, 1.0)
        if self.hold == 0:
            return channel_absmax(out.read_native())
        b = noise.octaves_bound(self.params.octaves)
        return (b, b)

    @staticmethod
    def cell_ratio(size: tuple[int, int], reference_size: int | None) -> tuple[int, int]:
        """White noise: pixel i reads grain cell i * a // b, (a, b) = (reference size, shorter side) reduced;
        (1, 1) at the reference size or without one."""
        if reference_size is None:
            return (1, 1)
        a, b = int(reference_size), min(int(size[0]), int(size[1]))
        g = math.gcd(a, b)
        return (a // g, b // g)

    def frequency(self, px_scale: float) -> float:
        """Cycles per image pixel: `scale` / px_scale (`scale` itself at the reference size)."""
        return self.params.scale if px_scale == 1.0 else self.params.scale / px_scale

    def reference(self, width: int, height: int, seed: int, frame: int = 0, px_scale: float = 1.0,
                  reference_size: int | None = None) -> Any:
        """The float64 CPU computation of this node's output, (H, W, 2)."""
        p = self.params
        if p.kind == "white":
            return noise.white_offsets(width, height, seed, frame, self.cell_ratio((width, height), reference_size))
        return noise.screen_offsets(width, height, self.frequency(px_scale), p.octaves, seed, p.mode)


GRADIENT_TABLES_KEPT = 8
"""Gradient tables (1 MB for 4 octaves) kept per GL context, by their octaves' lattice z (a seed's), newest last."""


def gradient_tables(gl: Any, zs: tuple[int, ...]) -> Any:
    """The R32UI texture array of `noise.gradient_table` for each octave's lattice z (layer i: octave i), made
    once per GL context and kept for the last `GRADIENT_TABLES_KEPT` seeds."""
    import moderngl

    kept = gl.resources.setdefault("perlin_noise.gradient_tables", {})
    tex = kept.pop(zs, None)
    if tex is None:
        data = np.stack([noise.gradient_table(z) for z in zs])
        tex = gl.ctx.texture_array((256, 256, len(zs)), 1, data=data.tobytes(), dtype="u4")
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)  # an integer texture: nearest, or it is incomplete
        while len(kept) >= GRADIENT_TABLES_KEPT:
            kept.pop(next(iter(kept))).release()
    kept[zs] = tex  # newest last
    return tex


def channel_absmax(a: np.ndarray) -> tuple[float, float]:
    """max |value| of each channel of an (H, W, 2) read-back, NaN where a channel holds one (as NumPy's max).
    Channel by channel: a reduction over both image axes of the interleaved array took 26.5 ms at 800x800
    here, the two strided channels 2.0 ms. Half pixels (the planned RG16F) are compared as their bits with
    the sign cleared, whose order as integers is the order of the magnitudes, NaN above infinity: at 4K
    0.03 s, against 0.14 s to convert them to float32 first."""
    if a.dtype == np.float16:
        bits = a.view(np.uint16)
        mags = [np.array(np.bitwise_and(bits[..., k], 0x7FFF).max(), np.uint16).view(np.float16) for k in (0, 1)]
        return (float(mags[0]), float(mags[1]))
    return (float(np.abs(a[..., 0]).max()), float(np.abs(a[..., 1]).max()))


NODE = PerlinNoise
