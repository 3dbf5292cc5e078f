"""rasterize: the G-buffer of the scene (Nienhaus & Döllner 2004, §3.1 and §4.2)."""

from __future__ import annotations

import warnings
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_serializer, model_validator

from nodegraph.gpu import footprint
from nodegraph.gpu.gl import MeshArrays, bind
from nodegraph.node import HashContext, Input, Node, NodeParams, Output, RunContext
from nodegraph.scene import lights, meshes, meshstore, origin, posing
from nodegraph.scene.meshes import MeshWarning
from nodegraph.types import SCENE, Texture, components
from nodegraph.values import Footprint

from .._shared.culling import HOLE_SHARE_CULL  # `auto` culls at most this share of holes

# tone_bands -> (N.L thresholds (dark | middle | light), colour factors (dark, middle, light)); N.L with the
# scene light in view space, the normal two-sided as the G-buffer has it. 2 bands: no middle band.
TONE_BANDS: dict[int, tuple[tuple[float, float], tuple[float, float, float]]] = {
    2: ((0.35, 0.35), (0.70, 0.70, 1.0)),
    3: ((0.25, 0.65), (0.60, 0.80, 1.0)),
}

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

_CLEAR = {**{p: clear for p, (clear, _) in _OUTPUTS.items()}, "motion": (0.0, 0.0, 0.0, 0.0), "spin": (0.0, 0.0)}


class Rasterize(Node):
    """Renders the scene's objects into a G-buffer: unlit colour (the shade map), view-space normals,
    window depth, linear view depth, object-space positions and object ids. Only the outputs the plan
    needs are written.

    Enlargement (paper §4.2) moves every vertex along its vertex normal in object space, so the
    G-buffer (above all `position`, g(s,t) of §4.3) also covers a band around each object. The paper
    needs a connected surface with shared, interpolated normals; for any other mesh the behaviour is
    defined: coincident vertices are welded (tolerance 1e-6 of the bounding-box diagonal) before the
    normals are computed, so split normals and duplicated seam vertices cannot open cracks, and each
    connected component (faces joined across manifold edges) is moved along its own angle-weighted
    normals, all by the same distance. A mesh file that needed either gets one `MeshWarning` per
    process naming the mesh and what was done (built-in scenes, assembled from parts on purpose, do not
    warn).

    Geometry is drawn relative to the camera's eye and each mesh's box centre where the scene lies far
    from the origin (`nodegraph/scene/origin.py`), so a scene at 1e8 renders like the same scene at 0; a scene
    that cannot be represented even so gets one `PrecisionWarning`."""

    version = "3"
    shaders = ("rasterize.glsl", "motion.glsl")
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
        "position": Output(Texture("RGBA32F"), "Object-space position g(s,t) (paper §4.3), alpha = coverage; for "
                           "a mesh whose box centre lies over 64 box radii from its origin, relative to that "
                           "centre (nodegraph/scene/origin.py)."),
        "object_id": Output(Texture("R32F"), "Index of the object + 1; 0 = background."),
        "motion": Output(Texture("RGBA32F"), "Where each covered pixel's surface point was in the previous frame "
                         "(frame - 1; frame 0: the pixel itself): xy its window position in pixels (gl_FragCoord "
                         "convention: origin lower-left, pixel centres at +0.5), z its window depth [0, 1] then "
                         "(2 where it was behind the camera), w = 1 where covered, 0 background. From the camera's "
                         "motion, object animation, skinning and morphs (nodegraph/output/motion.py warps with it)."),
        "spin": Output(Texture("RG32F"), "How far the surface under each pixel has turned in the picture's plane "
                       "since frame 0, as (cos, sin) (camera, object animation, skinning; a turn about an axis in "
                       "the picture's plane counts 0); (0, 0) background. Drawn with the same enlargement as the "
                       "other outputs, for the `spin` inputs of object_noise and sketch (docs/animation.md, Making "
                       "films)."),
    }

    class Params(NodeParams):
        select: Literal["all", "sketchy", "non_sketchy"] = Field(
            "all", description="Which objects to draw, by their scene `sketchy` flag.")
        lit: bool = Field(False, description="Shade the colour with the scene light, or the scene's punctual "
                                             "lights where it has any (docs/scenes.md, Lights; for ordinary, "
                                             "non-sketchy geometry); unlit flat colour otherwise (the paper's "
                                             "shade map).")
        ambient: float = Field(0.45, ge=0, le=1, description="Ambient share of the lit colour.")
        enlarge: float = Field(0.0, ge=0, le=0.5, description="Shift every vertex along its welded vertex normal "
                               "by this fraction of the object's bounding-box diagonal (paper §4.2); each "
                               "connected component moves along its own normals.")
        enlarge_unit: Literal["object", "scene"] = Field(
            "object", description="What `enlarge` is a fraction of: object: each object's own bounding-box "
            "diagonal; scene: the scene's bounding-box diagonal (the same world distance for every object: "
            "a band of even width around small and large objects alike).")
        crease_angle: float = Field(40.0, ge=0, le=180, description="Dihedral angle in degrees above which "
                                    "normals are split (sharp creases), below which they are smoothed.")
        backfaces: Literal["auto", "draw", "cull"] = Field(
            "auto", description="auto: cull back faces where holes can show at most 1% of the surface (closed "
            "meshes; ogre.obj, where culling changes 1 pixel of 800x800 and makes the G-buffer 2.5x faster), "
            "draw both sides otherwise (teapot.obj: culling would change 0.5% of its pixels); draw: always both "
            "sides; cull: never draw back faces.")
        tone_bands: Literal[0, 2, 3] = Field(
            0, description="Colour patches on the shade map from the light: 0: flat colour; 2: the colour times "
            "0.7 where N.L < 0.35, else the colour; 3: times 0.6 where N.L < 0.25, 0.8 up to 0.65, else the "
            "colour (N.L with the scene light in view space). For one-colour meshes, so the sketch's shifted "
            "colour patches read (not with `lit`).")

        @model_validator(mode="after")
        def _bands_unlit(self) -> Rasterize.Params:
            if self.tone_bands and self.lit:
                raise ValueError("tone_bands bands the unlit shade map; with lit: true give tone_bands: 0")
            return self

        @model_serializer(mode="wrap")
        def _dump(self, handler: Any) -> Any:
            """tone_bands came later: at its default 0 it stays out of the params' dump, so the keys (and the
            gallery's records) of every pipeline written before it hold."""
            out = handler(self)
            if isinstance(out, dict) and out.get("tone_bands") == 0:
                out.pop("tone_bands")
            return out

    def hash_extra(self, ctx: HashContext) -> Any:
        extra = origin.hash_extra(ctx.scene, ctx.frame)
        source = getattr(ctx.scene, "animated_source", lambda: None)()
        if source is not None:  # `motion` reads the frame before, which the pose alone does not name
            extra = {"origin": extra, "animation": source.animation.digest()}
        if ctx.scene is not None and any(o.mesh.rest is not None for o in ctx.scene.objects):
            from nodegraph.gpu.glsl import source_digest

            # posed meshes: `position` is the rest pose's, drawn by a pass of its own
            extra = {"origin": extra, "rest": source_digest(self.source_dir() / REST_SHADER)}
        if source is not None or (ctx.frame != 0 and getattr(ctx.scene, "orbit", None) is not None):
            from nodegraph.gpu.glsl import source_digest

            # `spin` compares the frame with frame 0: its shader is named where they can differ (a still frame 0
            # has no turn), so the keys of still scenes stay as they were
            extra = {"turn": extra, "spin": source_digest(self.source_dir() / SPIN_SHADER)}
        return extra

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        gl = ctx.gl
        scene = inputs.get("scene") or ctx.scene
        bands = self.params.tone_bands if "color" in needed else 0
        # punctual lights (scene.lights) shade instead of the scene light; their bands are made in the main pass
        lit_bands = bands if scene.lights else 0
        bands = 0 if scene.lights else bands
        # bands: the colour and an exact (float32) normal go to scratch textures, then a pass bands the colour
        ports = [p for p in _OUTPUTS if p in needed or (bands and p == "normal")]
        rects: list[tuple[int, int, int, int] | None] = []  # each object's pixel box: the outputs' footprint
        targets = {p: ctx.target(p, filter="nearest" if p == "object_id" else "linear") for p in ports}
        scratch = {}
        if bands:
            scratch = {"color": targets["color"], "normal": ctx.gl.texture(ctx.size, "RGBA32F", filter="nearest")}
            if "normal" in needed:
                scratch["normal_out"] = targets["normal"]
            targets["normal"] = scratch["normal"]
        objects = scene.select(self.params.select)
        # posed (skinned, morphed) meshes write their rest-pose position, in a pass of its own
        rest = "position" in ports and any(o.mesh.rest is not None for o in objects)
        main = [p for p in ports if not (rest and p == "position")]
        w, h = ctx.size
        cam = scene.camera_at(ctx.frame)
        _warn_depth_range_once(cam, "depth" in ports)
        origin.warn_once(scene, cam)
        view = cam.view_matrix()
        world = origin.world_origin(scene, cam)
        proj = cam.projection_matrix(w / h)
        light = np.asarray(scene.light_direction, dtype=np.float64)
        if scene.light_space == "world":
            light = view[:3, :3] @ light
        light = light / max(np.linalg.norm(light), 1e-12)
        punctual: dict[str, Any] = {}
        if scene.lights and (self.params.lit or lit_bands):
            punctual = lights.view_uniforms(scene.lights, view, scene.exposure)
            if lit_bands:
                (lo_t, hi_t), factors = TONE_BANDS[lit_bands]
                punctual.update({"u_thresholds": (lo_t, hi_t), "u_factors": factors})
        lo, hi = scene.scale_bounds()
        scene_diag = float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))
        if main:
            defines: dict[str, Any] = {_OUTPUTS[p][1]: i for i, p in enumerate(main)}
            defines["LIT"] = int(self.params.lit)
            defines["ENLARGE"] = int(self.params.enlarge > 0)
            if punctual:
                defines["LIGHTS"] = len(punctual["u_light_pos"])
                if lit_bands:
                    defines["BANDS"] = 1
            prog = ctx.program("rasterize.glsl", defines)
            depth_rb = gl.depth_buffer((w, h))
            fbo = gl.framebuffer([targets[p] for p in main], depth_rb)
            gl.clear_each(fbo, [_OUTPUTS[p][0] for p in main], depth=1.0)
            fbo.use()
            gl.ctx.viewport = (0, 0, w, h)
            with gl.depth_test() as state:
                for obj in objects:
                    if self.params.enlarge > 0:
                        _warn_enlarge_once(obj.mesh)
                    surface = _surface(obj)  # a glTF texture / vertex colours / cut-outs: a program of its own
                    oprog = prog if surface is None else ctx.program("rasterize.glsl",
                                                                       {**defines, **_surface_defines(surface)})
                    vao, diag, local, points = _geometry(gl, oprog, obj.mesh, self.params.crease_angle,
                                                         surface is not None)
                    model = np.asarray(obj.transform, dtype=np.float64)
                    u_view, u_model = origin.relative_matrices(view, model, world, local)
                    model_view = u_view @ u_model  # the origins move only its translation
                    normal_view = np.linalg.inv(model_view[:3, :3]).T
                    mvp = proj @ model_view
                    enlarge = self._enlarge(diag, model, scene_diag)
                    rects.append(_pixel_box(mvp, points, enlarge if self.params.enlarge > 0 else 0.0, (w, h)))
                    tex, surface_uniforms = _surface_bindings(gl, surface)
                    bind(oprog, tex, {
                        **surface_uniforms, "u_mvp": mvp, "u_view_z": tuple(float(c) for c in model_view[2]),
                        "u_normal_view": normal_view, "u_enlarge": enlarge,
                        "u_color": tuple(float(c) for c in obj.color),
                        "u_light": tuple(float(c) for c in light), "u_object_id": float(obj.index + 1),
                        "u_ambient": float(self.params.ambient), **punctual,
                        **({"u_model_view": model_view} if punctual else {})})
                    state.cull(_cull_face(obj, self.params.backfaces))
                    vao.render(gl.ctx.TRIANGLES)
        if rest:
            self._rest_pass(ctx, targets["position"], objects, view, world, proj, scene_diag)
        if "motion" in needed:
            targets["motion"] = self._motion_pass(ctx, scene, objects, (view, world, proj), scene_diag)
        if "spin" in needed:
            targets["spin"] = self._spin_pass(ctx, scene, objects, (view, world, proj), scene_diag)
        if bands:
            (lo_t, hi_t), factors = TONE_BANDS[bands]
            banded = ctx.target("color")
            gl.fullscreen(ctx.program("tone_bands.glsl"), [banded],
                          textures={"t_color": scratch["color"], "t_normal": scratch["normal"]},
                          uniforms={"u_light": tuple(float(c) for c in light), "u_thresholds": (lo_t, hi_t),
                                    "u_factors": factors})
            gl.release(scratch["color"])
            targets["color"] = banded
            if "normal_out" in scratch:  # the port's own format, from the exact normal
                gl.fullscreen(ctx.program("copy.glsl"), [scratch["normal_out"]],
                              textures={"t_in": scratch["normal"]})
                targets["normal"] = scratch["normal_out"]
            else:
                targets.pop("normal")
            gl.release(scratch["normal"])
        rect = footprint.union(rects) if main else None
        if rect is not None:  # outside the objects' boxes every output holds its clear value
            for p, tex in targets.items():
                if not (bands and p in ("color", "normal")):  # banded: made by a full-screen pass of their own
                    tex.footprint = Footprint(rect, _CLEAR[p][:components(tex.fmt)])
        return targets

    def _enlarge(self, diag: float, model: np.ndarray, scene_diag: float) -> float:
        """The object-space distance of enlargement: a fraction of the object's diagonal or the scene's."""
        if self.params.enlarge_unit == "scene":  # a world distance, in this object's units
            diag = scene_diag / max(abs(float(np.linalg.det(model[:3, :3]))) ** (1.0 / 3.0), 1e-12)
        return float(self.params.enlarge * diag)

    def _rest_pass(self, ctx: RunContext, target: Any, objects: list[Any], view: np.ndarray, world: np.ndarray,
                   proj: np.ndarray, scene_diag: float) -> None:
        """`position` of a scene with posed meshes: the posed geometry drawn again (own depth buffer, the same
        enlargement and culling), each fragment writing the rest-pose position of its surface point; meshes
        without a rest pose write their own position, as the main pass would."""
        gl = ctx.gl
        prog = ctx.program(REST_SHADER)
        w, h = ctx.size
        fbo = gl.framebuffer([target], gl.depth_buffer((w, h)))
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        fbo.use()
        gl.ctx.viewport = (0, 0, w, h)
        crease = self.params.crease_angle
        with gl.depth_test() as state:
            for obj in objects:
                model = np.asarray(obj.transform, dtype=np.float64)
                vao, diag, rest_diag, local = _rest_geometry(gl, prog, obj.mesh, crease)
                u_view, u_model = origin.relative_matrices(view, model, world, local)
                bind(prog, {}, {"u_model": u_model, "u_view": u_view, "u_proj": proj,
                                "u_enlarge": self._enlarge(diag, model, scene_diag),
                                "u_rest_enlarge": self._enlarge(rest_diag, model, scene_diag)})
                state.cull(_cull_face(obj, self.params.backfaces))
                vao.render(gl.ctx.TRIANGLES)


    def _motion_pass(self, ctx: RunContext, scene: Any, objects: list[Any], now: tuple[np.ndarray, ...],
                     scene_diag: float) -> Any:
        """`motion`: the geometry drawn again as the main pass draws it (own depth buffer, the same enlargement
        and culling), each fragment writing the previous frame's window position and depth of its surface point.
        Alpha cut-outs (glTF MASK) are cut as the main pass cuts them."""
        gl = ctx.gl
        w, h = ctx.size
        view, world, proj = now
        prev_scene, prev_frame = previous_scene(scene, ctx.frame)
        prev_cam = prev_scene.camera_at(prev_frame)
        prev_view, prev_proj = prev_cam.view_matrix(), prev_cam.projection_matrix(w / h)
        prev_world = origin.world_origin(prev_scene, prev_cam)
        target = ctx.target("motion", filter="nearest")
        prog = ctx.program(MOTION_SHADER)
        fbo = gl.framebuffer([target], gl.depth_buffer((w, h)))
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        fbo.use()
        gl.ctx.viewport = (0, 0, w, h)
        crease = self.params.crease_angle
        enlarging = self.params.enlarge > 0
        with gl.depth_test() as state:
            for obj in objects:
                prev = prev_scene.objects[obj.index] if obj.index < len(prev_scene.objects) else obj
                prev_mesh = prev.mesh if prev.mesh.n_vertices == obj.mesh.n_vertices else obj.mesh
                surface = _surface(obj)
                if surface is not None and surface.material.alpha_mode != "MASK":
                    surface = None  # only a cut-out changes what the motion pass covers
                oprog = prog if surface is None else ctx.program(MOTION_SHADER, _surface_defines(surface))
                vao, diag, prev_diag, local = _motion_geometry(gl, oprog, obj.mesh, prev_mesh, crease, enlarging,
                                                               surface is not None)
                model = np.asarray(obj.transform, dtype=np.float64)
                prev_model = np.asarray(prev.transform, dtype=np.float64)
                u_view, u_model = origin.relative_matrices(view, model, world, local)
                p_view, p_model = origin.relative_matrices(prev_view, prev_model, prev_world, local)
                tex, surface_uniforms = _surface_bindings(gl, surface)
                bind(oprog, tex, {**surface_uniforms, "u_mvp": proj @ (u_view @ u_model),
                                  "u_prev_mvp": prev_proj @ (p_view @ p_model),
                                  "u_enlarge": self._enlarge(diag, model, scene_diag) if enlarging else 0.0,
                                  "u_prev_enlarge": self._enlarge(prev_diag, prev_model, scene_diag) if enlarging
                                  else 0.0, "u_size": (float(w), float(h))})
                state.cull(_cull_face(obj, self.params.backfaces))
                vao.render(gl.ctx.TRIANGLES)
        return target

    def _spin_pass(self, ctx: RunContext, scene: Any, objects: list[Any], now: tuple[np.ndarray, ...],
                   scene_diag: float) -> Any:
        """`spin`: the geometry drawn again as the main pass draws it (own depth buffer, the same enlargement and
        culling), each fragment writing the turn in the picture's plane of its surface point since frame 0
        (spin.glsl)."""
        gl = ctx.gl
        w, h = ctx.size
        view, world, proj = now
        first = scene_at(scene, 0)
        first_view = np.asarray(first.camera_at(0).view_matrix(), dtype=np.float64)
        target = ctx.target("spin", filter="nearest")
        fbo = gl.framebuffer([target], gl.depth_buffer((w, h)))
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        fbo.use()
        gl.ctx.viewport = (0, 0, w, h)
        enlarging = self.params.enlarge > 0
        with gl.depth_test() as state:
            for obj in objects:
                then = first.objects[obj.index] if obj.index < len(first.objects) else obj
                then_mesh = then.mesh if then.mesh.n_vertices == obj.mesh.n_vertices else obj.mesh
                model = np.asarray(obj.transform, dtype=np.float64)
                then_lin = first_view[:3, :3] @ np.asarray(then.transform, dtype=np.float64)[:3, :3]
                if abs(np.linalg.det(then_lin)) <= 1e-300:
                    then_lin = np.eye(3)
                surface = _surface(obj)
                if surface is not None and surface.material.alpha_mode != "MASK":
                    surface = None  # only a cut-out changes what the pass covers
                defines = {**({"PER_VERTEX": 1} if _skinned(obj.mesh, then_mesh) else {}),
                           **(_surface_defines(surface) if surface is not None else {})}
                prog = ctx.program(SPIN_SHADER, defines or None)
                vao, diag, local = _spin_geometry(gl, prog, obj.mesh, then_mesh, self.params.crease_angle, enlarging,
                                                  surface is not None)
                u_view, u_model = origin.relative_matrices(view, model, world, local)
                tex, surface_uniforms = _surface_bindings(gl, surface)
                bind(prog, tex, {**surface_uniforms, "u_mvp": proj @ (u_view @ u_model),
                                 "u_now": view[:3, :3] @ model[:3, :3], "u_then": np.linalg.inv(then_lin),
                                 "u_enlarge": self._enlarge(diag, model, scene_diag) if enlarging else 0.0})
                state.cull(_cull_face(obj, self.params.backfaces))
                vao.render(gl.ctx.TRIANGLES)
        return target


REST_SHADER = "rest_position.glsl"
MOTION_SHADER = "motion.glsl"
SPIN_SHADER = "spin.glsl"


def scene_at(scene: Any, frame: int) -> Any:
    """The scene as it is at `frame`: the animated scene's pose there where `scene` is a pose (`Scene.at`), else
    the scene itself (whose camera_at(frame) turns its orbit)."""
    source = scene.animated_source() if hasattr(scene, "animated_source") else None
    return scene if source is None else source.at(frame)


def skin_turn(mesh: Any, first: Any) -> np.ndarray | None:
    """(n, 3, 3): each vertex's skin linear part now times its inverse at frame 0 (`first` the mesh then), or None
    where the mesh is not skinned (a rigid or morph-only mesh turns with its object)."""
    if not _skinned(mesh, first):
        return None
    key = first.content_hash()  # a digest of what shaped it: the frame-0 pose is the same for every frame
    inv = _FIRST_INVERSE.get(key)
    if inv is None:
        then = np.asarray(first.skin_linear, dtype=np.float64)
        ok = np.abs(np.linalg.det(then)) > 1e-12
        inv = np.broadcast_to(np.eye(3), then.shape).copy()
        inv[ok] = np.linalg.inv(then[ok])
        _FIRST_INVERSE[key] = inv
        while len(_FIRST_INVERSE) > 4:
            _FIRST_INVERSE.pop(next(iter(_FIRST_INVERSE)))
    return np.einsum("nij,njk->nik", np.asarray(mesh.skin_linear, dtype=np.float64), inv)


_FIRST_INVERSE: dict[str, np.ndarray] = {}  # frame-0 mesh hash -> its vertices' inverse skin linear parts (skin_turn)


def _skinned(mesh: Any, first: Any) -> bool:
    now, then = getattr(mesh, "skin_linear", None), getattr(first, "skin_linear", None)
    return now is not None and then is not None and len(now) == len(then)


def _spin_geometry(gl: Any, prog: Any, mesh: Any, first: Any, crease_angle: float, enlarging: bool,
                   surface: bool = False) -> tuple[Any, float, np.ndarray]:
    """The spin pass's vertex array over a mesh (and, for a skinned mesh, each render vertex's `skin_turn` against
    `first`, the mesh at frame 0), its diagonal and its positions' origin. `surface`: with the glTF surface's
    texture coordinates and vertex colours, for a cut-out."""
    per_vertex = _skinned(mesh, first)

    def build() -> MeshArrays:
        ra = mesh.render_arrays(crease_angle)
        local = origin.mesh_origin(mesh)
        pos = origin.positions(mesh, ra, local)
        smooth = enlarge_normals(mesh, crease_angle) if enlarging else np.zeros_like(pos)
        k = skin_turn(mesh, first)[ra.source_vertex].astype(np.float32) if per_vertex else None
        indices, extra = ra.indices, {}
        if surface:
            vertex, indices, extra = _surface_arrays(mesh, ra)
            pos, smooth, k = pos[vertex], smooth[vertex], (k[vertex] if k is not None else None)
        attrs: dict[str, tuple[np.ndarray, str]] = {"in_pos": (pos, "3f"), "in_smooth": (smooth, "3f"), **extra}
        if k is not None:
            attrs.update({f"in_k{c}": (np.ascontiguousarray(k[:, :, c]), "3f") for c in range(3)})
        return MeshArrays(attrs, indices, meta={"diag": mesh.diagonal(), "origin": local})

    kind = "rasterize.spin.surface" if surface else "rasterize.spin"
    key = (kind, mesh.content_hash(), first.content_hash() if per_vertex else None, float(crease_angle), enlarging)
    rest = mesh.rest
    slot = (kind, rest.content_hash(), float(crease_angle), enlarging, per_vertex) if rest is not None else None
    entry = gl.mesh_buffers(key, build, slot)
    return entry.vao(prog), entry.meta["diag"], entry.meta["origin"]


def previous_scene(scene: Any, frame: int) -> tuple[Any, int]:
    """The scene as it was one frame before `frame`, and that frame (`scene_at`); at frame 0 the scene itself at
    frame 0 (no motion)."""
    if frame == 0:
        return scene, 0
    return scene_at(scene, frame - 1), frame - 1


def _motion_geometry(gl: Any, prog: Any, mesh: Any, prev_mesh: Any, crease_angle: float, enlarging: bool,
                     surface: bool = False) -> tuple[Any, float, float, np.ndarray]:
    """The motion pass's vertex array over a mesh and its previous frame's pose (same faces), the two
    diagonals, and the positions' origin (both poses relative to the current one's). `surface`: with the glTF
    surface's texture coordinates and vertex colours (`_surface_arrays`), for a cut-out."""

    def build() -> MeshArrays:
        ra = mesh.render_arrays(crease_angle)
        local = origin.mesh_origin(mesh)
        pos = origin.positions(mesh, ra, local)
        prev_pos = (np.asarray(prev_mesh.vertices, dtype=np.float64)[ra.source_vertex] - local).astype(np.float32)
        if enlarging:
            smooth = enlarge_normals(mesh, crease_angle)
            prev_smooth = smooth if prev_mesh is mesh else enlarge_normals(prev_mesh, crease_angle)
        else:
            smooth = prev_smooth = np.zeros_like(pos)
        indices, extra = ra.indices, {}
        if surface:
            vertex, indices, extra = _surface_arrays(mesh, ra)
            pos, prev_pos, smooth, prev_smooth = pos[vertex], prev_pos[vertex], smooth[vertex], prev_smooth[vertex]
        return MeshArrays({"in_pos": (pos, "3f"), "in_smooth": (smooth, "3f"), "in_prev": (prev_pos, "3f"),
                           "in_prev_smooth": (prev_smooth, "3f"), **extra}, indices,
                          meta={"diag": mesh.diagonal(), "prev_diag": prev_mesh.diagonal(), "origin": local})

    kind = "rasterize.motion.surface" if surface else "rasterize.motion"
    key = (kind, mesh.content_hash(), prev_mesh.content_hash(), float(crease_angle), enlarging)
    slot = (kind, mesh.rest.content_hash(), float(crease_angle), enlarging) if mesh.rest is not None else None
    entry = gl.mesh_buffers(key, build, slot)
    return entry.vao(prog), entry.meta["diag"], entry.meta["prev_diag"], entry.meta["origin"]


def _cull_face(obj: Any, backfaces: str) -> str | None:
    """The faces one draw culls: back faces (front ones for mirrored objects) for closed meshes under `auto`,
    or under `cull`; None draws both sides.

    Drawing back faces in a second, front-culled draw after the front faces was measured as no faster
    on llvmpipe (the rejected fragments still cost their setup), so open meshes take one two-sided draw."""
    cull = backfaces == "cull" or (backfaces == "auto" and obj.mesh.hole_share() <= HOLE_SHARE_CULL)
    if not cull:
        return None
    return "front" if bool(getattr(obj, "mirrored", False)) else "back"


def _surface(obj: Any) -> Any:
    """The object's glTF surface (meshes.Surface) where it colours it: the mesh has one and the object's colour is
    the material's own (a colour given in a scene YAML paints the object flat, as before)."""
    surface = getattr(obj.mesh, "surface", None)
    if surface is None or tuple(obj.color) != tuple(surface.material.flat):
        return None
    return surface


def _surface_defines(surface: Any) -> dict[str, Any]:
    m = surface.material
    return {"SURFACE": 1, "TEXTURE": int(m.texture is not None), "VCOLOR": int(surface.colors is not None),
            "MASK": int(m.alpha_mode == "MASK")}


def _surface_bindings(gl: Any, surface: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """Textures and uniforms of a surface's draw ({} and {} for a flat colour)."""
    if surface is None:
        return {}, {}
    m, t = surface.material, surface.material.texture
    uniforms: dict[str, Any] = {"u_factor": tuple(float(c) for c in m.factor), "u_cutoff": float(m.alpha_cutoff)}
    if t is None:
        return {}, uniforms
    uniforms.update({"u_uv_row0": tuple(t.transform[:3]), "u_uv_row1": tuple(t.transform[3:]),
                     "u_mirror": tuple(float(wr == meshes.WRAP_MIRROR) for wr in t.wrap)})
    repeat = tuple(wr != meshes.WRAP_CLAMP for wr in t.wrap)
    tex = gl.image_texture(("rasterize.base", t.digest, t.min_filter, t.mag_filter, repeat), t.pixels,
                           filters=(t.min_filter, t.mag_filter), repeat=repeat)
    return {"t_base": tex}, uniforms


def _surface_arrays(mesh: Any, ra: Any) -> tuple[np.ndarray, np.ndarray, dict[str, tuple[np.ndarray, str]]]:
    """Render vertices split again where the glTF vertices they came from differ (a texture seam, a vertex colour
    edge): (render vertex of each new vertex, new triangles, the new vertices' surface attributes)."""
    surface = mesh.surface
    render = np.asarray(ra.indices, dtype=np.int64).reshape(-1)
    source = np.asarray(mesh.faces, dtype=np.int64).reshape(-1)
    keys, inverse = np.unique(render * max(mesh.n_vertices, 1) + source, return_inverse=True)
    vertex, src = keys // max(mesh.n_vertices, 1), keys % max(mesh.n_vertices, 1)
    tex = surface.material.texture
    uv = surface.uvs[tex.texcoord][src] if tex is not None else np.zeros((len(src), 2), np.float32)
    colors = surface.colors[src] if surface.colors is not None else np.ones((len(src), 4), np.float32)
    return vertex, inverse.reshape(-1, 3).astype(np.uint32), {"in_uv": (uv, "2f"), "in_vcolor": (colors, "4f")}


def _geometry(gl: Any, prog: Any, mesh: Any, crease_angle: float, surface: bool = False
              ) -> tuple[Any, float, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """The program's vertex array over the mesh's buffers (per mesh content and crease angle), the
    mesh's bounding-box diagonal, the object-space origin its positions are relative to, and the drawn
    positions and enlargement directions as (3, N) float32 rows (for `_pixel_box`). `surface`: with the glTF
    surface's texture coordinates and vertex colours (`_surface_arrays`)."""

    def build() -> MeshArrays:
        ra = mesh.render_arrays(crease_angle)
        bmin, bmax = mesh.bounds()
        local = origin.mesh_origin(mesh)
        pos, smooth = origin.positions(mesh, ra, local), enlarge_normals(mesh, crease_angle)
        normals, indices, extra = ra.normals, ra.indices, {}
        if surface:
            vertex, indices, extra = _surface_arrays(mesh, ra)
            pos, smooth, normals = pos[vertex], smooth[vertex], normals[vertex]
        # the drawn positions and directions as (3, N) rows, projected each frame for the outputs' footprint
        points = (np.ascontiguousarray(pos.T, dtype=np.float32), np.ascontiguousarray(smooth.T, dtype=np.float32))
        return MeshArrays({"in_pos": (pos, "3f"), "in_normal": (normals, "3f"), "in_smooth": (smooth, "3f"), **extra},
                          indices, meta={"diag": float(np.linalg.norm(np.asarray(bmax) - np.asarray(bmin))),
                                         "origin": local, "points": points})

    kind = "rasterize.surface" if surface else "rasterize.mesh"
    # a posed part's buffers take each frame's vertices in place (slot: its rest pose)
    slot = (kind, mesh.rest.content_hash(), float(crease_angle)) if mesh.rest is not None else None
    entry = gl.mesh_buffers((kind, mesh.content_hash(), float(crease_angle)), build, slot)
    return entry.vao(prog), entry.meta["diag"], entry.meta["origin"], entry.meta["points"]


BOX_MARGIN = 2
"""Pixels added around an object's projected vertices: the rasteriser snaps them to a sub-pixel grid."""


def _pixel_box(mvp: np.ndarray, points: tuple[np.ndarray, np.ndarray], enlarge: float,
               size: tuple[int, int]) -> tuple[int, int, int, int] | None:
    """The pixels an object can cover: the box of its drawn vertices' projections, moved along their
    enlargement directions as the vertex stage moves them (None: one lies behind the eye). Ogre's 62k vertices
    take about 0.6 ms a frame."""
    pos, smooth = points
    if enlarge > 0:
        pos = pos + np.float32(enlarge) * smooth
    return footprint.project_points(mvp, pos, size, BOX_MARGIN)


def _rest_geometry(gl: Any, prog: Any, mesh: Any, crease_angle: float) -> tuple[Any, float, float, np.ndarray]:
    """The rest pass's vertex array over a mesh (posed position and enlargement direction, and the rest
    pose's), the posed and the rest diagonals, and the posed positions' origin."""

    def build() -> MeshArrays:
        ra = mesh.render_arrays(crease_angle)
        local = origin.mesh_origin(mesh)
        pos, smooth = origin.positions(mesh, ra, local), enlarge_normals(mesh, crease_angle)
        rest = mesh.rest
        if rest is None:
            rest_pos, rest_smooth, rest_diag = pos, smooth, mesh.diagonal()
        else:
            rest_pos = (rest.vertices[ra.source_vertex] - origin.mesh_origin(rest)).astype(np.float32)
            rest_smooth, rest_diag = enlarge_normals(rest, crease_angle, ra), rest.diagonal()
        return MeshArrays({"in_pos": (pos, "3f"), "in_smooth": (smooth, "3f"), "in_rest": (rest_pos, "3f"),
                           "in_rest_smooth": (rest_smooth, "3f")}, ra.indices,
                          meta={"diag": mesh.diagonal(), "rest_diag": rest_diag, "origin": local})

    slot = ("rasterize.rest", mesh.rest.content_hash(), float(crease_angle)) if mesh.rest is not None else None
    entry = gl.mesh_buffers(("rasterize.rest", mesh.content_hash(), float(crease_angle)), build, slot)
    return entry.vao(prog), entry.meta["diag"], entry.meta["rest_diag"], entry.meta["origin"]


def enlarge_normals(mesh: Any, crease_angle: float = 40.0, render_arrays: Any = None) -> np.ndarray:
    """(k, 3) direction of enlargement for each vertex of `mesh.render_arrays(crease_angle)`.

    The angle-weighted normal of the faces around the vertex's welded position that belong to the
    vertex's own connected component: every render vertex at one welded position of one component gets
    the same direction (no cracks where normals are split), and components that touch keep their own.

    `render_arrays`: the render vertices to give directions for (default: the mesh's own, and then the
    directions of a large mesh are kept on disk, nodegraph/scene/meshstore.py: ogre's took 0.12 s); a posed mesh's,
    to read the directions of its rest pose (`mesh` the rest mesh, same vertices and faces).
    """
    if render_arrays is not None and render_arrays.source_vertex is not mesh.render_arrays(crease_angle).source_vertex:
        return _enlarge_normals(mesh, render_arrays)
    posed = posing.enlarge_directions(mesh, crease_angle)  # a posed part: with all parts posed with it
    if posed is not None:
        return posed

    def make() -> dict[str, np.ndarray]:
        return {"value": _enlarge_normals(mesh, mesh.render_arrays(crease_angle))}

    # kept on the mesh too: a posed part's rest pose is asked for its directions every frame (the rest pass), and
    # without a store they were found again each time (79 ms a frame for a 100k-vertex skin)
    return mesh._cached(("rasterize.enlarge", float(crease_angle)), lambda: meshstore.memo_arrays(
        mesh, f"enlarge{float(crease_angle)!r}", make, (__file__, meshes.__file__), ("value",))["value"])


def _enlarge_normals(mesh: Any, ra: Any) -> np.ndarray:
    welded, _ = mesh.weld()
    faces = mesh.faces
    comp = mesh.face_components().astype(np.int64)
    n_comp = int(comp.max()) + 1 if len(comp) else 1
    p = mesh.vertices[faces]  # (m, 3, 3)
    e = np.roll(p, -1, axis=1) - p  # e[:, i] = p[i+1] - p[i]
    cross = np.cross(e[:, 0], -e[:, 2])
    area2 = np.linalg.norm(cross, axis=1)
    face_n = np.divide(cross, area2[:, None], out=np.zeros_like(cross), where=area2[:, None] > 0)
    cos = -np.einsum("mij,mij->mi", e, np.roll(e, 1, axis=1))
    angles = np.arctan2(np.broadcast_to(area2[:, None], cos.shape), cos)  # corner angles (m, 3)
    corner_key = (welded[faces] * n_comp + comp[:, None]).ravel()
    keys, inverse = np.unique(corner_key, return_inverse=True)
    contrib = (face_n[:, None, :] * angles[:, :, None]).reshape(-1, 3)
    acc = np.stack([np.bincount(inverse, contrib[:, k], minlength=len(keys)) for k in range(3)], axis=1)
    length = np.linalg.norm(acc, axis=1)
    ok = length > 1e-12
    acc[ok] /= length[ok, None]
    vertex_key = welded[ra.source_vertex] * n_comp + ra.component.astype(np.int64)
    slot = np.clip(np.searchsorted(keys, vertex_key), 0, len(keys) - 1)
    found = (keys[slot] == vertex_key) & ok[slot]
    return np.where(found[:, None], acc[slot], ra.smooth_normals).astype(np.float32)


_WARNED: set[str] = set()
# far/near beyond which float32 window depth no longer separates nearby surfaces (measured break at
# 5e5 in docs/stability.md; linear view depth, used by edge_detect, holds to 1e6)
DEPTH_RANGE_WARN = 1e5


def _warn_depth_range_once(cam: Any, window_depth: bool) -> None:
    if getattr(cam, "orthographic", False):  # window depth is linear in view depth: no far/near limit (near may be 0)
        return
    ratio = cam.far / cam.near
    key = f"depth-range:{ratio:.3g}:{window_depth}"
    if ratio <= DEPTH_RANGE_WARN or key in _WARNED:
        return
    _WARNED.add(key)
    what = ("window depth (rasterize.depth, used by depth sprites) loses precision beyond 1e5 and fails at 5e5"
            if window_depth else "linear depth holds to about 1e6")
    warnings.warn(f"camera far/near = {ratio:.3g}: {what}; bring the near plane closer to the geometry",
                  RuntimeWarning, stacklevel=3)



def _warn_enlarge_once(mesh: Any) -> None:
    """One MeshWarning per mesh file and process when enlargement had to weld or split by component."""
    key = mesh.content_hash()
    if key in _WARNED or not mesh.source:
        return
    _WARNED.add(key)
    topo = mesh.topology()
    if topo.n_welded == 0 and topo.n_components <= 1:
        return
    done = []
    if topo.n_welded:
        done.append(f"welded {topo.n_welded} coincident vertices (split normals) before computing normals")
    if topo.n_components > 1:
        done.append(f"enlarged each of its {topo.n_components} connected components along its own normals")
    where = f" ({mesh.source})" if mesh.source else ""
    warnings.warn(f"mesh '{mesh.name}'{where} is not one connected surface with shared normals, which enlargement "
                  f"assumes (paper §4.2): " + " and ".join(done), MeshWarning, stacklevel=2)


NODE = Rasterize
