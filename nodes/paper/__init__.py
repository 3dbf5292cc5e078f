"""paper: a seeded, tileable paper-normal texture for pencil grain (Lee et al. 2006, §4.1.3 and §4.2.3)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import Field

from nodegraph.node import Node, NodeParams, Output, RunContext
from nodegraph.types import Texture


def paper_height(size: int, seed: int, grain: float, fibres: float, fibre_length: float) -> np.ndarray:
    """(size, size) float64 height field in [0, 1], periodic in both axes: band-limited noise (tooth of
    about `grain` texels) plus elongated fibres in three random orientations (`fibres` of the relief)."""
    rng = np.random.default_rng(seed)
    spectrum = np.fft.fft2(rng.standard_normal((size, size)))
    fy = np.fft.fftfreq(size)[:, None]
    fx = np.fft.fftfreq(size)[None, :]
    f2 = fx * fx + fy * fy
    sigma = 1.0 / (2.0 * math.pi * max(grain, 1e-3))
    tooth = np.exp(-f2 / (2.0 * sigma * sigma)) * (1.0 - np.exp(-f2 / (2.0 * (0.25 * sigma) ** 2)))
    filt = (1.0 - fibres) * tooth
    if fibres > 0.0:
        for angle in rng.random(3) * math.pi:
            along = fx * math.cos(angle) + fy * math.sin(angle)
            across = -fx * math.sin(angle) + fy * math.cos(angle)
            s_along = sigma / max(fibre_length, 1.0)
            filt = filt + fibres / 3.0 * np.exp(-(along / s_along) ** 2 / 2.0 - (across / sigma) ** 2 / 2.0) \
                * (1.0 - np.exp(-f2 / (2.0 * (0.25 * sigma) ** 2)))
    h = np.real(np.fft.ifft2(spectrum * filt))
    h -= h.min()
    top = h.max()
    return h / top if top > 0 else h


def paper_normals(height: np.ndarray, relief: float) -> np.ndarray:
    """(H, W, 4) float32: unit normal (x, y, z) of the periodic height field scaled by `relief` (texel
    units), and the height in w."""
    gx = (np.roll(height, -1, axis=1) - np.roll(height, 1, axis=1)) * 0.5 * relief
    gy = (np.roll(height, -1, axis=0) - np.roll(height, 1, axis=0)) * 0.5 * relief
    n = np.stack([-gx, -gy, np.ones_like(height)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.concatenate([n, height[..., None]], axis=-1).astype(np.float32)


class Paper(Node):
    """Paper normal texture: a periodic height field of paper tooth and fibres (seeded), its unit normals
    in xyz and the height in w. Consumers read it with wrap-around addressing at one texel per pixel and
    take the dot product of the grain normal with the stroke direction: graphite catches on the side of
    the tooth a stroke runs into (paper §4.2.3). `grain` and `relief` are in texels (= pixels) at the
    pipeline's reference size (docs/sizes.md): at another size the tooth is grain x px_scale texels and the
    relief relief x px_scale (so the normals lean as much), and the paper keeps its look relative to the
    picture. The tile keeps `size` texels (it repeats more often on a larger image)."""

    version = "1"
    persist = "never"  # ~30 ms on the CPU, about what reading it back from the disk cache costs
    outputs = {"out": Output(Texture("RGBA16F"), "Grain normal (xyz, unit, z up out of the paper) and height (w).")}

    class Params(NodeParams):
        size: int = Field(512, ge=16, le=4096, description="Tile width and height in texels (a power of two "
                          "is fastest).")
        grain: float = Field(1.2, gt=0, le=16, description="Size of the paper tooth in texels (pixels) at the "
                             "reference size.")
        fibres: float = Field(0.35, ge=0, le=1, description="Share of elongated fibres in the relief.")
        fibre_length: float = Field(6.0, ge=1, le=64, description="Fibres are this many times longer than wide.")
        relief: float = Field(6.0, gt=0, le=100, description="Height scale of the relief; larger: steeper "
                              "normals, stronger grain.")
        seed: int | None = Field(None, ge=0, description="Default: derived from the pipeline seed and the node id.")

    @property
    def context_keys(self) -> frozenset[str]:  # type: ignore[override]
        return frozenset({"px_scale"}) if self.params.seed is not None else frozenset({"seed", "px_scale"})

    def normals(self, seed: int, px_scale: float = 1.0) -> np.ndarray:
        p = self.params
        if px_scale == 1.0:
            return paper_normals(paper_height(p.size, seed, p.grain, p.fibres, p.fibre_length), p.relief)
        return paper_normals(paper_height(p.size, seed, p.grain * px_scale, p.fibres, p.fibre_length),
                             p.relief * px_scale)

    def output_shape(self, port: str, size: tuple[int, int]) -> tuple[int, int, int]:
        return (self.params.size, self.params.size, 1)

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        seed = self.params.seed if self.params.seed is not None else ctx.seed
        data = self.normals(seed, ctx.px_scale)
        tex = ctx.gl.texture((self.params.size, self.params.size), ctx.format("out"), data=data, repeat=True)
        return {"out": tex}


NODE = Paper
