"""posterize: each channel of an RGBA texture to `levels` evenly spaced values (an example plugin)."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import Texture

__all__ = ["Posterize", "register"]


class Posterize(Node):
    """Quantises each colour channel to `levels` evenly spaced values in [0, 1]:
    q(c) = min(floor(clamp(c, 0, 1) * levels), levels - 1) / (levels - 1), so the input range is cut into
    `levels` equal bands and each band maps to one output value (2 levels: below 0.5 -> 0, else 1).
    Alpha passes unchanged unless `alpha` is set. The output has the input's size."""

    version = "1"  # bump when compute() or the meaning of a param changes
    shaders = ("posterize.glsl",)
    context_keys = frozenset()  # reads no size, frame, seed, scene or camera: the input's key covers it
    inputs = {"color": Input(Texture("RGBA8"), "The image to posterize (any RGBA texture, e.g. rasterize.color).")}
    outputs = {"color": Output(Texture("RGBA16F"), "The posterized image, the input's size.")}

    class Params(NodeParams):
        levels: int = Field(4, ge=2, le=256, description="Output values per channel, evenly spaced from 0 to 1.")
        alpha: bool = Field(False, description="Posterize alpha too (otherwise alpha passes unchanged).")

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        src = inputs["color"]
        out = ctx.target("color", src.size)
        prog = ctx.program("posterize.glsl", {"POSTERIZE_ALPHA": self.params.alpha})
        ctx.gl.fullscreen(prog, [out], textures={"t_color": src}, uniforms={"u_levels": self.params.levels})
        return {"color": out}


def register(registry: Any) -> None:
    """The `nodegraph.nodes` entry point: called once with the registry."""
    registry.add(Posterize, "posterize")
