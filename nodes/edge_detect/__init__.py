"""edge_detect: the edge map from normal and depth discontinuities (paper §3.1)."""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import Field

from nodegraph.gpu import footprint
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import Texture

_PORTS = {"out": "LOC_OUT", "profile": "LOC_PROFILE", "inner": "LOC_INNER"}


class EdgeDetect(Node):
    """Edge intensities (1 = edge) from a G-buffer. Profile edges come from depth discontinuities and
    the object/background boundary and are marked on the nearer side, one `width` thick; inner edges
    come from normal discontinuities (creases) and are marked on both sides of the crease.
    `width` is in pixels at the pipeline's reference size (docs/sizes.md): the stencil radius is
    width x px_scale, and a radius that is not whole blends the stencils at its floor and its ceiling by
    the fraction, so a line 2 px at the reference size is 1 px at half of it and a faint, half-intensity
    line of 1 px at a quarter of it, never nothing."""

    version = "2"
    shaders = ("edge_detect.glsl",)
    context_keys = frozenset({"size", "px_scale"})
    inputs = {
        "normal_depth": Input(Texture("RGBA32F"), "View-space normal (xyz) and linear view depth (w, 0 = "
                              "background): rasterize.normal_depth."),
    }
    outputs = {
        "out": Output(Texture("R16F"), "Edge intensity: max(profile * profile_intensity, inner * inner_intensity)."),
        "profile": Output(Texture("R16F"), "Profile (silhouette/depth) edges only."),
        "inner": Output(Texture("R16F"), "Inner (crease) edges only."),
    }

    class Params(NodeParams):
        operator: Literal["four_neighbour", "sobel"] = Field(
            "four_neighbour", description="four_neighbour: 4 neighbours, depth by second differences (no "
            "false edges on slanted planes); sobel: 3x3 Sobel of normal chords and relative depth (its first "
            "derivative marks planes seen at 85 degrees or more, e.g. a receding floor: see docs/stability.md).")
        mode: Literal["normal_depth", "normal", "depth"] = Field(
            "normal_depth", description="Which discontinuities make edges.")
        normal_threshold: float = Field(0.4, gt=0, le=2, description="Normal chord |n_a - n_b| above which an "
                                        "inner edge starts (0.4 ~ 23 degrees, 0.6 ~ 35 degrees).")
        depth_threshold: float = Field(0.03, gt=0, description="Relative depth discontinuity above which a "
                                       "profile edge starts.")
        width: float = Field(1, gt=0, le=8, allow_inf_nan=False, description="Stencil radius in pixels at the "
                             "reference size; lines are about this thick. Not whole: the two nearest whole "
                             "stencils blended.")
        profile_intensity: float = Field(1.0, ge=0, le=1, description="Intensity of profile edges in `out`.")
        inner_intensity: float = Field(1.0, ge=0, le=1, description="Intensity of inner edges in `out`.")

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        ports = [port for port in _PORTS if port in needed]
        defines = {_PORTS[port]: i for i, port in enumerate(ports)}
        defines.update(OPERATOR=0 if p.operator == "four_neighbour" else 1,
                       USE_NORMAL=int(p.mode in ("normal_depth", "normal")),
                       USE_DEPTH=int(p.mode in ("normal_depth", "depth")))
        radius, frac = self.radius(ctx.px_scale)
        # the stencil's whole radius and whether a second one is blended are compile-time constants: with
        # the radius a uniform, llvmpipe computes every fetch address at run time (8.3-8.5 against 11.2-11.4
        # ms for the pass on spot at 800², one run each way); one program per (radius, blended) in use
        defines.update(RADIUS=radius, BLEND=int(frac > 0.0))
        prog = ctx.program("edge_detect.glsl", defines)
        size = inputs["normal_depth"].size
        targets = {port: ctx.target(port, size) for port in ports}
        # a pixel whose own texel is background (w <= 0) marks nothing: outside the G-buffer's footprint every
        # output is 0, and the pass draws only inside it
        fp = footprint.of(inputs["normal_depth"])
        rect = fp.rect if fp is not None and len(fp.blank) == 4 and fp.blank[3] <= 0.0 else None
        ctx.gl.fullscreen(prog, [targets[port] for port in ports],
                          textures={"t_normal_depth": inputs["normal_depth"]},
                          uniforms={"u_normal_threshold": p.normal_threshold, "u_depth_threshold": p.depth_threshold,
                                    "u_profile_intensity": p.profile_intensity,
                                    "u_inner_intensity": p.inner_intensity,
                                    "u_frac": frac},
                          rect=rect, blanks=[(0.0,)] * len(ports))
        return targets

    def radius(self, px_scale: float) -> tuple[int, float]:
        """The stencil radius at this scale as (whole part, fraction): width x px_scale."""
        return split_width(self.params.width * px_scale)


def split_width(width: float) -> tuple[int, float]:
    """(whole part, fraction) of a width in pixels; a fraction within 1e-9 of a whole number snaps to it."""
    whole = math.floor(width + 1e-9)
    frac = width - whole
    return whole, (0.0 if frac < 1e-9 else float(frac))


NODE = EdgeDetect
