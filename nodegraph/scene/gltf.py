"""glTF 2.0 files (`.gltf` with embedded or external buffers, `.glb`) as scenes, read with pygltflib.

What is read: the node hierarchy (TRS or matrix), every triangle primitive (triangles, strips and fans;
indices of any component type; quantized or normalized attributes; sparse accessors), the base colour
(baseColorFactor times the mean of the base colour texture where OpenImageIO decodes it, converted from
glTF's linear values to display values), perspective cameras, skins (linear-blend skinning), morph targets
(POSITION deltas) and animations (translation, rotation, scale and weights; LINEAR, STEP, CUBICSPLINE).
Points and lines are skipped; orthographic cameras cannot be used (the engine's camera is perspective);
extensions that change geometry (Draco, meshopt) are not decoded. Whatever is left out is named in ONE
warning per file. glTF is Y-up and right-handed, as the engine is.
"""

from __future__ import annotations

import base64
import hashlib
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeshError, PipelineError
from .animation import Animator, CameraAnim, ObjectAnim, Track, morph_vertices, skin_matrices, skin_weights, trs_matrix
from .meshes import GLTF_EXTENSIONS, Mesh, MeshWarning

_DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_NORM = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}
_MODES = {0: "POINTS", 1: "LINES", 2: "LINE_LOOP", 3: "LINE_STRIP", 4: "TRIANGLES", 5: "TRIANGLE_STRIP",
          6: "TRIANGLE_FAN"}
# extensions whose absence changes no geometry here (colour comes from the factor and texture anyway)
_HARMLESS_PREFIXES = ("KHR_materials_", "KHR_texture_", "KHR_lights_punctual", "KHR_mesh_quantization",
                      "EXT_texture_", "KHR_xmp")


def _srgb(linear: np.ndarray) -> np.ndarray:
    c = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


def _linear(srgb: np.ndarray) -> np.ndarray:
    c = np.clip(np.asarray(srgb, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, np.power((c + 0.055) / 1.055, 2.4))


@dataclass
class _Prim:
    name: str
    positions: np.ndarray  # (n, 3) float64, the rest pose (default morph weights NOT applied)
    faces: np.ndarray  # (m, 3) int
    color: tuple[float, float, float]
    joints: np.ndarray | None = None  # (n, 4k) int
    weights: np.ndarray | None = None  # (n, 4k) float64
    targets: np.ndarray | None = None  # (T, n, 3) POSITION deltas
    _rest: Mesh | None = None
    _skin: Any = None  # the sparse (n, J) skin weights, built on first use

    def rest_mesh(self) -> Mesh:
        if self._rest is None:
            self._rest = Mesh(self.name, self.positions, self.faces)
        return self._rest


@dataclass
class _Node:
    name: str
    local: np.ndarray  # (4, 4) rest local matrix
    trs: tuple[np.ndarray, np.ndarray, np.ndarray] | None  # None when given as a matrix
    children: list[int]
    parent: int | None = None
    mesh: int | None = None
    skin: int | None = None
    camera: int | None = None
    weights: np.ndarray | None = None


@dataclass
class _Camera:
    name: str
    kind: str
    yfov: float = 0.7
    znear: float = 0.1
    zfar: float | None = None


@dataclass
class GltfAnimation:
    name: str
    channels: list[tuple[int, str, Track]]
    start: float
    end: float


@dataclass
class GltfObject:
    """One drawable: a primitive of the mesh on a node."""

    node: int
    mesh: int
    prim: int
    name: str


@dataclass
class GltfAsset:
    path: Path
    digest: str
    nodes: list[_Node]
    meshes: list[list[_Prim]]
    mesh_weights: list[np.ndarray]
    skins: list[tuple[list[int], np.ndarray]]
    cameras: list[_Camera]
    animations: list[GltfAnimation]
    order: list[int]  # nodes in depth-first scene order
    objects: list[GltfObject]
    ignored: list[str] = field(default_factory=list)
    _worlds: dict[Any, Any] = field(default_factory=dict)

    # -- pose ----------------------------------------------------------------------------------
    def animation(self, which: str | int | None) -> GltfAnimation | None:
        if not self.animations:
            if which is not None:
                raise PipelineError(f"{self.path}: animation {which!r}: the file has no animations")
            return None
        if which is None:
            return self.animations[0]
        return self.animations[_pick(which, [a.name for a in self.animations], f"{self.path}: animation")]

    def pose(self, t: float, anim: GltfAnimation | None) -> tuple[np.ndarray, dict[int, np.ndarray]]:
        """(world matrices (N, 4, 4), morph weights per node) at time t."""
        key = (t, None if anim is None else anim.name, id(anim))
        hit = self._worlds.get(key)
        if hit is not None:
            return hit
        trs = {i: [np.array(n.trs[0]), np.array(n.trs[1]), np.array(n.trs[2])] for i, n in enumerate(self.nodes)
               if n.trs is not None}
        weights: dict[int, np.ndarray] = {}
        if anim is not None:
            for node, path, track in anim.channels:
                value = track.sample(t)
                if path == "weights":
                    weights[node] = value
                elif node in trs:
                    trs[node][{"translation": 0, "rotation": 1, "scale": 2}[path]] = value
        local = [trs_matrix(*trs[i]) if i in trs else n.local for i, n in enumerate(self.nodes)]
        world = np.tile(np.eye(4), (len(self.nodes), 1, 1))
        for i in self.order:
            p = self.nodes[i].parent
            world[i] = local[i] if p is None else world[p] @ local[i]
        if len(self._worlds) > 16:
            self._worlds.clear()
        self._worlds[key] = (world, weights)
        return world, weights

    def node_weights(self, node: int, weights: dict[int, np.ndarray]) -> np.ndarray | None:
        if node in weights:
            return weights[node]
        n = self.nodes[node]
        if n.weights is not None:
            return n.weights
        w = self.mesh_weights[n.mesh] if n.mesh is not None else None
        return w if w is not None and len(w) else None

    def moving(self, anim: GltfAnimation | None) -> tuple[set[int], set[int]]:
        """(nodes whose world matrix changes, nodes whose morph weights change) under `anim`."""
        if anim is None:
            return set(), set()
        direct = {n for n, path, _ in anim.channels if path != "weights"}
        morphing = {n for n, path, _ in anim.channels if path == "weights"}
        moving: set[int] = set()
        for i in self.order:
            p = self.nodes[i].parent
            if i in direct or (p is not None and p in moving):
                moving.add(i)
        return moving, morphing

    def posed_mesh(self, obj: GltfObject, world: np.ndarray, weights: dict[int, np.ndarray]) -> tuple[Mesh, bool]:
        """(mesh in the node's space, or in glTF world space when skinned; whether it is skinned)."""
        prim = self.meshes[obj.mesh][obj.prim]
        node = self.nodes[obj.node]
        w = self.node_weights(obj.node, weights) if prim.targets is not None else None
        skinned = node.skin is not None and prim.joints is not None
        if not skinned and w is None:
            return prim.rest_mesh(), False
        h = hashlib.sha256(prim.rest_mesh().content_hash().encode())
        v = prim.positions
        linear = None
        if w is not None:
            v = morph_vertices(v, prim.targets, w)
            h.update(np.asarray(w, dtype=np.float64).tobytes())
        if skinned:
            joints, ibm = self.skins[node.skin]
            mats = world[joints] @ ibm
            if prim._skin is None or prim._skin.shape[1] != len(mats):
                prim._skin = skin_weights(prim.joints, prim.weights, len(mats))
            blended = skin_matrices(None, prim._skin, mats)
            v = np.einsum("nij,nj->ni", blended[:, :, :3], v) + blended[:, :, 3]
            linear = blended[:, :, :3]
            h.update(mats.tobytes())
        # the rest pose rides along: object-space noise and curvature read it (docs/animation.md)
        mesh = Mesh(prim.name, v, prim.faces, rest=prim.rest_mesh(), skin_linear=linear)
        # what shaped the vertices (rest mesh, joint matrices, morph weights) names them: no hashing of
        # 100k posed vertices per frame
        mesh._cache["hash"] = h.hexdigest()
        return mesh, skinned

    def camera_nodes(self) -> list[tuple[int, int]]:
        """(camera index, the first node in scene order that carries it), by camera index."""
        seen: dict[int, int] = {}
        for i in self.order:
            c = self.nodes[i].camera
            if c is not None and c not in seen:
                seen[c] = i
        return sorted(seen.items())

    def bounds_at(self, t: float, anim: GltfAnimation | None, root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        world, weights = self.pose(t, anim)
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for obj in self.objects:
            mesh, skinned = self.posed_mesh(obj, world, weights)
            m = root if skinned else root @ world[obj.node]
            if mesh.n_vertices:
                v = mesh.vertices @ m[:3, :3].T + m[:3, 3]
                lo, hi = np.minimum(lo, v.min(axis=0)), np.maximum(hi, v.max(axis=0))
        if not np.all(np.isfinite(lo)):
            return np.zeros(3), np.zeros(3)
        return lo, hi


def _pick(which: str | int, names: list[str], what: str) -> int:
    text = str(which).strip()
    if text.lstrip("-").isdigit():
        i = int(text)
        if 0 <= i < len(names):
            return i
        raise PipelineError(f"{what} {i}: out of range; the file has {len(names)} (0..{len(names) - 1})")
    if text in names:
        return names.index(text)
    have = ", ".join(f"{i}: {n}" for i, n in enumerate(names)) or "none"
    raise PipelineError(f"{what} {text!r}: no such name; the file has {have}")


# --- reading ----------------------------------------------------------------------------------------


class _Reader:
    def __init__(self, path: Path):
        import pygltflib

        self.path = path
        try:
            self.doc = pygltflib.GLTF2().load(str(path))
        except Exception as exc:  # pygltflib raises whatever its JSON/struct parsing hits
            raise MeshError(f"{path}: not a readable glTF file: {str(exc).splitlines()[0] if str(exc) else exc}") \
                from None
        if self.doc is None:
            raise MeshError(f"{path}: not a readable glTF file")
        self.ignored: list[str] = []
        self._buffers: dict[int, bytes] = {}
        self.hasher = hashlib.sha256(path.read_bytes())

    def note(self, what: str) -> None:
        if what not in self.ignored:
            self.ignored.append(what)

    def buffer(self, i: int) -> bytes:
        if i not in self._buffers:
            buf = self.doc.buffers[i]
            uri = buf.uri
            if uri is None:
                data = self.doc.binary_blob()
                if data is None:
                    raise MeshError(f"{self.path}: buffer {i} has no uri and the file has no binary chunk")
            elif uri.startswith("data:"):
                data = base64.b64decode(uri.split(",", 1)[1])
            else:
                from urllib.parse import unquote

                p = self.path.parent / unquote(uri)
                if not p.is_file():
                    raise MeshError(f"{self.path}: buffer {i}: file not found: {p}")
                data = p.read_bytes()
                self.hasher.update(data)
            self._buffers[i] = bytes(data)
        return self._buffers[i]

    def _view(self, view_index: int, offset: int, count: int, dtype: Any, ncomp: int) -> np.ndarray:
        view = self.doc.bufferViews[view_index]
        data = self.buffer(view.buffer)
        start = (view.byteOffset or 0) + (offset or 0)
        item = np.dtype(dtype).itemsize * ncomp
        stride = view.byteStride or item
        if count == 0:
            return np.zeros((0, ncomp), dtype=dtype)
        need = start + stride * (count - 1) + item
        if need > len(data):
            raise MeshError(f"{self.path}: buffer view {view_index} reads past the end of buffer {view.buffer}")
        if stride == item:
            return np.frombuffer(data, dtype=dtype, count=count * ncomp, offset=start).reshape(count, ncomp)
        raw = np.frombuffer(data, dtype=np.uint8, count=stride * (count - 1) + item, offset=start)
        rows = np.lib.stride_tricks.as_strided(raw, shape=(count, item), strides=(stride, 1))
        return np.ascontiguousarray(rows).view(dtype).reshape(count, ncomp)

    def accessor(self, i: int, as_float: bool = True) -> np.ndarray:
        acc = self.doc.accessors[i]
        dtype = _DTYPES.get(acc.componentType)
        if dtype is None:
            raise MeshError(f"{self.path}: accessor {i}: unknown component type {acc.componentType}")
        ncomp = _NCOMP.get(acc.type)
        if ncomp is None:
            raise MeshError(f"{self.path}: accessor {i}: unknown type {acc.type!r}")
        if acc.bufferView is not None:
            arr = np.array(self._view(acc.bufferView, acc.byteOffset or 0, acc.count, dtype, ncomp))
        else:
            arr = np.zeros((acc.count, ncomp), dtype=dtype)
        if acc.sparse is not None and acc.sparse.count:
            sp = acc.sparse
            idx_dtype = _DTYPES[sp.indices.componentType]
            idx = self._view(sp.indices.bufferView, sp.indices.byteOffset or 0, sp.count, idx_dtype, 1)[:, 0]
            vals = self._view(sp.values.bufferView, sp.values.byteOffset or 0, sp.count, dtype, ncomp)
            arr[idx.astype(np.int64)] = vals
        if not as_float:
            return arr
        out = arr.astype(np.float64)
        if acc.normalized and acc.componentType in _NORM:
            out = np.maximum(out / _NORM[acc.componentType], -1.0)
        return out

    def color(self, material: int | None) -> tuple[float, float, float]:
        if material is None or material >= len(self.doc.materials):
            return (0.8, 0.8, 0.8)  # glTF's default material is white; a light grey reads better on paper
        pbr = self.doc.materials[material].pbrMetallicRoughness
        factor = np.array((pbr.baseColorFactor if pbr and pbr.baseColorFactor else [1, 1, 1, 1])[:3], np.float64)
        if pbr is not None and pbr.baseColorTexture is not None:
            mean = self.texture_mean(pbr.baseColorTexture.index)
            if mean is not None:
                factor = factor * mean
        return tuple(float(c) for c in _srgb(factor))  # type: ignore[return-value]

    def texture_mean(self, tex_index: int) -> np.ndarray | None:
        """Mean linear RGB of a base colour texture (sRGB-encoded per the spec), or None if undecodable."""
        try:
            import OpenImageIO as oiio

            tex = self.doc.textures[tex_index]
            img = self.doc.images[tex.source]
            if img.uri and not img.uri.startswith("data:"):
                from urllib.parse import unquote

                buf = oiio.ImageBuf(str(self.path.parent / unquote(img.uri)))
                pixels = buf.get_pixels(oiio.FLOAT)
            else:
                import tempfile

                if img.uri:
                    data = base64.b64decode(img.uri.split(",", 1)[1])
                else:
                    view = self.doc.bufferViews[img.bufferView]
                    start = view.byteOffset or 0
                    data = self.buffer(view.buffer)[start:start + view.byteLength]
                suffix = ".jpg" if (img.mimeType or "").endswith("jpeg") else ".png"
                with tempfile.NamedTemporaryFile(suffix=suffix) as f:
                    f.write(data)
                    f.flush()
                    buf = oiio.ImageBuf(f.name)
                    pixels = buf.get_pixels(oiio.FLOAT)
            if pixels is None or pixels.size == 0:
                raise ValueError("empty")
            px = np.asarray(pixels, dtype=np.float64).reshape(-1, pixels.shape[-1])
            rgb = px[:, :3] if px.shape[1] >= 3 else np.repeat(px[:, :1], 3, axis=1)
            return _linear(rgb).mean(axis=0)
        except Exception:
            self.note(f"base colour texture {tex_index} (not decoded; its factor alone is used)")
            return None


def _triangles(mode: int, idx: np.ndarray) -> np.ndarray:
    if mode == 4:
        tri = idx[: len(idx) // 3 * 3].reshape(-1, 3)
    elif mode == 5:
        k = np.arange(max(len(idx) - 2, 0))
        even = (k % 2 == 0)[:, None]
        a = np.stack([idx[k], idx[k + 1], idx[k + 2]], axis=1)
        b = np.stack([idx[k + 1], idx[k], idx[k + 2]], axis=1)
        tri = np.where(even, a, b)
    else:  # 6: fan
        k = np.arange(1, max(len(idx) - 1, 1))
        tri = np.stack([np.full(len(k), idx[0] if len(idx) else 0), idx[k], idx[k + 1]], axis=1) if len(idx) > 2 \
            else np.zeros((0, 3), np.int64)
    tri = np.asarray(tri, dtype=np.int64).reshape(-1, 3)
    keep = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])
    return tri[keep]


def _read(path: Path) -> GltfAsset:
    r = _Reader(path)
    doc = r.doc
    for ext in list(doc.extensionsRequired or []) + list(doc.extensionsUsed or []):
        if not ext.startswith(_HARMLESS_PREFIXES):
            r.note(f"extension {ext}")
    meshes: list[list[_Prim]] = []
    mesh_weights: list[np.ndarray] = []
    for mi, m in enumerate(doc.meshes):
        prims: list[_Prim] = []
        base = m.name or f"mesh{mi}"
        for pi, p in enumerate(m.primitives):
            label = f"mesh '{base}' primitive {pi}"
            mode = 4 if p.mode is None else int(p.mode)
            if mode not in (4, 5, 6):
                r.note(f"{label}: {_MODES.get(mode, mode)} (only triangles, strips and fans are drawn)")
                continue
            if p.extensions and any(not k.startswith(_HARMLESS_PREFIXES) for k in p.extensions):
                r.note(f"{label}: compressed ({', '.join(p.extensions)}; not decoded)")
                continue
            attrs = p.attributes
            if attrs.POSITION is None:
                r.note(f"{label}: no POSITION")
                continue
            pos = r.accessor(attrs.POSITION)[:, :3]
            n = len(pos)
            idx = (r.accessor(p.indices, as_float=False)[:, 0].astype(np.int64) if p.indices is not None
                   else np.arange(n, dtype=np.int64))
            if len(idx) and (idx.min() < 0 or idx.max() >= n):
                raise MeshError(f"{path}: {label}: index out of range (0..{n - 1})")
            faces = _triangles(mode, idx)
            prim = _Prim(name=base if len(m.primitives) == 1 else f"{base}.{pi}", positions=pos, faces=faces,
                         color=r.color(p.material))
            joints = [getattr(attrs, f"JOINTS_{k}", None) for k in range(4)]
            wts = [getattr(attrs, f"WEIGHTS_{k}", None) for k in range(4)]
            pairs = [(j, w) for j, w in zip(joints, wts, strict=True) if j is not None and w is not None]
            if pairs:
                prim.joints = np.concatenate([r.accessor(j, as_float=False).astype(np.int64) for j, _ in pairs], 1)
                prim.weights = np.concatenate([r.accessor(w) for _, w in pairs], axis=1)
            if p.targets:
                deltas = []
                for ti, tgt in enumerate(p.targets):
                    a = tgt.get("POSITION") if isinstance(tgt, dict) else getattr(tgt, "POSITION", None)
                    deltas.append(r.accessor(a)[:, :3] if a is not None else np.zeros((n, 3)))
                    if a is None:
                        r.note(f"{label}: morph target {ti} without POSITION (normals are recomputed anyway)")
                prim.targets = np.stack(deltas)
            prims.append(prim)
        meshes.append(prims)
        mesh_weights.append(np.asarray(m.weights or [], dtype=np.float64))

    nodes: list[_Node] = []
    for i, nd in enumerate(doc.nodes):
        if nd.matrix is not None and len(nd.matrix) == 16:
            local = np.asarray(nd.matrix, dtype=np.float64).reshape(4, 4).T  # column-major in the file
            trs = None
        else:
            t = np.asarray(nd.translation if nd.translation is not None else [0, 0, 0], dtype=np.float64)
            q = np.asarray(nd.rotation if nd.rotation is not None else [0, 0, 0, 1], dtype=np.float64)
            s = np.asarray(nd.scale if nd.scale is not None else [1, 1, 1], dtype=np.float64)
            trs = (t, q, s)
            local = trs_matrix(t, q, s)
        nodes.append(_Node(name=nd.name or f"node{i}", local=local, trs=trs, children=list(nd.children or []),
                           mesh=nd.mesh, skin=nd.skin, camera=nd.camera,
                           weights=None if not getattr(nd, "weights", None) else np.asarray(nd.weights, float)))
    for i, nd in enumerate(nodes):
        for c in nd.children:
            if not 0 <= c < len(nodes) or nodes[c].parent is not None:
                raise MeshError(f"{path}: node {i}: child {c} is out of range or has two parents")
            nodes[c].parent = i
    if doc.scenes:
        si = doc.scene if doc.scene is not None and 0 <= doc.scene < len(doc.scenes) else 0
        roots = list(doc.scenes[si].nodes or [])
    else:
        roots = [i for i, nd in enumerate(nodes) if nd.parent is None]
    order: list[int] = []
    stack = list(reversed(roots))
    while stack:
        i = stack.pop()
        if i in order:
            raise MeshError(f"{path}: node {i} is reached twice (the hierarchy has a cycle)")
        order.append(i)
        stack.extend(reversed(nodes[i].children))

    skins = []
    for si, sk in enumerate(doc.skins):
        joints = list(sk.joints or [])
        if sk.inverseBindMatrices is not None:
            ibm = r.accessor(sk.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
        else:
            ibm = np.tile(np.eye(4), (len(joints), 1, 1))
        if len(ibm) != len(joints):
            raise MeshError(f"{path}: skin {si}: {len(joints)} joints but {len(ibm)} inverse bind matrices")
        skins.append((joints, ibm))

    cameras = []
    for ci, c in enumerate(doc.cameras):
        name = c.name or f"camera{ci}"
        if c.type == "perspective" and c.perspective is not None:
            pc = c.perspective
            cameras.append(_Camera(name, "perspective", float(pc.yfov), float(pc.znear),
                                   None if pc.zfar is None else float(pc.zfar)))
        else:
            cameras.append(_Camera(name, c.type or "unknown"))

    animations = []
    for ai, an in enumerate(doc.animations):
        channels = []
        for ch in an.channels:
            tgt = ch.target
            if tgt is None or tgt.node is None:
                continue
            if tgt.path not in ("translation", "rotation", "scale", "weights"):
                r.note(f"animation {ai}: channel path {tgt.path!r}")
                continue
            if nodes[tgt.node].trs is None and tgt.path != "weights":
                r.note(f"animation {ai}: node {tgt.node} has a matrix (not animatable)")
                continue
            smp = an.samplers[ch.sampler]
            times = r.accessor(smp.input)[:, 0]
            values = r.accessor(smp.output)
            interp = (smp.interpolation or "LINEAR").upper()
            if interp not in ("LINEAR", "STEP", "CUBICSPLINE"):
                r.note(f"animation {ai}: interpolation {interp}")
                interp = "LINEAR"
            try:
                track = Track(times, values, interp, quaternion=tgt.path == "rotation")  # type: ignore[arg-type]
            except ValueError as exc:
                raise MeshError(f"{path}: animation {ai} channel on node {tgt.node}: {exc}") from None
            channels.append((int(tgt.node), tgt.path, track))
        if channels:
            start = min(tr.start for _, _, tr in channels)
            end = max(tr.end for _, _, tr in channels)
            animations.append(GltfAnimation(an.name or f"animation{ai}", channels, start, end))

    objects = []
    for i in order:
        nd = nodes[i]
        if nd.mesh is None:
            continue
        for pi, prim in enumerate(meshes[nd.mesh]):
            objects.append(GltfObject(i, nd.mesh, pi, nd.name if len(meshes[nd.mesh]) == 1 else f"{nd.name}.{pi}"))
            del prim
    return GltfAsset(path=path, digest=r.hasher.hexdigest(), nodes=nodes, meshes=meshes, mesh_weights=mesh_weights,
                     skins=skins, cameras=cameras, animations=animations, order=order, objects=objects,
                     ignored=r.ignored)


_ASSETS: dict[tuple[str, int, int], GltfAsset] = {}


def load_asset(path: str | Path) -> GltfAsset:
    """Read a glTF file (memoised by path, mtime and size); one warning names what was left out."""
    p = Path(path).expanduser().absolute()
    if not p.is_file():
        raise MeshError(f"{p}: glTF file not found")
    st = p.stat()
    key = (str(p), st.st_mtime_ns, st.st_size)
    asset = _ASSETS.get(key)
    if asset is None:
        asset = _read(p)
        if not any(asset.meshes[o.mesh] for o in asset.objects):
            raise MeshError(f"{p}: no triangle meshes to draw"
                            + (f" (left out: {'; '.join(asset.ignored)})" if asset.ignored else ""))
        if asset.ignored:
            warnings.warn(f"{p.name}: left out: {'; '.join(asset.ignored)}", MeshWarning, stacklevel=2)
        for k in [k for k in _ASSETS if k[0] == key[0]]:
            del _ASSETS[k]
        _ASSETS[key] = asset
    return asset


# --- as scene objects -----------------------------------------------------------------------------------


@dataclass
class GltfInstance:
    """A glTF file placed in a scene: its objects at t, under `root` (object -> world of the whole file)."""

    asset: GltfAsset
    root: np.ndarray
    anim: GltfAnimation | None

    @property
    def animated(self) -> bool:
        return self.anim is not None

    def digest(self) -> str:
        return hashlib.sha256(f"{self.asset.digest}|{None if self.anim is None else self.anim.name}|"
                              f"{self.root.tobytes().hex()}".encode()).hexdigest()

    def objects_at(self, t: float) -> list[tuple[str, Mesh, np.ndarray, tuple[float, float, float]]]:
        world, weights = self.asset.pose(t, self.anim)
        out = []
        for obj in self.asset.objects:
            mesh, skinned = self.asset.posed_mesh(obj, world, weights)
            m = self.root if skinned else self.root @ world[obj.node]
            out.append((obj.name, mesh, m, self.asset.meshes[obj.mesh][obj.prim].color))
        return out

    def object_anims(self, first_index: int) -> dict[int, ObjectAnim]:
        """Animations of the objects that move (scene indices from `first_index`); still ones get none."""
        moving, morphing = self.asset.moving(self.anim)
        anims: dict[int, ObjectAnim] = {}
        for k, obj in enumerate(self.asset.objects):
            node = self.asset.nodes[obj.node]
            prim = self.asset.meshes[obj.mesh][obj.prim]
            skinned = node.skin is not None and prim.joints is not None
            moves = (obj.node in morphing and prim.targets is not None) or (
                any(j in moving for j in self.asset.skins[node.skin][0]) if skinned else obj.node in moving)
            if not moves:
                continue

            def pose(t: float, obj: GltfObject = obj) -> tuple[Mesh | None, np.ndarray]:
                world, weights = self.asset.pose(t, self.anim)
                mesh, sk = self.asset.posed_mesh(obj, world, weights)
                return mesh, self.root if sk else self.root @ world[obj.node]

            anims[first_index + k] = ObjectAnim(pose, f"{self.digest()}|object{k}")
        return anims

    def camera_names(self) -> list[tuple[str, int]]:
        """(name, camera index) of the cameras placed on nodes, by camera index."""
        return [(self.asset.cameras[c].name, c) for c, _ in self.asset.camera_nodes()]

    def camera_params(self, camera_index: int, t: float, center: np.ndarray, radius: float) -> dict[str, Any]:
        """Camera(...) keyword arguments for glTF camera `camera_index` at time t (see `camera_params`)."""
        cam = self.asset.cameras[camera_index]
        if cam.kind != "perspective":
            raise PipelineError(f"{self.asset.path.name}: camera '{cam.name}' is {cam.kind}: sketchgraph's camera is "
                                "perspective only; choose a perspective camera (--camera NAME|INDEX, `camera:`)")
        node = dict(self.asset.camera_nodes())[camera_index]
        moving, _ = self.asset.moving(self.anim)
        world, _ = self.asset.pose(t if node in moving else 0.0, self.anim)
        return camera_params(self.root @ world[node], cam, center, radius)

    def camera_moves(self, camera_index: int) -> bool:
        node = dict(self.asset.camera_nodes())[camera_index]
        return node in self.asset.moving(self.anim)[0]

    def find_camera(self, which: str | int | None) -> int | None:
        """A camera index by name or index; None: the first perspective camera placed on a node (None if
        there is none; orthographic ones skipped are noted)."""
        placed = self.camera_names()
        if which is None:
            for name, ci in placed:
                if self.asset.cameras[ci].kind == "perspective":
                    return ci
                warnings.warn(f"{self.asset.path.name}: camera '{name}' is {self.asset.cameras[ci].kind} (the "
                              "engine's camera is perspective only): skipped", MeshWarning, stacklevel=2)
            return None
        text = str(which).strip()
        names = [self.asset.cameras[ci].name for _, ci in placed]
        if text.isdigit():
            i = int(text)
            if i < len(self.asset.cameras) and i in {ci for _, ci in placed}:
                return i
            raise PipelineError(f"{self.asset.path.name}: camera {i}: no such camera on a node; cameras: "
                                + (", ".join(f"{ci}: {n}" for n, ci in placed) or "none"))
        if text in names:
            return placed[names.index(text)][1]
        raise PipelineError(f"{self.asset.path.name}: camera {text!r}: no such camera; cameras: "
                            + (", ".join(f"{ci}: {n}" for n, ci in placed) or "none"))


def camera_params(world: np.ndarray, cam: _Camera, center: np.ndarray, radius: float) -> dict[str, Any]:
    """Keyword arguments of the engine's Camera for a glTF camera whose node has world matrix `world`: it
    looks down its local -Z with +Y up (scale ignored), so its view matrix is the inverse of the (rigid)
    world matrix; the target is on the view axis level with the scene's centre; a missing zfar hugs the
    scene; yfov becomes the field of view across the shorter image side (the same for wide images)."""
    eye = world[:3, 3].copy()
    fwd = -world[:3, 2] / np.linalg.norm(world[:3, 2])
    up = world[:3, 1] / np.linalg.norm(world[:3, 1])
    d = float(np.dot(np.asarray(center) - eye, fwd))
    if not d > 0.0:
        d = max(radius, 1.0)
    near = cam.znear
    far = cam.zfar
    if far is None:  # infinite in the file: hug the scene
        dist = float(np.linalg.norm(np.asarray(center) - eye))
        far = max(dist + 1.05 * max(radius, 1e-6), near * 1e3)
    return {"eye": eye, "target": eye + fwd * d, "up": up, "fov_y_deg": math.degrees(cam.yfov), "near": near,
            "far": max(far, near * 1.001)}


def gltf_mesh(path: str | Path) -> Mesh:
    """The whole file as one static mesh at t = 0 (world transforms applied): for `mesh:` paths."""
    from .meshes import merge_meshes

    asset = load_asset(path)
    inst = GltfInstance(asset, np.eye(4), asset.animation(None))
    parts = [m.transformed(x, name) for name, m, x, _ in inst.objects_at(0.0)]
    return merge_meshes(parts, Path(path).stem)


def animator_for(objects: dict[int, ObjectAnim], camera: CameraAnim | None, instances: list[GltfInstance],
                 fps: float, extra_range: tuple[float, float] | None = None) -> Animator | None:
    ranges = [(i.anim.start, i.anim.end) for i in instances if i.anim is not None]
    if extra_range is not None:
        ranges.append(extra_range)
    if not objects and camera is None:
        return None
    start = min((a for a, _ in ranges), default=0.0)
    end = max((b for _, b in ranges), default=0.0)
    return Animator(objects=objects, camera=camera, fps=fps, start=min(start, 0.0), end=end)


def load_any_mesh(path: str | Path) -> Mesh:
    """`meshes.load_mesh`, and glTF files as one static mesh (`gltf_mesh`)."""
    from .meshes import load_mesh

    if Path(path).suffix.lower() in GLTF_EXTENSIONS:
        return gltf_mesh(path)
    return load_mesh(path)
