"""pencil_shade: curvature-oriented, 3-way blended pencil hatching (Lee et al. 2006, §3.2.1.3 and §4.2.2)."""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from nodegraph import origin
from nodegraph.errors import NodeError
from nodegraph.gl import MeshArrays, bind
from nodegraph.node import HashContext, Input, Node, NodeParams, Output, RunContext
from nodegraph.types import ARRAYS, SCENE, Texture, TextureArray

from .._shared.curvature import DirectionSource, object_field
from .._shared.pencil import GRAPHITE_COLOR, PAPER_COLOR, Color, view_light
from . import reference

_GEOMETRY_PORTS = {"shade": "LOC_SHADE", "blend": "LOC_BLEND"}


class PencilShade(Node):
    """Shades the scene's objects with the tonal art map. Brightness b = max(N.L, 0) from the scene light;
    the tone index is max_darkness x (tones - 1) x (1 - sqrt(b x light_intensity)), continuous (the two
    nearest tones are blended; they are nested, so without seams). Hatching is sampled in screen space in a
    frame rotated to each vertex's projected minimum-curvature direction (curvature node); a fragment
    blends the three frames of its triangle's vertices by its barycentric weights (3-way blending), which
    sum to 1, so where the three directions agree it is one rotated texture. Where a direction is
    unreliable (the curvature node's fixed-frame fallback, or seen nearly end-on) it turns towards
    `fallback_angle` on screen. Up to `layers` hatching layers are drawn, lighter first: layer k starts at
    darkness k x layer_offset, is turned by its layer angle and multiplies the result, so crossings
    darken. Graphite is modulated by the paper grain: the dot product of the grain normal and the stroke
    direction. `color` adds the contours (multiplied) and the paper colour; `shade` is the hatching value
    alone; `blend` holds the weights (rgb) and the tone index (a; -1 off the objects)."""

    version = "1"
    shaders = ("pencil_shade.glsl", "composite.glsl")
    context_keys = frozenset({"size", "frame", "scene", "camera", "px_scale"})
    inputs = {
        "tam": Input(TextureArray("R8"), "Tonal art map, layer 0 lightest (hatching_synthesis.tones)."),
        "curvature": Input(ARRAYS, "Per-object curvature arrays (curvature.out) of the same scene."),
        "paper": Input(Texture("RGBA16F"), "Paper grain normals (paper.out); no grain when not connected.",
                       optional=True),
        "contour": Input(Texture("R16F"), "Contour drawing, 1 = paper (contour.out), multiplied into `color`.",
                         optional=True),
        "scene": Input(SCENE, "Scene to draw; the pipeline's scene when not connected.", optional=True),
    }
    outputs = {
        "color": Output(Texture("RGBA16F"), "The pencil drawing: graphite on paper, alpha 1."),
        "shade": Output(Texture("R16F"), "Hatching value alone: 1 = bare paper, 0 = black."),
        "blend": Output(Texture("RGBA16F"), "3-way blending weights (rgb) and tone index (a), -1 off the objects."),
    }

    class Params(NodeParams):
        light_intensity: float = Field(1.0, gt=0, le=8, description="Light intensity; brightness is "
                                       "sqrt(clamp(N.L x intensity, 0, 1)).")
        max_darkness: float = Field(0.6, gt=0, le=1, description="Darkest tone a layer uses, as a fraction of "
                                    "the tonal art map's range (the report's maxDarkness / 32).")
        layers: int = Field(2, ge=1, le=3, description="Hatching layers, lighter first (2: cross-hatching in "
                            "the shadows).")
        layer_offset: float = Field(0.45, ge=0, lt=1, description="Layer k starts where the darkness (0..1) "
                                    "exceeds k x layer_offset.")
        layer_angle: float = Field(30.0, ge=0, le=90, description="Layer 1 is turned by +layer_angle, layer 2 "
                                   "by -layer_angle degrees from the curvature frame.")
        texel_scale: float = Field(0.7, gt=0, le=8, description="Tonal-art-map texels per screen pixel at the "
                                   "reference size (below 1: broader strokes; above 1: finer, from the mipmaps); "
                                   "per image pixel it is texel_scale / px_scale, so strokes keep their size "
                                   "relative to the picture.")
        grain: float = Field(0.15, ge=0, le=1, description="Paper grain: graphite darkness times 1 + 2.5 x grain x "
                           "(grain normal . stroke direction), clamped to [0, 2].")
        fallback_angle: float = Field(45.0, ge=-180, le=180, description="Screen direction in degrees "
                                      "(counter-clockwise from +x) where curvature directions are unreliable.")
        foreshortening: tuple[float, float] = Field((0.15, 0.45), description="Projected/true length of a "
                                                    "direction below which it is replaced by the fallback, "
                                                    "and above which it is kept (smooth in between).")
        anchor: Literal["object", "screen"] = Field("object", description="Centre the hatching frame on each "
                                                    "object's projected centre (less swimming when objects "
                                                    "move) or on the screen origin.")
        crease_angle: float = Field(40.0, ge=0, le=180, description="Dihedral angle in degrees above which "
                                    "normals are split (sharp creases shade flat).")
        paper_tint: float = Field(0.05, ge=0, le=1, description="How much the paper relief shows on bare paper.")
        paper_color: Color = Field(PAPER_COLOR, description="Paper colour (RGB, 0..1).")
        graphite_color: Color = Field(GRAPHITE_COLOR, description="Colour of fully dark graphite (RGB, 0..1).")

        @model_validator(mode="after")
        def _check(self) -> PencilShade.Params:
            lo, hi = self.foreshortening
            if not 0.0 <= lo < hi <= 1.0:
                raise ValueError(f"foreshortening needs 0 <= lo < hi <= 1, got {list(self.foreshortening)}")
            return self

    # -- uniforms shared with the reference ---------------------------------------------------
    def layer_rotations(self) -> np.ndarray:
        """(layers, 2) (cos, sin) of each layer's turn: 0, +layer_angle, -layer_angle."""
        a = math.radians(self.params.layer_angle)
        angles = [0.0, a, -a][: self.params.layers]
        return np.array([[math.cos(t), math.sin(t)] for t in angles], dtype=np.float32)

    def layer_shifts(self) -> np.ndarray:
        return reference.LAYER_SHIFTS[: self.params.layers].astype(np.float32)

    def texel_scale(self, px_scale: float) -> float:
        """Tonal-art-map texels per image pixel: texel_scale / px_scale (docs/sizes.md)."""
        return self.params.texel_scale if px_scale == 1.0 else self.params.texel_scale / px_scale

    def hash_extra(self, ctx: HashContext) -> Any:
        return origin.hash_extra(ctx.scene, ctx.frame)

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        gl = ctx.gl
        scene = inputs.get("scene") or ctx.scene
        if scene is None:
            raise NodeError("needs a scene: connect `scene` or give the pipeline one", self.id, self.type_name)
        curv = inputs["curvature"]
        tam = inputs["tam"]
        paper = inputs.get("paper")
        contour = inputs.get("contour")
        geo_ports = ["shade"] + (["blend"] if "blend" in needed else [])  # shade also feeds `color`
        defines: dict[str, Any] = {_GEOMETRY_PORTS[port]: i for i, port in enumerate(geo_ports)}
        defines.update(LAYERS=p.layers, PAPER=int(paper is not None))
        prog = ctx.program("pencil_shade.glsl", defines)
        w, h = ctx.size
        targets = {port: ctx.target(port, filter="nearest") for port in geo_ports}
        fbo = gl.framebuffer([targets[port] for port in geo_ports], gl.depth_buffer((w, h)))
        fbo.clear(depth=1.0)
        gl.framebuffer([targets["shade"]]).clear(1.0, 1.0, 1.0, 1.0)
        if "blend" in targets:
            gl.framebuffer([targets["blend"]]).clear(0.0, 0.0, 0.0, -1.0)
        fbo.use()
        gl.ctx.viewport = (0, 0, w, h)
        cam = scene.camera_at(ctx.frame)
        origin.warn_once(scene, cam)
        view = cam.view_matrix()
        world = origin.world_origin(scene, cam)
        proj = cam.projection_matrix(w / h)
        textures: dict[str, Any] = {"t_tam": tam}
        if paper is not None:
            textures["t_paper"] = paper
        fallback = math.radians(p.fallback_angle)
        light = view_light(scene, cam)
        max_tone = p.max_darkness * (tam.layers - 1)
        texel_scale = self.texel_scale(ctx.px_scale)
        bind(prog, textures, {
            "u_proj": proj, "u_viewport": (float(w), float(h)),
            "u_fallback_dir": (math.cos(fallback), math.sin(fallback)),
            "u_foreshortening": tuple(float(v) for v in p.foreshortening),
            "u_light": tuple(float(c) for c in light), "u_light_intensity": p.light_intensity,
            "u_max_tone": float(max_tone), "u_layer_offset": p.layer_offset,
            "u_layer_rot": self.layer_rotations(), "u_layer_shift": self.layer_shifts(),
            "u_texel_scale": texel_scale, "u_lod": max(math.log2(texel_scale), 0.0), "u_grain": p.grain,
        })
        # one texel per pixel or coarser needs no mipmaps: plain bilinear is 3x cheaper on llvmpipe
        sampler = _sampler(gl, mipmaps=texel_scale > 1.0)
        sampler.use(location=0)  # t_tam is bound first, to unit 0
        try:
            with gl.depth_test() as state:
                for index, obj in enumerate(scene.objects):
                    geometry = _geometry(gl, prog, obj.mesh, curv, index, p.crease_angle, self)
                    if geometry is None:
                        continue
                    vao, local = geometry
                    # closed meshes hide their back faces: culling them halves the shaded fragments
                    face = None
                    if obj.mesh.topology().closed:
                        outward = (obj.mesh.signed_volume() > 0.0) != obj.mirrored
                        face = "back" if outward else "front"
                    state.cull(face)
                    model = np.asarray(obj.transform, dtype=np.float64)
                    anchor = (0.0, 0.0)
                    if p.anchor == "object":
                        anchor = reference.project_to_pixels(0.5 * np.add(*obj.world_bounds()), view, proj, (w, h))
                    normal_view = np.linalg.inv(view[:3, :3] @ model[:3, :3]).T
                    u_view, u_model = origin.relative_matrices(view, model, world, local)
                    bind(prog, {}, {"u_view": u_view, "u_model": u_model, "u_normal_view": normal_view,
                                    "u_anchor": tuple(float(a) for a in anchor)})
                    vao.render(gl.ctx.TRIANGLES)
        finally:
            sampler.clear(location=0)
        out = {port: targets[port] for port in geo_ports if port in needed}
        if "color" in needed:
            same = contour is not None and contour.size == (w, h)
            comp = ctx.program("composite.glsl", {"CONTOUR": int(contour is not None), "PAPER": int(paper is not None),
                                                  "CONTOUR_SAME_SIZE": int(same)})
            color = ctx.target("color")
            tex = {"t_shade": targets["shade"]}
            if contour is not None:
                tex["t_contour"] = contour
            if paper is not None:
                tex["t_paper"] = paper
            gl.fullscreen(comp, [color], textures=tex, uniforms={
                "u_paper_color": p.paper_color, "u_graphite_color": p.graphite_color, "u_paper_tint": p.paper_tint})
            out["color"] = color
        if "shade" not in needed:
            gl.release(targets["shade"])
        return out


def _sampler(gl: Any, mipmaps: bool) -> Any:
    key = ("pencil_shade.sampler", mipmaps)
    smp = gl.resources.get(key)
    if smp is None:
        f = gl.ctx.LINEAR_MIPMAP_LINEAR if mipmaps else gl.ctx.LINEAR
        smp = gl.ctx.sampler(repeat_x=True, repeat_y=True, filter=(f, gl.ctx.LINEAR), anisotropy=1.0)
        gl.resources[key] = smp
    return smp



def _geometry(gl: Any, prog: Any, mesh: Any, curv: Any, index: int, crease_angle: float,
              node: Node) -> tuple[Any, np.ndarray] | None:
    """The program's vertex array over position (relative to the mesh's origin, nodegraph/origin.py), split
    normal, curvature direction and trust, per (mesh, crease angle, curvature), and that origin."""
    if mesh.n_faces == 0:
        return None
    name = object_field(index, "dmin")
    if name not in curv.data:
        raise NodeError(f"the curvature input has no arrays for object {index}; connect the curvature node of the "
                        "same scene", node.id, node.type_name)
    dmin = curv.data[name]
    if dmin.shape != (mesh.n_vertices, 3):
        raise NodeError(f"curvature of object {index} has {dmin.shape[0]} vertices, its mesh {mesh.n_vertices}; "
                        "connect the curvature node of the same scene", node.id, node.type_name)
    ckey = str(curv.data.get(object_field(index, "key"), ""))

    def build() -> MeshArrays:
        ra = mesh.render_arrays(crease_angle)
        src = ra.source_vertex
        local = origin.mesh_origin(mesh)
        trust = (curv.data[object_field(index, "source")][src] != DirectionSource.FIXED_FRAME).astype(np.float32)
        return MeshArrays({"in_pos": (origin.positions(mesh, ra, local), "3f"), "in_normal": (ra.normals, "3f"),
                           "in_dir": (skinned_directions(mesh, dmin, src), "3f"), "in_trust": (trust, "1f")},
                          ra.indices,
                          meta={"origin": local})

    entry = gl.mesh_buffers(("pencil_shade.mesh", mesh.content_hash(), float(crease_angle), ckey), build)
    return entry.vao(prog), entry.meta["origin"]


def skinned_directions(mesh: Any, directions: np.ndarray, src: np.ndarray) -> np.ndarray:
    """(k, 3) float32 curvature directions of the render vertices `src`: as measured, or for a skinned mesh
    (measured in its rest pose, see the curvature node) carried by each vertex's skin matrix, so hatching
    follows the skin instead of swimming over it."""
    d = directions[src]
    linear = getattr(mesh, "skin_linear", None)
    if linear is None:
        return d
    out = np.einsum("nij,nj->ni", linear[src], d.astype(np.float64))
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, length, out=np.zeros_like(out), where=length > 1e-12).astype(np.float32)


NODE = PencilShade
