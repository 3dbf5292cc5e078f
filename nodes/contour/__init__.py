"""contour: multiple contour drawing with shaken edge maps (Lee et al. 2006, §3.2.1.3 and §4.2.1)."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from nodegraph.errors import NodeError
from nodegraph.gpu import footprint
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.scene import lights
from nodegraph.types import Texture, TextureArray

from .._shared.pencil import ALBEDO_REF, GRAPHITE_COLOR, MAX_AMPLITUDE, PAPER_COLOR, Color, screen_bounds, view_light


class Contour(Node):
    """Draws the edge map several times, once through each distortion layer (a shaken attempt), with pencil tone:
    attempt k darkens by tone x pressure_k x edge x (1 - light_weight x l), where l = sqrt((N.L) x 0.5 + 0.5) is the
    light contribution of the surface under the pixel (as the report implementing Lee et al. computes it; off the
    surface, under the first attempt's edge sample), so lines in shadow are darker; with `albedo` connected the
    brightness is also scaled by the surface colour's lightness (`albedo_weight`), so lines over darker materials
    are darker. With a paper texture the
    darkness is modulated by the dot product of the grain normal and the stroke direction (across the projected
    normal). Attempts combine as value = prod_k (1 - darkness_k): where they overlap the line darkens. Per-attempt
    pressures are drawn from the node seed in [1 - pressure_jitter, 1], the same for the whole sequence by default
    (`hold: N`: new ones every N frames)."""

    version = "1"
    shaders = ("contour.glsl",)
    key_omits = frozenset({"hold"})  # covered by the held frame in the key
    inputs = {
        "edges": Input(Texture("R16F"), "Edge intensities, 1 = edge (edge_detect.out)."),
        "distortion": Input(TextureArray("RG16F"), "Offsets in pixels, one layer per attempt (distortion_map.out)."),
        "normal_depth": Input(Texture("RGBA16F"), "View-space normal and linear depth (rasterize.normal_depth)."),
        "paper": Input(Texture("RGBA16F"), "Paper grain normals (paper.out); no grain when not connected.",
                       optional=True),
        "albedo": Input(Texture("RGBA8"), "Surface colour (rasterize.color), the size of normal_depth: lines over "
                        "darker materials are darker (`albedo_weight`); the light alone when not connected.",
                        optional=True),
    }
    outputs = {
        "out": Output(Texture("R16F"), "Contour drawing as paper value: 1 = bare paper, 0 = black."),
        "color": Output(Texture("RGBA16F"), "The contours in graphite on paper (RGB), alpha 1."),
    }

    class Params(NodeParams):
        tone: float = Field(0.85, ge=0, le=1, description="Darkness of one full-pressure attempt over a full "
                            "edge in shadow (pencil tone).")
        light_weight: float = Field(0.45, ge=0, le=1, description="How much a fully lit surface lightens its "
                                    "contour (0: the light has no effect).")
        pressure_jitter: float = Field(0.35, ge=0, lt=1, description="Per-attempt pressure varies in "
                                       "[1 - pressure_jitter, 1].")
        grain: float = Field(0.3, ge=0, le=1, description="Paper grain: graphite darkness times 1 + 2.5 x grain x "
                           "(grain normal . stroke direction), clamped to [0, 2].")
        paper_tint: float = Field(0.05, ge=0, le=1, description="How much the paper relief shows on bare paper "
                                  "in `color`.")
        paper_color: Color = Field(PAPER_COLOR, description="Paper colour (RGB, 0..1).")
        graphite_color: Color = Field(GRAPHITE_COLOR, description="Colour of fully dark graphite (RGB, 0..1).")
        albedo_weight: float = Field(1.0, ge=0, le=4, description="With `albedo` connected: the light's brightness "
                                     "under a line is scaled by (L* / L*_ref) ^ albedo_weight, L* the surface "
                                     "colour's CIE lightness and L*_ref the default mesh colour's (81.8), as "
                                     "pencil_shade's tone; 0: the light alone.")
        hold: int = Field(0, ge=0, le=100_000, description="Frames per change of the per-attempt pressures: 0 "
                          "keeps them for the whole sequence, N draws new ones every N frames.")

    @property
    def context_keys(self) -> frozenset[str]:  # type: ignore[override]
        keys = {"size", "seed", "scene", "camera"}
        if self.params.hold != 0:
            keys.add("frame")
        return frozenset(keys)

    def pressures(self, seed: int, layers: int) -> np.ndarray:
        u = np.random.default_rng(seed).random(layers)
        return 1.0 - self.params.pressure_jitter * u

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        dist = inputs["distortion"]
        layers = dist.layers
        ports = [port for port in ("out", "color") if port in needed]
        paper = inputs.get("paper")
        albedo = inputs.get("albedo") if p.albedo_weight > 0 else None
        defines = {f"LOC_{port.upper()}": i for i, port in enumerate(ports)}
        defines.update(LAYERS=layers, PAPER=int(paper is not None), ALBEDO=int(albedo is not None))
        scene = ctx.scene
        punctual: dict[str, Any] = {}
        if scene is not None and scene.lights:  # punctual lights: sqrt(brightness) instead of the half-Lambert term
            nd_w, nd_h = inputs["normal_depth"].size
            punctual = {**lights.view_uniforms(scene.lights, ctx.camera.view_matrix(), scene.exposure),
                        "u_inv_proj": np.linalg.inv(ctx.camera.projection_matrix(nd_w / nd_h))}
            defines["LIGHTS"] = len(punctual["u_light_pos"])
        prog = ctx.program("contour.glsl", defines)
        size = inputs["edges"].size
        targets = {port: ctx.target(port, size) for port in ports}
        textures = {"t_edges": inputs["edges"], "t_distortion": dist, "t_normal_depth": inputs["normal_depth"]}
        if paper is not None:
            textures["t_paper"] = paper
        if albedo is not None:
            if albedo.size != inputs["normal_depth"].size:
                raise NodeError(f"contour: albedo is {albedo.size[0]}x{albedo.size[1]} but normal_depth is "
                                f"{inputs['normal_depth'].size[0]}x{inputs['normal_depth'].size[1]}: connect the "
                                "same rasterize's color")
            textures["t_albedo"] = albedo
        light = view_light(ctx.scene, ctx.camera) if ctx.scene is not None else np.array([0.0, 0.0, 1.0])
        uniforms = {"u_light": tuple(float(c) for c in light), "u_tone": p.tone, "u_light_weight": p.light_weight,
                    "u_grain": p.grain, "u_pressure": self.pressures(ctx.seed, layers).astype(np.float32),
                    "u_paper_color": p.paper_color, "u_graphite_color": p.graphite_color, "u_paper_tint": p.paper_tint,
                    **punctual, **({"u_albedo_ref": ALBEDO_REF, "u_albedo_weight": p.albedo_weight} if albedo is not
                                   None else {})}
        fbo = ctx.gl.framebuffer([targets[port] for port in ports])
        rect = self._rect(inputs["edges"], dist, size)
        if rect is not None and "color" not in targets:  # the value alone: 1 outside, a footprint
            ctx.gl.fullscreen(prog, [targets["out"]], textures=textures, uniforms=uniforms, rect=rect, blanks=[(1.0,)])
            return targets
        if rect is not None:
            # outside the edges' footprint grown by the largest shift the value is 1: only the paper is drawn
            # there (a cheap pass over the whole image), and the attempts inside the rectangle
            ctx.gl.fullscreen(ctx.program("contour.glsl", {**defines, "OUTSIDE": 1}),
                              [targets[port] for port in ports], textures={"t_paper": paper} if paper else {},
                              uniforms={**uniforms, "u_outside": 1.0}, fbo=fbo)
            fbo.scissor = rect
            try:
                ctx.gl.fullscreen(prog, [targets[port] for port in ports], textures=textures, uniforms=uniforms,
                                  fbo=fbo)
            finally:
                fbo.scissor = None
            return targets
        box = None
        if ctx.scene is not None and "color" not in targets:
            # edges lie on the objects and attempts are shifted by at most MAX_AMPLITUDE x height: only
            # pixels near the objects' projected boxes can be drawn on (the rest is bare paper, cleared)
            box = screen_bounds(ctx.scene, ctx.camera, size, int(np.ceil(MAX_AMPLITUDE * size[1])) + 2)
        if box is not None:
            fbo.clear(1.0, 1.0, 1.0, 1.0)
            fbo.scissor = box
        try:
            ctx.gl.fullscreen(prog, [targets[port] for port in ports], textures=textures, uniforms=uniforms, fbo=fbo)
        finally:
            fbo.scissor = None
        return targets

    @staticmethod
    def _rect(edges: Any, dist: Any, size: tuple[int, int]) -> tuple[int, int, int, int] | None:
        """Where an attempt can read an edge: the edges' footprint (blank 0) grown by the largest shift, each
        offset component at most MAX_AMPLITUDE x the distortion's height (distortion_map bounds its amplitude
        by it), plus the bilinear texel and a margin. None: unknown (no footprint), or the whole image."""
        fp = footprint.of(edges)
        if fp is None or fp.blank[0] != 0.0:
            return None
        reach = int(np.ceil(MAX_AMPLITUDE * max(size[1], dist.size[1]))) + 2
        rect = footprint.grow(fp.rect, reach, reach, size)
        return None if footprint.covers_image(rect, size) else rect


NODE = Contour
