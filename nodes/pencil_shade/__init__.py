"""pencil_shade: curvature-oriented, 3-way blended pencil hatching (Lee et al. 2006, §3.2.1.3 and §4.2.2)."""

from __future__ import annotations

import itertools
import math
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from nodegraph.errors import NodeError
from nodegraph.gpu.gl import MeshArrays, bind
from nodegraph.node import HashContext, Input, Node, NodeParams, Output, RunContext
from nodegraph.scene import lights, meshes, meshstore, origin
from nodegraph.types import ARRAYS, SCENE, Texture, TextureArray

from .._shared.culling import HOLE_SHARE_CULL
from .._shared.curvature import DirectionSource, object_field
from .._shared.pencil import ALBEDO_REF, GRAPHITE_COLOR, PAPER_COLOR, Color, screen_bounds, view_light
from . import reference

_LOCATIONS = {"shade": "LOC_SHADE", "blend": "LOC_BLEND", "color": "LOC_COLOR"}


class PencilShade(Node):
    """Shades the scene's objects with the tonal art map. Brightness b = max(N.L, 0) from the scene light (where
    the scene has punctual lights, the luminance of their irradiance instead: docs/scenes.md, Lights),
    and no less than grazing_floor x (1 - N.V / sin grazing_angle) (N.V: the normal against the ray to the eye)
    where a surface is seen within `grazing_angle` of edge-on: seen at a grazing angle from the side the light
    does not reach, a surface keeps a readable mid tone (a sheet at 10 degrees: brightness 0.25, darkness 0.5)
    rather than the darkest cross-hatching; `grazing_floor` 0 turns the rule off. The tone index is
    max_darkness x (tones - 1) x (1 - sqrt(b x light_intensity)), continuous (the two nearest tones are
    blended; they are nested, so without seams). Hatching is sampled in screen space in a
    frame rotated to each vertex's projected minimum-curvature direction (curvature node); a fragment
    blends the three frames of its triangle's vertices by its barycentric weights (3-way blending), which
    sum to 1, so where the three directions agree it is one rotated texture. Where a direction is
    unreliable (the curvature node's fixed-frame fallback, or seen nearly end-on) it turns towards
    `fallback_angle` on screen. On flat faces (`planes`) the direction is the plane's own instead
    (nodes/_shared/planes.py: along its outline), so a box's side is hatched one way all over. Up to `layers`
    hatching layers are drawn, lighter first: layer k starts at darkness k x layer_offset, is turned by its layer
    angle and multiplies the result, so crossings darken. Graphite is modulated by the paper grain: the dot product
    of the grain normal and the stroke direction. `color` adds the contours (multiplied) and the paper colour;
    `shade` is the hatching value alone; `blend` holds the weights (rgb) and the tone index (a; -1 off the objects)."""

    version = "4"  # 3: mirrored objects shaded from their outside (their tone was inverted); 4: planes
    shaders = ("pencil_shade.glsl", "hatch.glsl")
    context_keys = frozenset({"size", "frame", "scene", "camera", "px_scale"})
    inputs = {
        "tam": Input(TextureArray("R8"), "Tonal art map, layer 0 lightest (hatching_synthesis.tones)."),
        "curvature": Input(ARRAYS, "Per-object curvature arrays (curvature.out) of the same scene."),
        "paper": Input(Texture("RGBA16F"), "Paper grain normals (paper.out); no grain when not connected.",
                       optional=True),
        "contour": Input(Texture("R16F"), "Contour drawing, 1 = paper (contour.out), multiplied into `color`.",
                         optional=True),
        "albedo": Input(Texture("RGBA8"), "Surface colour (rasterize.color): darker materials hatch darker "
                        "(`albedo_weight`); N.L alone when not connected.", optional=True),
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
                                    "the tonal art map's range (maxDarkness / 32 in the report implementing Lee "
                                    "et al., \"Real-Time Pencil Rendering\", 2006).")
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
        anchor: Literal["object", "screen", "surface"] = Field(
            "object", description="Centre the screen-space hatching frame on each object's projected centre (less "
            "swimming when objects move) or on the screen origin; or `surface` (for films): hatching coordinates "
            "fixed to the rest-pose surface, each corner's (P . d, P . (n x d)) from its object-space curvature "
            "direction d, so strokes move and bend with the object (docs/pencil.md, Hatching on the surface).")
        grazing_floor: float = Field(0.5, ge=0, le=1, description="Brightness a surface keeps when seen edge-on "
                                     "(seen at a grazing angle, a surface turned from the light would be hatched "
                                     "nearly black): brightness is at least grazing_floor x (1 - N.V / sin "
                                     "grazing_angle), N.V the cosine between its normal and the view ray, so the "
                                     "lift fades to nothing at grazing_angle from edge-on. 0: plain N.L.")
        grazing_angle: float = Field(20.0, gt=0, le=90, description="Angle in degrees between the view ray and the "
                                     "surface below which `grazing_floor` lifts the tone (at 0 degrees, edge-on, "
                                     "it is the whole floor).")
        crease_angle: float = Field(40.0, ge=0, le=180, description="Dihedral angle in degrees above which "
                                    "normals are split (sharp creases shade flat).")
        planes: bool = Field(True, description="Flat faces of a rigid mesh (planes over 0.5 % of its area) "
                             "hatched along their plane's direction (its outline's longer side) instead of the "
                             "curvature directions measured at their corners across the creases, which turn "
                             "from corner to corner.")
        albedo_weight: float = Field(1.0, ge=0, le=4, description="With `albedo` connected: brightness is N.L x "
                                     "(L* / L*_ref) ^ albedo_weight, L* the albedo's CIE lightness (its value, as "
                                     "an artist judges it), L*_ref the default mesh colour's, 81.8 (objects of that "
                                     "colour hatch as without it; white a little lighter, pure red (L* 53) darker, "
                                     "black darkest); 0: N.L alone.")
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
        scene = ctx.input_scene(inputs)
        curv = inputs["curvature"]
        tam = inputs["tam"]
        paper = inputs.get("paper")
        contour = inputs.get("contour")
        albedo = inputs.get("albedo") if p.albedo_weight > 0 else None
        w, h = ctx.size
        # 1. geometry: per pixel the three corner angles, darkness, blending weights and anchor (G-buffer)
        face_order = "blend" in needed  # weights in the triangles' corner order: one lookup per fragment more
        surface = p.anchor == "surface"
        # punctual lights (scene.lights): their irradiance's brightness instead of the scene light's N.L
        punctual = lights.view_uniforms(scene.lights, scene.camera_at(ctx.frame).view_matrix(), scene.exposure) \
            if scene.lights else {}
        prog = ctx.program("pencil_shade.glsl", {"FACE_ORDER": int(face_order), "SLOT_ROW": SLOT_ROW,
                                                 **({"LIGHTS": len(scene.lights[:lights.MAX_LIGHTS])} if punctual
                                                    else {}), **({"SURFACE": 1} if surface else {})})
        gbuffer, fbo = _gbuffer(gl, (w, h))
        surface_tex: tuple[Any, Any] | None = None
        if surface:
            *surface_tex, fbo = _surface_gbuffer(gl, (w, h), gbuffer)
        # only the depth is cleared (clearing RGBA32F costs about a full-screen pass here): the passes below read
        # the G-buffer only where the depth test says an object was drawn
        gl.framebuffer([], gl.depth_buffer((w, h))).clear(depth=1.0)
        fbo.use()
        gl.ctx.viewport = (0, 0, w, h)
        cam = scene.camera_at(ctx.frame)
        origin.warn_once(scene, cam)
        view = cam.view_matrix()
        world = origin.world_origin(scene, cam)
        proj = cam.projection_matrix(w / h)
        fallback = math.radians(p.fallback_angle)
        light = view_light(scene, cam)
        bind(prog, {}, {
            "u_proj_y": float(proj[1, 1]), "u_viewport": (float(w), float(h)),
            "u_fallback_dir": (math.cos(fallback), math.sin(fallback)),
            "u_foreshortening": tuple(float(v) for v in p.foreshortening),
            "u_light": tuple(float(c) for c in light), "u_light_intensity": p.light_intensity,
            # an orthographic camera sees every pixel along the view axis: (0, 0) makes the ray (0, 0, 1)
            "u_tan_half": (0.0, 0.0) if cam.orthographic else (float(1.0 / proj[0, 0]), float(1.0 / proj[1, 1])),
            "u_grazing": (p.grazing_floor, math.sin(math.radians(p.grazing_angle))), **punctual,
        })
        anchors = np.zeros((1, max(len(scene.objects), 1), 2), dtype=np.float32)  # screen anchor: the origin
        texel_scale = self.texel_scale(ctx.px_scale)
        if surface:
            bind(prog, {}, {"u_tam_size": float(tam.size[0])})
        with gl.depth_test() as state:
            for index, obj in enumerate(scene.objects):
                geometry = _geometry(gl, prog, obj.mesh, curv, index, p.crease_angle, self, surface, p.planes)
                if geometry is None:
                    continue
                vao, local, slots = geometry
                # closed meshes hide their back faces, and meshes whose holes show at most 1% of the surface
                # nearly so (rasterize's `backfaces: auto`; ogre.obj): culling halves the rasterised triangles
                # a mirrored object's triangles wind clockwise on screen: clockwise is its front, so gl_FrontFacing
                # still tells the outside from the inside (its normals are right already: the inverse transpose)
                state.front_face(clockwise=obj.mirrored)
                face = None
                if obj.mesh.topology().closed or obj.mesh.hole_share() <= HOLE_SHARE_CULL:
                    face = "back" if obj.mesh.signed_volume() > 0.0 else "front"
                state.cull(face)
                model = np.asarray(obj.transform, dtype=np.float64)
                if p.anchor == "object":
                    centre = 0.5 * np.add(*obj.world_bounds())
                    anchors[0, index] = reference.project_to_pixels(centre, view, proj, (w, h))
                normal_view = np.linalg.inv(view[:3, :3] @ model[:3, :3]).T
                u_view, u_model = origin.relative_matrices(view, model, world, local)
                slot_tex = gl.upload(slots, "R8", filter="nearest") if face_order else None
                tiles = {"u_tiles": surface_tiles(scene, index, (w, h), texel_scale / float(tam.size[0]))} \
                    if surface else {}
                bind(prog, {"t_slots": slot_tex} if face_order else {},
                     {"u_mvp": proj @ u_view @ u_model, "u_model3": u_model[:3, :3], "u_normal_view": normal_view,
                      "u_object": index, **({"u_model_view": u_view @ u_model} if punctual else {}), **tiles})
                vao.render(gl.ctx.TRIANGLES)
                if slot_tex is not None:
                    gl.release(slot_tex)
        # 2. bare paper over the whole image, then the hatching where an object was drawn: depth-tested against
        # the geometry pass (llvmpipe skips a block of pixels that fails the depth test, not a branch) and
        # scissored to the objects' projected boxes
        ports = [port for port in ("shade", "blend", "color") if port in needed]
        same = contour is not None and contour.size == (w, h)
        defines: dict[str, Any] = {_LOCATIONS[port]: i for i, port in enumerate(ports)}
        defines.update(LAYERS=p.layers, PAPER=int(paper is not None), CONTOUR=int(contour is not None),
                       CONTOUR_SAME_SIZE=int(same), ALBEDO=int(albedo is not None))
        if surface:
            defines["SURFACE"] = 1
        targets = [ctx.target(port, filter="nearest" if port != "color" else "linear") for port in ports]
        anchor_tex = gl.upload(anchors, "RG32F", filter="nearest")
        textures: dict[str, Any] = {"t_tam": tam, "t_gbuffer": gbuffer, "t_anchors": anchor_tex}
        if paper is not None:
            textures["t_paper"] = paper
        if contour is not None:
            textures["t_contour"] = contour
        if albedo is not None:
            textures["t_albedo"] = albedo
        uniforms = {"u_max_tone": float(p.max_darkness * (tam.layers - 1)), "u_layer_offset": p.layer_offset,
                    "u_layer_rot": self.layer_rotations(), "u_layer_shift": self.layer_shifts(),
                    "u_texel_scale": texel_scale, "u_lod": max(math.log2(texel_scale), 0.0), "u_grain": p.grain,
                    "u_paper_color": p.paper_color, "u_graphite_color": p.graphite_color,
                    "u_paper_tint": p.paper_tint, "u_albedo_ref": ALBEDO_REF, "u_albedo_weight": p.albedo_weight}
        shaded = gl.framebuffer(targets, gl.depth_buffer((w, h)))
        gl.fullscreen(ctx.program("hatch.glsl", {**defines, "BACKGROUND": 1}), targets, textures=textures,
                      uniforms=uniforms, fbo=shaded)
        box = screen_bounds(scene, cam, (w, h), 1)
        # one texel per pixel or coarser needs no mipmaps: plain bilinear is 3x cheaper on llvmpipe (on the surface
        # strokes foreshorten: mipmaps, at each pixel's own level)
        sampler = _sampler(gl, mipmaps=texel_scale > 1.0 or surface)
        shaded.depth_mask = False  # read the depth, keep it
        shaded.scissor = box
        hatch = ctx.program("hatch.glsl", {**defines, "BACKGROUND": 0})
        hatch_textures = textures if surface_tex is None else \
            {**textures, "t_surface0": surface_tex[0], "t_surface1": surface_tex[1]}
        # t_tam is bound first, to unit 0; where only `blend` is asked for the program does not read it (the unit
        # goes to the integer G-buffer, which a filtering sampler would make read as 0)
        tam_used = "t_tam" in hatch
        try:
            with gl.depth_test(">"):  # the pass's triangle lies at depth 1, the clear value: covered pixels pass
                if tam_used:
                    sampler.use(location=0)
                gl.fullscreen(hatch, targets, textures=hatch_textures, uniforms=uniforms, fbo=shaded)
        finally:
            if tam_used:
                sampler.clear(location=0)
            shaded.depth_mask = True  # framebuffers are shared: leave it as the others expect
            shaded.scissor = None
        gl.release(anchor_tex)
        return dict(zip(ports, targets, strict=True))


def _gbuffer(gl: Any, size: tuple[int, int]) -> tuple[Any, Any]:
    """The geometry pass's RGBA32UI texture (no pooled format holds integers) and its framebuffer with the
    shared depth buffer, kept for the last size used (an allocation costs more than the pass)."""
    key = "pencil_shade.gbuffer"
    entry = gl.resources.get(key)
    if entry is None or entry[0] != size:
        if entry is not None:
            gl.framebuffer([], gl.depth_buffer(size)).use()  # never leave a released framebuffer bound
            entry[2].release()
            entry[1].release()
        tex = gl.ctx.texture(size, 4, dtype="u4")
        tex.filter = (gl.ctx.NEAREST, gl.ctx.NEAREST)
        entry = gl.resources[key] = (size, tex, gl.ctx.framebuffer([tex], gl.depth_buffer(size)))
    return entry[1], entry[2]


def _surface_gbuffer(gl: Any, size: tuple[int, int], gbuffer: Any) -> tuple[Any, Any, Any]:
    """The two RGBA32F surface-coordinate textures of `anchor: surface` and the geometry pass's framebuffer over
    `gbuffer` (the RGBA32UI G-buffer) and them, kept for the last size used."""
    key = "pencil_shade.surface"
    entry = gl.resources.get(key)
    if entry is None or entry[0] != size or entry[4] is not gbuffer:
        if entry is not None:
            gl.framebuffer([], gl.depth_buffer(size)).use()
            for res in (entry[3], entry[1], entry[2]):
                res.release()
        texs = [gl.ctx.texture(size, 4, dtype="f4") for _ in range(2)]
        for tex in texs:
            tex.filter = (gl.ctx.NEAREST, gl.ctx.NEAREST)
        entry = gl.resources[key] = (size, *texs, gl.ctx.framebuffer([gbuffer, *texs], gl.depth_buffer(size)),
                                     gbuffer)
    return entry[1], entry[2], entry[3]


def surface_coordinates(gl: Any) -> np.ndarray | None:
    """(h, w, 3, 2) the last `anchor: surface` geometry pass's hatching coordinates (tiles) of the three corners,
    in slot order (corner order where `blend` was asked for), and (h, w) their level of detail, bottom row first;
    None before any. For tests and inspection: the values are meaningful where an object was drawn."""
    entry = gl.resources.get("pencil_shade.surface")
    if entry is None:
        return None
    w, h = entry[0]
    s0 = np.frombuffer(entry[1].read(), dtype=np.float32).reshape(h, w, 4)
    s1 = np.frombuffer(entry[2].read(), dtype=np.float32).reshape(h, w, 4)
    return np.stack([s0[..., 0:2], s0[..., 2:4], s1[..., 0:2]], axis=2), s1[..., 2]


def surface_tiles(scene: Any, index: int, size: tuple[int, int], tiles_per_pixel: float) -> float:
    """Tonal-art-map tiles per object unit of `anchor: surface` for object `index`: the screen modes' tiles per
    pixel times the pixels an object unit spans at the centre of the object's rest-pose box in the film's first
    frame (frame 0: the scene posed there, seen by its camera), so strokes there are spaced on screen as in the
    screen modes, and the scale is the same in every frame of the film, whatever the camera or the object does
    (strokes then grow and shrink with the object on screen). A still scene's frame 0 is itself."""
    source = scene.animated_source() if hasattr(scene, "animated_source") else None
    first = source.at(0) if source is not None else scene
    key = ("pencil_shade.tiles", index, tuple(size), float(tiles_per_pixel))
    memo = getattr(source if source is not None else scene, "_cache", None)
    if memo is not None and key in memo:
        return memo[key]
    cam = first.camera_at(0)
    obj = first.objects[index]
    w, h = size
    proj = cam.projection_matrix(w / h)
    model = np.asarray(obj.transform, dtype=np.float64)
    lo, hi = (np.asarray(b, dtype=np.float64) for b in (obj.mesh.rest if obj.mesh.rest is not None
                                                        else obj.mesh).bounds())
    centre = model @ np.append((lo + hi) / 2.0, 1.0)
    units = abs(float(np.linalg.det(model[:3, :3]))) ** (1.0 / 3.0)  # world units per object unit (mean)
    px_per_unit = float(proj[1, 1]) * 0.5 * h * units
    if not cam.orthographic:
        depth = -float((cam.view_matrix() @ centre)[2])
        px_per_unit /= max(depth, float(cam.near))
    out = tiles_per_pixel * px_per_unit
    if memo is not None:
        memo[key] = out
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
              node: Node, surface: bool = False, planes: bool = False) -> tuple[Any, np.ndarray, np.ndarray] | None:
    """The program's vertex array over position (relative to the mesh's origin, nodegraph/scene/origin.py), split
    normal, curvature direction, trust and corner slot (`surface`: and the rest-pose frame, `surface_frame`),
    built once per (mesh, crease angle, curvature) and kept across frames, that origin, and each triangle's
    slots as `_slot_codes` gives them."""
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
        local = origin.mesh_origin(mesh)
        sv = _slotted(mesh.topology_mesh(), crease_angle)  # a posed part: its rest pose's, made once
        vertex = sv["vertex"]
        dirs, trust, flat = vertex_directions(mesh, ra, dmin, curv.data[object_field(index, "source")], planes)
        arrays = {"in_pos": (origin.positions(mesh, ra, local)[vertex], "3f"),
                  "in_normal": (ra.normals[vertex], "3f"),
                  "in_dir": (dirs[vertex], "3f"),
                  "in_trust": (trust[vertex].astype(np.float32), "1f"), "in_corner": (sv["corner"], "1f")}
        if surface:
            rest, rdir, rperp = surface_frame(mesh.topology_mesh(), dmin, crease_angle, flat)
            arrays.update(in_rest=(rest[vertex], "3f"), in_rdir=(rdir[vertex], "3f"), in_rperp=(rperp[vertex], "3f"))
        return MeshArrays(arrays, sv["indices"], meta={"origin": local, "slots": sv["codes"]})

    # a posed part's buffers take each frame's vertices in place (slot: its rest pose)
    kind = ("pencil_shade.surface" if surface else "pencil_shade.slots") + (".planes" if planes else "")
    slot = (kind, mesh.rest.content_hash(), float(crease_angle), ckey) if mesh.rest is not None else None
    entry = gl.mesh_buffers((kind, mesh.content_hash(), float(crease_angle), ckey), build, slot)
    return entry.vao(prog), entry.meta["origin"], entry.meta["slots"]


def surface_frame(rest: Any, dmin: np.ndarray, crease_angle: float,
                  flat: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per render vertex of the rest-pose mesh `rest` (float32, (k, 3) each): its position relative to the centre
    of the rest pose's box, its minimum-curvature direction (or, where `flat` = plane_directions marks it, its
    plane's direction) made tangent to its (split) normal n and unit (0 where it has none), and n x that
    direction: the frame `anchor: surface` hatches in."""
    ra = rest.render_arrays(crease_angle)
    src = ra.source_vertex
    lo, hi = (np.asarray(b, dtype=np.float64) for b in rest.bounds())
    pos = np.asarray(rest.vertices, dtype=np.float64)[src] - (lo + hi) / 2.0
    n = np.asarray(ra.normals, dtype=np.float64)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    d = np.asarray(dmin, dtype=np.float64)[src]
    if flat is not None:
        d[flat[1]] = flat[0][flat[1]]
    d = d - n * np.einsum("ij,ij->i", d, n)[:, None]
    length = np.linalg.norm(d, axis=1, keepdims=True)
    d = np.divide(d, length, out=np.zeros_like(d), where=length > 1e-9)
    return pos.astype(np.float32), d.astype(np.float32), np.cross(n, d).astype(np.float32)


def _slotted(shape: Any, crease_angle: float) -> dict[str, np.ndarray]:
    """The slotted vertices of a mesh's render triangles, topology alone (made once per rest pose and crease
    angle, not per frame): every triangle's corners get the slots 0, 1, 2 (see pencil_shade.glsl), a render
    vertex is copied once per slot its triangles give it (about 1.5 copies a vertex) and the draw stays indexed.
    "vertex": the render vertex of each copy; "corner": its slot (float32); "indices": the triangles over the
    copies (uint32); "codes": `_slot_codes`."""
    def make() -> dict[str, np.ndarray]:
        ra = shape.render_arrays(crease_angle)
        slots = _mesh_corner_slots(shape, ra, crease_angle)
        keys, inverse = np.unique(np.asarray(ra.indices, dtype=np.int64) * 3 + slots, return_inverse=True)
        out = {"vertex": keys // 3, "corner": (keys % 3).astype(np.float32),
               "indices": inverse.reshape(-1, 3).astype(np.uint32), "codes": _slot_codes(slots)}
        for a in out.values():
            a.flags.writeable = False
        return out

    return shape._cached(("pencil_shade.slotted", float(crease_angle)), make)


def _mesh_corner_slots(mesh: Any, ra: Any, crease_angle: float) -> np.ndarray:
    """`corner_slots` of the mesh's render triangles, kept on disk for a large mesh (nodegraph/scene/meshstore.py):
    the greedy pass is a Python loop, 0.69 s of CPU on ogre's 124k triangles in every process that draws it."""
    def make() -> dict[str, np.ndarray]:
        return {"value": corner_slots(ra.indices, ra.n_vertices).astype(np.uint8)}

    stored = meshstore.memo_arrays(mesh, f"slots{float(crease_angle)!r}", make, (__file__, meshes.__file__),
                                   ("value",))["value"]
    return stored.astype(np.int64)


_PERMUTATIONS = tuple(itertools.permutations(range(3)))


def corner_slots(triangles: np.ndarray, n_vertices: int) -> np.ndarray:
    """(m, 3) slot 0, 1 or 2 of every triangle corner, the three of a triangle distinct, chosen greedily so that
    a vertex needs as few slots (copies) as it can: each triangle takes the permutation that reuses most of
    its vertices' existing slots."""
    have = [0] * n_vertices  # bit s: the vertex has a copy in slot s
    out = np.empty((len(triangles), 3), dtype=np.int64)
    for t, (a, b, c) in enumerate(np.asarray(triangles).tolist()):
        ha, hb, hc = have[a], have[b], have[c]
        best, choice = 4, _PERMUTATIONS[0]
        for perm in _PERMUTATIONS:
            cost = (not (ha >> perm[0]) & 1) + (not (hb >> perm[1]) & 1) + (not (hc >> perm[2]) & 1)
            if cost < best:
                best, choice = cost, perm
                if cost == 0:
                    break
        have[a], have[b], have[c] = ha | 1 << choice[0], hb | 1 << choice[1], hc | 1 << choice[2]
        out[t] = choice
    return out


SLOT_ROW = 1024  # triangles per row of the slot texture


def _slot_codes(slots: np.ndarray) -> np.ndarray:
    """(rows, SLOT_ROW) uint8 slot(0) + 3 slot(1) of every triangle (slot(2) is the one left), row-major by
    triangle, zero-padded: what the geometry pass reads by gl_PrimitiveID to put the weights in corner order."""
    codes = np.zeros(-(-len(slots) // SLOT_ROW) * SLOT_ROW, dtype=np.uint8)
    codes[: len(slots)] = slots[:, 0] + 3 * slots[:, 1]
    return codes.reshape(-1, SLOT_ROW)


def vertex_directions(mesh: Any, ra: Any, dmin: np.ndarray, source: np.ndarray, planes: bool
                      ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """Per render vertex of `ra` (both shading paths): its hatching direction (`skinned_directions` of the
    curvature node's `dmin`, or on a plane its plane's direction), whether that direction is trusted (not the
    curvature node's fixed-frame fallback, or on a plane), and `plane_directions` (None with `planes` off)."""
    src = ra.source_vertex
    dirs = skinned_directions(mesh, dmin, src)
    trust = source[src] != DirectionSource.FIXED_FRAME
    flat = plane_directions(mesh, ra) if planes else None
    if flat is not None:
        dirs = dirs.copy()
        dirs[flat[1]] = flat[0][flat[1]]
        trust = trust | flat[1]
    return dirs, trust, flat


def plane_directions(mesh: Any, ra: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """The planes' directions at the render vertices `ra` of a rigid mesh: ((k, 3) float32 directions, (k,) bool
    where a render vertex's triangles all lie in one plane (nodes/_shared/planes.py), which then takes that
    plane's `along`); None for a posed mesh or one without planes."""
    from .._shared.planes import cached_planes

    if mesh.rest is not None:
        return None
    found = cached_planes(mesh)
    if not len(found):
        return None
    k = ra.n_vertices
    idx = np.asarray(ra.indices, np.int64).ravel()
    fp = np.repeat(found.face_plane, 3)
    lo = np.full(k, np.iinfo(np.int64).max)
    hi = np.full(k, -1, np.int64)
    np.minimum.at(lo, idx, fp)
    np.maximum.at(hi, idx, fp)
    on = (lo == hi) & (hi >= 0)
    dirs = np.zeros((k, 3), np.float32)
    dirs[on] = found.along[hi[on]]
    return dirs, on


def skinned_directions(mesh: Any, directions: np.ndarray, src: np.ndarray) -> np.ndarray:
    """(k, 3) float32 curvature directions of the render vertices `src`: as measured, or for a skinned mesh
    (measured in its rest pose, see the curvature node) carried by each vertex's skin matrix, so hatching
    follows the skin instead of swimming over it."""
    d = directions[src]
    linear = getattr(mesh, "skin_linear", None)
    if linear is None:
        return d
    lin = linear[src]
    d = d.astype(np.float64)
    # B d, row by row, the terms added in the order einsum("nij,nj->ni") adds them, without its per-row loop
    out = lin[:, :, 0] * d[:, 0:1]
    out += lin[:, :, 1] * d[:, 1:2]
    out += lin[:, :, 2] * d[:, 2:3]
    length = np.sqrt(np.einsum("ij,ij->i", out, out))[:, None]
    return np.divide(out, length, out=np.zeros_like(out), where=length > 1e-12).astype(np.float32)


NODE = PencilShade
