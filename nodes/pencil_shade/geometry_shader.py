"""The previous implementation of pencil_shade (node version 1): one geometry pass whose geometry shader hands
every fragment its triangle's three directions and its barycentric coordinates, shading every fragment as it
is drawn, then a full-screen composite. The node no longer uses it; it stays as the reference the deferred
implementation is measured against in one run (`sketchgraph bench pencil-shade`) and compared with pixel for
pixel (tests/nodes/pencil_shade). `compute(node, ctx, inputs, needed)` takes what `PencilShade.compute`
takes and gives the same outputs."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from nodegraph.gpu.gl import MeshArrays, bind
from nodegraph.node import RunContext
from nodegraph.scene import origin

from .._shared.curvature import object_field
from .._shared.pencil import view_light
from . import reference

SHADER = "geometry_shader.glsl"
COMPOSITE = "geometry_shader_composite.glsl"
_GEOMETRY_PORTS = {"shade": "LOC_SHADE", "blend": "LOC_BLEND"}


def compute(node: Any, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
    from . import _sampler, vertex_directions

    p = node.params
    gl = ctx.gl
    scene = ctx.input_scene(inputs)
    curv = inputs["curvature"]
    tam = inputs["tam"]
    paper = inputs.get("paper")
    contour = inputs.get("contour")
    geo_ports = ["shade"] + (["blend"] if "blend" in needed else [])  # shade also feeds `color`
    defines: dict[str, Any] = {_GEOMETRY_PORTS[port]: i for i, port in enumerate(geo_ports)}
    defines.update(LAYERS=p.layers, PAPER=int(paper is not None))
    prog = ctx.program(SHADER, defines)
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
    view = cam.view_matrix()
    world = origin.world_origin(scene, cam)
    proj = cam.projection_matrix(w / h)
    textures: dict[str, Any] = {"t_tam": tam}
    if paper is not None:
        textures["t_paper"] = paper
    fallback = math.radians(p.fallback_angle)
    light = view_light(scene, cam)
    texel_scale = node.texel_scale(ctx.px_scale)  # as the node scales it (docs/sizes.md)
    bind(prog, textures, {
        "u_proj": proj, "u_viewport": (float(w), float(h)),
        "u_fallback_dir": (math.cos(fallback), math.sin(fallback)),
        "u_foreshortening": tuple(float(v) for v in p.foreshortening),
        "u_light": tuple(float(c) for c in light), "u_light_intensity": p.light_intensity,
        "u_max_tone": float(p.max_darkness * (tam.layers - 1)), "u_layer_offset": p.layer_offset,
        "u_layer_rot": node.layer_rotations(), "u_layer_shift": node.layer_shifts(),
        "u_texel_scale": texel_scale, "u_lod": max(math.log2(texel_scale), 0.0), "u_grain": p.grain,
    })
    sampler = _sampler(gl, mipmaps=texel_scale > 1.0)
    sampler.use(location=0)
    try:
        with gl.depth_test() as state:
            for index, obj in enumerate(scene.objects):
                mesh = obj.mesh
                if mesh.n_faces == 0:
                    continue
                dmin = curv.data[object_field(index, "dmin")]
                ckey = str(curv.data.get(object_field(index, "key"), ""))

                def build(mesh: Any = mesh, dmin: np.ndarray = dmin, index: int = index) -> MeshArrays:
                    ra = mesh.render_arrays(p.crease_angle)
                    local = origin.mesh_origin(mesh)
                    dirs, trust, _ = vertex_directions(mesh, ra, dmin, curv.data[object_field(index, "source")],
                                                       p.planes)
                    return MeshArrays({"in_pos": (origin.positions(mesh, ra, local), "3f"),
                                       "in_normal": (ra.normals, "3f"),
                                       "in_dir": (dirs, "3f"),
                                       "in_trust": (trust.astype(np.float32), "1f")}, ra.indices,
                                      meta={"origin": local})

                entry = gl.mesh_buffers(("pencil_shade.geometry_shader", mesh.content_hash(), float(p.crease_angle),
                                         ckey, bool(p.planes)), build)
                local = entry.meta["origin"]
                state.front_face(clockwise=obj.mirrored)  # as the deferred node: gl_FrontFacing means outside
                face = None
                if mesh.topology().closed:  # version 1 culled closed meshes only
                    face = "back" if mesh.signed_volume() > 0.0 else "front"
                state.cull(face)
                model = np.asarray(obj.transform, dtype=np.float64)
                anchor = (0.0, 0.0)
                if p.anchor == "object":
                    anchor = reference.project_to_pixels(0.5 * np.add(*obj.world_bounds()), view, proj, (w, h))
                normal_view = np.linalg.inv(view[:3, :3] @ model[:3, :3]).T
                u_view, u_model = origin.relative_matrices(view, model, world, local)
                bind(prog, {}, {"u_view": u_view, "u_model": u_model, "u_normal_view": normal_view,
                                "u_anchor": tuple(float(a) for a in anchor)})
                entry.vao(prog).render(gl.ctx.TRIANGLES)
    finally:
        sampler.clear(location=0)
    out = {port: targets[port] for port in geo_ports if port in needed}
    if "color" in needed:
        same = contour is not None and contour.size == (w, h)
        comp = ctx.program(COMPOSITE, {"CONTOUR": int(contour is not None), "PAPER": int(paper is not None),
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
