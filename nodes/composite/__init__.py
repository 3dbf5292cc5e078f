"""composite: lay an image or an ink mask over (or multiply it onto) a colour image."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from nodegraph.errors import NodeError
from nodegraph.gpu import footprint
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import Texture

from .._shared.params import Color


class Composite(Node):
    """Plain compositing of one layer onto `base`, pixel by pixel (all inputs the same size). The layer's
    colour is `top`'s RGB, or the `color` param when `top` is not connected; its alpha is `mask`'s red
    channel when connected (an ink coverage such as particle_sketch.ink), else `top`'s alpha; both times
    `opacity`. `over`: rgb = mix(base, layer, a), alpha = a + base alpha (1 - a) (straight alpha).
    `multiply`: rgb = base x mix(1, layer, a), alpha = base alpha (dark ink darkens, white leaves the base
    unchanged)."""

    version = "1"
    shaders = ("composite.glsl",)
    inputs = {
        "base": Input(Texture("RGBA8"), "The image underneath (e.g. sketch.color)."),
        "top": Input(Texture("RGBA8"), "The layer's colour and, without `mask`, its alpha.", optional=True),
        "mask": Input(Texture("R8"), "The layer's alpha (e.g. particle_sketch.ink).", optional=True),
    }
    outputs = {"color": Output(Texture("RGBA8"), "The composite.")}

    class Params(NodeParams):
        mode: Literal["over", "multiply"] = Field("over", description="over: the layer covers the base by its "
                                                  "alpha; multiply: the layer darkens the base.")
        color: Color = Field((0.1, 0.1, 0.12), description="Layer colour when `top` is not connected (RGB, 0..1).")
        opacity: float = Field(1.0, ge=0, le=1, description="Multiplies the layer's alpha.")

    @classmethod
    def check_connections(cls, connected: set[str]) -> str | None:
        if not connected & {"top", "mask"}:
            return "connect `top` (an RGBA layer), `mask` (an alpha such as particle_sketch.ink), or both"
        return None

    def check_size(self, size: tuple[int, int], inputs: dict[str, tuple[int, int, int] | None]) -> str | None:
        base = inputs.get("base")  # sizes that follow the image or an input are checked in compute
        for name in ("top", "mask"):
            shape = inputs.get(name)
            if base is not None and shape is not None and shape[:2] != base[:2]:
                return (f"input '{name}' is {shape[0]}x{shape[1]}, 'base' is {base[0]}x{base[1]}; composite needs "
                        "equal sizes")
        return None

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        base = inputs["base"]
        for name in ("top", "mask"):
            if name in inputs and inputs[name].size != base.size:
                raise NodeError(f"input '{name}' is {inputs[name].size[0]}x{inputs[name].size[1]}, 'base' is "
                                f"{base.size[0]}x{base.size[1]}; composite needs equal sizes", self.id, self.type_name)
        defines = {"MODE": int(p.mode == "multiply"), "HAS_TOP": int("top" in inputs),
                   "HAS_MASK": int("mask" in inputs)}
        prog = ctx.program("composite.glsl", defines)
        names = [name for name in ("base", "top", "mask") if name in inputs]
        uniforms = {"u_color": tuple(p.color), "u_opacity": p.opacity}

        def draw(textures: list[Any], rect: Any = None, blanks: Any = None) -> Any:
            out = ctx.target("color", textures[0].size)  # 1x1 for `footprint.blank_results`
            ctx.gl.fullscreen(prog, [out], textures={f"t_{n}": t for n, t in zip(names, textures, strict=True)},
                              uniforms=uniforms, rect=rect, blanks=blanks)
            return out

        fps = [footprint.of(inputs[name]) for name in names]
        if all(fp is not None for fp in fps):
            # per pixel, so outside the union of the inputs' footprints every pixel is the composite of their
            # blank values: asked of the pass itself on 1x1 blank inputs
            rect = footprint.union(fp.rect for fp in fps)  # type: ignore[union-attr]
            if not footprint.covers_image(rect, base.size):
                sources = [(inputs[n].fmt, fp.blank) for n, fp in zip(names, fps, strict=True)]  # type: ignore[union-attr]
                key = ("composite", p.model_dump_json(), tuple(sorted(defines.items())), ctx.format("color"),
                       tuple(sources))
                blanks = footprint.blank_results(ctx.gl, key, sources, lambda src: [draw(src)])
                if blanks is not None:
                    return {"color": draw([inputs[n] for n in names], rect, blanks)}
        return {"color": draw([inputs[n] for n in names])}


NODE = Composite
