"""The Blender side of `sketchgraph bench peer`: a worker run by a Python that imports `bpy` (Blender 5 as a
Python module), in a process of its own, never beside nodegraph.

It is started once and reads requests, one JSON object a line, on stdin; it answers each with one JSON object a
line on the stdout it was started with. Blender's own messages (render progress, "Saved: ...") go to stderr: the
worker points file descriptor 1 there before importing bpy, so nothing but answers reaches the protocol stream.

Requests (`op`):

- `load`: a mesh file and the camera, light and colour sketchgraph renders it with (the matrices computed by the
  caller, nodegraph/tools/bench/peer.py); builds one scene per setup (`cycles`: Cycles on the CPU with Freestyle
  lines; `workbench`: Workbench with a Grease Pencil Line Art modifier; `freestyle_svg`: Freestyle's lines
  written as SVG by the Freestyle SVG Exporter) sharing the imported mesh, camera and sun.
  Answers the OBJ import's seconds, the setup's, the mesh's bounds in sketchgraph's world frame (to check the
  import against the framing) and where the given points project.
- `render`: one render of `name`'s `setup` scene; answers the seconds of the render call alone (Blender's own
  `render.render` operator, the scene already loaded: the render depsgraph, Cycles' scene sync and BVH, the
  Freestyle or Line Art lines are all computed inside it). `save`: write that render to a PNG (not timed).
- `info`: the Blender version and the GPU backend (after a Workbench render the GPU module is initialised).
- `quit`.

This file imports nothing from nodegraph: the Python that runs it need not have the project installed.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from typing import Any

SETUPS = ("cycles", "workbench", "freestyle_svg")
SVG_ADDONS = ("render_freestyle_svg", "bl_ext.blender_org.render_freestyle_svg")  # bundled (<= 4.1), extension


class Worker:
    def __init__(self, bpy: Any) -> None:
        self.bpy = bpy
        self.scenes: dict[tuple[str, str], str] = {}  # (name, setup) -> Blender scene name

    # -- scene building ------------------------------------------------------------------------------------------
    def load(self, req: dict[str, Any]) -> dict[str, Any]:
        bpy = self.bpy
        from mathutils import Matrix, Vector

        name = req["name"]
        staging = bpy.data.scenes.new(f"{name}:import")
        t0 = time.perf_counter()
        before = set(bpy.data.objects)
        with bpy.context.temp_override(scene=staging, view_layer=staging.view_layers[0],
                                       collection=staging.collection):
            # forward +Y and up +Z are Blender's own axes: the file's coordinates are taken as they are, and the
            # object matrix below stands the mesh up exactly as sketchgraph does (its world frame is Y-up)
            bpy.ops.wm.obj_import(filepath=req["mesh"], forward_axis="Y", up_axis="Z", validate_meshes=False)
        import_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        meshes = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
        if not meshes:
            raise RuntimeError(f"no mesh imported from {req['mesh']}")
        to_world = Matrix(req["object_matrix"])
        for o in meshes:
            o.matrix_world = to_world @ o.matrix_world
            for poly in o.data.polygons:
                poly.use_smooth = True
        material = bpy.data.materials.new(f"{name}:surface")
        material.diffuse_color = (*req["color"], 1.0)  # Workbench's MATERIAL colour
        bsdf = next((n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
        if bsdf is not None:
            bsdf.inputs["Base Color"].default_value = (*req["color"], 1.0)
            bsdf.inputs["Roughness"].default_value = 0.8
        for o in meshes:
            o.data.materials.clear()
            o.data.materials.append(material)
        camera = self._camera(name, req["blender_camera"])
        sun = self._sun(name, req["sun_rotation"])
        w, h = req["size"]
        for setup in req.get("setups", SETUPS):
            scene = bpy.data.scenes.new(f"{name}:{setup}")
            for o in (*meshes, camera, sun):
                scene.collection.objects.link(o)
            scene.camera = camera
            scene.render.resolution_x, scene.render.resolution_y = int(w), int(h)
            scene.render.resolution_percentage = 100
            scene.render.image_settings.file_format = "PNG"
            scene.view_settings.view_transform = "Standard"
            scene.world = self._world(name)
            if setup == "cycles":
                self._cycles(scene, int(req.get("cycles_samples", 16)))
            elif setup == "workbench":
                self._workbench(scene, name)
            elif setup == "freestyle_svg":
                self._freestyle_svg(scene, name)
            else:
                raise ValueError(f"unknown setup {setup!r}; expected one of {', '.join(SETUPS)}")
            self.scenes[(name, setup)] = scene.name
        for o in meshes:
            staging.collection.objects.unlink(o)
        bpy.data.scenes.remove(staging)
        setup_s = time.perf_counter() - t0
        lo = [math.inf] * 3
        hi = [-math.inf] * 3
        for o in meshes:
            mw = o.matrix_world
            for v in o.data.vertices:
                p = mw @ v.co
                for k in range(3):
                    lo[k], hi[k] = min(lo[k], p[k]), max(hi[k], p[k])
        from bpy_extras.object_utils import world_to_camera_view

        any_scene = bpy.data.scenes[self.scenes[(name, req.get("setups", SETUPS)[0])]]
        projected = []
        for p in req.get("probe_points", []):
            c = world_to_camera_view(any_scene, camera, Vector(p))  # x, y in [0, 1] from the bottom left
            projected.append([c.x, c.y])
        return {"import_s": import_s, "setup_s": setup_s, "bounds": [lo, hi], "projected": projected,
                "faces": sum(len(o.data.polygons) for o in meshes)}

    def _camera(self, name: str, cam: dict[str, Any]) -> Any:
        bpy = self.bpy
        from mathutils import Matrix

        data = bpy.data.cameras.new(f"{name}:camera")
        data.type = "PERSP"
        data.sensor_fit = cam["sensor_fit"]
        data.sensor_width = data.sensor_height = cam["sensor_mm"]
        data.lens = cam["lens_mm"]
        data.clip_start, data.clip_end = cam["clip_start"], cam["clip_end"]
        obj = bpy.data.objects.new(f"{name}:camera", data)
        obj.matrix_world = Matrix(cam["matrix_world"])
        return obj

    def _sun(self, name: str, rotation: list[list[float]]) -> Any:
        bpy = self.bpy
        from mathutils import Matrix

        data = bpy.data.lights.new(f"{name}:sun", type="SUN")
        data.energy = 1.5
        data.angle = math.radians(2.0)
        obj = bpy.data.objects.new(f"{name}:sun", data)
        obj.matrix_world = Matrix(rotation).to_4x4()
        return obj

    def _world(self, name: str) -> Any:
        bpy = self.bpy
        world = bpy.data.worlds.get(f"{name}:world") or bpy.data.worlds.new(f"{name}:world")
        world.color = (1.0, 1.0, 1.0)
        if world.node_tree is not None:
            bg = next((n for n in world.node_tree.nodes if n.type == "BACKGROUND"), None)
            if bg is not None:
                bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
                bg.inputs["Strength"].default_value = 1.0
        return world

    def _cycles(self, scene: Any, samples: int) -> None:
        scene.render.engine = "CYCLES"
        c = scene.cycles
        c.device = "CPU"
        c.samples = samples
        c.use_adaptive_sampling = False
        c.use_denoising = False
        scene.render.threads_mode = "AUTO"
        scene.render.use_persistent_data = False  # every render syncs the scene and builds its BVH anew
        scene.render.use_freestyle = True
        scene.render.line_thickness_mode = "ABSOLUTE"
        scene.render.line_thickness = 1.5
        for layer in scene.view_layers:
            layer.use_freestyle = True
            fs = layer.freestyle_settings
            fs.mode = "EDITOR"
            lineset = fs.linesets[0] if len(fs.linesets) else fs.linesets.new("LineSet")
            lineset.select_by_visibility = True
            lineset.visibility = "VISIBLE"
            lineset.select_by_edge_types = True
            lineset.select_silhouette = True
            lineset.select_border = True
            lineset.select_crease = True

    def _freestyle_svg(self, scene: Any, name: str) -> None:
        """Freestyle's lines written as SVG by Blender's Freestyle SVG Exporter (a bundled add-on up to Blender 4.1,
        an extension since): the cycles setup's line set, Cycles at 1 sample (Freestyle needs a render engine;
        the lines are the work), one SVG a frame into a temporary folder."""
        import tempfile

        import addon_utils

        self._cycles(scene, 1)
        for module in SVG_ADDONS:
            try:
                addon_utils.enable(module, default_set=True)
            except Exception:  # noqa: BLE001 - the next name, then one error line below
                continue
            if hasattr(scene, "svg_export"):
                break
        if not hasattr(scene, "svg_export"):
            raise RuntimeError("the Freestyle SVG Exporter is not installed in this Blender (add-on "
                               "render_freestyle_svg, an extension since Blender 4.2): setup freestyle_svg cannot run")
        scene.svg_export.use_svg_export = True
        scene.svg_export.mode = "FRAME"
        scene.render.filepath = os.path.join(tempfile.mkdtemp(prefix="peer_svg_"), f"{name}_")

    def _workbench(self, scene: Any, name: str) -> None:
        bpy = self.bpy
        scene.render.engine = "BLENDER_WORKBENCH"
        scene.render.use_freestyle = False
        shading = scene.display.shading
        shading.light = "STUDIO"
        shading.color_type = "MATERIAL"
        # Grease Pencil v3: a GREASEPENCIL object whose LINEART modifier draws the scene's lines into its layer
        data = bpy.data.grease_pencils.new(f"{name}:lineart")
        layer = data.layers.new("Lines")
        layer.frames.new(scene.frame_current)
        ink = bpy.data.materials.new(f"{name}:ink")
        bpy.data.materials.create_gpencil_data(ink)
        ink.grease_pencil.color = (0.0, 0.0, 0.0, 1.0)
        data.materials.append(ink)
        obj = bpy.data.objects.new(f"{name}:lineart", data)
        scene.collection.objects.link(obj)
        mod = obj.modifiers.new("Line Art", "LINEART")
        mod.source_type = "SCENE"
        mod.target_layer = layer.name
        mod.target_material = ink
        mod.use_contour = mod.use_crease = mod.use_loose = True
        mod.radius = float(self._line_radius(scene))

    def _line_radius(self, scene: Any) -> float:
        """Two pixels' worth of world units at the camera's target (halfway between the clip distances, which hug
        the mesh's bounding sphere): drawn about 2 px wide, near Freestyle's 1.5 px."""
        data = scene.camera.data
        target_dist = (data.clip_start + data.clip_end) / 2.0
        px = min(scene.render.resolution_x, scene.render.resolution_y)  # the fitted (shorter) side
        return 2.0 * (2.0 * target_dist * (data.sensor_height / 2.0) / data.lens) / px

    # -- rendering -------------------------------------------------------------------------------------------------
    def render(self, req: dict[str, Any]) -> dict[str, Any]:
        scene = self.scenes[(req["name"], req["setup"])]
        t0 = time.perf_counter()
        self.bpy.ops.render.render(write_still=False, scene=scene)
        return {"render_s": time.perf_counter() - t0}

    def save(self, req: dict[str, Any]) -> dict[str, Any]:
        bpy = self.bpy
        scene = bpy.data.scenes[self.scenes[(req["name"], req["setup"])]]
        bpy.ops.render.render(write_still=False, scene=scene.name)
        bpy.data.images["Render Result"].save_render(req["path"], scene=scene)
        return {"path": req["path"]}

    def info(self) -> dict[str, Any]:
        bpy = self.bpy
        out: dict[str, Any] = {"version": bpy.app.version_string, "version_tuple": list(bpy.app.version),
                               "background": bool(bpy.app.background)}
        try:
            import gpu

            out["gpu_backend"] = gpu.platform.backend_type_get()
            out["gpu_renderer"] = gpu.platform.renderer_get()
            out["gpu_version"] = gpu.platform.version_get()
        except Exception as exc:  # no GPU context yet, or none at all
            out["gpu_backend"] = f"unavailable ({exc})"
        return out


def main() -> int:
    answers = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # Blender writes to fd 1 from C: send it to stderr, away from the answers
    sys.stdout = sys.stderr

    def answer(obj: dict[str, Any]) -> None:
        answers.write(json.dumps(obj) + "\n")
        answers.flush()

    t0 = time.perf_counter()
    try:
        import bpy
    except ImportError as exc:
        answer({"ok": False, "error": f"cannot import bpy: {exc}"})
        return 1
    bpy.ops.wm.read_factory_settings(use_empty=True)
    worker = Worker(bpy)
    answer({"ok": True, "op": "ready", "import_s": time.perf_counter() - t0, "version": bpy.app.version_string})
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            req = json.loads(line)
            op = req.get("op")
            if op == "quit":
                answer({"ok": True})
                return 0
            if op == "load":
                result = worker.load(req)
            elif op == "render":
                result = worker.render(req)
            elif op == "save":
                result = worker.save(req)
            elif op == "info":
                result = worker.info()
            else:
                raise ValueError(f"unknown op {op!r}")
            answer({"ok": True, **result})
        except Exception as exc:  # answered, not raised: the parent reports it as one line
            answer({"ok": False, "error": f"{type(exc).__name__}: {exc}"})
    return 0


if __name__ == "__main__":
    sys.exit(main())
