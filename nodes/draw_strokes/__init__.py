"""draw_strokes: Strokes drawn on the GPU as textured quads (pencil, ink, chalk), over paper or transparent."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from nodegraph.gpu.gl import bind
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import STROKES, Texture

from .._shared.params import Color
from .._shared.pencil import GRAPHITE_COLOR, PAPER_COLOR
from . import quads

BRUSH_COLORS: dict[str, Color] = {"pencil": GRAPHITE_COLOR, "ink": (0.04, 0.04, 0.05), "chalk": (0.22, 0.21, 0.2)}
BRUSH_SOFT = {"pencil": 1.0, "ink": 1.0, "chalk": 1.5}  # edge ramp in pixels
BRUSH_REPEAT = {"pencil": 8.0, "ink": 1.0, "chalk": 8.0}  # brush texture length in stroke widths


class DrawStrokes(Node):
    """Draws each stroke as a strip of quads around its polyline (nodes/draw_strokes/quads.py): two vertices a
    point, offset half the width plus an edge margin along the mitred normal (the mitre limited to 4 half-widths),
    and a quad past each end that the fragment shader rounds off (round caps; a one-point stroke is a dot).
    A fragment's darkness is coverage x tone x opacity x brush: coverage falls linearly from 1 to 0 over
    `soft` pixels centred on the stroke's edge (so a straight stroke's coverage across it sums to its width);
    the brush texture (made in code) is read at u = arc length / (width x repeat) along the stroke and v across
    it: ink solid, pencil graphite streaks and grain, chalk broken. Widths are the strokes' per-vertex `width`
    (the strokes' `width` where NaN) times `width_scale`; a width under one pixel is drawn one pixel wide at that
    fraction of its darkness. Overlaps: ink keeps the darker value, pencil and chalk lay one over the other
    ("over": crossings darken). With `paper` the paper's grain (grain normal . stroke direction, as the pencil
    nodes) modulates pencil and chalk, and `color` is the strokes over the paper colour, alpha 1; without it,
    the brush colour with the darkness as alpha (straight). Only visible strokes are drawn unless `hidden`."""

    version = "1"
    shaders = ("draw_strokes.glsl",)
    context_keys = frozenset({"size"})
    inputs = {
        "strokes": Input(STROKES, "Polylines in pixels, y up (mesh_lines.strokes, stroke_hatching.strokes)."),
        "paper": Input(Texture("RGBA16F"), "Paper grain normals (paper.out): strokes drawn over paper; transparent "
                       "when not connected.", optional=True),
    }
    outputs = {"color": Output(Texture("RGBA16F"), "The strokes over paper (alpha 1), or their colour with the "
                                                   "darkness as alpha.")}

    class Params(NodeParams):
        brush: Literal["pencil", "ink", "chalk"] = Field("pencil", description="Brush texture and overlap rule.")
        color: Color | None = Field(None, description="Stroke colour (RGB, 0..1); default: the brush's (pencil "
                                    "graphite, near-black ink, grey chalk).")
        width_scale: float = Field(1.0, gt=0, le=64, description="Stroke widths times this.")
        opacity: float = Field(1.0, ge=0, le=1, description="Darkness of a full-tone stroke.")
        soft: float | None = Field(None, gt=0, le=16, description="Edge ramp in pixels (default: the brush's, 1 "
                                   "or 1.5).")
        grain: float = Field(0.15, ge=0, le=1, description="With paper, pencil and chalk: darkness times 1 + 2.5 x "
                             "grain x (grain normal . stroke direction), clamped to [0, 2].")
        hidden: bool = Field(False, description="Draw hidden strokes too.")
        paper_color: Color = Field(PAPER_COLOR, description="Paper colour (RGB, 0..1) with `paper`.")
        paper_tint: float = Field(0.05, ge=0, le=1, description="How much the paper relief shows on bare paper.")

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        gl = ctx.gl
        strokes = inputs["strokes"]
        paper = inputs.get("paper")
        size = strokes.size if strokes.size[0] > 0 and strokes.size[1] > 0 else ctx.size
        w, h = size
        if not p.hidden and len(strokes):
            strokes = strokes.subset(strokes.stroke_attr("visible"))
        soft = p.soft if p.soft is not None else BRUSH_SOFT[p.brush]
        width = np.where(np.isnan(strokes["width"]), strokes.width, strokes["width"]).astype(np.float64) \
            * p.width_scale
        alpha = np.clip(strokes["tone"].astype(np.float64), 0.0, 1.0) * p.opacity * np.minimum(width, 1.0)
        verts, tris = quads.expand(strokes.xy, strokes.starts, 0.5 * np.maximum(width, 1.0), alpha, soft)
        dark = gl.texture((w, h), "R16F", filter="nearest")
        try:
            fbo = gl.framebuffer([dark])
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            if len(tris):
                _draw(ctx, fbo, (w, h), verts, tris, paper, p.brush, soft, p.grain)
            color = ctx.target("color", (w, h))
            textures: dict[str, Any] = {"t_dark": dark}
            if paper is not None:
                textures["t_paper"] = paper
            rgb = p.color if p.color is not None else BRUSH_COLORS[p.brush]
            gl.fullscreen(ctx.program("draw_strokes.glsl", {"STROKES": 0, "PAPER": int(paper is not None)}),
                          [color], textures=textures,
                          uniforms={"u_color": tuple(rgb), "u_paper_color": tuple(p.paper_color),
                                    "u_paper_tint": p.paper_tint})
        finally:
            gl.release(dark)
        return {"color": color}


_BRUSHES: dict[str, np.ndarray] = {}


def _draw(ctx: RunContext, fbo: Any, size: tuple[int, int], verts: np.ndarray, tris: np.ndarray, paper: Any,
          brush: str, soft: float, grain: float) -> None:
    import moderngl

    gl = ctx.gl
    prog = ctx.program("draw_strokes.glsl", {"STROKES": 1, "PAPER": int(paper is not None and brush != "ink")})
    if brush not in _BRUSHES:
        _BRUSHES[brush] = quads.brush_texture(brush)
    tex = gl.ctx.texture((quads.BRUSH_SIZE[0], quads.BRUSH_SIZE[1]), 1, _BRUSHES[brush].tobytes(), dtype="f4")
    tex.repeat_x, tex.repeat_y = True, False
    vbo = gl.ctx.buffer(np.ascontiguousarray(verts, np.float32).tobytes())
    ibo = gl.ctx.buffer(np.ascontiguousarray(tris, np.uint32).tobytes())
    vao = gl.ctx.vertex_array(prog, [(vbo, "2f 4f 3f", "in_pos", "in_frame", "in_dir")], index_buffer=ibo,
                              index_element_size=4)
    mgl = gl.ctx
    try:
        fbo.use()
        mgl.viewport = (0, 0, size[0], size[1])
        textures: dict[str, Any] = {"t_brush": tex}
        if paper is not None and brush != "ink":
            textures["t_paper"] = paper
        bind(prog, textures, {"u_viewport": (float(size[0]), float(size[1])), "u_soft": float(soft),
                              "u_repeat": BRUSH_REPEAT[brush], "u_grain": float(grain)})
        mgl.enable(moderngl.BLEND)
        if brush == "ink":
            mgl.blend_equation = moderngl.MAX
            mgl.blend_func = moderngl.ONE, moderngl.ONE
        else:  # darkness "over": d = s + d (1 - s)
            mgl.blend_equation = moderngl.FUNC_ADD
            mgl.blend_func = moderngl.ONE, moderngl.ONE_MINUS_SRC_COLOR
        vao.render(mgl.TRIANGLES)
    finally:
        mgl.disable(moderngl.BLEND)
        mgl.blend_equation = moderngl.FUNC_ADD
        mgl.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        vao.release()
        vbo.release()
        ibo.release()
        tex.release()


NODE = DrawStrokes
