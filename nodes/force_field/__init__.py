"""force_field: Curtis' force field ff = ff1 - ff2 from the depth gradient (Curtis, "Loose and Sketchy
Animation", 1998)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from nodegraph.gpu import footprint
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import Texture

from .._shared import scaled_kernels as kernels


class ForceField(Node):
    """The field that steers the particles of `particle_sketch`, from depth_edges.gradient, Curtis' Sobel
    pair g = (gx, gy) of the blurred depth: ff1 = g rotated by 90 degrees, (-gy, gx); ff2 = the Sobel pair
    of the magnitude image min(|g|, clamp) blurred by a 9x9 tent ([1 2 3 4 5 4 3 2 1] outer itself, / 625),
    rotated by 90 degrees; ff = ff1 - ff2. Borders clamp to the edge pixel.

    Both parts are rotated gradients, so ff runs along the edges (clockwise around a near object on a far
    background) and nothing in it points towards an edge: Curtis' prose says ff2 "forces the particle
    back onto the edge", its pseudocode computes a shear. `restoring: gradient` is the prose's reading
    (ff2 unrotated: a pull up the blurred magnitude, onto the edge); docs/particles.md measures both and
    explains why the default stays the pseudocode's.

    `saturate` s > 0 divides ff by max(|ff|, s): the streamlines stay, the speed is capped at 1, so a faint
    inner edge and a strong silhouette are drawn at the same pace (with the raw field a silhouette runs
    ten times faster than an inner edge and no single time step suits both). Set it to the edge threshold
    of depth_edges; 0 gives Curtis' raw field.

    The 9x9 tent and the Sobel pair have their footprint in pixels at the pipeline's reference size
    (docs/sizes.md): at px_scale s the tent's half-width is 5 s px and the difference reads the blur at
    +-s px, linearly interpolated (../_shared/scaled_kernels.py), so ff2 has the same shape in the picture at
    every size and is, like depth_edges' scaled gradient, per reference pixel (particle_sketch multiplies
    the field by s). At the reference size (and for a node run on its own image) it is Curtis'."""

    version = "2"
    shaders = ("force_field.glsl",)
    context_keys = frozenset({"size", "px_scale"})
    inputs = {
        "gradient": Input(Texture("RG32F"), "Curtis' Sobel pair (gx, gy) of the blurred depth: "
                          "depth_edges.gradient."),
    }
    outputs = {
        "out": Output(Texture("RG32F"), "The force field (ffx, ffy), x right, y up, in pixels."),
    }

    class Params(NodeParams):
        clamp: float = Field(1.0, gt=0, description="Magnitude clamp before the 9x9 blur: Curtis' 255 for "
                             "8-bit depth, on depth in [0, 1].")
        saturate: float = Field(0.03, ge=0, description="Divide ff by max(|ff|, saturate): same directions, speed "
                                "at most 1 (use depth_edges.threshold); 0 = Curtis' raw field.")
        restoring: Literal["rotated", "gradient"] = Field(
            "rotated", description="ff2 as Curtis' pseudocode computes it (rotated by 90 degrees: a shear "
            "along the edge) or as its prose describes it (gradient: unrotated, pulls particles onto the edge; "
            "furry lines, see docs/particles.md).")

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        grad = inputs["gradient"]
        size = grad.size
        k = kernels.kernels(5.0, ctx.px_scale)
        fp = footprint.of(grad)
        rects = blanks = None
        if fp is not None:
            # outside the gradient's footprint grown by the window (along x for the x pass, then along y) every
            # fetch reads the blank gradient: the field there is what the passes give on a constant
            rects = kernels.pass_rects(fp.rect, k, size)
            key = ("force_field", self.params.model_dump_json(), grad.fmt, fp.blank, ctx.px_scale, kernels.split(k))
            blanks = footprint.blank_results(ctx.gl, key, [(grad.fmt, fp.blank)],
                                             lambda src: self._draw(ctx, src[0], k, keep_across=True))
            if blanks is None:
                rects = None
        return {"out": self._draw(ctx, grad, k, rects, blanks)[-1]}

    def _draw(self, ctx: RunContext, grad: Any, k: kernels.Kernels, rects: tuple[Any, ...] | None = None,
              blanks: list[tuple[float, ...]] | None = None, keep_across: bool = False) -> list[Any]:
        """The passes over `grad` (the image's, or a 1x1 one for `footprint.blank_results`): the x pass and the y
        pass, or the four split ones for wide kernels (`kernels.draw`). `rects`/`blanks`: where each pass draws and
        the values outside. Returns [field], or with `keep_across` the intermediate textures first."""
        p = self.params
        out = ctx.target("out", grad.size)
        return kernels.draw(ctx, "force_field.glsl", k, grad.size, ({}, {"t_gradient": grad}, {"u_clamp": p.clamp}),
                            ({"RESTORING": int(p.restoring == "gradient")}, {"t_gradient": grad},
                             {"u_saturate": p.saturate}, [out]), rects, blanks, keep=keep_across)


NODE = ForceField
