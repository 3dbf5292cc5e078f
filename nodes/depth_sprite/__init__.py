"""depth_sprite: compose the sketch with ordinary geometry by its perturbed depth (paper §3.3)."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from nodegraph.gpu import footprint
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import Texture

from .._shared.params import Color


class DepthSprite(Node):
    """Draws the sketch as a depth sprite over `under_color`/`under_depth` (ordinary, non-sketchy
    geometry rendered with the same camera) or over paper. The sprite's depth at each pixel is the
    minimum of the depth map read at the edge-shifted and the shade-shifted coordinates (`offsets` from
    the sketch node), so everything the sketch draws beyond the object's boundary gets the depth of the
    surface it came from; the ordinary depth test then gives correct occlusion both ways. Pixels whose
    perturbed depth is the far plane are rejected early. Depth is read with nearest filtering so no
    depth is invented across silhouettes (our choice; the paper does not say).

    Repeated edges (paper §3.4) need the depth map read once per edge layer: connect `sketch_depth`
    (sketch.depth, the minimum over every layer's and the shade map's lookup) and it is used as the
    perturbed depth instead of the two lookups through `offsets`, which then only hold the first layer.
    With `sketch_depth` connected and nothing under the sprite, the node does no GPU work: over paper the
    depth test passes exactly where the perturbed depth is below the far plane, where the sketch already
    holds its colour (paper elsewhere), so colour and depth pass through; the sketch pass is then the
    paper's single final pass (§3.5)."""

    version = "4"
    shaders = ("depth_sprite.glsl",)
    inputs = {
        "color": Input(Texture("RGBA8"), "The sketch (sketch.color); 8 bits per channel are enough for a "
                                         "display colour, so the engine allocates the sketch that way."),
        "offsets": Input(Texture("RGBA16F"), "Edge and shade shifts (sketch.offsets); needed when "
                         "`sketch_depth` is not connected.", optional=True),
        "depth": Input(Texture("R32F"), "Window depth of the sketchy objects (rasterize.depth), read through "
                       "`offsets`; not needed with `sketch_depth`.", optional=True),
        "sketch_depth": Input(Texture("R32F"), "Perturbed depth over all edge layers and the shade map "
                              "(sketch.depth); replaces the lookups through `offsets`.", optional=True),
        "under_color": Input(Texture("RGBA8"), "Colour of ordinary geometry to compose with.", optional=True),
        "under_depth": Input(Texture("R32F"), "Window depth of that geometry (same camera).", optional=True),
    }
    outputs = {
        "color": Output(Texture("RGBA8"), "The composed image (display colour, like its inputs)."),
        "depth": Output(Texture("R32F"), "The composed window depth (1 = nothing drawn)."),
    }

    class Params(NodeParams):
        paper: Color = Field((0.98, 0.97, 0.94), description="Colour where nothing is drawn.")

    def check_connections(self, connected: set[str]) -> str | None:
        if ("under_color" in connected) != ("under_depth" in connected):
            return "connect both under_color and under_depth, or neither"
        if "sketch_depth" not in connected and not {"offsets", "depth"} <= connected:
            return ("connect sketch_depth (sketch.depth), or offsets (sketch.offsets) and depth (rasterize.depth), "
                    "to give the sprite its depth")
        return None

    def passthrough(self, connected: set[str]) -> dict[str, str]:
        # Over paper the depth test passes wherever the sprite's depth is below the far plane, and the
        # sketch (with its `depth` connected) is paper wherever it is not: the sprite is the sketch.
        if "sketch_depth" in connected and "under_color" not in connected:
            return {"color": "color", "depth": "sketch_depth"}
        return {}

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        gl = ctx.gl
        has_under = "under_color" in inputs and "under_depth" in inputs
        size = inputs["color"].size
        color = ctx.target("color", size)
        depth = ctx.target("depth", size, filter="nearest")
        rb = gl.depth_buffer(size)
        fbo = gl.framebuffer([color, depth], rb)
        textures = {f"t_{port}": inputs[port] for port in ("color", "offsets", "depth") if port in inputs}
        has_sketch_depth = "sketch_depth" in inputs
        if has_sketch_depth:
            textures["t_sketch_depth"] = inputs["sketch_depth"]
        if has_under:
            textures.update(t_under_color=inputs["under_color"], t_under_depth=inputs["under_depth"])
        uniforms = {"u_paper": tuple(self.params.paper), "u_has_under": float(has_under)}
        sprite_defines = {"PASS": 1, "SKETCH_DEPTH": int(has_sketch_depth)}
        if not has_under:
            # Over paper at the far plane the depth test always passes where the sprite has depth < 1:
            # one plain pass gives the same pixels, with no depth buffer, clear or fragment-depth write.
            gl.fullscreen(ctx.program("depth_sprite.glsl", {**sprite_defines, "OVER_PAPER": 1}), [color, depth],
                          textures, uniforms)
            return {"color": color, "depth": depth}
        # the sprite's depth is the far plane outside its footprint, where "<" passes nowhere: the sprite pass
        # draws inside it only (the same pixels)
        fp = footprint.of(inputs.get("sketch_depth"))
        sprite_rect = fp.rect if fp is not None and fp.blank[0] >= 1.0 else None
        with gl.depth_test("1") as state:  # first lay down the ordinary geometry's colour and depth
            gl.fullscreen(ctx.program("depth_sprite.glsl", {"PASS": 0}), [color, depth], textures, uniforms,
                          fbo=fbo)
            state.depth_func("<")
            fbo.scissor = sprite_rect
            try:
                gl.fullscreen(ctx.program("depth_sprite.glsl", sprite_defines), [color, depth], textures, uniforms,
                              fbo=fbo)
            finally:
                fbo.scissor = None  # framebuffers are shared: leave it as the others expect
        return {"color": color, "depth": depth}


NODE = DepthSprite
