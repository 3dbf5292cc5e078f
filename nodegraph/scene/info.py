"""What a scene file holds and what sketchgraph does with each part of it (`sketchgraph scene info FILE`).

`info(path)` returns a plain dict (JSON-ready); `format_info(d)` makes the aligned text the command prints.
glTF files are read by the glTF reader itself (`gltf._Reader`, which checks the whole document, and
`gltf.load_asset`, which says what is drawn); mesh files by `meshes.load_mesh` with `framing.orient` and
`meshes.health_notes`; scene YAML files are validated and their objects listed, nothing loaded.

What sketchgraph does with each kind of thing is written in ONE place, `DOES` (and `extension_does` for
extensions): a change to what the renderer draws changes a line there.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

from ..errors import MeshError, PipelineError, SketchgraphError
from .meshes import GLTF_EXTENSIONS, SUPPORTED_EXTENSIONS

# --- what sketchgraph does with each thing: (verdict, why). Verdicts: drawn, used, ignored ----------------------
DOES: dict[str, tuple[str, str]] = {
    "mesh": ("drawn", ""),
    "mesh.unplaced": ("ignored", "on no node of the scene"),
    "mesh.hidden": ("ignored", "its nodes are hidden (KHR_node_visibility)"),
    "primitive.points_lines": ("ignored", "points and lines are not drawn"),
    "material": ("used", "base colour: factor x vertex colours x texture, sampled per pixel"),
    "material.other_textures": ("ignored", "shading comes from the geometry's own normals and one light"),
    "material.alpha": ("used", "MASK cuts out below alphaCutoff; BLEND is drawn opaque"),
    "vertex_colors": ("used", "COLOR_0 multiplies the base colour"),
    "texture.base_color": ("used", "sampled through its TEXCOORD_n, wrap modes and filters"),
    "texture.base_color.undecoded": ("ignored", "not decoded (the factor alone is used)"),
    "texture.other": ("ignored", "only base colour textures are read"),
    "texture.unused": ("ignored", "no material uses it"),
    "animation.default": ("used", "plays (every clip plays, together; --animation NAME|INDEX picks one)"),
    "animation.other": ("ignored", "no channel sketchgraph reads"),
    "skin": ("used", "linear-blend skinning"),
    "morph": ("used", "POSITION deltas"),
    "camera.default": ("used", "the default view (first camera on a node)"),
    "camera.perspective": ("used", "with --camera NAME|INDEX"),
    "camera.orthographic": ("used", "with --camera NAME|INDEX (ymag: half the picture's height)"),
    "camera.unplaced": ("ignored", "on no node of the scene"),
    "light": ("used", "shades the drawing (directional, point, spot; the first 8), placed and animated by its "
                      "node; exposure: docs/scenes.md"),
    "mesh_file": ("drawn", "one object, turned so that 'up' is +Y, seen from its front"),
}

_EXTENSIONS: dict[str, tuple[str, str]] = {  # by name, then by prefix (ending in _)
    "KHR_mesh_quantization": ("used", "quantized attributes are read"),
    "KHR_lights_punctual": DOES["light"],
    "EXT_mesh_gpu_instancing": ("used", "every instance is drawn, an object of its own (node world x instance "
                                        "TRS) sharing its mesh"),
    "KHR_animation_pointer": ("used", "channels that point at a node's translation, rotation, scale or weights, a "
                                      "camera's yfov, ymag, znear or zfar, or a light's colour, intensity, range "
                                      "or cone angles play; other pointers are not read"),
    "KHR_node_visibility": ("used", "a node with visible: false is not drawn, nor is anything below it"),
    "KHR_texture_transform": ("used", "offset, rotation, scale and texCoord of the base colour texture"),
    "KHR_draco_mesh_compression": ("used", "decoded (DracoPy); a primitive that also carries an uncompressed copy "
                                           "is read from the copy"),
    "EXT_meshopt_compression": ("ignored", "not decoded: the buffer views' uncompressed fallback is read (a file "
                                           "that requires the extension is refused)"),
    "KHR_xmp": ("ignored", "metadata"),
    "KHR_xmp_json_ld": ("ignored", "metadata"),
    "KHR_materials_": ("ignored", "material extension: only the base colour is read"),
    "EXT_texture_webp": ("used", "WebP base colour textures are decoded"),
    "EXT_texture_": ("ignored", "image format extension: PNG, JPEG and WebP sources are read"),
    "KHR_texture_": ("ignored", "texture extension: PNG, JPEG and WebP sources are read"),
}


def animation_does(index: int, readable: list[int]) -> dict[str, str]:
    """What is done with animation `index` of a file whose animations with channels sketchgraph reads are
    `readable` (file indices): all of them play, together, unless --animation or `animation:` picks one."""
    return does("animation.default" if index in readable else "animation.other")


def does(key: str) -> dict[str, str]:
    verdict, why = DOES[key]
    return {"does": verdict, "why": why}


def extension_does(name: str) -> dict[str, str]:
    """What sketchgraph does with a glTF extension (`_EXTENSIONS`, by name, then by prefix)."""
    found = _EXTENSIONS.get(name) or next((v for k, v in _EXTENSIONS.items() if k.endswith("_")
                                           and name.startswith(k)), None)
    verdict, why = found or ("ignored", "unknown to sketchgraph")
    return {"does": verdict, "why": why}


# --- the dict ---------------------------------------------------------------------------------------------------
def info(path: str | Path, allow_outside: bool = False) -> dict[str, Any]:
    """What the file at `path` holds (glTF/GLB, OBJ/PLY/OFF/STL, scene YAML), with what sketchgraph does with
    each part. A file that cannot be read at all is a one-line SketchgraphError."""
    p = Path(path).expanduser()
    if not p.is_file():
        raise SketchgraphError(f"{p}: file not found")
    ext = p.suffix.lower()
    if ext in GLTF_EXTENSIONS:
        return gltf_info(p, allow_outside)
    if ext in SUPPORTED_EXTENSIONS:
        return mesh_info(p)
    if ext in (".yaml", ".yml"):
        return scene_yaml_info(p)
    raise SketchgraphError(f"{p}: scene info reads glTF (.gltf, .glb), mesh files ({', '.join(SUPPORTED_EXTENSIONS)})"
                           f" and scene YAML files (.yaml); found '{ext or 'no extension'}'")


def _num(x: Any) -> float | int:
    return round(float(x), 6) if not isinstance(x, int) else x


def _name(obj: dict[str, Any], fallback: str) -> str:
    n = obj.get("name")
    return n if isinstance(n, str) and n else fallback


_TEXTURE_SLOTS = (("pbrMetallicRoughness", "baseColorTexture", "base colour"),
                  ("pbrMetallicRoughness", "metallicRoughnessTexture", "metallic-roughness"),
                  ("", "normalTexture", "normal"), ("", "occlusionTexture", "occlusion"),
                  ("", "emissiveTexture", "emissive"))


def gltf_info(path: Path, allow_outside: bool = False) -> dict[str, Any]:
    from . import gltf

    p = path.expanduser().absolute()
    with warnings.catch_warnings(record=True) as caught:  # what the loader warns is listed below instead
        warnings.simplefilter("always")
        problem = ""
        asset = None
        try:
            asset = gltf.load_asset(p, allow_outside)
        except MeshError as exc:  # the file is refused for drawing: say why, and still list what it holds
            problem = " ".join(str(exc).splitlines())
        r = gltf._Reader(p, allow_outside or gltf.OUTSIDE_ALLOWED.get())  # the document, checked
    j = r.j
    jnodes, jmeshes, jmats = r.coll("nodes"), r.coll("meshes"), r.coll("materials")
    jtex, jimg = r.coll("textures"), r.coll("images")
    left_out = list(asset.ignored) if asset is not None else []
    nodes_of: dict[tuple[str, int], list[int]] = {}
    hidden = gltf.hidden_nodes(r)
    for i in r.order:
        for key in ("mesh", "camera", "skin"):
            if key in jnodes[i]:
                nodes_of.setdefault((key, jnodes[i][key]), []).append(i)
        light = ((jnodes[i].get("extensions") or {}).get("KHR_lights_punctual") or {}).get("light")
        if isinstance(light, int):
            nodes_of.setdefault(("light", light), []).append(i)

    def node_names(key: str, index: int) -> list[str]:
        return [_name(jnodes[i], f"node{i}") for i in nodes_of.get((key, index), [])]

    # meshes
    meshes = []
    for mi, m in enumerate(jmeshes):
        tris = verts = 0
        skipped: list[str] = []
        colors = False
        for pi, prim in enumerate(m["primitives"]):
            attrs = prim["attributes"]
            n = r.accs[attrs["POSITION"]].count if "POSITION" in attrs else 0
            k = r.accs[prim["indices"]].count if "indices" in prim else n
            mode = prim.get("mode", 4)
            verts += n
            colors = colors or any(a.startswith("COLOR_") for a in attrs)
            if mode == 4:
                tris += k // 3
            elif mode in (5, 6):
                tris += max(k - 2, 0)
            else:
                skipped.append(f"primitive {pi} ({gltf._MODES.get(mode, mode)}): {DOES['primitive.points_lines'][1]}")
        placed = node_names("mesh", mi)
        if not placed:
            key = "mesh.unplaced"
        elif all(i in hidden for i in nodes_of[("mesh", mi)]):
            key = "mesh.hidden"
        elif len(skipped) < len(m["primitives"]):
            key = "mesh"
        else:
            key = "primitive.points_lines"
        item: dict[str, Any] = {"index": mi, "name": _name(m, f"mesh{mi}"), "primitives": len(m["primitives"]),
                                "triangles": tris, "vertices": verts, "morph_targets": r.mesh_targets[mi],
                                "vertex_colors": colors, "nodes": placed,
                                "sketchgraph": does(key)}
        instanced = {_name(jnodes[i], f"node{i}"): r.instance_count(i)
                     for i in nodes_of.get(("mesh", mi), []) if i in r.instancing}
        if instanced:  # EXT_mesh_gpu_instancing: instances per node
            item["instances"] = instanced
        if skipped:
            item["left_out"] = skipped
        meshes.append(item)

    # textures and images: which material slots use each texture
    slots: dict[int, set[str]] = {}
    for mat in jmats:
        for parent, key, label in _TEXTURE_SLOTS:
            holder = mat.get(parent) or {} if parent else mat
            info_ = holder.get(key)
            if isinstance(info_, dict) and isinstance(info_.get("index"), int):
                slots.setdefault(info_["index"], set()).add(label)
    undecoded = {t for t in range(len(jtex)) if any(note.startswith(f"base colour texture {t} ")
                                                    for note in left_out)}
    images = []
    for ii, im in enumerate(jimg):
        item = {"index": ii, "name": _name(im, f"image{ii}"),
                "source": "file " + im["uri"] if "uri" in im and im["uri"][:5].lower() != "data:"
                else "data URI" if "uri" in im else f"bufferView {im['bufferView']}",
                "format": (im.get("mimeType") or "").replace("image/", "")}
        try:
            data = r.image_bytes(ii)
        except MeshError as exc:
            item["problem"] = " ".join(str(exc).splitlines())
        else:
            head = gltf._image_size(data)
            item["bytes"] = len(data)
            if head is None:
                item["problem"] = "not a PNG, JPEG or WebP"
            else:
                item["format"], item["width"], item["height"] = head
                if not head[1] or not head[2]:
                    item["problem"] = f"a broken {head[0].upper()} header"
        images.append(item)
    textures = []
    for ti, t in enumerate(jtex):
        used = sorted(slots.get(ti, set()))
        key = ("texture.unused" if not used else "texture.base_color.undecoded" if ti in undecoded
               else "texture.base_color" if "base colour" in used else "texture.other")
        textures.append({"index": ti, "name": _name(t, f"texture{ti}"), "image": t.get("source"), "used_as": used,
                         "sketchgraph": does(key)})

    # materials
    materials = []
    for mi, mat in enumerate(jmats):
        pbr = mat.get("pbrMetallicRoughness") or {}
        item = {"index": mi, "name": _name(mat, f"material{mi}"),
                "base_color": [_num(c) for c in (pbr.get("baseColorFactor") or [1.0, 1.0, 1.0, 1.0])],
                "base_color_texture": (pbr.get("baseColorTexture") or {}).get("index"),
                "other_textures": [label for parent, key, label in _TEXTURE_SLOTS[1:]
                                   if ((mat.get(parent) or {}) if parent else mat).get(key) is not None],
                "alpha_mode": mat.get("alphaMode", "OPAQUE"), "double_sided": bool(mat.get("doubleSided", False)),
                "extensions": sorted(mat.get("extensions") or {}), "sketchgraph": does("material")}
        notes = []
        if item["other_textures"]:
            notes.append(f"{', '.join(item['other_textures'])} textures ignored: "
                         f"{DOES['material.other_textures'][1]}")
        if item["alpha_mode"] != "OPAQUE":
            notes.append(f"alphaMode {item['alpha_mode']} ignored: {DOES['material.alpha'][1]}")
        if notes:
            item["left_out"] = notes
        materials.append(item)

    # animations: the times are each sampler input's min and max (required by the spec, checked by the reader)
    readable = [ai for ai, an in enumerate(r.coll("animations")) if any(
        isinstance(ch["target"].get("node"), int) and ch["target"]["path"] in gltf._ANIM_OUTPUT
        for ch in an["channels"])]
    animations = []
    for ai, an in enumerate(r.coll("animations")):
        times = [t for s in an["samplers"] for t in (r.accs[s["input"]].minimum[0], r.accs[s["input"]].maximum[0])]
        targets: dict[str, set[str]] = {}
        for ch in an["channels"]:
            node = ch["target"].get("node")
            label = _name(jnodes[node], f"node{node}") if isinstance(node, int) else "(extension)"
            targets.setdefault(label, set()).add(str(ch["target"]["path"]))
        animations.append({"index": ai, "name": _name(an, f"animation{ai}"), "channels": len(an["channels"]),
                           "targets": {k: sorted(v) for k, v in targets.items()},
                           "start": _num(min(times)), "end": _num(max(times)),
                           "seconds": _num(max(times) - min(0.0, min(times))),
                           "sketchgraph": animation_does(ai, readable)})

    skins = [{"index": si, "name": _name(s, f"skin{si}"), "joints": len(s["joints"]), "nodes": node_names("skin", si),
              "sketchgraph": does("skin")} for si, s in enumerate(r.coll("skins"))]
    morphs = [{"mesh": m["name"], "targets": m["morph_targets"], "sketchgraph": does("morph")}
              for m in meshes if m["morph_targets"]]

    # cameras: the default is the first perspective or orthographic camera on a node in scene order
    # (GltfInstance.find_camera)
    placed_cams = []
    for i in r.order:
        c = jnodes[i].get("camera")
        if c is not None and c not in placed_cams:
            placed_cams.append(c)
    default_cam = next((c for c in placed_cams if r.coll("cameras")[c]["type"] in ("perspective", "orthographic")),
                       None)
    cameras = []
    for ci, c in enumerate(r.coll("cameras")):
        kind = c["type"]
        item = {"index": ci, "name": _name(c, f"camera{ci}"), "type": kind, "nodes": node_names("camera", ci)}
        spec = c.get(kind) or {}
        if kind == "perspective":
            item["yfov_deg"] = _num(round(float(spec["yfov"]) * 180.0 / 3.141592653589793, 3))
            if "aspectRatio" in spec:
                item["aspect_ratio"] = _num(spec["aspectRatio"])
        elif kind == "orthographic":
            item["xmag"], item["ymag"] = _num(spec["xmag"]), _num(spec["ymag"])
        item["znear"] = _num(spec["znear"]) if "znear" in spec else None
        item["zfar"] = _num(spec["zfar"]) if "zfar" in spec else None
        key = ("camera.unplaced" if not item["nodes"] else "camera.default" if ci == default_cam
               else "camera.perspective" if kind == "perspective" else "camera.orthographic")
        item["sketchgraph"] = does(key)
        cameras.append(item)

    lights = []
    raw_lights = ((j.get("extensions") or {}).get("KHR_lights_punctual") or {}).get("lights") or []
    for li, lt in enumerate(raw_lights if isinstance(raw_lights, list) else []):
        if not isinstance(lt, dict):
            continue
        item = {"index": li, "name": _name(lt, f"light{li}"), "type": str(lt.get("type", "?")),
                "color": [_num(c) for c in (lt.get("color") or [1.0, 1.0, 1.0])],
                "intensity": _num(lt.get("intensity", 1.0)), "nodes": node_names("light", li),
                "sketchgraph": does("light")}
        if "range" in lt:
            item["range"] = _num(lt["range"])
        spot = lt.get("spot")
        if isinstance(spot, dict):
            item["spot_deg"] = [_num(round(float(spot.get(k, d)) * 180.0 / 3.141592653589793, 3))
                                for k, d in (("innerConeAngle", 0.0), ("outerConeAngle", 0.7853981633974483))]
        lights.append(item)

    required = set(j.get("extensionsRequired") or [])
    extensions = [{"name": e, "required": e in required, "sketchgraph": extension_does(e)}
                  for e in j.get("extensionsUsed") or []]
    drawn = asset.objects if asset is not None else []
    summary = {"format": "GLB" if p.suffix.lower() == ".glb" else "glTF", "version": j["asset"].get("version"),
               "generator": j["asset"].get("generator"), "nodes": len(jnodes), "scenes": len(r.coll("scenes")),
               "drawn_objects": len(drawn),
               "drawn_triangles": sum(len(asset.meshes[o.mesh][o.prim].faces) for o in drawn) if asset else 0}
    out: dict[str, Any] = {"file": str(path), "kind": "gltf", "summary": summary, "meshes": meshes,
                           "materials": materials, "textures": textures, "images": images, "animations": animations,
                           "skins": skins, "morph_targets": morphs, "cameras": cameras, "lights": lights,
                           "extensions": extensions, "left_out": left_out}
    if problem:
        out["problem"] = problem
    notes = [str(w.message) for w in caught if not str(w.message).startswith(f"{p.name}: left out:")]
    if notes:
        out["warnings"] = notes
    return out


def mesh_info(path: Path) -> dict[str, Any]:
    import numpy as np

    from . import framing
    from .meshes import health_notes, load_mesh

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = load_mesh(path)
        v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
        used = framing.used_vertices(v, f) if len(f) else v
        lo, hi = (used.min(axis=0), used.max(axis=0)) if len(used) else (np.zeros(3), np.zeros(3))
        orient = framing.orient(v, f, path.suffix.lower())
        health = health_notes(mesh)
    notes = [str(w.message) for w in caught]
    conv_up = framing.convention(path.suffix.lower())[0]
    return {"file": str(path), "kind": "mesh", "summary": {
        "format": path.suffix.lower().lstrip(".").upper(), "vertices": int(len(v)), "faces": int(len(f)),
        "bounds_min": [_num(x) for x in lo], "bounds_max": [_num(x) for x in hi],
        "size": [_num(x) for x in hi - lo], "format_up": conv_up, "up": orient.up,
        "front": framing.axis_name(orient.front)},
        "orientation_notes": orient.notes, "health": list(dict.fromkeys(health + notes)),
        "sketchgraph": does("mesh_file")}


def scene_yaml_info(path: Path) -> dict[str, Any]:
    from .. import yamlio
    from .scene import SceneSpec, _resolve

    data = yamlio.load(path)
    if not isinstance(data, dict):
        raise PipelineError(f"{path}: a scene file must be a mapping with 'objects:'")
    named_camera = data.get("camera")
    checked = {k: v for k, v in data.items() if k != "camera"} if isinstance(named_camera, (str, int)) else data
    spec = yamlio.validate(SceneSpec, checked, str(path), root=data, what="scene")
    objects = []
    for i, obj in enumerate(spec.objects):
        if obj.primitive is not None:
            source, kind, exists = str(obj.primitive.get("type")), "primitive", True
        else:
            kind = "gltf" if obj.gltf is not None else "mesh"
            target = _resolve(path.parent, obj.gltf or obj.mesh or "")
            source, exists = str(obj.gltf or obj.mesh), target.is_file()
        item: dict[str, Any] = {"index": i, "name": obj.name or (Path(source).stem if kind != "primitive"
                                                                 else f"{source}{i}"),
                                "kind": kind, "source": source, "exists": exists, "sketchy": obj.sketchy}
        if obj.animation is not None:
            item["animation"] = obj.animation
        if obj.animate is not None:
            item["keyframes"] = sorted(k for k in ("translate", "rotate", "scale") if getattr(obj.animate, k, None))
        objects.append(item)
    camera = (f"glTF camera {named_camera}" if isinstance(named_camera, (str, int))
              else "framed from the bounding box" if spec.camera is None
              else f"view {spec.camera.view}" if spec.camera.view else "eye/target")
    return {"file": str(path), "kind": "scene", "summary": {
        "name": spec.scene or path.stem, "objects": len(objects), "camera": camera, "fps": spec.fps,
        "light": f"{list(spec.light.direction)} ({spec.light.space} space)", "orbit": spec.orbit is not None},
        "objects": objects}


# --- the text ---------------------------------------------------------------------------------------------------
def _table(rows: list[list[str]]) -> list[str]:
    widths = [max(len(r[k]) for r in rows if k < len(r)) for k in range(max(len(r) for r in rows))]
    return ["  " + "  ".join(c.ljust(widths[k]) if k < len(r) - 1 else c for k, c in enumerate(r)).rstrip()
            for r in rows]


def _verdict(item: dict[str, Any]) -> str:
    s = item["sketchgraph"]
    return f"{s['does']}: {s['why']}" if s["why"] else s["does"]


def _section(title: str, items: list[dict[str, Any]], cells: Any, one: str = "") -> list[str]:
    if not items:
        return []
    lines = [f"{title} ({len(items)})"]
    lines += _table([cells(it) for it in items])
    for it in items:
        for note in it.get("left_out", []):
            lines.append(f"    {one or title} {it['index']}: {note}")
    return lines


def _n(k: int, what: str) -> str:
    return f"{k} {what}" if k == 1 else f"{k} {what}s"


def _nodes(names: list[str]) -> str:
    if not names:
        return "on no node"
    return "on " + ", ".join(names[:3]) + (f" +{len(names) - 3}" if len(names) > 3 else "")


def _color(c: list[Any]) -> str:
    return "(" + ", ".join(f"{float(x):.3g}" for x in c) + ")"


def format_info(d: dict[str, Any]) -> str:
    """The dict of `info` as short aligned text."""
    s = d["summary"]
    if d["kind"] == "mesh":
        lines = [f"{d['file']}: {s['format']} mesh, {s['vertices']} vertices, {s['faces']} faces",
                 *_table([["bounds", f"{_color(s['bounds_min'])} .. {_color(s['bounds_max'])}"],
                          ["size", _color(s["size"])],
                          ["up", f"{s['up']} (the format's convention: {s['format_up']}), front {s['front']}"],
                          ["sketchgraph", _verdict(d)]])]
        lines += [f"  note: {n}" for n in d["orientation_notes"]]
        lines += [f"  health: {n}" for n in d["health"]] or ["  health: no problems found"]
        return "\n".join(lines)
    if d["kind"] == "scene":
        lines = [f"{d['file']}: scene '{s['name']}', {s['objects']} objects; camera: {s['camera']}; fps {s['fps']:g}; "
                 f"light {s['light']}" + ("; orbit" if s["orbit"] else "")]
        lines += _section("objects", d["objects"], lambda o: [
            str(o["index"]), o["name"], o["kind"], o["source"] + ("" if o["exists"] else "  (MISSING)"),
            ("sketchy" if o["sketchy"] else "plain") + (f", animation {o['animation']}" if "animation" in o else "")
            + (f", keyframes {'/'.join(o['keyframes'])}" if o.get("keyframes") else "")])
        return "\n".join(lines)
    head = f"{d['file']}: {s['format']} {s['version']}"
    if s.get("generator"):
        head += f" ({s['generator'][:60]})"
    lines = [head + f"; {s['nodes']} nodes; drawn: {s['drawn_objects']} objects, {s['drawn_triangles']} triangles"]
    if "problem" in d:
        lines.append(f"  not drawable: {d['problem']}")
    lines += _section("meshes", d["meshes"], lambda m: [
        str(m["index"]), m["name"], _n(m["primitives"], "primitive"), _n(m["triangles"], "triangle"),
        _n(m["vertices"], "vertex").replace("vertexs", "vertices"),
        _nodes([f"{n} x{m['instances'][n]}" if n in m.get("instances", {}) else n for n in m["nodes"]]),
        _verdict(m) + (f"; COLOR_n {DOES['vertex_colors'][0]}" if m["vertex_colors"] else "")], "mesh")
    lines += _section("materials", d["materials"], lambda m: [
        str(m["index"]), m["name"], "base " + _color(m["base_color"])
        + (f" x texture {m['base_color_texture']}" if m["base_color_texture"] is not None else ""),
        _verdict(m)], "material")
    images = {im["index"]: im for im in d["images"]}

    def texture_cells(t: dict[str, Any]) -> list[str]:
        im = images.get(t["image"]) if t["image"] is not None else None
        size = ("no image" if im is None else im.get("problem") or f"{im['format'].upper()} {im['width']}x"
                f"{im['height']}, {im['bytes']} bytes, {im['source']}")
        return [str(t["index"]), t["name"], ", ".join(t["used_as"]) or "unused", size, _verdict(t)]

    lines += _section("textures", d["textures"], texture_cells)
    lines += _section("animations", d["animations"], lambda a: [
        str(a["index"]), a["name"], _n(a["channels"], "channel"), _n(len(a["targets"]), "node"),
        f"{a['seconds']:.3g} s", _verdict(a)])
    lines += _section("skins", d["skins"], lambda k: [str(k["index"]), k["name"], f"{k['joints']} joints",
                                                      _nodes(k["nodes"]), _verdict(k)])
    lines += _section("morph targets", [dict(m, index=i) for i, m in enumerate(d["morph_targets"])], lambda m: [
        m["mesh"], _n(m["targets"], "target"), _verdict(m)])

    def camera_cells(c: dict[str, Any]) -> list[str]:
        lens = (f"yfov {c['yfov_deg']:.4g} deg" if c["type"] == "perspective"
                else f"xmag {c['xmag']:g}, ymag {c['ymag']:g}" if c["type"] == "orthographic" else "")
        return [str(c["index"]), c["name"], c["type"], lens, _nodes(c["nodes"]), _verdict(c)]

    lines += _section("cameras", d["cameras"], camera_cells)
    lines += _section("lights", d["lights"], lambda lt: [
        str(lt["index"]), lt["name"], lt["type"], f"colour {_color(lt['color'])}", f"intensity {lt['intensity']:g}",
        _nodes(lt["nodes"]), _verdict(lt)])
    lines += _section("extensions", [dict(e, index=i) for i, e in enumerate(d["extensions"])], lambda e: [
        e["name"], "required" if e["required"] else "used", _verdict(e)])
    if d["left_out"]:
        lines.append("left out when drawn:")
        lines += [f"  {n}" for n in d["left_out"]]
    lines += [f"warning: {w}" for w in d.get("warnings", [])]
    return "\n".join(lines)
