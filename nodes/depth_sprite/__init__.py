"""depth_sprite: compose the sketch with ordinary geometry by its perturbed depth (paper §3.3)."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from nodegraph.node import Input, Node, NodeParams, Output
from nodegraph.types import Texture


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
    perturbed depth instead of the two lookups through `offsets`, which then only hold the first layer."""

    version = "2"
    shaders = ("depth_sprite.glsl",)
    inputs = {
        "color": Input(Texture("RGBA16F"), "The sketch (sketch.color)."),
        "offsets": Input(Texture("RGBA16F"), "Edge and shade shifts (sketch.offsets)."),
        "depth": Input(Texture("R32F"), "Window depth of the sketchy objects (rasterize.depth)."),
        "sketch_depth": Input(Texture("R32F"), "Perturbed depth over all edge layers and the shade map "
                              "(sketch.depth); replaces the lookups through `offsets`.", optional=True),
        "under_color": Input(Texture("RGBA8"), "Colour of ordinary geometry to compose with.", optional=True),
        "under_depth": Input(Texture("R32F"), "Window depth of that geometry (same camera).", optional=True),
    }
    outputs = {
        "color": Output(Texture("RGBA16F"), "The composed image."),
        "depth": Output(Texture("R32F"), "The composed window depth (1 = nothing drawn)."),
    }

    class Params(NodeParams):
        paper: tuple[float, float, float] = Field((0.98, 0.97, 0.94), description="Colour where nothing is drawn.")

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        gl = ctx.gl
        has_under = "under_color" in inputs and "under_depth" in inputs
        if ("under_color" in inputs) != ("under_depth" in inputs):
            raise ValueError(f"node '{self.id}': connect both under_color and under_depth, or neither")
        size = inputs["color"].size
        color = ctx.target("color", size)
        depth = ctx.target("depth", size, filter="nearest")
        rb = gl.resources.get(("depth_renderbuffer", size))
        if rb is None:
            rb = gl.resources[("depth_renderbuffer", size)] = gl.ctx.depth_renderbuffer(size)
        fbo = gl.framebuffer([color, depth], rb)
        mgl = gl.ctx
        textures = {"t_color": inputs["color"], "t_offsets": inputs["offsets"], "t_depth": inputs["depth"]}
        has_sketch_depth = "sketch_depth" in inputs
        if has_sketch_depth:
            textures["t_sketch_depth"] = inputs["sketch_depth"]
        if has_under:
            textures.update(t_under_color=inputs["under_color"], t_under_depth=inputs["under_depth"])
        uniforms = {"u_paper": tuple(self.params.paper), "u_has_under": float(has_under)}
        mgl.enable(mgl.DEPTH_TEST)
        try:
            if has_under:  # lay down the ordinary geometry's colour and depth
                mgl.depth_func = "1"
                gl.fullscreen(ctx.program("depth_sprite.glsl", {"PASS": 0}), [color, depth], textures, uniforms,
                              fbo=fbo)
            else:  # paper at the far plane: a clear is enough
                fbo.clear(*self.params.paper, 1.0, depth=1.0)
                gl.framebuffer([depth]).clear(1.0, 0.0, 0.0, 0.0)
            mgl.depth_func = "<"
            gl.fullscreen(ctx.program("depth_sprite.glsl", {"PASS": 1, "SKETCH_DEPTH": int(has_sketch_depth)}),
                          [color, depth], textures, uniforms, fbo=fbo)
        finally:
            mgl.depth_func = "<"
            mgl.disable(mgl.DEPTH_TEST)
        return {"color": color, "depth": depth}


NODE = DepthSprite
