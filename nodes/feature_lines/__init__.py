"""feature_lines: suggestive contours, ridges and valleys from per-vertex curvature, drawn as screen-space
line maps (DeCarlo et al. 2003; Ohtake, Belyaev and Seidel 2004)."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from nodegraph.errors import NodeError
from nodegraph.gpu import footprint
from nodegraph.node import HashContext, Input, Node, NodeParams, Output, RunContext
from nodegraph.scene import origin
from nodegraph.types import ARRAYS, SCENE, Texture
from nodegraph.values import Footprint

from .._shared import feature_lines as lines
from .._shared.curvature import object_field

_KINDS = ("suggestive", "ridges", "valleys")


class FeatureLines(Node):
    """Object-space feature lines, drawn into edge maps like edge_detect's (1 = line). From the curvature
    node's per-vertex principal curvatures and directions (connect one with `smoothing: 0`: the measured
    directions), per frame on the CPU: the radial curvature kappa_r = k1 cos^2 phi + k2 sin^2 phi of the
    view direction projected into each vertex's tangent plane and its face gradients; suggestive contours
    are its zeros inside triangles where D_w kappa_r > 0, trimmed as DeCarlo et al. 2003 trim them
    (D_w kappa_r / |w| > t_d, theta > theta_c), none inside planar regions (docs/feature_lines.md). Ridges
    (maxima of k1 along e1, k1 > |k2|) and valleys (minima of k2 along e2, k2 < -|k1|) after Ohtake et al.
    2004 are frame-independent and extracted once per mesh. Segments on back faces are dropped; the rest are
    drawn `width` pixels wide and hidden where the G-buffer (normal_depth, w = linear depth) is nearer than the
    line by more than `depth_tolerance`.
    `out` is the maximum of the connected `edges` and every kind times its intensity. Objects are assumed
    rigidly placed (uniform scale at most); the view vector is taken in object space."""

    version = "2"
    shaders = ("feature_lines.glsl", "edges.glsl")
    context_keys = frozenset({"size", "frame", "scene", "camera", "px_scale"})
    inputs = {
        "curvature": Input(ARRAYS, "Per-object curvature arrays (curvature.out, best with smoothing: 0)."),
        "normal_depth": Input(Texture("RGBA32F"), "G-buffer normal and linear depth (rasterize.normal_depth): "
                              "the occluders, and the output size."),
        "edges": Input(Texture("R16F"), "An edge map (edge_detect.out) combined into `out` by maximum.",
                       optional=True),
        "scene": Input(SCENE, "Scene to draw; the pipeline's scene when not connected.", optional=True),
    }
    outputs = {
        "out": Output(Texture("R16F"), "max(edges, suggestive x suggestive_intensity, ridges x "
                      "ridge_intensity, valleys x valley_intensity)."),
        "suggestive": Output(Texture("R16F"), "Suggestive contours only."),
        "ridges": Output(Texture("R16F"), "Ridges only."),
        "valleys": Output(Texture("R16F"), "Valleys only."),
    }

    class Params(NodeParams):
        derivative_threshold: float = Field(2.0, ge=0, le=1e4, description="t_d: suggestive contours need "
                                            "D_w kappa_r / |w| x (bounding-box diagonal)^2 above this (full "
                                            "intensity at twice it).")
        angle_threshold: float = Field(25.0, ge=0, lt=90, description="theta_c in degrees: no suggestive "
                                       "contours where the view and the normal are closer than this (full "
                                       "intensity 10 degrees beyond).")
        ridge_threshold: float = Field(20.0, ge=0, le=1e4, description="Ridges and valleys need |k| x "
                                       "bounding-box diagonal above this (full intensity at twice it).")
        curvature_smoothing: float = Field(0.01, ge=0, le=0.2, description="k1 and k2 are diffused over this "
                                           "fraction of the bounding-box diagonal (RMS radius) before the lines "
                                           "are extracted, whatever the mesh density: averages out scanner noise.")
        min_length: float = Field(0.03, ge=0, le=1, description="Chains of segments (connected across mesh "
                                  "edges) shorter than this fraction of the bounding-box diagonal are dropped: "
                                  "curvature noise on scanned meshes gives many short fragments.")
        chain_strength: float = Field(0.5, ge=0, le=1, description="Hysteresis: a chain is kept only where its "
                                      "strongest point reaches this intensity; its weaker parts stay with it.")
        width: float = Field(2.0, ge=1, le=8, description="Line width in pixels at the reference size (times "
                             "px_scale; below one pixel: drawn one pixel wide at that fraction of the intensity).")
        depth_tolerance: float = Field(0.01, ge=0, le=0.5, description="A line is hidden where the G-buffer "
                                       "is nearer by more than this fraction of its depth.")
        suggestive_intensity: float = Field(1.0, ge=0, le=1, description="Suggestive contours in `out`.")
        ridge_intensity: float = Field(0.8, ge=0, le=1, description="Ridges in `out`.")
        valley_intensity: float = Field(0.8, ge=0, le=1, description="Valleys in `out`.")

    def hash_extra(self, ctx: HashContext) -> Any:
        return origin.hash_extra(ctx.scene, ctx.frame)

    def segments(self, ctx: RunContext, curv: Any, index: int, mesh: Any, eye_object: np.ndarray,
                 kinds: set[str], keep: int = 8) -> dict[str, lines.Segments]:
        """The segments of each kind in `kinds` for one object, seen from `eye_object` (object space; a
        homogeneous (4,) direction at infinity for an orthographic camera, lines.towards_eye). The per-mesh data
        (operators, smoothed curvature, ridges and valleys) is kept for the last `keep` meshes (at least 8): a
        frame of a scene asks for every object's, so `keep` is at least the scene's object count."""
        p = self.params
        name = object_field(index, "kmin")
        if name not in curv.data:
            raise NodeError(f"the curvature input has no arrays for object {index}; connect the curvature node "
                            "of the same scene", self.id, self.type_name)
        if curv.data[name].shape != (mesh.n_vertices,):
            raise NodeError(f"curvature of object {index} has {curv.data[name].shape[0]} vertices, its mesh "
                            f"{mesh.n_vertices}; connect the curvature node of the same scene", self.id,
                            self.type_name)
        ckey = str(curv.data.get(object_field(index, "key"), ""))
        cache = ctx.gl.resources.setdefault("feature_lines.ops", {})
        base = (mesh.content_hash(), ckey, p.curvature_smoothing)
        entry = cache.get(base)
        if entry is None:
            while len(cache) >= max(8, keep):  # the oldest first
                cache.pop(next(iter(cache)))
            arr = {k: curv.data[object_field(index, k)] for k in ("kmin", "kmax", "dmin", "dmax", "normal",
                                                                  "confidence")}
            weld = mesh.weld()[0]
            ops = lines.mesh_ops(mesh.vertices, mesh.faces, **arr, weld=weld)
            ops = lines.smooth_curvature(ops, p.curvature_smoothing * ops.diag, weld)
            entry = cache[base] = {"ops": ops, "ext": lines.extrema_data(ops, weld), "weld": weld}
        ops, weld = entry["ops"], entry["weld"]
        min_len = p.min_length * ops.diag

        def filtered(seg: lines.Segments) -> lines.Segments:
            return lines.filter_chains(seg, min_len, weld, p.chain_strength)

        out: dict[str, lines.Segments] = {}
        if "suggestive" in kinds:
            out["suggestive"] = filtered(lines.suggestive_contours(ops, eye_object, p.derivative_threshold,
                                                                   p.angle_threshold))
        for kind, label in (("ridges", "ridge"), ("valleys", "valley")):
            if kind not in kinds:
                continue
            rkey = (kind, p.ridge_threshold, min_len, p.chain_strength)
            if rkey not in entry:
                entry[rkey] = filtered(lines.ridges(ops, entry["ext"], p.ridge_threshold, label))
            seg = entry[rkey]
            out[kind] = seg.select(lines.front_facing(ops, seg.face, eye_object))
        return out

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        gl = ctx.gl
        scene = ctx.input_scene(inputs)
        nd = inputs["normal_depth"]
        edges = inputs.get("edges")
        if edges is not None and edges.size != nd.size:
            raise NodeError(f"edges are {edges.size[0]}x{edges.size[1]}, normal_depth {nd.size[0]}x{nd.size[1]}; "
                            "give both the same size", self.id, self.type_name)
        w, h = nd.size
        cam = scene.camera_at(ctx.frame)
        view = cam.view_matrix()
        proj = cam.projection_matrix(w / h)
        # the eye in homogeneous coordinates: a point, or (for an orthographic camera) the direction towards the
        # viewer at infinity (w = 0), which inverse model matrices carry into object space all the same
        eye = np.r_[np.linalg.inv(view)[:3, 3], 1.0] if not cam.orthographic else cam.toward_eye()
        world = origin.world_origin(scene, cam)
        kinds = {k for k in _KINDS if k in needed} | (set(_KINDS) if "out" in needed else set())
        weights = {"suggestive": p.suggestive_intensity, "ridges": p.ridge_intensity, "valleys": p.valley_intensity}
        if "out" in needed:
            kinds = {k for k in kinds if k in needed or weights[k] > 0.0}
        per_object = []
        for index, obj in enumerate(scene.objects):
            if obj.mesh.n_faces == 0:
                continue
            model = np.asarray(obj.transform, dtype=np.float64)
            eye_obj = np.linalg.inv(model) @ eye
            if not cam.orthographic:
                eye_obj = eye_obj[:3]
            per_object.append((obj, model, self.segments(ctx, inputs["curvature"], index, obj.mesh, eye_obj, kinds,
                                                         keep=len(scene.objects))))
        line_width, line_scale = self.drawn_width(ctx.px_scale)
        targets = {port: ctx.target(port, nd.size) for port in ("out", *_KINDS) if port in needed}
        # where each port can be drawn on: its segments' projected points grown by half the quad's width (the
        # quads' ends reach that far past the points), and the edges' footprint where they are copied in
        margin = int(np.ceil(0.5 * line_width * np.sqrt(2.0))) + 2
        rects: dict[str, list[tuple[int, int, int, int] | None]] = {port: [] for port in targets}
        for port, target in targets.items():
            with_edges = port == "out" and edges is not None
            fbo = gl.framebuffer([target], gl.depth_buffer((w, h)))
            fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            if with_edges:  # no depth test: the copy leaves the cleared depth as it is
                gl.fullscreen(ctx.program("edges.glsl"), [target], textures={"t_edges": edges}, fbo=fbo)
                fp = footprint.of(edges)
                rects[port].append(fp.rect if fp is not None and fp.blank == (0.0,) else None)
            prog = ctx.program("feature_lines.glsl", {"EDGES": int(with_edges)})
            fbo.use()
            gl.ctx.viewport = (0, 0, w, h)
            textures = {"t_normal_depth": nd}
            if with_edges:
                textures["t_edges"] = edges
            with gl.depth_test("<"):
                for obj, model, segs in per_object:
                    parts = [(segs[k], weights[k] if port == "out" else 1.0) for k in _KINDS
                             if k in segs and (port == "out" or port == k)]
                    parts = [(s, wt) for s, wt in parts if len(s) and wt > 0.0]
                    if not parts:
                        continue
                    local = origin.mesh_origin(obj.mesh)
                    pts = np.concatenate([s.points for s, _ in parts]).reshape(-1, 3) - local
                    inten = np.concatenate([s.intensity * wt for s, wt in parts]).reshape(-1)
                    u_view, u_model = origin.relative_matrices(view, model, world, local)
                    rects[port].append(footprint.project_points(proj @ u_view @ u_model, pts.T, (w, h), margin))
                    _draw(gl, prog, textures, {"u_model": u_model, "u_view": u_view, "u_proj": proj,
                                               "u_viewport": (float(w), float(h)), "u_width": float(line_width),
                                               "u_depth_tolerance": p.depth_tolerance, "u_scale": line_scale},
                          pts, inten)
        for port, target in targets.items():  # cleared to 0, drawn on only there
            rect = footprint.union(rects[port])
            if rect is not None:
                target.footprint = Footprint(rect, (0.0,))
        return targets

    def drawn_width(self, px_scale: float) -> tuple[float, float]:
        """(quad width in pixels, intensity factor) at px_scale: width x px_scale, and a line thinner than a
        pixel drawn one pixel wide at that fraction of the intensity (its coverage), so it fades, not drops."""
        w = self.params.width * px_scale
        return (w, 1.0) if w >= 1.0 else (1.0, w)


def _draw(gl: Any, prog: Any, textures: dict[str, Any], uniforms: dict[str, Any], pts: np.ndarray,
          inten: np.ndarray) -> None:
    from nodegraph.gpu.gl import bind

    data = np.concatenate([pts.astype(np.float32), inten.astype(np.float32)[:, None]], axis=1)
    buf = gl.ctx.buffer(np.ascontiguousarray(data).tobytes())
    try:
        vao = gl.ctx.vertex_array(prog, [(buf, "3f 1f", "in_pos", "in_intensity")])
        try:
            bind(prog, textures, uniforms)
            vao.render(gl.ctx.LINES)
        finally:
            vao.release()
    finally:
        buf.release()


NODE = FeatureLines
