"""object_noise: uncertainty values from object-space positions (Nienhaus & Döllner 2004, §4.1–4.3)."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from nodegraph.errors import NodeError
from nodegraph.gpu import footprint
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import Texture

from .._shared import noise


class ObjectNoise(Node):
    """Geometry-controlled uncertainty: (off_s, off_t) = F(g(s,t) * k + o), F(g(s,t) * k + o + c1), where
    g(s,t) is the object-space position that `rasterize` wrote for the (enlarged) geometry, F is Perlin
    turbulence (or fbm) in 3D, o the paper's domain offset and c1 a fixed offset that decorrelates the
    second channel (`nodes/_shared/noise.py`, `noise3_at`). The values stick to the surface, so
    a moving camera sees the same uncertainty on the same surface point: the shower-door effect of
    screen-space noise goes away (paper §4.3).

    The paper reads a 3D texture holding Perlin noise; this node evaluates the same improved-noise
    function per pixel instead (our choice): no resolution limit, no tiling, nothing to bake, and the
    GPU matches the float64 CPU reference at the same positions to ~1e-6. Where `position` has no
    coverage (beyond the enlarged geometry) the output is `background`. The seed comes from the pipeline
    seed and the node id, and by default never the frame (`hold: 0`); `hold: N` draws a new noise domain
    every N frames (a boil that still sticks to the surface between changes). For a skinned or morphing
    mesh, rasterize writes rest-pose positions, so the noise follows the deforming surface.

    The values are a pair of offsets in the picture's axes. With `spin` connected (our addition; the paper's
    offsets keep the picture's axes) the pair is turned by the angle the surface under the pixel has turned in the
    picture since frame 0 (`rasterize.spin`): a part turning in the picture's plane (a bending arm, a wheel, a
    rolling camera) carries its marks' offsets with it instead of keeping them pointing the same way on the
    screen while the lines turn under them. At frame 0 and for a still the turn is 0 and the values are the
    same as without it. The pair is turned before `sketch` applies its matrices, so a sheared matrix's slant stays
    on the page; `sketch`'s own `spin` input turns the shifts after them instead (the whole mark turns)."""

    version = "1"
    shaders = ("object_noise.glsl",)  # includes ../perlin_noise/improved_noise.glsl: hashed with it
    key_omits = frozenset({"hold"})  # covered by the held frame in the key
    inputs = {
        "position": Input(Texture("RGBA32F"), "Object-space position g(s,t), alpha = coverage "
                          "(rasterize.position, usually with `enlarge` > 0)."),
        "spin": Input(Texture("RG32F"), "The surface's turn in the picture since frame 0 (rasterize.spin "
                      "of the same rasterize node): the pair (off_s, off_t) is turned by it, so the offsets turn "
                      "with the surface (a film setting; docs/animation.md, Making films).", optional=True),
    }
    outputs = {"out": Output(Texture("RG32F"), "Uncertainty values (off_s, off_t) for the sketch node.")}

    class Params(NodeParams):
        scale: float = Field(4.0, gt=0, le=1e6, description="Noise frequency: cycles per `unit`.")
        unit: Literal["scene", "absolute"] = Field(
            "scene", description="scene: `scale` counts cycles per diagonal of the scene's bounding box, so "
            "meshes of any size look alike; absolute: cycles per object-space unit.")
        octaves: int = Field(3, ge=1, le=12, description="Octaves summed, each at twice the frequency and half "
                                                         "the amplitude.")
        mode: Literal["turbulence", "fbm"] = Field(
            "turbulence", description="turbulence: sum of |noise| (>= 0, mean ~0.43, the paper's); fbm: signed, "
            "mean 0, so the maps are not shifted on average.")
        background: tuple[float, float] = Field((0.0, 0.0), description="Value where no geometry was rasterized.")
        hold: int = Field(0, ge=0, le=100_000, description="Frames per change of the noise (the boil rate): 0 "
                          "keeps it for the whole sequence, N draws a new noise domain every N frames.")

    @property
    def context_keys(self) -> frozenset[str]:  # type: ignore[override]
        keys = {"size", "seed", "scene"}
        if self.params.hold != 0:
            keys.add("frame")
        return frozenset(keys)

    def key_parts(self, ctx: Any, input_keys: dict[str, str]) -> dict[str, Any]:
        """With `spin` connected, the turning pass's shader joins the key (without it the key is as it always was)."""
        parts = super().key_parts(ctx, input_keys)
        if "spin" in input_keys:
            from nodegraph.gpu.glsl import source_digest

            parts = {**parts, "glsl": [*parts["glsl"], source_digest(self.source_dir() / SPIN_SHADER)]}
        return parts

    def frequency(self, scene: Any) -> float:
        """Cycles per object-space unit."""
        p = self.params
        if p.unit == "absolute" or scene is None:
            return p.scale
        lo, hi = scene.scale_bounds()  # fixed over an animation: the noise does not change scale per frame
        diag = float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))
        return p.scale / diag if diag > 0 else p.scale

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        gl = ctx.gl
        prog = ctx.program("object_noise.glsl")
        cell, frac = noise.seed_offset_parts(ctx.seed)
        size = inputs["position"].size
        spin = inputs.get("spin")
        if spin is not None and spin.size != size:
            raise NodeError(f"spin is {spin.size[0]}x{spin.size[1]} but position is {size[0]}x{size[1]}: connect "
                            "both from the same rasterize node")
        out = ctx.target("out", size)
        # outside the position's footprint nothing was drawn (coverage 0): the background, written by a clear
        fp = footprint.of(inputs["position"])
        rect = fp.rect if fp is not None and len(fp.blank) == 4 and fp.blank[3] <= 0.0 else None
        background = tuple(float(b) for b in p.background)
        gl.fullscreen(prog, [out], textures={"t_position": inputs["position"]}, rect=rect,
                      blanks=[background] if rect is not None else None,
                      uniforms={"u_scale": float(np.float32(self.frequency(ctx.scene))),
                                "u_seed_cell": tuple(int(c) for c in cell),
                                "u_seed_frac": tuple(float(f) for f in frac),
                                "u_octaves": p.octaves, "u_mode": 0 if p.mode == "turbulence" else 1,
                                "u_background": background})
        if spin is not None:  # a second pass turns the pair (its shader is in the key only then: key_parts)
            turned = ctx.target("out", size)
            gl.fullscreen(ctx.program(SPIN_SHADER), [turned], textures={"t_noise": out, "t_spin": spin}, rect=rect,
                          blanks=[background] if rect is not None else None)
            gl.release(out)
            out = turned
        # |value| bound for consumers that shift lookups by it (sketch's footprint): the noise (a turned pair's
        # components up to sqrt(2) times it), or the background
        b = noise.octaves_bound(p.octaves) * (np.sqrt(2.0) if spin is not None else 1.0)
        out.absmax = tuple(max(b, abs(float(v))) for v in p.background)
        return {"out": out}

    def reference(self, position: np.ndarray, seed: int, scene: Any = None, spin: np.ndarray | None = None
                  ) -> np.ndarray:
        """float64 CPU version of `out` for a read-back position texture (H, W, 4) and, where connected, spin
        texture (H, W, 2)."""
        p = self.params
        pos = np.asarray(position, dtype=np.float64)
        k = float(np.float32(self.frequency(scene)))
        vals = noise.noise3_at(pos[..., :3], p.octaves, seed, p.mode, k)
        if spin is not None:
            vals = noise.turn_pairs(vals, spin)
        return np.where(pos[..., 3:4] > 0, vals, np.asarray(p.background, dtype=np.float64))


SPIN_SHADER = "spin_turn.glsl"
NODE = ObjectNoise
