"""rasterize: the G-buffer of the scene (Nienhaus & Döllner 2004, §3.1 and §4.2)."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from nodegraph.node import Input, Node, NodeParams, Output
from nodegraph.types import SCENE, Texture

# output port -> (clear value, shader define)
_OUTPUTS = {
    "color": ((0.0, 0.0, 0.0, 0.0), "LOC_COLOR"),
    "normal": ((0.0, 0.0, 0.0, 0.0), "LOC_NORMAL"),
    "normal_depth": ((0.0, 0.0, 0.0, 0.0), "LOC_NORMAL_DEPTH"),
    "depth": ((1.0, 0.0, 0.0, 0.0), "LOC_DEPTH"),
    "linear_depth": ((0.0, 0.0, 0.0, 0.0), "LOC_LINEAR_DEPTH"),
    "position": ((0.0, 0.0, 0.0, 0.0), "LOC_POSITION"),
    "object_id": ((0.0, 0.0, 0.0, 0.0), "LOC_OBJECT_ID"),
}


class Rasterize(Node):
    """Renders the scene's objects into a G-buffer: unlit colour (the shade map), view-space normals,
    window depth, linear view depth, object-space positions and object ids. Only the outputs the plan
    needs are written. Objects can be enlarged along their welded vertex normals (paper §4.2)."""

    version = "1"
    shaders = ("rasterize.glsl",)
    context_keys = frozenset({"size", "frame", "scene", "camera"})
    persist = "auto"
    inputs = {"scene": Input(SCENE, "Scene to draw; the pipeline's scene when not connected.", optional=True)}
    outputs = {
        "color": Output(Texture("RGBA8"), "Flat colour of each object (lit when `lit`), alpha = coverage."),
        "normal": Output(Texture("RGBA16F"), "View-space unit normal, alpha = coverage."),
        "normal_depth": Output(Texture("RGBA32F"), "View-space normal in xyz and linear view depth in w "
                               "(0 = background): one fetch per neighbour for edge detection."),
        "depth": Output(Texture("R32F"), "Window-space depth in [0, 1]; 1 = background (far plane)."),
        "linear_depth": Output(Texture("R32F"), "Distance along the view axis in scene units; 0 = background."),
        "position": Output(Texture("RGBA32F"), "Object-space position g(s,t) (paper §4.3), alpha = coverage."),
        "object_id": Output(Texture("R32F"), "Index of the object + 1; 0 = background."),
    }

    class Params(NodeParams):
        select: Literal["all", "sketchy", "non_sketchy"] = Field(
            "all", description="Which objects to draw, by their scene `sketchy` flag.")
        lit: bool = Field(False, description="Shade the colour with the scene light (for ordinary, non-sketchy "
                                             "geometry); unlit flat colour otherwise (the paper's shade map).")
        ambient: float = Field(0.45, ge=0, le=1, description="Ambient share of the lit colour.")
        enlarge: float = Field(0.0, ge=0, le=0.5, description="Shift every vertex along its welded vertex normal "
                               "by this fraction of the object's bounding-box diagonal (paper §4.2).")
        crease_angle: float = Field(40.0, ge=0, le=180, description="Dihedral angle in degrees above which "
                                    "normals are split (sharp creases), below which they are smoothed.")
        cull_backfaces: bool = Field(False, description="Skip back faces (faster; wrong for open meshes).")

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        gl = ctx.gl
        scene = inputs.get("scene") or ctx.scene
        ports = [p for p in _OUTPUTS if p in needed]
        defines: dict[str, Any] = {_OUTPUTS[p][1]: i for i, p in enumerate(ports)}
        defines["LIT"] = int(self.params.lit)
        prog = ctx.program("rasterize.glsl", defines)
        targets = {p: ctx.target(p, filter="nearest" if p == "object_id" else "linear") for p in ports}
        w, h = ctx.size
        depth_rb = _depth_buffer(gl, (w, h))
        fbo = gl.framebuffer([targets[p] for p in ports], depth_rb)
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        for p in ports:  # buffers whose background is not zero get their own clear
            if any(_OUTPUTS[p][0]):
                gl.framebuffer([targets[p]]).clear(*_OUTPUTS[p][0])
        fbo.use()
        gl.ctx.viewport = (0, 0, w, h)
        mgl = gl.ctx
        mgl.enable(mgl.DEPTH_TEST)
        if self.params.cull_backfaces:
            mgl.enable(mgl.CULL_FACE)
        else:
            mgl.disable(mgl.CULL_FACE)
        cam = scene.camera_at(ctx.frame)
        view = cam.view_matrix()
        proj = cam.projection_matrix(w / h)
        light = np.asarray(scene.light_direction, dtype=np.float64)
        if scene.light_space == "world":
            light = view[:3, :3] @ light
        light = light / max(np.linalg.norm(light), 1e-12)
        try:
            for index, obj in enumerate(scene.objects):
                if self.params.select == "sketchy" and not obj.sketchy:
                    continue
                if self.params.select == "non_sketchy" and obj.sketchy:
                    continue
                vao, diag = _geometry(gl, prog, obj.mesh, self.params.crease_angle)
                model = np.asarray(obj.transform, dtype=np.float64)
                mv = view @ model
                normal_view = np.linalg.inv(mv[:3, :3]).T
                _set(prog, "u_model", model)
                _set(prog, "u_view", view)
                _set(prog, "u_proj", proj)
                _set(prog, "u_normal_view", normal_view)
                _set(prog, "u_enlarge", float(self.params.enlarge * diag))
                _set(prog, "u_color", tuple(float(c) for c in obj.color))
                _set(prog, "u_light", tuple(float(c) for c in light))
                _set(prog, "u_object_id", float(index + 1))
                _set(prog, "u_ambient", float(self.params.ambient))
                vao.render(mgl.TRIANGLES)
        finally:
            mgl.disable(mgl.DEPTH_TEST)
            mgl.disable(mgl.CULL_FACE)
        return targets


def _set(prog: Any, name: str, value: Any) -> None:
    if name not in prog:
        return
    if isinstance(value, np.ndarray):
        prog[name].write(np.ascontiguousarray(value.T, dtype=np.float32).tobytes())  # column-major
    else:
        prog[name].value = value


def _depth_buffer(gl: Any, size: tuple[int, int]) -> Any:
    key = ("depth_renderbuffer", size)
    rb = gl.resources.get(key)
    if rb is None:
        rb = gl.ctx.depth_renderbuffer(size)
        gl.resources[key] = rb
    return rb


def _geometry(gl: Any, prog: Any, mesh: Any, crease_angle: float) -> tuple[Any, float]:
    """Vertex buffers per (mesh content, crease angle), kept for the life of the GL context."""
    key = ("mesh", mesh.content_hash(), float(crease_angle))
    entry = gl.resources.get(key)
    if entry is None:
        ra = mesh.render_arrays(crease_angle)
        ctx = gl.ctx
        bufs = {
            "in_pos": ctx.buffer(np.ascontiguousarray(ra.positions, dtype=np.float32).tobytes()),
            "in_normal": ctx.buffer(np.ascontiguousarray(ra.normals, dtype=np.float32).tobytes()),
            "in_smooth": ctx.buffer(np.ascontiguousarray(ra.smooth_normals, dtype=np.float32).tobytes()),
        }
        ibo = ctx.buffer(np.ascontiguousarray(ra.indices, dtype=np.uint32).tobytes())
        bmin, bmax = mesh.bounds()
        diag = float(np.linalg.norm(np.asarray(bmax) - np.asarray(bmin)))
        entry = {"bufs": bufs, "ibo": ibo, "vaos": {}, "diag": diag}
        gl.resources[key] = entry
    vao = entry["vaos"].get(id(prog))
    if vao is None:
        content = [(buf, "3f", name) for name, buf in entry["bufs"].items() if name in prog]
        vao = gl.ctx.vertex_array(prog, content, index_buffer=entry["ibo"], index_element_size=4)
        entry["vaos"][id(prog)] = vao
    return vao, entry["diag"]


NODE = Rasterize
