"""glTF 2.0 files (`.gltf` with embedded or external buffers, `.glb`) as scenes.

What is read: the node hierarchy (TRS or matrix), every triangle primitive (triangles, strips and fans; indices of
any component type; quantized or normalized attributes; sparse accessors), the base colour (baseColorFactor, the
base colour texture decoded by OpenImageIO with its TEXCOORD_n, KHR_texture_transform, sampler and alpha mode, and
COLOR_0, kept on the mesh as a `Surface` for `rasterize`; one flat colour, the factor times their means, converted
from glTF's linear values to display values), perspective and orthographic cameras, skins (linear-blend skinning),
morph targets (POSITION deltas) and animations (translation, rotation, scale and weights; LINEAR, STEP,
CUBICSPLINE; every clip plays, together, unless one is chosen: `GltfAsset.animation`), and KHR_lights_punctual
lights (directional, point, spot: they shade the drawing, placed and moved by their nodes;
nodegraph/scene/lights.py). Also read: KHR_draco_mesh_compression (decoded by DracoPy), EXT_mesh_gpu_instancing
(an object per instance), KHR_node_visibility, EXT_texture_webp, and KHR_animation_pointer's channels of nodes,
cameras and lights. An orthographic camera's `ymag` (KHR: a half extent) is half the image's height, as `yfov`
spans the height; the width follows the output's shape (`xmag` is not used). Points and lines are skipped;
meshopt-compressed buffers are not decoded (a file that requires them is refused). Whatever is left out is named
in ONE warning per file. glTF is Y-up and right-handed, as the engine is.

A glTF file is untrusted input. The container (GLB header and chunks) and the JSON are parsed here, and the
whole document is checked against the spec and the actual buffer bytes before any of it is used: every
failure is one `MeshError` line naming the JSON path (`walk.gltf: meshes[0].primitives[1].attributes.
POSITION: accessor 99 does not exist (3 accessors)`). Buffer and image URIs must stay inside the file's
folder after percent-decoding and resolving symlinks (`allow_outside=True` lifts that for trusted files);
only regular files are opened, and only the declared bytes are read. The work is bounded by the MAX_*
limits below, each checked before the work it bounds.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import json
import math
import os
import re
import stat
import struct
import tempfile
import warnings
import zlib
from collections.abc import Sequence
from contextvars import ContextVar
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, NoReturn
from urllib.parse import unquote

import numpy as np

from .. import fsio
from ..errors import MeshError, PipelineError
from .animation import (
    AnimationNote,
    Animator,
    CameraAnim,
    LoopedTrack,
    ObjectAnim,
    Track,
    morph_vertices,
    quat_matrix,
    skin_weights,
    trs_matrix,
)
from .meshes import (
    GLTF_EXTENSIONS,
    WRAP_CLAMP,
    WRAP_MIRROR,
    WRAP_REPEAT,
    BaseTexture,
    Material,
    Mesh,
    MeshWarning,
    Surface,
)
from .timeline import ANIMATION_ENDS

_DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_NORM = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}
_MODES = {0: "POINTS", 1: "LINES", 2: "LINE_LOOP", 3: "LINE_STRIP", 4: "TRIANGLES", 5: "TRIANGLE_STRIP",
          6: "TRIANGLE_FAN"}
# extensions whose absence changes no geometry here (colour comes from the factor and texture anyway)
_HARMLESS_PREFIXES = ("KHR_materials_", "KHR_texture_", "KHR_mesh_quantization", "EXT_texture_", "KHR_xmp")
# extensions a file may list in extensionsRequired: read here (quantization, lights) or irrelevant to a
# flat-coloured drawing (materials, texture transforms, metadata); any other required one refuses the file, as the
# spec says a loader must
_SUPPORTED_REQUIRED = ("KHR_mesh_quantization", "KHR_materials_", "KHR_texture_transform", "KHR_lights_punctual",
                       "KHR_xmp", "EXT_texture_webp", "EXT_mesh_gpu_instancing", "KHR_node_visibility",
                       "KHR_draco_mesh_compression")
_READ_EXTENSIONS = ("KHR_lights_punctual", "EXT_mesh_gpu_instancing", "KHR_node_visibility",  # not noted as left out
                    "KHR_draco_mesh_compression", "KHR_animation_pointer")  # pointer: nodes' channels; others noted
_IMAGE_TYPES = ("image/png", "image/jpeg", "image/webp")  # image/webp: EXT_texture_webp (decoded by OpenImageIO)

# --- limits: each is checked before the work it bounds; going past one is a one-line MeshError naming it ------
MAX_FILE_BYTES = 2 << 30  # the .gltf or .glb file itself
MAX_JSON_BYTES = 32 << 20  # its JSON text, data: URIs not counted (they count as buffers and images)
MAX_JSON_OBJECTS = 2_000_000  # JSON objects ({...}) in it
MAX_BUFFER_BYTES = 1 << 30  # all buffers together, by their declared byteLength
MAX_IMAGE_BYTES = 256 << 20  # one encoded image (PNG, JPEG or WebP): a file, a data: URI or a bufferView
MAX_TEXTURE_PIXELS = 8192 * 8192  # one texture, width x height read from the image's header before decoding
MAX_NODES = 200_000
MAX_DEPTH = 1_000  # levels below a root node
MAX_ACCESSOR_COUNT = 1 << 26  # elements of one accessor
MAX_DECODED_BYTES = 2 << 30  # the arrays made of all the accessors read (estimated before each is made)
MAX_OBJECTS = 200_000  # scene objects (a primitive on a node; a mesh on many nodes counts each time)
MAX_DRAWN_TRIANGLES = 50_000_000  # triangles of all the scene objects together


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
    surface: Surface | None = None  # texture coordinates, vertex colours and material, where they colour it
    _rest: Mesh | None = None
    _skin: Any = None  # the sparse (n, J) skin weights, built on first use

    def rest_mesh(self) -> Mesh:
        if self._rest is None:
            self._rest = Mesh(self.name, self.positions, self.faces, surface=self.surface)
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
    light: int | None = None  # KHR_lights_punctual light on the node


@dataclass
class _Camera:
    name: str
    kind: str
    yfov: float = 0.7
    znear: float = 0.1
    zfar: float | None = None
    ymag: float = 1.0  # orthographic: half the view's height (KHR: a half-width, not a magnification)


@dataclass
class GltfAnimation:
    name: str
    channels: list[tuple[int, str, Track | LoopedTrack]]
    start: float
    end: float
    index: int = -1  # in the file's `animations` (a clip without a channel the reader reads is left out)
    # KHR_animation_pointer channels of cameras and lights: (("camera" | "light", index, field), track)
    props: list[tuple[tuple[str, int, str], Track | LoopedTrack]] = field(default_factory=list)

    def value(self, kind: str, index: int, t: float) -> dict[str, Any]:
        """The animated fields of camera or light `index` at time t (field -> value)."""
        out: dict[str, Any] = {}
        for (k, i, f), tr in self.props:
            if k == kind and i == index:
                v = np.asarray(tr.sample(t), dtype=np.float64).reshape(-1)
                out[f] = float(v[0]) if len(v) == 1 else tuple(float(x) for x in v)
        return out

    def animates(self, kind: str, index: int) -> bool:
        return any(k == kind and i == index for (k, i, _), _ in self.props)


@dataclass(eq=False)  # an instance's matrix is an array: objects are told apart by identity
class GltfObject:
    """One drawable: a primitive of the mesh on a node (and, under EXT_mesh_gpu_instancing, one instance of it:
    `instance` is its T x R x S in the node's space)."""

    node: int
    mesh: int
    prim: int
    name: str
    instance: np.ndarray | None = None

    def world(self, world: np.ndarray) -> np.ndarray:
        """The object's world matrix (unskinned) from the nodes' world matrices."""
        return world[self.node] if self.instance is None else world[self.node] @ self.instance


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
    lights: list[Any] = field(default_factory=list)  # KHR_lights_punctual definitions (lights.Light at the origin)
    rest_local: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 4)))  # (N, 4, 4) rest local matrices
    # the scene's nodes level by level from its roots: (nodes, their parents; None for the roots)
    levels: list[tuple[np.ndarray, np.ndarray | None]] = field(default_factory=list)
    _worlds: dict[Any, Any] = field(default_factory=dict)
    _posed: dict[Any, Any] = field(default_factory=dict)  # (world, weights) -> every posed object (`_posed_all`)
    _skin_rows: dict[Any, Any] = field(default_factory=dict)  # the stacked skin weights of the parts of one skin

    # -- pose ----------------------------------------------------------------------------------
    def clip_list(self) -> str:
        """The file's clips as a note says them: `0 'walk' 1.2 s, 1 'wave' 0.5 s`."""
        return ", ".join(f"{a.index} {a.name!r} {a.end:g} s" for a in self.animations)

    def animation(self, which: str | int | None, end: str = "hold", note: bool = True) -> GltfAnimation | None:
        """What plays: every clip together (`which` None or "all", as glTF viewers do) or one clip by name or
        index; None when the file has none. Clips play from t = 0 on one clock; after its last key a shorter
        clip holds its last pose (`end` "hold") or loops over [0, its end] (`end` "loop", `loop_time`). Two
        clips driving the same channel (a node's translation, rotation, scale or weights): the later clip in
        the file wins. `note`: say in one line (AnimationNote) what a file with several clips plays, and
        which channels a later clip took over."""
        if end not in ANIMATION_ENDS:
            raise PipelineError(f"animation end {end!r}: expected one of {', '.join(ANIMATION_ENDS)}")
        text = None if which is None else str(which).strip()
        every = text is None or text.lower() == "all"
        if not self.animations:
            if not every:
                raise PipelineError(f"{self.path.name}: animation {text!r}: the file has no animations")
            return None
        if every:
            picked = list(range(len(self.animations)))
        elif text.lstrip("-").isdigit() and not any(a.name == text for a in self.animations):
            i = int(text)
            found = [k for k, a in enumerate(self.animations) if a.index == i]
            if not found:
                raise PipelineError(f"{self.path.name}: animation {i}: no such animation; the file's animations: "
                                    f"{self.clip_list()} (or all)")
            picked = found
        elif any(a.name == text for a in self.animations):
            picked = [next(i for i, a in enumerate(self.animations) if a.name == text)]
        else:
            raise PipelineError(f"{self.path.name}: animation {text!r}: no such animation; the file's animations: "
                                f"{self.clip_list()} (or all)")
        clips = [self.animations[i] for i in picked]
        channels: dict[tuple[int, str], tuple[int, str, Any]] = {}
        props: dict[tuple[str, int, str], Any] = {}
        owner: dict[tuple[int, str], int] = {}
        taken: list[str] = []
        for clip in clips:
            for node, path, track in clip.channels:
                if (node, path) in owner:
                    taken.append(f"{path} of node {node} {self.nodes[node].name!r}: clip {clip.index} over clip "
                                 f"{owner[node, path]}")
                owner[node, path] = clip.index
                channels[node, path] = (node, path, LoopedTrack(track, clip.end) if end == "loop" else track)
            for target, track in clip.props:  # cameras' and lights' fields: the later clip wins too
                props[target] = LoopedTrack(track, clip.end) if end == "loop" else track
        if note and len(self.animations) > 1:
            plays = "all play together" if every else f"playing {clips[0].index} {clips[0].name!r}"
            if every and len({c.end for c in clips}) > 1:
                plays += ", the shorter " + ("looping" if end == "loop" else "holding their last pose")
            warnings.warn(f"{self.path.name}: {len(self.animations)} animations: {self.clip_list()}; {plays} "
                          "(--animation NAME|INDEX|all)", AnimationNote, stacklevel=3)
        if note and taken:
            more = f" and {len(taken) - 3} more" if len(taken) > 3 else ""
            warnings.warn(f"{self.path.name}: clips animate the same channel; the later clip in the file wins: "
                          f"{'; '.join(taken[:3])}{more}", AnimationNote, stacklevel=3)
        if len(clips) == 1 and end == "hold":
            return clips[0]  # one clip as the file has it: its name (and so every key of it) as before
        name = f"{'+'.join(str(c.index) for c in clips)}:{end}"
        return GltfAnimation(name, list(channels.values()), min(c.start for c in clips), max(c.end for c in clips),
                             props=list(props.items()))

    def pose(self, t: float, anim: GltfAnimation | None) -> tuple[np.ndarray, dict[int, np.ndarray]]:
        """(world matrices (N, 4, 4), morph weights per node) at time t."""
        key = (t, None if anim is None else anim.name, id(anim))
        hit = self._worlds.get(key)
        if hit is not None:
            return hit
        local = self.rest_local
        weights: dict[int, np.ndarray] = {}
        if anim is not None:
            trs: dict[int, list[np.ndarray]] = {}
            for node, path, track in anim.channels:
                value = track.sample(t)
                if path == "weights":
                    weights[node] = value
                    continue
                if node not in trs:
                    rest = self.nodes[node].trs
                    assert rest is not None  # a node given by a matrix has no TRS channels (checked on reading)
                    trs[node] = [np.array(rest[0]), np.array(rest[1]), np.array(rest[2])]
                trs[node][{"translation": 0, "rotation": 1, "scale": 2}[path]] = value
            if trs:
                local = local.copy()
                for node, (tr, rot, sc) in trs.items():
                    local[node] = trs_matrix(tr, rot, sc)
        world = np.tile(np.eye(4), (len(self.nodes), 1, 1))
        for nodes, parents in self.levels:  # parents before children: one batched product per level
            world[nodes] = local[nodes] if parents is None else world[parents] @ local[nodes]
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
        if not (node.skin is not None and prim.joints is not None) and (
                prim.targets is None or self.node_weights(obj.node, weights) is None):
            return prim.rest_mesh(), False
        return self._posed_all(world, weights)[(obj.node, obj.mesh, obj.prim)]

    def _posed_all(self, world: np.ndarray, weights: dict[int, np.ndarray]) -> dict[tuple[int, int, int],
                                                                                   tuple[Mesh, bool]]:
        """Every skinned or morphed object posed at once, by (node, mesh, primitive): the parts of one skin
        skinned together (one sparse product and one einsum over all their vertices, row for row what each
        part alone gives), and their derived arrays made together on first use (nodegraph/scene/posing.py)."""
        from .posing import PoseBatch
        from .posing import skin as posing_skin

        hit = self._posed.get((id(world), id(weights)))
        if hit is not None and hit[0] is world and hit[1] is weights:
            return hit[2]
        groups: dict[int | None, list[tuple[GltfObject, _Prim, np.ndarray, Any]]] = {}
        for obj in self.objects:
            prim = self.meshes[obj.mesh][obj.prim]
            node = self.nodes[obj.node]
            w = self.node_weights(obj.node, weights) if prim.targets is not None else None
            skinned = node.skin is not None and prim.joints is not None
            if not skinned and w is None:
                continue
            h = hashlib.sha256(prim.rest_mesh().content_hash().encode())
            v = prim.positions
            if w is not None:
                v = morph_vertices(v, prim.targets, w)
                h.update(np.asarray(w, dtype=np.float64).tobytes())
            groups.setdefault(node.skin if skinned else None, []).append((obj, prim, v, h))
        out: dict[tuple[int, int, int], tuple[Mesh, bool]] = {}
        for skin, parts in groups.items():
            verts: list[np.ndarray] = [v for _, _, v, _ in parts]
            linear: list[np.ndarray | None] = [None] * len(parts)
            if skin is not None:
                joints, ibm = self.skins[skin]
                mats = world[joints] @ ibm
                stacked = self._skin_stack(skin, [p for _, p, _, _ in parts], len(mats))
                v_all, lin_all = posing_skin(stacked, mats, np.concatenate(verts))
                at = np.cumsum([0] + [len(v) for v in verts])
                verts = [v_all[a:b] for a, b in zip(at[:-1], at[1:], strict=True)]
                linear = [lin_all[a:b] for a, b in zip(at[:-1], at[1:], strict=True)]
                for _, _, _, h in parts:
                    h.update(mats.tobytes())
            for (obj, prim, _, h), v, lin in zip(parts, verts, linear, strict=True):
                rest = prim.rest_mesh()
                # the rest pose rides along: object-space noise and curvature read it (docs/animation.md); its
                # faces are shared, and with them its topology (`Mesh.topology_mesh`)
                mesh = Mesh(prim.name, v, rest.faces, rest=rest, skin_linear=lin, surface=prim.surface)
                # what shaped the vertices (rest mesh, joint matrices, morph weights) names them: no hashing of
                # 100k posed vertices per frame
                mesh._cache["hash"] = h.hexdigest()
                out[(obj.node, obj.mesh, obj.prim)] = (mesh, skin is not None)
        PoseBatch([m for m, _ in out.values()])
        if len(self._posed) >= 4:
            self._posed.clear()
        self._posed[(id(world), id(weights))] = (world, weights, out)
        return out

    def _skin_stack(self, skin: int, prims: list[_Prim], n_joints: int) -> Any:
        """The sparse skin weights of `prims` (all on skin `skin`) stacked, rows in order: built once."""
        key = (skin, n_joints, tuple(id(p) for p in prims))
        hit = self._skin_rows.get(key)
        if hit is None:
            import scipy.sparse as sp

            for prim in prims:
                if prim._skin is None or prim._skin.shape[1] != n_joints:
                    prim._skin = skin_weights(prim.joints, prim.weights, n_joints)
            hit = self._skin_rows[key] = (prims, sp.vstack([p._skin for p in prims], format="csr"))
        return hit[1]

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
            m = root if skinned else root @ obj.world(world)
            if mesh.n_vertices:
                v = mesh.vertices @ m[:3, :3].T + m[:3, 3]
                lo, hi = np.minimum(lo, v.min(axis=0)), np.maximum(hi, v.max(axis=0))
        if not np.all(np.isfinite(lo)):
            return np.zeros(3), np.zeros(3)
        return lo, hi


# --- reading ----------------------------------------------------------------------------------------

_GLB_MAGIC = b"glTF"
_CHUNK_JSON, _CHUNK_BIN = 0x4E4F534A, 0x004E4942
_CSIZE = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_COLLECTIONS = {"accessors": "accessor", "animations": "animation", "buffers": "buffer", "bufferViews": "bufferView",
                "cameras": "camera", "images": "image", "materials": "material", "meshes": "mesh", "nodes": "node",
                "samplers": "sampler", "scenes": "scene", "skins": "skin", "textures": "texture"}
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")
_DATA_URI = re.compile(r'"data:[^"\\]*"')
_ATTRIBUTE_NAME = re.compile(r"^(POSITION|NORMAL|TANGENT|(TEXCOORD|COLOR|JOINTS|WEIGHTS)_(0|[1-9][0-9]*)|_.+)$")
# how far a rotation quaternion's length may be from 1, and a vertex's skin weights' float32 sum from 1 per
# weight used: the official glTF validator's tolerances
_UNIT_TOLERANCE = 0.00769
_WEIGHT_TOLERANCE = 2e-7

# (componentType, normalized) formats
_F, _B, _BN, _UB, _UBN = (5126, False), (5120, False), (5120, True), (5121, False), (5121, True)
_S, _SN, _US, _USN, _UI = (5122, False), (5122, True), (5123, False), (5123, True), (5125, False)
_QUANT = (_B, _BN, _UB, _UBN, _S, _SN, _US, _USN)
# semantic: (types, formats, formats added by KHR_mesh_quantization)
_ATTRIBUTES: dict[str, tuple[tuple[str, ...], tuple[tuple[int, bool], ...], tuple[tuple[int, bool], ...]]] = {
    "POSITION": (("VEC3",), (_F,), _QUANT),
    "NORMAL": (("VEC3",), (_F,), (_BN, _SN)),
    "TANGENT": (("VEC4",), (_F,), (_BN, _SN)),
    "TEXCOORD": (("VEC2",), (_F, _UBN, _USN), (_B, _BN, _UB, _S, _SN, _US)),
    "COLOR": (("VEC3", "VEC4"), (_F, _UBN, _USN), ()),
    "JOINTS": (("VEC4",), (_UB, _US), ()),
    "WEIGHTS": (("VEC4",), (_F, _UBN, _USN), ()),
}
_TARGET_ATTRIBUTES = {
    "POSITION": (("VEC3",), (_F,), (_B, _BN, _S, _SN)),
    "NORMAL": (("VEC3",), (_F,), (_BN, _SN)),
    "TANGENT": (("VEC3",), (_F,), (_BN, _SN)),
    "TEXCOORD": (("VEC2",), (_F, _BN, _UBN, _SN, _USN), ()),
    "COLOR": (("VEC3", "VEC4"), (_F, _BN, _UBN, _SN, _USN), ()),
}
_ANIM_OUTPUT = {
    "translation": (("VEC3",), (_F,), _QUANT),
    "scale": (("VEC3",), (_F,), _QUANT),
    "rotation": (("VEC4",), (_F, _BN, _UBN, _SN, _USN), ()),
    "weights": (("SCALAR",), (_F, _BN, _UBN, _SN, _USN), ()),
}
_INTERPOLATIONS = ("LINEAR", "STEP", "CUBICSPLINE")
_NODE_POINTER = re.compile(r"/nodes/(\d{1,9})/(translation|rotation|scale|weights)")  # KHR_animation_pointer
_PROP_POINTER = re.compile(  # KHR_animation_pointer: the camera and light fields a drawing uses
    r"/cameras/(?P<cam>\d{1,9})/(?P<ctype>perspective|orthographic)/(?P<cfield>yfov|znear|zfar|ymag)"
    r"|/extensions/KHR_lights_punctual/lights/(?P<light>\d{1,9})/"
    r"(?P<lfield>color|intensity|range|spot/innerConeAngle|spot/outerConeAngle)")
_INSTANCE_ATTRIBUTES = {  # EXT_mesh_gpu_instancing
    "TRANSLATION": (("VEC3",), (_F,), (_B, _BN, _S, _SN)),
    "ROTATION": (("VEC4",), (_F, _BN, _SN), ()),
    "SCALE": (("VEC3",), (_F,), (_B, _BN, _S, _SN)),
}


def _kind(v: Any) -> str:
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, (int, float)):
        return f"the number {v!r}" if len(repr(v)) < 24 else "a number"
    return {str: "a string", list: "an array", dict: "an object", type(None): "null"}.get(type(v), type(v).__name__)


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v: Any) -> bool:
    return (isinstance(v, float) or (_is_int(v) and abs(v) < 1e300)) and not isinstance(v, bool)


def _element_size(kind: str, csize: int) -> int:
    """Bytes of one element; matrix columns of 1- and 2-byte components are padded to 4 bytes."""
    if kind == "MAT2" and csize == 1:
        return 8
    if kind == "MAT3" and csize in (1, 2):
        return 12 * csize
    return _NCOMP[kind] * csize


def _mib(n: float) -> str:
    return f"{n / (1 << 20):.1f} MiB"


def _image_size(data: bytes) -> tuple[str, int, int] | None:
    """('png' | 'jpeg' | 'webp', width, height) from the header bytes (0, 0 where the header is broken); None:
    none of them."""
    if data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        return ("webp", *_webp_size(data))
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        if len(data) < 24 or data[12:16] != b"IHDR":
            return "png", 0, 0
        w, h = struct.unpack(">II", data[16:24])
        return "png", w, h
    if data[:2] == b"\xff\xd8":
        i = 2
        while i + 4 <= len(data):
            if data[i] != 0xFF:
                break
            marker = data[i + 1]
            if marker == 0xFF:  # fill byte
                i += 1
                continue
            if marker == 0x01 or 0xD0 <= marker <= 0xD8:  # markers without a length
                i += 2
                continue
            if marker in (0xD9, 0xDA):  # end of image, start of scan: no frame header before them
                break
            seglen = int.from_bytes(data[i + 2:i + 4], "big")
            if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):  # start of frame: P, Y, X
                if i + 9 > len(data):
                    break
                return "jpeg", int.from_bytes(data[i + 7:i + 9], "big"), int.from_bytes(data[i + 5:i + 7], "big")
            if seglen < 2:
                break
            i += 2 + seglen
        return "jpeg", 0, 0
    return None


def _webp_size(data: bytes) -> tuple[int, int]:
    """Width and height from a WebP file's first chunk (lossy VP8, lossless VP8L or extended VP8X); (0, 0) where
    it is broken."""
    kind, body = data[12:16], data[20:30]
    if kind == b"VP8 " and len(body) >= 10 and body[3:6] == b"\x9d\x01\x2a":  # frame tag, start code, sizes
        return int.from_bytes(body[6:8], "little") & 0x3FFF, int.from_bytes(body[8:10], "little") & 0x3FFF
    if kind == b"VP8L" and len(body) >= 5 and body[0] == 0x2F:  # signature, then 14 + 14 bits of size - 1
        bits = int.from_bytes(body[1:5], "little")
        return (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1
    if kind == b"VP8X" and len(body) >= 10:  # flags, reserved, then 24 + 24 bits of canvas size - 1
        return int.from_bytes(body[4:7], "little") + 1, int.from_bytes(body[7:10], "little") + 1
    return 0, 0


_PNG_DEPTHS = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}  # colour type: bit depths
_PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}
_ADAM7 = ((0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2))


def _png_sound(data: bytes) -> bool:
    """Whether a PNG is whole before a decoder sees it (libpng writes its errors to the process's stderr, past
    any one-line error): every chunk's CRC, the header's fields, a palette where one is needed, and the
    image data inflated a MiB at a time (nothing kept) to exactly the size the header implies, each row
    starting with a filter type 0..4."""
    pos, header, idat, palette, ended = 8, None, [], False, False
    while pos + 12 <= len(data):
        n = int.from_bytes(data[pos:pos + 4], "big")
        kind = data[pos + 4:pos + 8]
        if n > len(data) - pos - 12:
            return False
        body = data[pos + 8:pos + 8 + n]
        if zlib.crc32(body, zlib.crc32(kind)) != int.from_bytes(data[pos + 8 + n:pos + 12 + n], "big"):
            return False
        if (header is None) != (kind == b"IHDR"):
            return False  # IHDR first, and once
        if kind == b"IHDR":
            if n != 13:
                return False
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"PLTE":
            palette = True
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            ended = True
            break
        pos += 12 + n
    if header is None or not idat or not ended:
        return False
    width, height, depth, ctype, method, filtering, interlace = header
    if (depth not in _PNG_DEPTHS.get(ctype, ()) or method or filtering or interlace > 1 or not width or not height
            or (ctype == 3 and not palette)):
        return False
    bits = _PNG_CHANNELS[ctype] * depth
    passes = [(0, 0, 1, 1)] if interlace == 0 else _ADAM7
    segments = []  # (end offset in the inflated stream, row length with its filter byte)
    end = 0
    for x0, y0, dx, dy in passes:
        w, h = (width - x0 + dx - 1) // dx, (height - y0 + dy - 1) // dy
        if w and h:
            row = 1 + (w * bits + 7) // 8
            end += h * row
            segments.append((end, row))
    inflate = zlib.decompressobj()
    seen, row_start, seg = 0, 0, 0
    pending = b"".join(idat)
    while True:
        try:
            chunk = inflate.decompress(pending, 1 << 20)
        except zlib.error:
            return False
        pending = inflate.unconsumed_tail
        if seen + len(chunk) > end:
            return False
        if chunk:
            arr = np.frombuffer(chunk, np.uint8)
            while seg < len(segments) and row_start < seen + len(chunk):
                stop, row = segments[seg]
                starts = np.arange(row_start, min(stop, seen + len(chunk)), row)
                if len(starts) and arr[starts - seen].max() > 4:
                    return False
                row_start = int(starts[-1]) + row if len(starts) else row_start
                if row_start >= stop:
                    seg += 1
            seen += len(chunk)
        if not chunk and not pending:
            break
    return inflate.eof and not inflate.unused_data and seen == end


class _HierarchyError(Exception):
    def __init__(self, node: int, why: str):
        super().__init__(why)
        self.node = node
        self.why = why


def _walk(children: Sequence[Sequence[int]], roots: Sequence[int], n: int,
          max_depth: int) -> tuple[list[int], list[int]]:
    """Depth-first order and depth of the nodes below `roots`. Linear: each node is visited, and its children
    read, once (a bytearray says which were seen: no list search); a node reached twice or deeper than
    `max_depth` raises _HierarchyError."""
    seen = bytearray(n)
    order: list[int] = []
    depth: list[int] = []
    stack = [(r, 0) for r in reversed(roots)]
    while stack:
        i, d = stack.pop()
        if seen[i]:
            raise _HierarchyError(i, "is reached twice (a cycle, or a node with two parents)")
        if d > max_depth:
            raise _HierarchyError(i, f"is {d} levels below a root node: the limit is {max_depth} (MAX_DEPTH)")
        seen[i] = 1
        order.append(i)
        depth.append(d)
        kids = children[i]
        if kids:
            stack.extend((c, d + 1) for c in reversed(kids))
    return order, depth


@dataclass
class _Acc:
    """An accessor's checked metadata."""

    ctype: int
    kind: str
    ncomp: int
    count: int
    normalized: bool
    view: int | None
    offset: int
    elsize: int
    minimum: list[float] | None
    maximum: list[float] | None
    sparse: tuple[int, int, int, int, int, int] | None  # count, index view, its offset, index type, value view,
    # its offset



OUTSIDE_ALLOWED: ContextVar[bool] = ContextVar("gltf_outside_allowed", default=False)
"""True: every glTF file read in this context may name buffers and images outside its folder, as if loaded with
`allow_outside=True` (the command line's --allow-outside-scene-dir sets it for its process)."""


class _Reader:
    def __init__(self, path: Path, allow_outside: bool = False):
        self.path = path
        self.name = path.name
        self.base = path.parent
        self.root = self.base.resolve()
        self.allow_outside = allow_outside or OUTSIDE_ALLOWED.get()
        self.ignored: dict[str, None] = {}  # insertion-ordered set
        self._buffers: dict[int, bytes] = {}
        self._textures: dict[int, tuple[np.ndarray, str, np.ndarray] | None] = {}
        self._colors: dict[int | None, tuple[float, float, float]] = {}
        self._decoded = 0
        self._draco: dict[int, np.ndarray] = {}  # accessor -> its values decoded from a Draco stream
        raw = self._read_file()
        self.hasher = hashlib.sha256(raw)
        text, self.bin = self._container(raw)
        del raw
        self.j = self._parse_json(text)
        self._validate()

    # -- errors and small checks ---------------------------------------------------------------------
    def fail(self, where: str, msg: str) -> NoReturn:
        raise MeshError(f"{self.name}: {where}: {msg}" if where else f"{self.name}: {msg}")

    def note(self, what: str) -> None:
        self.ignored[what] = None

    @staticmethod
    def _at(where: str, key: str) -> str:
        return f"{where}.{key}" if where else key

    def coll(self, key: str) -> list[dict[str, Any]]:
        return self.j.get(key) or []

    def _get(self, obj: dict[str, Any], key: str, where: str, check: Any, expected: str, required: bool,
             default: Any = None) -> Any:
        v = obj.get(key)
        if v is None:
            if key in obj:
                self.fail(self._at(where, key), f"expected {expected}, found null")
            if required:
                self.fail(where, f"'{key}' is required")
            return default
        if not check(v):
            self.fail(self._at(where, key), f"expected {expected}, found {_kind(v)}")
        return v

    def _int(self, obj: dict[str, Any], key: str, where: str, default: int | None = None, lo: int | None = None,
             hi: int | None = None, required: bool = False) -> Any:
        v = self._get(obj, key, where, _is_int, "an integer", required, default)
        if v is not None and ((lo is not None and v < lo) or (hi is not None and v > hi)):
            rng = f"at least {lo}" if hi is None else f"{lo}..{hi}" if lo is not None else f"at most {hi}"
            self.fail(self._at(where, key), f"{v} is out of range ({rng})")
        return v

    def _num(self, obj: dict[str, Any], key: str, where: str, default: float | None = None,
             required: bool = False) -> Any:
        v = self._get(obj, key, where, _is_num, "a number", required, default)
        return None if v is None else float(v)

    def _str(self, obj: dict[str, Any], key: str, where: str, default: str | None = None,
             required: bool = False) -> Any:
        return self._get(obj, key, where, lambda v: isinstance(v, str), "a string", required, default)

    def _bool(self, obj: dict[str, Any], key: str, where: str, default: bool = False) -> bool:
        return bool(self._get(obj, key, where, lambda v: isinstance(v, bool), "true or false", False, default))

    def _list(self, obj: dict[str, Any], key: str, where: str, required: bool = False,
              nonempty: bool = False) -> list[Any]:
        v = self._get(obj, key, where, lambda v: isinstance(v, list), "an array", required, [])
        if nonempty and not v and (required or key in obj):
            self.fail(self._at(where, key), "must not be empty")
        return v

    def _dict(self, obj: dict[str, Any], key: str, where: str, required: bool = False) -> Any:
        return self._get(obj, key, where, lambda v: isinstance(v, dict), "an object", required)

    def _numbers(self, obj: dict[str, Any], key: str, where: str, length: int | None = None,
                 lo: float | None = None, hi: float | None = None) -> list[float] | None:
        v = self._get(obj, key, where, lambda v: isinstance(v, list), "an array of numbers", False)
        if v is None:
            return None
        if length is not None and len(v) != length:
            self.fail(self._at(where, key), f"expected {length} numbers, found {len(v)}")
        for k, x in enumerate(v):
            if not _is_num(x):
                self.fail(f"{where}.{key}[{k}]", f"expected a number, found {_kind(x)}")
            if (lo is not None and x < lo) or (hi is not None and x > hi):
                self.fail(f"{where}.{key}[{k}]", f"{x} is out of range ({lo}..{hi})")
        return [float(x) for x in v]

    def _index(self, v: Any, where: str, coll: str, n: int | None = None, owner: str = "") -> int:
        """`v` as an index into top-level `coll` (or a local list of `n`), checked."""
        if not _is_int(v):
            self.fail(where, f"expected an index ({_COLLECTIONS.get(coll, coll)}), found {_kind(v)}")
        size = len(self.coll(coll)) if n is None else n
        if not 0 <= v < size:
            one = _COLLECTIONS.get(coll, coll.rstrip("s"))
            self.fail(where, f"{one} {v} does not exist ({size} {one if size == 1 else coll}{owner})")
        return int(v)

    def _ref(self, obj: dict[str, Any], key: str, where: str, coll: str, required: bool = False) -> int | None:
        if key not in obj:
            if required:
                self.fail(where, f"'{key}' is required")
            return None
        return self._index(obj[key], self._at(where, key), coll)

    # -- the file, its container and its JSON -----------------------------------------------------------
    def _read_file(self) -> bytes:
        try:
            st = os.stat(self.path)
        except OSError as exc:
            raise MeshError(f"{self.path}: glTF file cannot be read: {exc.strerror}") from None
        if not stat.S_ISREG(st.st_mode):
            raise MeshError(f"{self.path}: not a regular file")
        if st.st_size > MAX_FILE_BYTES:
            self.fail("", f"the file has {_mib(st.st_size)}: the limit is {_mib(MAX_FILE_BYTES)} (MAX_FILE_BYTES)")
        return self._read_regular(self.path, st, st.st_size, "", follow=True)

    def _container(self, raw: bytes) -> tuple[bytes, memoryview | None]:
        """(JSON bytes, the GLB binary chunk (a view of `raw`: not copied) or None)."""
        if raw[:4] != _GLB_MAGIC:
            if self.path.suffix.lower() == ".glb":
                self.fail("GLB header", f"magic is {raw[:4]!r}, not b'glTF'")
            return raw, None
        if len(raw) < 20:
            self.fail("GLB header", f"the file has {len(raw)} bytes: too short for a GLB header and JSON chunk")
        version, length = struct.unpack_from("<II", raw, 4)
        if version != 2:
            self.fail("GLB header", f"version {version}: only GLB version 2 (glTF 2.0) is read")
        if length > len(raw) or length < 20:
            self.fail("GLB header", f"length {length} but the file has {len(raw)} bytes")
        if length < len(raw):
            self.note(f"{len(raw) - length} bytes after the GLB's length (ignored)")
            raw = raw[:length]
        pos, chunk, text, binary = 12, 0, b"", None
        while pos < len(raw):
            if pos + 8 > len(raw):
                self.fail(f"GLB chunk {chunk}", f"{len(raw) - pos} bytes left: too short for a chunk header")
            clen, ctype = struct.unpack_from("<II", raw, pos)
            if clen % 4:
                self.fail(f"GLB chunk {chunk}", f"length {clen} is not a multiple of 4")
            if pos + 8 + clen > len(raw):
                self.fail(f"GLB chunk {chunk}", f"length {clen} runs past the end of the file "
                          f"({len(raw) - pos - 8} bytes left)")
            data = memoryview(raw)[pos + 8:pos + 8 + clen]
            if chunk == 0:
                if ctype != _CHUNK_JSON:
                    self.fail("GLB chunk 0", f"type 0x{ctype:08X}: the first chunk must be JSON (0x4E4F534A)")
                text = bytes(data)
            elif ctype == _CHUNK_BIN:
                if chunk != 1:
                    self.fail(f"GLB chunk {chunk}", "a BIN chunk must be the second chunk, and only one")
                binary = data
            elif ctype == _CHUNK_JSON:
                self.fail(f"GLB chunk {chunk}", "a second JSON chunk")
            # chunks of other types are skipped, as the spec says
            pos += 8 + clen
            chunk += 1
        return text, binary

    def _parse_json(self, data: bytes) -> dict[str, Any]:
        if data.startswith(b"\xef\xbb\xbf"):
            self.fail("JSON", "starts with a byte order mark (glTF JSON is UTF-8 without one)")
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as exc:
            self.fail("JSON", f"not UTF-8 (byte {exc.start})")
        structural = len(text)
        if structural > MAX_JSON_BYTES:  # data: URIs do not count
            structural -= sum(m.end() - m.start() for m in _DATA_URI.finditer(text))
        if structural > MAX_JSON_BYTES:
            self.fail("JSON", f"{_mib(structural)} of JSON (data: URIs not counted): the limit is "
                      f"{_mib(MAX_JSON_BYTES)} (MAX_JSON_BYTES)")
        objects = [0]

        def pairs(items: list[tuple[str, Any]]) -> dict[str, Any]:
            objects[0] += 1
            if objects[0] > MAX_JSON_OBJECTS:
                self.fail("JSON", f"more than {MAX_JSON_OBJECTS} objects (MAX_JSON_OBJECTS)")
            d = dict(items)
            if len(d) != len(items):
                seen: set[str] = set()
                dup = next(k for k, _ in items if k in seen or seen.add(k))  # type: ignore[func-returns-value]
                self.fail("JSON", f"key {dup!r} appears twice in one object")
            return d

        def constant(name: str) -> Any:
            raise ValueError(f"{name} is not a JSON number")

        def number(s: str) -> float:
            v = float(s)
            if not math.isfinite(v):
                raise ValueError(f"the number {s[:20]} is out of range")
            return v

        try:
            doc = json.loads(text, object_pairs_hook=pairs, parse_constant=constant, parse_float=number)
        except json.JSONDecodeError as exc:
            self.fail("JSON", f"not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})")
        except RecursionError:
            self.fail("JSON", "nested too deeply")
        except ValueError as exc:
            self.fail("JSON", f"not valid JSON: {str(exc).splitlines()[0][:120]}")
        if not isinstance(doc, dict):
            self.fail("JSON", f"expected an object at the top, found {_kind(doc)}")
        return doc

    # -- URIs: inside the folder, regular files, declared sizes ---------------------------------------------
    def _data_uri(self, uri: str, where: str, max_bytes: int) -> str:
        """The base64 payload of a data: URI, its length checked against `max_bytes` before any decoding."""
        head, sep, payload = uri.partition(",")
        if not sep or not head.lower().endswith(";base64"):
            self.fail(where, "a data: URI must be base64 (data:<type>;base64,...)")
        if len(payload) > 4 * -(-max_bytes // 3):
            self.fail(where, f"the data: URI holds {len(payload)} base64 characters: more than {max_bytes} bytes")
        return payload

    def _decode64(self, payload: str, where: str) -> bytes:
        try:
            return base64.b64decode(payload, validate=True)
        except (binascii.Error, ValueError):
            self.fail(where, "the data: URI is not valid base64")

    def _local(self, uri: str, where: str) -> Path:
        """The file a relative URI names, refused unless it stays in the glTF file's folder (after decoding
        %XX and resolving symlinks; `allow_outside` lifts that). Nothing is opened here."""
        if "\0" in uri:
            self.fail(where, "the URI contains a NUL byte")
        m = _SCHEME.match(uri)
        if m:
            self.fail(where, f"URI scheme '{m.group(0)}' is not read: only files beside {self.name} and data: URIs")
        try:
            text = unquote(uri, errors="strict")
        except UnicodeDecodeError:
            self.fail(where, f"URI {uri[:80]!r}: its %XX escapes are not UTF-8")
        if "\0" in text:
            self.fail(where, "the URI contains a NUL byte (%00)")
        if not text:
            self.fail(where, "the URI is empty")
        if text.startswith(("/", "\\")) and not self.allow_outside:
            self.fail(where, f"URI {uri[:80]!r} is an absolute path: only files in the folder of {self.name} are "
                      "read (--allow-outside-scene-dir or allow_outside=True for a trusted file)")
        try:
            real = (self.base / text).resolve()
        except (OSError, RuntimeError, ValueError) as exc:
            self.fail(where, f"URI {uri[:80]!r} cannot be resolved: {exc}")
        if not self.allow_outside and not real.is_relative_to(self.root):
            self.fail(where, f"URI {uri[:80]!r} leads outside the folder of {self.name} (after resolving '..' and "
                      "symlinks; --allow-outside-scene-dir or allow_outside=True for a trusted file)")
        return real

    def _read_regular(self, real: Path, st: os.stat_result, size: int, where: str, follow: bool = False) -> bytes:
        """`size` bytes from the start of the regular file `real` (stat `st`), never waiting on a FIFO nor
        (unless `follow`: the glTF file itself) following a last symlink; refused if it changed since the stat."""
        flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
        if not follow:
            flags |= getattr(os, "O_NOFOLLOW", 0)
        try:
            fd = os.open(real, flags)
        except OSError as exc:
            self.fail(where, f"{real.name}: cannot be opened: {exc.strerror}")
        try:
            now = os.fstat(fd)
            if not stat.S_ISREG(now.st_mode) or (now.st_dev, now.st_ino) != (st.st_dev, st.st_ino):
                self.fail(where, f"{real.name}: the file changed while it was opened")
            chunks, left = [], size
            while left > 0:
                part = os.read(fd, min(left, 64 << 20))
                if not part:
                    break
                chunks.append(part)
                left -= len(part)
        except OSError as exc:
            self.fail(where, f"{real.name}: cannot be read: {exc.strerror}")
        finally:
            os.close(fd)
        if left > 0:
            self.fail(where, f"{real.name}: the file ended after {size - left} of {size} bytes")
        return b"".join(chunks)

    def _read_uri(self, uri: str, where: str, need: int | None, limit: int, limit_name: str) -> bytes:
        """A file named by a relative URI: `need` bytes (a buffer's byteLength; refused if the file is
        shorter, the rest is not read), or the whole file up to `limit` (an image). Stat before open: only
        regular files are opened."""
        real = self._local(uri, where)
        try:
            st = os.stat(real)
        except FileNotFoundError:
            self.fail(where, f"file not found: {uri[:80]!r} (URIs are relative to the folder of {self.name})")
        except OSError as exc:
            self.fail(where, f"{uri[:80]!r} cannot be read: {exc.strerror}")
        if not stat.S_ISREG(st.st_mode):
            what = ("a directory" if stat.S_ISDIR(st.st_mode) else "a FIFO" if stat.S_ISFIFO(st.st_mode)
                    else "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)
                    else "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
            self.fail(where, f"{uri[:80]!r} is {what}: only regular files are read")
        if need is not None:
            if st.st_size < need:
                self.fail(where, f"{uri[:80]!r} has {st.st_size} bytes; the buffer declares byteLength {need}")
            size = need
        else:
            size = st.st_size
            if size > limit:
                self.fail(where, f"{uri[:80]!r} has {_mib(size)}: the limit is {_mib(limit)} ({limit_name})")
        data = self._read_regular(real, st, size, where)
        self.hasher.update(data)
        return data

    # -- the document, checked before anything in it is used ------------------------------------------------
    def _validate(self) -> None:
        j = self.j
        asset = self._dict(j, "asset", "", required=True)
        version = self._str(asset, "version", "asset", required=True)
        if not re.fullmatch(r"2\.[0-9]+", version):
            self.fail("asset.version", f"{version[:20]!r}: only glTF 2.x is read")
        minimum = self._str(asset, "minVersion", "asset")
        if minimum is not None and minimum != "2.0":
            self.fail("asset.minVersion", f"{minimum[:20]!r}: this reader implements glTF 2.0")
        used = self._list(j, "extensionsUsed", "")
        required = self._list(j, "extensionsRequired", "")
        for key, names in (("extensionsUsed", used), ("extensionsRequired", required)):
            for k, e in enumerate(names):
                if not isinstance(e, str):
                    self.fail(f"{key}[{k}]", f"expected an extension name, found {_kind(e)}")
        for k, e in enumerate(required):
            if not e.startswith(_SUPPORTED_REQUIRED):
                self.fail(f"extensionsRequired[{k}]", f"the file requires extension {e[:80]}, which is not supported")
            if e not in used:
                self.fail(f"extensionsRequired[{k}]", f"{e[:80]} is not listed in extensionsUsed")
        for e in used:
            if e in _READ_EXTENSIONS:
                pass
            elif not e.startswith(_HARMLESS_PREFIXES):
                self.note(f"extension {e[:80]}")
        self.quantized = "KHR_mesh_quantization" in used
        for key, names in (("extensionsUsed", used), ("extensionsRequired", required)):
            if len(set(names)) != len(names):
                self.fail(key, "lists an extension twice")
        for key in ("generator", "copyright"):
            self._str(asset, key, "asset")
        for key in _COLLECTIONS:
            items = self._list(j, key, "")
            for i, item in enumerate(items):
                if not isinstance(item, dict):
                    self.fail(f"{key}[{i}]", f"expected an object, found {_kind(item)}")
                if "name" in item and not isinstance(item["name"], str):
                    self.fail(f"{key}[{i}].name", f"expected a string, found {_kind(item['name'])}")
                if "extensions" in item and not isinstance(item["extensions"], dict):
                    self.fail(f"{key}[{i}].extensions", f"expected an object, found {_kind(item['extensions'])}")
        n = len(self.coll("nodes"))
        if n > MAX_NODES:
            self.fail("nodes", f"{n} nodes: the limit is {MAX_NODES} (MAX_NODES)")
        self._check_buffers()
        self._check_views()
        self._check_accessors()
        self._check_materials()
        self._check_meshes()
        self._check_cameras()
        self._check_nodes()
        self._check_skins()
        self._check_scenes()
        self._check_lights()
        self._check_animations()  # after the lights: KHR_animation_pointer may animate them

    def _check_buffers(self) -> None:
        total = 0
        self.buffer_len: list[int] = []
        for i, b in enumerate(self.coll("buffers")):
            w = f"buffers[{i}]"
            length = self._int(b, "byteLength", w, lo=1, required=True)
            total += length
            if total > MAX_BUFFER_BYTES:
                self.fail(f"{w}.byteLength", f"the buffers declare {_mib(total)} so far: the limit is "
                          f"{_mib(MAX_BUFFER_BYTES)} (MAX_BUFFER_BYTES)")
            uri = self._str(b, "uri", w)
            if uri is None:  # without a uri only a .glb's buffers[0] has data; another is refused if read
                if self.bin is not None and i == 0 and len(self.bin) < length:
                    self.fail(f"{w}.byteLength", f"{length}, but the GLB binary chunk has {len(self.bin)} bytes")
            elif uri[:5].lower() == "data:":
                self._data_uri(uri, f"{w}.uri", length)
            else:
                self._local(uri, f"{w}.uri")
            self.buffer_len.append(length)

    def _check_views(self) -> None:
        self.views: list[tuple[int, int, int, int | None]] = []  # buffer, offset, length, stride
        for i, v in enumerate(self.coll("bufferViews")):
            w = f"bufferViews[{i}]"
            b = self._ref(v, "buffer", w, "buffers", required=True)
            assert b is not None
            off = self._int(v, "byteOffset", w, 0, lo=0)
            length = self._int(v, "byteLength", w, lo=1, required=True)
            stride = self._int(v, "byteStride", w)
            if stride is not None and not (4 <= stride <= 252 and stride % 4 == 0):
                self.fail(f"{w}.byteStride", f"{stride}: must be a multiple of 4 in 4..252")
            target = self._int(v, "target", w)
            if target is not None and target not in (34962, 34963):
                self.fail(f"{w}.target", f"{target}: must be 34962 (vertices) or 34963 (indices)")
            if off + length > self.buffer_len[b]:
                self.fail(w, f"bytes {off}..{off + length} run past the end of buffers[{b}] "
                          f"(byteLength {self.buffer_len[b]})")
            self.views.append((b, off, length, stride))

    def _fits(self, w: str, view: int, offset: int, count: int, elsize: int, stride: int | None,
              csize: int) -> None:
        _, voff, vlen, _ = self.views[view]
        if offset % csize or (voff + offset) % csize:
            self.fail(w, f"offset {voff + offset} in the buffer is not a multiple of the component size {csize}")
        if stride is not None and stride < elsize:
            self.fail(w, f"bufferViews[{view}].byteStride {stride} is less than the element size {elsize}")
        end = offset + (stride or elsize) * (count - 1) + elsize
        if end > vlen:
            self.fail(w, f"{count} elements from byte {offset} need {end} bytes; bufferViews[{view}] has {vlen}")

    def _check_accessors(self) -> None:
        self.accs: list[_Acc] = []
        for i, a in enumerate(self.coll("accessors")):
            w = f"accessors[{i}]"
            ctype = self._int(a, "componentType", w, required=True)
            if ctype not in _DTYPES:
                self.fail(f"{w}.componentType", f"{ctype} is not a glTF component type (5120, 5121, 5122, 5123, "
                          "5125, 5126)")
            kind = self._str(a, "type", w, required=True)
            if kind not in _NCOMP:
                self.fail(f"{w}.type", f"{kind[:20]!r} is not an accessor type ({', '.join(_NCOMP)})")
            normalized = self._bool(a, "normalized", w)
            if normalized and ctype in (5125, 5126):
                self.fail(f"{w}.normalized", "only byte and short components can be normalized")
            count = self._int(a, "count", w, lo=1, required=True)
            if count > MAX_ACCESSOR_COUNT:
                self.fail(f"{w}.count", f"{count} elements: the limit is {MAX_ACCESSOR_COUNT} (MAX_ACCESSOR_COUNT)")
            ncomp, csize = _NCOMP[kind], _CSIZE[ctype]
            elsize = _element_size(kind, csize)
            view = self._ref(a, "bufferView", w, "bufferViews")
            offset = self._int(a, "byteOffset", w, 0, lo=0)
            if view is None and offset:
                self.fail(f"{w}.byteOffset", "is given without a bufferView")
            if view is not None:
                self._fits(w, view, offset, count, elsize, self.views[view][3], csize)
            lo = self._numbers(a, "min", w, ncomp)
            hi = self._numbers(a, "max", w, ncomp)
            sparse = None
            sp = self._dict(a, "sparse", w)
            if sp is not None:
                ws = f"{w}.sparse"
                scount = self._int(sp, "count", ws, lo=1, hi=count, required=True)
                idx = self._dict(sp, "indices", ws, required=True)
                vals = self._dict(sp, "values", ws, required=True)
                iv = self._ref(idx, "bufferView", f"{ws}.indices", "bufferViews", required=True)
                ioff = self._int(idx, "byteOffset", f"{ws}.indices", 0, lo=0)
                ictype = self._int(idx, "componentType", f"{ws}.indices", required=True)
                if ictype not in (5121, 5123, 5125):
                    self.fail(f"{ws}.indices.componentType", f"{ictype}: must be 5121, 5123 or 5125 (unsigned)")
                vv = self._ref(vals, "bufferView", f"{ws}.values", "bufferViews", required=True)
                voff = self._int(vals, "byteOffset", f"{ws}.values", 0, lo=0)
                assert iv is not None and vv is not None
                for vi, where in ((iv, f"{ws}.indices"), (vv, f"{ws}.values")):
                    if self.views[vi][3] is not None:
                        self.fail(where, f"bufferViews[{vi}] has a byteStride (sparse data is tightly packed)")
                self._fits(f"{ws}.indices", iv, ioff, scount, _CSIZE[ictype], None, _CSIZE[ictype])
                self._fits(f"{ws}.values", vv, voff, scount, elsize, None, csize)
                sparse = (scount, iv, ioff, ictype, vv, voff)
            self.accs.append(_Acc(ctype, kind, ncomp, count, normalized, view, offset, elsize, lo, hi, sparse))

    def _format(self, acc: int, where: str, rule: tuple[Any, ...], what: str) -> _Acc:
        """Accessor `acc` (already an index in range), checked to suit `what` (its type and formats)."""
        a = self.accs[acc]
        types, formats, quant = rule
        allowed = formats + (quant if self.quantized else ())
        if a.kind not in types:
            self.fail(where, f"accessor {acc} is {a.kind}; {what} must be {' or '.join(types)}")
        if (a.ctype, a.normalized) not in allowed:
            names = {5120: "byte", 5121: "unsigned byte", 5122: "short", 5123: "unsigned short",
                     5125: "unsigned int", 5126: "float"}
            have = ("normalized " if a.normalized else "") + names[a.ctype]
            want = ", ".join(("normalized " if nm else "") + names[c] for c, nm in allowed)
            self.fail(where, f"accessor {acc} has {have} components; {what} takes {want}")
        return a

    def _check_texture_info(self, obj: dict[str, Any], key: str, where: str, sets: set[int]) -> None:
        info = self._dict(obj, key, where)
        if info is not None:
            self._ref(info, "index", self._at(where, key), "textures", required=True)
            sets.add(self._int(info, "texCoord", self._at(where, key), 0, lo=0))
            for factor in ("scale", "strength"):
                self._num(info, factor, self._at(where, key))

    def _check_materials(self) -> None:
        for i, im in enumerate(self.coll("images")):
            w = f"images[{i}]"
            uri = self._str(im, "uri", w)
            view = self._ref(im, "bufferView", w, "bufferViews")
            mime = self._str(im, "mimeType", w)
            if (uri is None) == (view is None):
                self.fail(w, "needs exactly one of 'uri' and 'bufferView'")
            if mime is not None and mime not in _IMAGE_TYPES:
                self.fail(f"{w}.mimeType", f"{mime[:40]!r}: must be image/png, image/jpeg or image/webp (others "
                          "come with an extension this reader does not read)")
            if view is not None:
                if mime is None:
                    self.fail(w, "'mimeType' is required with 'bufferView'")
                if self.views[view][3] is not None:
                    self.fail(f"{w}.bufferView", f"bufferViews[{view}] has a byteStride (image data is not strided)")
            elif uri is not None:
                if uri[:5].lower() == "data:":
                    self._data_uri(uri, f"{w}.uri", MAX_IMAGE_BYTES)
                else:
                    self._local(uri, f"{w}.uri")
        for i, s in enumerate(self.coll("samplers")):
            w = f"samplers[{i}]"
            for key in ("magFilter", "minFilter", "wrapS", "wrapT"):  # unused here; the schema lets any integer by
                self._int(s, key, w)
        for i, t in enumerate(self.coll("textures")):
            w = f"textures[{i}]"
            self._ref(t, "source", w, "images")
            self._ref(t, "sampler", w, "samplers")
            webp = self._dict(self._dict(t, "extensions", w) or {}, "EXT_texture_webp", f"{w}.extensions")
            if webp is not None:
                self._ref(webp, "source", f"{w}.extensions.EXT_texture_webp", "images")
        self.material_uvs: list[set[int]] = []
        for i, m in enumerate(self.coll("materials")):
            w = f"materials[{i}]"
            sets: set[int] = set()
            self.material_uvs.append(sets)
            pbr = self._dict(m, "pbrMetallicRoughness", w)
            if pbr is not None:
                wp = f"{w}.pbrMetallicRoughness"
                self._numbers(pbr, "baseColorFactor", wp, 4, 0.0, 1.0)
                for key in ("metallicFactor", "roughnessFactor"):
                    v = self._num(pbr, key, wp)
                    if v is not None and not 0.0 <= v <= 1.0:
                        self.fail(f"{wp}.{key}", f"{v} is out of range (0..1)")
                self._check_texture_info(pbr, "baseColorTexture", wp, sets)
                self._check_texture_info(pbr, "metallicRoughnessTexture", wp, sets)
            for key in ("normalTexture", "occlusionTexture", "emissiveTexture"):
                self._check_texture_info(m, key, w, sets)
            self._numbers(m, "emissiveFactor", w, 3, 0.0, 1.0)
            self._str(m, "alphaMode", w)  # unused here; the schema lets any string by
            cutoff = self._num(m, "alphaCutoff", w)
            if cutoff is not None and cutoff < 0:
                self.fail(f"{w}.alphaCutoff", f"{cutoff}: must be >= 0")
            self._bool(m, "doubleSided", w)

    def _attributes(self, attrs: dict[str, Any], where: str, rules: dict[str, Any]) -> dict[str, int]:
        out: dict[str, int] = {}
        for name, v in attrs.items():
            if not _ATTRIBUTE_NAME.match(name):
                self.fail(f"{where}.{name[:40]}", "not a glTF attribute name (POSITION, NORMAL, TANGENT, "
                          "TEXCOORD_n, COLOR_n, JOINTS_n, WEIGHTS_n, or _APPLICATION_SPECIFIC)")
            acc = self._index(v, f"{where}.{name}", "accessors")
            rule = rules.get(name.split("_")[0] if name[0] != "_" else "")
            if name[0] != "_" and rule is None:
                self.fail(f"{where}.{name}", "is not allowed here")
            if rule is not None:
                self._format(acc, f"{where}.{name}", rule, name)
            out[name] = acc
        counts = {self.accs[a].count for a in out.values()}
        if len(counts) > 1:
            self.fail(where, f"its accessors have different counts ({', '.join(map(str, sorted(counts)))})")
        return out

    def _vertex_attributes(self, found: dict[str, int], where: str) -> None:
        """POSITION has bounds; vertex data is 4-byte aligned; a bufferView shared by vertex attributes has a
        byteStride."""
        if "POSITION" in found:
            a = self.accs[found["POSITION"]]
            if a.minimum is None or a.maximum is None:
                self.fail(f"{where}.POSITION", f"accessor {found['POSITION']} has no min and max (POSITION needs both)")
        for name, acc in found.items():
            a = self.accs[acc]
            if a.view is None:
                continue
            if (self.views[a.view][1] + a.offset) % 4:
                self.fail(f"{where}.{name}", f"accessor {acc} starts at byte {self.views[a.view][1] + a.offset} of "
                          "its buffer: vertex data must be 4-byte aligned")
            users = self._vertex_views.setdefault(a.view, set())
            users.add(acc)
            if len(users) > 1 and self.views[a.view][3] is None:
                self.fail(f"{where}.{name}", f"bufferViews[{a.view}] holds several vertex attributes without a "
                          "byteStride")

    def _check_meshes(self) -> None:
        self._vertex_views: dict[int, set[int]] = {}
        self.mesh_targets: list[int] = []
        self.mesh_skinned: list[bool] = []
        for mi, m in enumerate(self.coll("meshes")):
            w = f"meshes[{mi}]"
            prims = self._list(m, "primitives", w, required=True, nonempty=True)
            targets: int | None = None
            skinned = True
            for pi, p in enumerate(prims):
                wp = f"{w}.primitives[{pi}]"
                if not isinstance(p, dict):
                    self.fail(wp, f"expected an object, found {_kind(p)}")
                attrs = self._dict(p, "attributes", wp, required=True)
                if not attrs:
                    self.fail(f"{wp}.attributes", "must not be empty")
                found = self._attributes(attrs, f"{wp}.attributes", _ATTRIBUTES)
                for k in range(len(found)):
                    if (f"JOINTS_{k}" in found) != (f"WEIGHTS_{k}" in found):
                        self.fail(f"{wp}.attributes", f"JOINTS_{k} and WEIGHTS_{k} come together")
                skinned = skinned and "JOINTS_0" in found
                idx = self._ref(p, "indices", wp, "accessors")
                if idx is not None:
                    a = self._format(idx, f"{wp}.indices", (("SCALAR",), (_UB, _US, _UI), ()), "indices")
                    if a.view is not None and self.views[a.view][3] is not None:  # none: zeros (or sparse)
                        self.fail(f"{wp}.indices", f"bufferViews[{a.view}] has a byteStride (indices are packed)")
                self._check_draco(p, wp, found, idx)
                material = self._ref(p, "material", wp, "materials")
                if material is not None:
                    for uv in sorted(self.material_uvs[material]):
                        if f"TEXCOORD_{uv}" not in found:
                            self.fail(f"{wp}.material", f"materials[{material}] samples TEXCOORD_{uv}, which the "
                                      "primitive does not have")
                self._vertex_attributes(found, f"{wp}.attributes")
                self._int(p, "mode", wp, 4, lo=0, hi=6)
                tl = self._list(p, "targets", wp, nonempty=True)
                count = next(iter({self.accs[a].count for a in found.values()}))
                for ti, t in enumerate(tl):
                    if not isinstance(t, dict) or not t:
                        self.fail(f"{wp}.targets[{ti}]", f"expected an object with attributes, found {_kind(t)}")
                    tf = self._attributes(t, f"{wp}.targets[{ti}]", _TARGET_ATTRIBUTES)
                    self._vertex_attributes(tf, f"{wp}.targets[{ti}]")
                    if self.accs[next(iter(tf.values()))].count != count:
                        self.fail(f"{wp}.targets[{ti}]", f"{self.accs[next(iter(tf.values()))].count} elements, "
                                  f"the primitive's attributes have {count}")
                if targets is None:
                    targets = len(tl)
                elif targets != len(tl):
                    self.fail(f"{wp}.targets", f"{len(tl)} morph targets; the mesh's first primitive has {targets}")
            weights = self._numbers(m, "weights", w)
            if weights is not None and len(weights) != (targets or 0):
                self.fail(f"{w}.weights", f"{len(weights)} weights for {targets or 0} morph targets")
            self.mesh_targets.append(targets or 0)
            self.mesh_skinned.append(skinned)

    def _check_cameras(self) -> None:
        for ci, c in enumerate(self.coll("cameras")):
            w = f"cameras[{ci}]"
            kind = self._str(c, "type", w, required=True)
            if kind not in ("perspective", "orthographic"):
                continue  # an extension's camera (the schema allows any type): never looked through here
            other = "orthographic" if kind == "perspective" else "perspective"
            if other in c:
                self.fail(w, f"a {kind} camera with '{other}'")
            p = self._dict(c, kind, w, required=True)
            wp = f"{w}.{kind}"
            if kind == "perspective":
                yfov = self._num(p, "yfov", wp, required=True)
                if not 0.0 < yfov < math.pi:
                    self.fail(f"{wp}.yfov", f"{yfov}: must be in (0, pi) radians")
                znear = self._num(p, "znear", wp, required=True)
                if not znear > 0.0:
                    self.fail(f"{wp}.znear", f"{znear}: must be > 0")
                zfar = self._num(p, "zfar", wp)
                if zfar is not None and not zfar > znear:
                    self.fail(f"{wp}.zfar", f"{zfar}: must be > znear ({znear})")
                aspect = self._num(p, "aspectRatio", wp)
                if aspect is not None and not aspect > 0.0:
                    self.fail(f"{wp}.aspectRatio", f"{aspect}: must be > 0")
            else:
                for key in ("xmag", "ymag"):
                    if self._num(p, key, wp, required=True) == 0.0:
                        self.fail(f"{wp}.{key}", "must not be zero")
                znear = self._num(p, "znear", wp, required=True)
                zfar = self._num(p, "zfar", wp, required=True)
                if not znear >= 0.0:
                    self.fail(f"{wp}.znear", f"{znear}: must be >= 0")
                if not zfar > znear:
                    self.fail(f"{wp}.zfar", f"{zfar}: must be > znear ({znear})")

    def _check_nodes(self) -> None:
        nodes = self.coll("nodes")
        n = len(nodes)
        self.children: list[list[int]] = []
        self.instancing: dict[int, dict[str, int]] = {}
        self.hidden: set[int] = set()  # KHR_node_visibility visible: false (the node and all below it)
        self.parent = [-1] * n
        parent = self.parent
        none: list[int] = []
        for i, nd in enumerate(nodes):
            w = f"nodes[{i}]"
            kids = self._list(nd, "children", w, nonempty=True) if "children" in nd else none
            for k, c in enumerate(kids):
                if not (_is_int(c) and 0 <= c < n):
                    self._index(c, f"{w}.children[{k}]", "nodes")
                if c == i:
                    self.fail(f"{w}.children[{k}]", "a node cannot be its own child")
                if parent[c] != -1:
                    self.fail(f"{w}.children[{k}]", f"node {c} is already a child of node {parent[c]} "
                              "(a node has one parent)")
                parent[c] = i
            self.children.append(kids)
            if len(nd) == 1 and isinstance(nd.get("name"), str):  # the common leaf: nothing more to check
                continue
            mesh = self._ref(nd, "mesh", w, "meshes")
            skin = self._ref(nd, "skin", w, "skins")
            self._ref(nd, "camera", w, "cameras")
            matrix = self._numbers(nd, "matrix", w, 16)
            self._numbers(nd, "translation", w, 3)
            rot = self._numbers(nd, "rotation", w, 4, -1.0, 1.0)
            self._numbers(nd, "scale", w, 3)
            if matrix is not None and (matrix[3], matrix[7], matrix[11], matrix[15]) != (0.0, 0.0, 0.0, 1.0):
                self.fail(f"{w}.matrix", "is not an affine transform (its last row must be 0, 0, 0, 1)")
            if matrix is not None:
                cols = [matrix[0:3], matrix[4:7], matrix[8:11]]
                norms = [math.sqrt(sum(x * x for x in c)) for c in cols]
                for a_, b_ in ((0, 1), (0, 2), (1, 2)):
                    if abs(sum(x * y for x, y in zip(cols[a_], cols[b_], strict=True))) > 1e-4 * norms[a_] * norms[b_]:
                        self.fail(f"{w}.matrix", "has shear: it is not translation x rotation x scale")
            if matrix is not None and any(k in nd for k in ("translation", "rotation", "scale")):
                self.fail(w, "has both 'matrix' and translation/rotation/scale")
            if rot is not None and abs(math.sqrt(sum(x * x for x in rot)) - 1.0) > _UNIT_TOLERANCE:
                self.fail(f"{w}.rotation", "is not a unit quaternion")
            if skin is not None and mesh is None:
                self.fail(f"{w}.skin", "a node with a skin needs a mesh")
            self._check_instancing(i, nd, w, mesh)
            ext = nd.get("extensions")
            if isinstance(ext, dict) and "KHR_node_visibility" in ext:
                vis = self._dict(ext, "KHR_node_visibility", f"{w}.extensions", required=True)
                if not self._bool(vis, "visible", f"{w}.extensions.KHR_node_visibility", True):
                    self.hidden.add(i)
            if skin is not None and not self.mesh_skinned[mesh]:  # type: ignore[index]
                self.fail(f"{w}.skin", f"meshes[{mesh}] has a primitive without JOINTS_0 and WEIGHTS_0")
            weights = self._numbers(nd, "weights", w)
            if weights is not None:
                have = self.mesh_targets[mesh] if mesh is not None else 0
                if len(weights) != have or not have:
                    self.fail(f"{w}.weights", f"{len(weights)} weights for {have} morph targets of its mesh")
            name = nd.get("name")
            if name is not None and not isinstance(name, str):
                self.fail(f"{w}.name", f"expected a string, found {_kind(name)}")
        # every node below a root (a node without parent): what is left over hangs in a cycle
        roots = [i for i in range(n) if self.parent[i] == -1]
        try:
            reached, depth = _walk(self.children, roots, n, MAX_DEPTH)
        except _HierarchyError as exc:
            self.fail(f"nodes[{exc.node}]", exc.why)
        if len(reached) != n:
            seen = bytearray(n)
            for i in reached:
                seen[i] = 1
            k = seen.index(0)
            self.fail(f"nodes[{k}]", "is in a cycle of children (no root node above it)")
        self.depth = [0] * n
        for i, d in zip(reached, depth, strict=True):
            self.depth[i] = d

    def _check_draco(self, p: dict[str, Any], wp: str, found: dict[str, int], indices: int | None) -> None:
        """KHR_draco_mesh_compression on a primitive: its bufferView, and Draco unique ids for attributes the
        primitive has (their accessors carry no bufferView: the stream holds their values)."""
        ext = self._dict(p, "extensions", wp) or {}
        draco = self._dict(ext, "KHR_draco_mesh_compression", f"{wp}.extensions")
        if draco is None:
            return
        wd = f"{wp}.extensions.KHR_draco_mesh_compression"
        self._ref(draco, "bufferView", wd, "bufferViews", required=True)
        ids = self._dict(draco, "attributes", wd, required=True)
        for name in ids:
            self._int(ids, name, f"{wd}.attributes", lo=0, required=True)
            if name not in found:
                self.fail(f"{wd}.attributes.{name[:40]}", "names an attribute the primitive does not have")
        if indices is None and p.get("mode", 4) == 4:
            self.fail(wp, "a Draco-compressed triangle primitive needs indices")

    def draco(self, p: dict[str, Any], where: str) -> None:
        """Decode a primitive's KHR_draco_mesh_compression stream (DracoPy, Google's decoder) into the values of
        the accessors it stands for, each checked against its accessor's count and components, the indices
        against the vertex count. The accessors' declared sizes are counted against MAX_DECODED_BYTES first;
        their min and max are not checked (writers give those of the values before quantization)."""
        ext = p["extensions"]["KHR_draco_mesh_compression"]
        wd = f"{where}.extensions.KHR_draco_mesh_compression"
        attrs = {name: p["attributes"][name] for name in ext["attributes"]}
        for acc in [*attrs.values(), p["indices"]]:
            a = self.accs[acc]
            self._spend(a.count * a.ncomp * 8, wd)
        b, off, length, _ = self.views[ext["bufferView"]]
        import DracoPy

        try:
            mesh = DracoPy.decode(self.buffer(b)[off:off + length])
            faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1)
        except Exception:  # the decoder raises its own types for a broken stream
            self.fail(wd, "its Draco stream does not decode as a mesh")
        n = None
        for name, acc in attrs.items():
            uid = ext["attributes"][name]
            att = mesh.get_attribute_by_unique_id(uid)
            a = self.accs[acc]
            values = None if att is None else np.asarray(att["data"])
            if values is None or values.ndim != 2 or values.shape != (a.count, a.ncomp):
                have = "nothing" if values is None else "x".join(map(str, values.shape))
                self.fail(f"{wd}.attributes.{name}", f"Draco attribute {uid} holds {have}; accessor {acc} declares "
                          f"{a.count} x {a.ncomp}")
            self._draco[acc] = values.astype(_DTYPES[a.ctype])
            n = a.count
        ia = self.accs[p["indices"]]
        if len(faces) != ia.count or (n is not None and len(faces) and faces.max() >= n):
            self.fail(f"{where}.indices", f"the Draco stream holds {len(faces)} indices up to "
                      f"{int(faces.max()) if len(faces) else 0}; accessor {p['indices']} declares {ia.count} for "
                      f"{n} vertices")
        self._draco[p["indices"]] = faces.astype(_DTYPES[ia.ctype]).reshape(-1, 1)

    def _check_instancing(self, i: int, nd: dict[str, Any], w: str, mesh: int | None) -> None:
        """EXT_mesh_gpu_instancing on node i: its TRANSLATION / ROTATION / SCALE accessors, one count
        (`self.instancing[i]`: attribute name -> accessor)."""
        ext = nd.get("extensions")
        if not isinstance(ext, dict) or "EXT_mesh_gpu_instancing" not in ext:
            return
        we = f"{w}.extensions.EXT_mesh_gpu_instancing"
        inst = self._dict(ext, "EXT_mesh_gpu_instancing", f"{w}.extensions", required=True)
        attrs = self._dict(inst, "attributes", we, required=True)
        if mesh is None:
            self.fail(we, "instances a mesh, but the node has none")
        found: dict[str, int] = {}
        counts: set[int] = set()
        for name, v in attrs.items():
            if name.startswith("_"):  # application-specific (instance ids, colours): not drawn
                continue
            if name not in _INSTANCE_ATTRIBUTES:
                self.fail(f"{we}.attributes.{name[:40]}", "not an instancing attribute (TRANSLATION, ROTATION, SCALE "
                          "or _APPLICATION_SPECIFIC)")
            acc = self._index(v, f"{we}.attributes.{name}", "accessors")
            a = self._format(acc, f"{we}.attributes.{name}", _INSTANCE_ATTRIBUTES[name], name)
            found[name] = acc
            counts.add(a.count)
        if not found:
            self.fail(f"{we}.attributes", "names none of TRANSLATION, ROTATION and SCALE")
        if len(counts) > 1:
            self.fail(f"{we}.attributes", "its accessors have different counts "
                      f"({', '.join(map(str, sorted(counts)))})")
        self.instancing[i] = found

    def instance_count(self, node: int) -> int:
        """How many instances EXT_mesh_gpu_instancing gives node `node` (one of `self.instancing`)."""
        return self.accs[next(iter(self.instancing[node].values()))].count

    def _check_skins(self) -> None:
        self.skin_joints: list[list[int]] = []
        for si, s in enumerate(self.coll("skins")):
            w = f"skins[{si}]"
            joints = [self._index(v, f"{w}.joints[{k}]", "nodes")
                      for k, v in enumerate(self._list(s, "joints", w, required=True, nonempty=True))]
            if len(set(joints)) != len(joints):
                self.fail(f"{w}.joints", "lists a node twice")
            self._ref(s, "skeleton", w, "nodes")
            ibm = self._ref(s, "inverseBindMatrices", w, "accessors")
            if ibm is not None:
                a = self._format(ibm, f"{w}.inverseBindMatrices", (("MAT4",), (_F,), ()), "inverseBindMatrices")
                if a.count < len(joints):
                    self.fail(f"{w}.inverseBindMatrices", f"accessor {ibm} has {a.count} matrices for "
                              f"{len(joints)} joints")
            self.skin_joints.append(joints)

    def _check_scenes(self) -> None:
        scenes = self.coll("scenes")
        for si, s in enumerate(scenes):
            w = f"scenes[{si}]"
            listed = set()
            for k, v in enumerate(self._list(s, "nodes", w)):
                v = self._index(v, f"{w}.nodes[{k}]", "nodes")
                if self.parent[v] != -1:
                    self.fail(f"{w}.nodes[{k}]", f"node {v} is a child of node {self.parent[v]}: a scene lists "
                              "root nodes")
                if v in listed:
                    self.fail(f"{w}.nodes[{k}]", f"node {v} is listed twice")
                listed.add(v)
        si = self._ref(self.j, "scene", "", "scenes")
        if scenes:
            roots = list(scenes[si or 0].get("nodes") or [])
        else:
            roots = [i for i, p in enumerate(self.parent) if p == -1]
        self.order, _ = _walk(self.children, roots, len(self.parent), MAX_DEPTH)  # checked above: no error

    def _check_animations(self) -> None:
        nodes = self.coll("nodes")
        self.props: dict[tuple[int, int], tuple[str, int, str]] = {}
        for ai, an in enumerate(self.coll("animations")):
            w = f"animations[{ai}]"
            samplers = self._list(an, "samplers", w, required=True, nonempty=True)
            for si, s in enumerate(samplers):
                ws = f"{w}.samplers[{si}]"
                if not isinstance(s, dict):
                    self.fail(ws, f"expected an object, found {_kind(s)}")
                inp = self._ref(s, "input", ws, "accessors", required=True)
                self._ref(s, "output", ws, "accessors", required=True)
                interp = self._str(s, "interpolation", ws, "LINEAR")
                if interp not in _INTERPOLATIONS:
                    self.note(f"animation {ai}: interpolation {interp[:20]!r} (played as LINEAR)")
                a = self._format(inp, f"{ws}.input", (("SCALAR",), (_F,), ()), "animation input (times)")  # type: ignore[arg-type]
                if a.minimum is None or a.maximum is None:
                    self.fail(f"{ws}.input", f"accessor {inp} has no min and max (animation inputs need both)")
                if interp == "CUBICSPLINE" and self.accs[inp].count < 2:  # type: ignore[index]
                    self.fail(f"{ws}.input", "CUBICSPLINE needs at least 2 keys")
            targets: set[tuple[int, str]] = set()
            for ci, ch in enumerate(self._list(an, "channels", w, required=True, nonempty=True)):
                wc = f"{w}.channels[{ci}]"
                if not isinstance(ch, dict):
                    self.fail(wc, f"expected an object, found {_kind(ch)}")
                if "sampler" not in ch:
                    self.fail(wc, "'sampler' is required")
                smp = self._index(ch["sampler"], f"{wc}.sampler", "samplers", len(samplers), f" in {w}")
                tgt = self._dict(ch, "target", wc, required=True)
                self._ref(tgt, "node", f"{wc}.target", "nodes")
                self._str(tgt, "path", f"{wc}.target", required=True)
                node, path = self.target_of(tgt, f"{wc}.target")
                if node is None and tgt["path"] == "pointer":
                    self._check_prop(ai, ci, path, samplers[smp], f"{w}.samplers[{smp}]", wc)
                if path not in _ANIM_OUTPUT:
                    continue  # an extension's path (the schema allows any string): noted when read
                if node is None:
                    continue  # the target is given by an extension
                if (node, path) in targets:
                    self.fail(f"{wc}.target", f"a second channel for {path} of node {node}")
                targets.add((node, path))
                if path == "weights":
                    mesh = nodes[node].get("mesh")
                    k = self.mesh_targets[mesh] if mesh is not None else 0
                    if not k:
                        self.fail(f"{wc}.target", f"weights of node {node}, whose mesh has no morph targets")
                else:
                    k = 1
                    if "matrix" in nodes[node]:
                        self.fail(f"{wc}.target", f"node {node} is given by a matrix: its {path} cannot be animated")
                self._check_output(samplers[smp], f"{w}.samplers[{smp}]", _ANIM_OUTPUT[path], path, k)

    def _check_output(self, s: dict[str, Any], ws: str, rule: tuple[Any, ...], what: str, k: int) -> None:
        """A sampler's output: `rule`'s format, `k` values a key (three times that for CUBICSPLINE)."""
        out = self._format(s["output"], f"{ws}.output", rule, f"{what} output")
        keys = self.accs[s["input"]].count
        per = 3 * k if s.get("interpolation") == "CUBICSPLINE" else k
        if out.count != keys * per:
            self.fail(f"{ws}.output", f"{out.count} elements; {keys} keys of {what} need {keys * per}")

    def _check_prop(self, ai: int, ci: int, ptr: str, s: dict[str, Any], ws: str, wc: str) -> None:
        """A KHR_animation_pointer channel of a camera's or a light's field (`_PROP_POINTER`): the camera or light
        exists and is of the pointer's type, the output is that field's format with one value per key
        (`self.props[(ai, ci)]`: (kind, index, field))."""
        m = _PROP_POINTER.fullmatch(ptr)
        if m is None:
            return
        wp = f"{wc}.target.extensions.KHR_animation_pointer.pointer"
        if m.group("cam") is not None:
            kind, index, fld = "camera", self._index(int(m.group("cam")), wp, "cameras"), m.group("cfield")
            cam = self.coll("cameras")[index]
            if cam.get("type") != m.group("ctype"):
                self.fail(wp, f"camera {index} is {cam.get('type')!r}, not {m.group('ctype')!r}")
        else:
            lights = self.light_defs
            index = self._index(int(m.group("light")), wp, "lights", len(lights), " in KHR_lights_punctual")
            kind, fld = "light", m.group("lfield")
            if fld.startswith("spot/") and lights[index].kind != "spot":
                self.fail(wp, f"light {index} is a {lights[index].kind} light, not a spot")
        self._check_output(s, ws, (("VEC3",) if fld == "color" else ("SCALAR",), (_F,), ()), f"{kind} {fld}", 1)
        self.props[(ai, ci)] = (kind, index, fld)

    def target_of(self, tgt: dict[str, Any], where: str) -> tuple[int | None, str]:
        """(node, path) a channel animates: its own, or under KHR_animation_pointer a JSON pointer to a node's
        translation, rotation, scale or weights (other pointers: (None, their pointer), not read)."""
        node, path = tgt.get("node"), tgt["path"]
        if path != "pointer":
            return node, path
        ext = self._dict(tgt, "extensions", where) or {}
        pointer = self._dict(ext, "KHR_animation_pointer", f"{where}.extensions")
        if pointer is None:
            return None, path  # another extension's target: noted, not read
        ptr = self._str(pointer, "pointer", f"{where}.extensions.KHR_animation_pointer", required=True)
        m = _NODE_POINTER.fullmatch(ptr)
        if m is None:
            return None, ptr
        node = self._index(int(m.group(1)), f"{where}.extensions.KHR_animation_pointer.pointer", "nodes")
        return node, m.group(2)

    # -- data ------------------------------------------------------------------------------------------
    def _check_lights(self) -> None:
        """KHR_lights_punctual: the light definitions (`self.light_defs`, placed at the origin) and the node that
        carries each (`self.node_lights`)."""
        from .lights import Light

        self.light_defs: list[Light] = []
        self.node_lights: dict[int, int] = {}
        ext = self._dict(self.j, "extensions", "") or {}
        khr = self._dict(ext, "KHR_lights_punctual", "extensions")
        if khr is None:
            return
        base = "extensions.KHR_lights_punctual"
        for li, lt in enumerate(self._list(khr, "lights", base)):
            w = f"{base}.lights[{li}]"
            if not isinstance(lt, dict):
                self.fail(w, f"expected an object, found {_kind(lt)}")
            kind = self._str(lt, "type", w, required=True)
            if kind not in ("directional", "point", "spot"):
                self.fail(f"{w}.type", f"{kind[:40]!r}: expected directional, point or spot")
            color = self._numbers(lt, "color", w, 3, 0.0) or [1.0, 1.0, 1.0]
            intensity = self._num(lt, "intensity", w, 1.0)
            if not (math.isfinite(intensity) and intensity >= 0.0):
                self.fail(f"{w}.intensity", f"{intensity}: must be >= 0")
            rng = self._num(lt, "range", w)
            if rng is not None and not (math.isfinite(rng) and rng > 0.0):
                self.fail(f"{w}.range", f"{rng}: must be > 0")
            inner, outer = 0.0, math.pi / 4.0
            if kind == "spot":
                spot = self._dict(lt, "spot", w, required=True)
                inner = self._num(spot, "innerConeAngle", f"{w}.spot", 0.0)
                outer = self._num(spot, "outerConeAngle", f"{w}.spot", math.pi / 4.0)
                if not 0.0 <= inner < outer <= math.pi / 2.0:
                    self.fail(f"{w}.spot", f"innerConeAngle {inner}, outerConeAngle {outer}: expected 0 <= inner < "
                              "outer <= pi/2")
            name = lt.get("name") if isinstance(lt.get("name"), str) else f"light{li}"
            self.light_defs.append(Light(kind, tuple(color), intensity,  # type: ignore[arg-type]
                                         None if kind == "directional" else rng, inner, outer, name=name))
        for i, nd in enumerate(self.coll("nodes")):
            node_ext = nd.get("extensions")
            if not isinstance(node_ext, dict) or "KHR_lights_punctual" not in node_ext:
                continue
            w = f"nodes[{i}].extensions.KHR_lights_punctual"
            ref = node_ext["KHR_lights_punctual"]
            if not isinstance(ref, dict):
                self.fail(w, f"expected an object, found {_kind(ref)}")
            self.node_lights[i] = self._index(ref.get("light"), f"{w}.light", "lights", len(self.light_defs),
                                              " in extensions.KHR_lights_punctual")

    def buffer(self, i: int) -> bytes:
        """Buffer i, exactly its byteLength bytes (checked: the data holds at least that many)."""
        if i not in self._buffers:
            b = self.j["buffers"][i]
            w = f"buffers[{i}]"
            length = self.buffer_len[i]
            uri = b.get("uri")
            if uri is None:
                if self.bin is None or i != 0:
                    self.fail(w, "has no uri and is not the GLB binary chunk (only buffers[0] of a .glb can be)")
                data = self.bin[:length]
            elif uri[:5].lower() == "data:":
                data = self._decode64(self._data_uri(uri, f"{w}.uri", length), f"{w}.uri")
                if len(data) != length:
                    self.fail(f"{w}.uri", f"the data: URI holds {len(data)} bytes; byteLength is {length}")
            else:
                data = self._read_uri(uri, f"{w}.uri", length, MAX_BUFFER_BYTES, "MAX_BUFFER_BYTES")
            self._buffers[i] = bytes(data)
        return self._buffers[i]

    def _spend(self, nbytes: int, where: str) -> None:
        self._decoded += nbytes
        if self._decoded > MAX_DECODED_BYTES:
            self.fail(where, f"the accessors read need about {_mib(self._decoded)}: the limit is "
                      f"{_mib(MAX_DECODED_BYTES)} (MAX_DECODED_BYTES)")

    def _view(self, view_index: int, offset: int, count: int, dtype: Any, ncomp: int) -> np.ndarray:
        """(count, ncomp) elements from a bufferView (bounds checked in _check_accessors)."""
        b, voff, _, vstride = self.views[view_index]
        data = self.buffer(b)
        start = voff + offset
        item = np.dtype(dtype).itemsize * ncomp
        stride = vstride or item
        if stride == item:
            return np.frombuffer(data, dtype=dtype, count=count * ncomp, offset=start).reshape(count, ncomp)
        raw = np.frombuffer(data, dtype=np.uint8, count=stride * (count - 1) + item, offset=start)
        rows = np.lib.stride_tricks.as_strided(raw, shape=(count, item), strides=(stride, 1))
        return np.ascontiguousarray(rows).view(dtype).reshape(count, ncomp)

    def accessor(self, i: int, where: str, as_float: bool = True) -> np.ndarray:
        """Accessor i (its metadata checked for `where`'s use already) as (count, ncomp) float64 (or raw);
        its size is counted against MAX_DECODED_BYTES before anything is made; non-finite values refused."""
        a = self.accs[i]
        dtype = _DTYPES[a.ctype]
        self._spend(a.count * a.ncomp * (np.dtype(dtype).itemsize + (8 if as_float else 0)), where)
        if i in self._draco:
            arr = self._draco[i]
        elif a.view is not None:
            arr = np.array(self._view(a.view, a.offset, a.count, dtype, a.ncomp))
        else:
            arr = np.zeros((a.count, a.ncomp), dtype=dtype)
        if a.sparse is not None:
            scount, iv, ioff, ictype, vv, voff = a.sparse
            idx = self._view(iv, ioff, scount, _DTYPES[ictype], 1)[:, 0].astype(np.int64)
            if np.any(np.diff(idx) <= 0) or idx[-1] >= a.count:
                self.fail(f"accessors[{i}].sparse.indices", f"must increase strictly and stay below count {a.count}")
            arr[idx] = self._view(vv, voff, scount, dtype, a.ncomp)
        if a.ctype == 5126 and not np.all(np.isfinite(arr)):
            self.fail(where, f"accessor {i} holds NaN or infinite values")
        for bound, have, word in ((a.minimum, arr.min(axis=0), "min"), (a.maximum, arr.max(axis=0), "max")):
            # float bounds are compared as float32, as the data is: JSON writers print a float32 value in as few
            # digits as name it (0.1 for float32 0.1), and the Khronos validator reads bounds so too. Zeros that
            # no bufferView or sparse part gave are not checked (nor by the validator)
            if bound is None or (a.view is None and a.sparse is None):
                continue
            with np.errstate(over="ignore"):  # a bound past float32's range becomes inf, and differs
                declared = np.asarray(bound, np.float32 if a.ctype == 5126 else np.float64)
            off = declared != have.astype(declared.dtype)
            if np.any(off):
                k = int(np.argmax(off))
                self.fail(where, f"accessor {i} declares {word} {bound[k]!r} for component {k}; its data has "
                          f"{float(have[k])!r}")
        if not as_float:
            return arr
        out = arr.astype(np.float64)
        if a.normalized and a.ctype in _NORM:
            out = np.maximum(out / _NORM[a.ctype], -1.0)
        return out

    def color(self, material: int | None) -> tuple[float, float, float]:
        if material not in self._colors:
            if material is None:
                self._colors[None] = (0.8, 0.8, 0.8)  # glTF's default material is white; light grey reads better
            else:
                pbr = self.j["materials"][material].get("pbrMetallicRoughness") or {}
                factor = np.array((pbr.get("baseColorFactor") or [1, 1, 1, 1])[:3], np.float64)
                tex = pbr.get("baseColorTexture")
                if tex is not None:
                    decoded = self.texture(tex["index"])
                    if decoded is not None:
                        factor = factor * decoded[2]
                self._colors[material] = tuple(float(c) for c in _srgb(factor))  # type: ignore[assignment]
        return self._colors[material]

    def base_texture(self, info: dict[str, Any], where: str) -> BaseTexture | None:
        """A material's baseColorTexture as drawn: decoded pixels, the TEXCOORD set, KHR_texture_transform's
        matrix and the sampler's wrap modes and filters; None where the image cannot be decoded."""
        decoded = self.texture(info["index"])
        if decoded is None:
            return None
        texcoord = int(info.get("texCoord", 0))
        m = np.eye(3)
        ext = info.get("extensions")
        tt = ext.get("KHR_texture_transform") if isinstance(ext, dict) else None
        if tt is not None:
            wt = f"{where}.extensions.KHR_texture_transform"
            if not isinstance(tt, dict):
                self.fail(wt, f"expected an object, found {_kind(tt)}")
            ox, oy = self._numbers(tt, "offset", wt, 2) or (0.0, 0.0)
            sx, sy = self._numbers(tt, "scale", wt, 2) or (1.0, 1.0)
            r = self._num(tt, "rotation", wt, 0.0)
            texcoord = self._int(tt, "texCoord", wt, texcoord, lo=0)
            c, sn = math.cos(r), math.sin(r)
            # the extension's uv' = T R S uv: T the offset, R = [[cos, sin], [-sin, cos]], S the scale
            m = (np.array([[1.0, 0.0, ox], [0.0, 1.0, oy], [0.0, 0.0, 1.0]])
                 @ np.array([[c, sn, 0.0], [-sn, c, 0.0], [0.0, 0.0, 1.0]])
                 @ np.diag([sx, sy, 1.0]))
        smp_index = self.j["textures"][info["index"]].get("sampler")
        smp = self.j["samplers"][smp_index] if smp_index is not None else {}
        wraps = []
        for key in ("wrapS", "wrapT"):
            mode = smp.get(key, WRAP_REPEAT)
            if mode not in (WRAP_REPEAT, WRAP_CLAMP, WRAP_MIRROR):
                self.note(f"samplers[{smp_index}].{key} {mode} (not a wrap mode; REPEAT is used)")
                mode = WRAP_REPEAT
            wraps.append(int(mode))
        mag = smp.get("magFilter", 9729)
        mag = mag if mag in (9728, 9729) else 9729
        mini = smp.get("minFilter", 9987)
        mini = mini if mini in (9728, 9729, 9984, 9985, 9986, 9987) else 9987
        return BaseTexture(decoded[0], decoded[1], texcoord, tuple(float(v) for v in m[:2].ravel()),
                           (wraps[0], wraps[1]), int(mag), int(mini))

    def surface(self, p: dict[str, Any], n: int, where: str, label: str) -> Surface | None:
        """A primitive's texture coordinates, vertex colours (COLOR_0) and material, where they colour it (a base
        colour texture or vertex colours); None for a flat colour."""
        attrs = p["attributes"]
        material = p.get("material")
        jm = self.j["materials"][material] if material is not None else {}
        pbr = jm.get("pbrMetallicRoughness") or {}
        tex = None
        if pbr.get("baseColorTexture") is not None:
            tex = self.base_texture(pbr["baseColorTexture"], f"materials[{material}].pbrMetallicRoughness."
                                    "baseColorTexture")
            if tex is not None and f"TEXCOORD_{tex.texcoord}" not in attrs:
                self.note(f"{label}: its base colour texture samples TEXCOORD_{tex.texcoord}, which it does not "
                          "have (its flat colour is used)")
                tex = None
        colors = None
        if "COLOR_0" in attrs:
            c = self.accessor(attrs["COLOR_0"], f"{where}.attributes.COLOR_0")
            colors = np.ones((n, 4), np.float32)
            colors[:, : c.shape[1]] = np.clip(c[:, :4], 0.0, 1.0)
        if tex is None and colors is None:
            return None
        uvs = tuple(self.accessor(attrs[f"TEXCOORD_{k}"], f"{where}.attributes.TEXCOORD_{k}")[:, :2]
                    .astype(np.float32) for k in range(tex.texcoord + 1)) if tex is not None else ()
        # no material: glTF's default is white; the flat colour (0.8 grey) stands for it where nothing colours it
        factor = tuple(float(v) for v in (pbr.get("baseColorFactor") or [1.0, 1.0, 1.0, 1.0]))
        flat = np.asarray(factor[:3]) * (self._textures[pbr["baseColorTexture"]["index"]][2]  # type: ignore[index]
                                         if tex is not None else 1.0)
        if colors is not None:
            flat = flat * colors[:, :3].astype(np.float64).mean(axis=0)
        mode = jm.get("alphaMode", "OPAQUE")
        if mode == "BLEND":
            self.note(f"{label}: alphaMode BLEND (drawn opaque)")
        mat = Material(factor=factor, flat=tuple(float(v) for v in _srgb(flat)),  # type: ignore[arg-type]
                       texture=tex, alpha_mode=mode if mode in ("MASK", "BLEND") else "OPAQUE",
                       alpha_cutoff=float(jm.get("alphaCutoff", 0.5)))
        return Surface(mat, uvs, colors)

    def image_bytes(self, img: int) -> bytes:
        im = self.j["images"][img]
        w = f"images[{img}]"
        uri = im.get("uri")
        if uri is None:
            b, off, length, _ = self.views[im["bufferView"]]
            if length > MAX_IMAGE_BYTES:
                self.fail(f"{w}.bufferView", f"{_mib(length)} of image: the limit is {_mib(MAX_IMAGE_BYTES)} "
                          "(MAX_IMAGE_BYTES)")
            return self.buffer(b)[off:off + length]
        if uri[:5].lower() == "data:":
            return self._decode64(self._data_uri(uri, f"{w}.uri", MAX_IMAGE_BYTES), f"{w}.uri")
        return self._read_uri(uri, f"{w}.uri", None, MAX_IMAGE_BYTES, "MAX_IMAGE_BYTES")

    def texture(self, tex_index: int) -> tuple[np.ndarray, str, np.ndarray] | None:
        """A base colour texture decoded: (h, w, 4) uint8 pixels (RGB sRGB-encoded per the spec, alpha linear),
        the digest of its encoded bytes, its mean linear RGB; None if undecodable (noted). The image's size is
        read from its PNG, JPEG or WebP header first and refused over MAX_TEXTURE_PIXELS; decoded images are kept per
        content digest for the process (`decode_image`)."""
        if tex_index in self._textures:
            return self._textures[tex_index]
        out = None
        tex = self.j["textures"][tex_index]
        webp = (tex.get("extensions") or {}).get("EXT_texture_webp")
        src = (webp or {}).get("source", tex.get("source"))  # the WebP image where given; `source`: its fallback
        if src is None:
            self.note(f"base colour texture {tex_index} (no PNG, JPEG or WebP source; its factor alone is used)")
        else:
            data = self.image_bytes(src)
            head = _image_size(data)
            if head is None or not head[1] or not head[2]:
                self.note(f"base colour texture {tex_index} (not a readable PNG, JPEG or WebP; its factor alone is "
                          "used)")
            elif head[1] * head[2] > MAX_TEXTURE_PIXELS:
                self.fail(f"images[{src}]", f"{head[1]}x{head[2]} pixels: the limit is {MAX_TEXTURE_PIXELS} "
                          "(MAX_TEXTURE_PIXELS)")
            else:
                digest = hashlib.sha256(data).hexdigest()
                found = _DECODED.get(digest)
                if found is None and (head[0] != "png" or _png_sound(data)):
                    px = self._decode_pixels(data, head)
                    if px is not None:
                        px.flags.writeable = False
                        found = _DECODED[digest] = (px, _texture_mean(px))
                if found is None:
                    self.note(f"base colour texture {tex_index} (not decoded; its factor alone is used)")
                else:
                    out = (found[0], digest, found[1])
        self._textures[tex_index] = out
        return out

    def _decode_pixels(self, data: bytes, head: tuple[str, int, int]) -> np.ndarray | None:
        """The (h, w, 4) uint8 pixels of a PNG, JPEG or WebP whose header said width x height (within
        MAX_TEXTURE_PIXELS), decoded by OpenImageIO in one read (grey -> RGB, no alpha -> 255); None where it
        cannot be decoded. The one place images are decoded."""
        try:
            oiio = fsio.oiio()
        except ImportError:
            return None
        kind, width, height = head
        with tempfile.NamedTemporaryFile(suffix={"png": ".png", "jpeg": ".jpg"}.get(kind, ".webp")) as tmp, \
                fsio.native_stderr():  # OIIO reads files; libpng and libjpeg print past it: the note says it
            tmp.write(data)
            tmp.flush()
            name = tmp.name
            inp = None
            try:
                config = oiio.ImageSpec()
                config.attribute("oiio:UnassociatedAlpha", 1)  # glTF's colours are not premultiplied by alpha
                inp = oiio.ImageInput.open(name, config)
                if inp is None:
                    return None
                spec = inp.spec()
                if (spec.width, spec.height) != (width, height) or spec.depth != 1 or not 1 <= spec.nchannels <= 4:
                    return None  # the decoder sees another image than the header said
                nch = spec.nchannels
                px = inp.read_image(0, 0, 0, nch, oiio.UINT8)
                if px is None or np.asarray(px).size != height * width * nch:
                    return None
                if inp.has_error:  # a truncated JPEG reads to the end, with an error (a property)
                    return None
            except Exception:  # OpenImageIO's decoders raise whatever a broken image makes them
                return None
            finally:
                if inp is not None:
                    inp.geterror()
                    inp.close()
                oiio.geterror()  # taken, so that OpenImageIO does not print it at exit
        px = np.asarray(px, dtype=np.uint8).reshape(height, width, nch)
        out = np.full((height, width, 4), 255, np.uint8)
        if nch >= 3:
            out[..., :3] = px[..., :3]
        else:  # grey, grey + alpha
            out[..., :3] = px[..., :1]
        if nch in (2, 4):
            out[..., 3] = px[..., -1]
        return out


# decoded base colour textures by the sha256 of their encoded bytes: (pixels, mean linear RGB), for the process
_DECODED: dict[str, tuple[np.ndarray, np.ndarray]] = {}
_SRGB_TO_LINEAR = _linear(np.arange(256) / 255.0)  # the 256 values an 8-bit channel can hold


def _texture_mean(px: np.ndarray) -> np.ndarray:
    """Mean linear RGB of (h, w, 4) uint8 sRGB pixels: a histogram per channel, then 256 decoded values."""
    flat = px.reshape(-1, 4)
    counts = [np.bincount(flat[:, c], minlength=256) for c in range(3)]
    return np.array([float(k @ _SRGB_TO_LINEAR) for k in counts]) / max(len(flat), 1)


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


def draco_only(r: _Reader, prim: dict[str, Any]) -> bool:
    """Whether a primitive's geometry is only in a Draco stream (then decoded: `_Reader.draco`). An extension on a
    primitive that the file does not require leaves the primitive's own data whole (feature ids, variants,
    outlines: ignored); KHR_draco_mesh_compression's primitive is read from its uncompressed copy where it carries
    one (every accessor it names has a bufferView)."""
    ext = prim.get("extensions")
    return isinstance(ext, dict) and "KHR_draco_mesh_compression" in ext and any(
        r.accs[a].view is None for a in [*prim["attributes"].values(), prim.get("indices")] if a is not None)


def _read_mesh(r: _Reader, mi: int) -> list[_Prim]:
    m = r.j["meshes"][mi]
    prims: list[_Prim] = []
    base = m.get("name") if isinstance(m.get("name"), str) else f"mesh{mi}"
    for pi, p in enumerate(m["primitives"]):
        label = f"mesh '{base}' primitive {pi}"
        w = f"meshes[{mi}].primitives[{pi}]"
        mode = p.get("mode", 4)
        if mode not in (4, 5, 6):
            r.note(f"{label}: {_MODES.get(mode, mode)} (only triangles, strips and fans are drawn)")
            continue
        attrs = p["attributes"]
        if draco_only(r, p):
            r.draco(p, w)
        if "POSITION" not in attrs:
            r.note(f"{label}: no POSITION")
            continue
        pos = r.accessor(attrs["POSITION"], f"{w}.attributes.POSITION")[:, :3]
        n = len(pos)
        if "indices" in p:
            ia = r.accs[p["indices"]]
            idx = r.accessor(p["indices"], f"{w}.indices", as_float=False)[:, 0].astype(np.int64)
            restart = (1 << (8 * _CSIZE[ia.ctype])) - 1
            if len(idx) and (idx.max() >= n or idx.max() == restart):
                bad = int(idx.max())
                r.fail(f"{w}.indices", f"index {bad} is out of range: {n} vertices (0..{n - 1})"
                       if bad >= n else f"index {bad} is the primitive restart value, which glTF forbids")
        else:
            r._spend(8 * n, f"{w}.attributes.POSITION")
            idx = np.arange(n, dtype=np.int64)
        faces = _triangles(mode, idx)
        surface = r.surface(p, n, w, label)
        prim = _Prim(name=base if len(m["primitives"]) == 1 else f"{base}.{pi}", positions=pos, faces=faces,
                     color=surface.material.flat if surface is not None else r.color(p.get("material")),
                     surface=surface)
        pairs = [(attrs[f"JOINTS_{k}"], attrs[f"WEIGHTS_{k}"]) for k in range(len(attrs)) if f"JOINTS_{k}" in attrs]
        if pairs:
            prim.joints = np.concatenate([r.accessor(j, f"{w}.attributes.JOINTS_{k}", as_float=False)
                                          .astype(np.int64) for k, (j, _) in enumerate(pairs)], 1)
            prim.weights = np.concatenate([r.accessor(wt, f"{w}.attributes.WEIGHTS_{k}")
                                           for k, (_, wt) in enumerate(pairs)], axis=1)
            if np.any(prim.weights < 0):
                r.fail(f"{w}.attributes", "negative skin weights")
            sums = np.zeros(len(prim.weights), np.float32)
            for col in prim.weights.T.astype(np.float32):  # in float32, one weight after the other
                sums += col
            off = np.abs(sums.astype(np.float64) - 1.0) > _WEIGHT_TOLERANCE * np.count_nonzero(prim.weights, axis=1)
            if np.any(off):
                k = int(np.argmax(off))
                r.fail(f"{w}.attributes", f"the skin weights of vertex {k} sum to {float(sums[k]):.9g}, not 1")
            used = np.where(prim.weights > 0, prim.joints, -1 - np.arange(prim.joints.shape[1]))
            used = np.sort(used, axis=1)
            if np.any((used[:, 1:] == used[:, :-1]) & (used[:, 1:] >= 0)):
                r.fail(f"{w}.attributes", "a vertex names one joint twice (with weight)")
        targets = p.get("targets") or []
        if targets:
            deltas = []
            for ti, tgt in enumerate(targets):
                a = tgt.get("POSITION")
                if a is None:
                    r.note(f"{label}: morph target {ti} without POSITION (normals are recomputed anyway)")
                    r._spend(24 * n, f"{w}.targets[{ti}]")
                    deltas.append(np.zeros((n, 3)))
                else:
                    deltas.append(r.accessor(a, f"{w}.targets[{ti}].POSITION")[:, :3])
            prim.targets = np.stack(deltas)
        prims.append(prim)
    return prims


_T0, _Q0, _S0 = np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), np.ones(3)
for _a in (_T0, _Q0, _S0):
    _a.flags.writeable = False


def _instance_matrices(r: _Reader, node: int) -> np.ndarray:
    """EXT_mesh_gpu_instancing: each instance's T x R x S in the node's space, (count, 4, 4); the extension places
    an instance at node world x T x R x S."""
    w = f"nodes[{node}].extensions.EXT_mesh_gpu_instancing.attributes"
    cols = {name: r.accessor(acc, f"{w}.{name}") for name, acc in r.instancing[node].items()}
    count = len(next(iter(cols.values())))
    out = np.tile(np.eye(4), (count, 1, 1))
    out[:, :3, :3] = quat_matrix(cols["ROTATION"]) if "ROTATION" in cols else np.eye(3)
    if "SCALE" in cols:
        out[:, :3, :3] *= cols["SCALE"][:, None, :]
    if "TRANSLATION" in cols:
        out[:, :3, 3] = cols["TRANSLATION"]
    if not np.all(np.isfinite(out)):
        r.fail(w, "an instance's transform is not finite")
    return out


_PROP_LIMITS = {"yfov": (1e-4, math.pi - 1e-4), "ymag": (1e-9, math.inf), "znear": (0.0, math.inf),
                "zfar": (1e-9, math.inf), "intensity": (0.0, math.inf), "range": (1e-9, math.inf),
                "color": (0.0, math.inf), "spot/innerConeAngle": (0.0, math.pi / 2),
                "spot/outerConeAngle": (1e-4, math.pi / 2)}


def _channel_track(r: _Reader, an: dict[str, Any], ch: dict[str, Any], ai: int, path: str) -> Track:
    """The track of a channel's sampler: times from 0 on, rotations unit quaternions (slerped); a camera's or a
    light's field (`_PROP_LIMITS`, `_Reader._check_prop`) clamped to what it can hold (a yfov in (0, pi), an
    intensity >= 0, cone angles in [0, pi/2])."""
    smp = an["samplers"][ch["sampler"]]
    ws = f"animations[{ai}].samplers[{ch['sampler']}]"
    times = r.accessor(smp["input"], f"{ws}.input")[:, 0]
    if times[0] < 0:
        r.fail(f"{ws}.input", f"key time {float(times[0])} is negative")
    values = r.accessor(smp["output"], f"{ws}.output")
    if path in _PROP_LIMITS:
        values = np.clip(values, *_PROP_LIMITS[path])
    interp = smp.get("interpolation", "LINEAR")
    interp = interp if interp in _INTERPOLATIONS else "LINEAR"
    if path == "rotation":
        norms = np.linalg.norm(values[1::3] if interp == "CUBICSPLINE" else values, axis=1)
        if np.any(np.abs(norms - 1.0) > _UNIT_TOLERANCE):
            r.fail(f"{ws}.output", "a rotation key is not a unit quaternion")
    try:
        return Track(times, values, interp, quaternion=path == "rotation")
    except ValueError as exc:
        r.fail(ws, str(exc))


def hidden_nodes(r: _Reader) -> set[int]:
    """KHR_node_visibility: the scene's nodes with `visible: false` and every node below one."""
    hidden: set[int] = set()
    for i in r.order:  # parents come before their children
        if i in r.hidden or r.parent[i] in hidden:
            hidden.add(i)
    return hidden


def _read(path: Path, allow_outside: bool = False) -> GltfAsset:
    r = _Reader(path, allow_outside)
    j = r.j
    jnodes = r.coll("nodes")
    hidden = hidden_nodes(r)
    drawn = [i for i in r.order if "mesh" in jnodes[i] and i not in hidden]
    used = sorted({jnodes[i]["mesh"] for i in drawn})
    # limits on what is drawn, from the metadata alone: objects, and (an upper bound of) their triangles
    instances = {i: r.instance_count(i) for i in drawn if i in r.instancing}
    n_obj = sum(len(j["meshes"][jnodes[i]["mesh"]]["primitives"]) * instances.get(i, 1) for i in drawn)
    if n_obj > MAX_OBJECTS:
        r.fail("nodes", f"the scene places {n_obj} primitives (instances counted): the limit is {MAX_OBJECTS} "
               "(MAX_OBJECTS)")
    meshes: list[list[_Prim]] = [[] for _ in r.coll("meshes")]
    for mi in used:
        meshes[mi] = _read_mesh(r, mi)
    tris = sum(len(p.faces) * instances.get(i, 1) for i in drawn for p in meshes[jnodes[i]["mesh"]])
    if tris > MAX_DRAWN_TRIANGLES:
        r.fail("nodes", f"the scene draws {tris} triangles: the limit is {MAX_DRAWN_TRIANGLES} (MAX_DRAWN_TRIANGLES)")
    mesh_weights = [np.asarray(m.get("weights") or [], dtype=np.float64) for m in r.coll("meshes")]

    n = len(jnodes)
    rest_local = np.tile(np.eye(4), (n, 1, 1))
    nodes: list[_Node] = []
    for i, nd in enumerate(jnodes):
        if "matrix" in nd:
            rest_local[i] = np.asarray(nd["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major in the file
            trs = None
        elif "translation" in nd or "rotation" in nd or "scale" in nd:
            t = np.asarray(nd["translation"], dtype=np.float64) if "translation" in nd else _T0
            q = np.asarray(nd["rotation"], dtype=np.float64) if "rotation" in nd else _Q0
            s = np.asarray(nd["scale"], dtype=np.float64) if "scale" in nd else _S0
            trs = (t, q, s)
            rest_local[i] = trs_matrix(t, q, s)
        else:
            trs = (_T0, _Q0, _S0)  # shared: posing copies them before changing any
        name = nd.get("name")
        nodes.append(_Node(name=name if isinstance(name, str) else f"node{i}", local=rest_local[i], trs=trs,
                           children=r.children[i], parent=None if r.parent[i] == -1 else r.parent[i],
                           mesh=nd.get("mesh"), skin=nd.get("skin"), camera=nd.get("camera"),
                           light=r.node_lights.get(i),
                           weights=np.asarray(nd["weights"], float) if nd.get("weights") else None))
    # the scene's nodes by level: each level's world matrices are one batched product
    by_level: dict[int, list[int]] = {}
    for i in r.order:
        by_level.setdefault(r.depth[i], []).append(i)
    levels: list[tuple[np.ndarray, np.ndarray | None]] = []
    parent = np.asarray(r.parent, dtype=np.int64)
    for d in sorted(by_level):
        idx = np.asarray(by_level[d], dtype=np.int64)
        levels.append((idx, None if d == 0 else parent[idx]))

    skins = []
    for si, sk in enumerate(r.coll("skins")):
        joints = r.skin_joints[si]
        if "inverseBindMatrices" in sk:
            ibm = r.accessor(sk["inverseBindMatrices"], f"skins[{si}].inverseBindMatrices")
            ibm = ibm[: len(joints)].reshape(-1, 4, 4).transpose(0, 2, 1)
            if np.any(ibm[:, 3, :] != np.array([0.0, 0.0, 0.0, 1.0])):
                r.fail(f"skins[{si}].inverseBindMatrices", "a matrix is not affine (last row 0, 0, 0, 1)")
        else:
            ibm = np.tile(np.eye(4), (len(joints), 1, 1))
        skins.append((joints, ibm))
    for i in r.order:  # every joint index a skinned primitive uses names a joint of the node's skin
        nd = nodes[i]
        if nd.skin is not None and nd.mesh is not None:
            have = len(skins[nd.skin][0])
            for pi, prim in enumerate(meshes[nd.mesh]):
                if prim.joints is not None and len(prim.joints) and int(prim.joints.max()) >= have:
                    r.fail(f"nodes[{i}]", f"meshes[{nd.mesh}].primitives[{pi}] uses joint {int(prim.joints.max())}; "
                           f"skins[{nd.skin}] has {have} joints")

    cameras = []
    for ci, c in enumerate(r.coll("cameras")):
        name = c.get("name") if isinstance(c.get("name"), str) else f"camera{ci}"
        if c["type"] == "perspective":
            pc = c["perspective"]
            cameras.append(_Camera(name, "perspective", float(pc["yfov"]), float(pc["znear"]),
                                   None if pc.get("zfar") is None else float(pc["zfar"])))
        elif c["type"] == "orthographic":
            oc = c["orthographic"]
            cameras.append(_Camera(name, "orthographic", znear=float(oc["znear"]), zfar=float(oc["zfar"]),
                                   ymag=abs(float(oc["ymag"]))))
        else:
            cameras.append(_Camera(name, c["type"]))

    animations = []
    for ai, an in enumerate(r.coll("animations")):
        channels = []
        props: list[tuple[tuple[str, int, str], Track]] = []
        unread: list[str] = []  # targets of this clip's channels that are not read, for one note
        for ci, ch in enumerate(an["channels"]):
            node, pth = r.target_of(ch["target"], f"animations[{ai}].channels[{ci}].target")
            prop = r.props.get((ai, ci))
            if prop is not None:
                props.append((prop, _channel_track(r, an, ch, ai, prop[2])))
            elif node is None or pth not in _ANIM_OUTPUT:
                unread.append(f"channel {ci} {pth[:60]!r}")
            else:
                channels.append((node, pth, _channel_track(r, an, ch, ai, pth)))
        if unread:
            r.note(f"animation {ai}: {len(unread)} channel{'s' if len(unread) > 1 else ''} whose target is not read "
                   f"(an extension's: {', '.join(unread[:3])}" + (f" and {len(unread) - 3} more)" if len(unread) > 3
                                                                 else ")"))
        if channels or props:
            tracks = [tr for _, _, tr in channels] + [tr for _, tr in props]
            name = an.get("name") if isinstance(an.get("name"), str) else f"animation{ai}"
            animations.append(GltfAnimation(name, channels, min(tr.start for tr in tracks),
                                            max(tr.end for tr in tracks), ai, props))

    objects = []
    for i in drawn:
        nd = nodes[i]
        assert nd.mesh is not None
        placed: list[np.ndarray | None] = [None]
        if i in instances:  # one object per instance, all sharing the primitive's mesh (and what is derived from it)
            if nd.skin is not None:
                r.note(f"node '{nd.name}': EXT_mesh_gpu_instancing of a skinned mesh (drawn once)")
            else:
                placed = list(_instance_matrices(r, i))
        for pi in range(len(meshes[nd.mesh])):
            base = nd.name if len(meshes[nd.mesh]) == 1 else f"{nd.name}.{pi}"
            for k, inst in enumerate(placed):
                objects.append(GltfObject(i, nd.mesh, pi, base if inst is None else f"{base}[{k}]", inst))
    asset = GltfAsset(path=path, digest=r.hasher.hexdigest(), nodes=nodes, meshes=meshes, mesh_weights=mesh_weights,
                      skins=skins, cameras=cameras, animations=animations, order=r.order, objects=objects,
                      ignored=list(r.ignored), rest_local=rest_local, levels=levels, lights=list(r.light_defs))
    world, _ = asset.pose(0.0, None)
    if not np.all(np.isfinite(world)):
        bad = int(np.argwhere(~np.isfinite(world))[0][0])
        r.fail(f"nodes[{bad}]", "its world matrix overflows (not finite)")
    for obj in asset.objects:
        if obj.instance is not None and not np.all(np.isfinite(obj.world(world))):
            r.fail(f"nodes[{obj.node}].extensions.EXT_mesh_gpu_instancing", f"instance {obj.name!r}: its world "
                   "matrix overflows (not finite)")
    return asset


def left_out(notes: list[str]) -> str:
    """The reader's notes as one text: notes that say the same of more than three primitives ("mesh 'A' primitive
    0: alphaMode BLEND (drawn opaque)") as one, with the first three named and a count."""
    groups: dict[tuple[bool, str], list[str]] = {}  # (of primitives?, what is said) -> the primitives
    for note in notes:
        label, sep, what = note.partition(": ")
        of_prims = bool(sep) and label.startswith("mesh '")
        groups.setdefault((of_prims, what if of_prims else note), []).append(label)
    out = []
    for (of_prims, what), labels in groups.items():
        if not of_prims:
            out.append(what)
        elif len(labels) <= 3:
            out += [f"{label}: {what}" for label in labels]
        else:
            out.append(f"{len(labels)} primitives: {what} ({', '.join(labels[:3])} and {len(labels) - 3} more)")
    return "; ".join(out)


_ASSETS: dict[tuple[str, int, int, bool], GltfAsset] = {}
_ASSETS_KEPT = 16


def load_asset(path: str | Path, allow_outside: bool = False) -> GltfAsset:
    """Read a glTF file (memoised by path, mtime and size); one warning names what was left out. Its buffers
    and images must lie in its folder unless `allow_outside` (for a trusted file) or `OUTSIDE_ALLOWED`."""
    allow_outside = bool(allow_outside or OUTSIDE_ALLOWED.get())
    p = Path(path).expanduser().absolute()
    if not p.is_file():
        raise MeshError(f"{p}: glTF file not found")
    st = p.stat()
    key = (str(p), st.st_mtime_ns, st.st_size, bool(allow_outside))
    asset = _ASSETS.get(key)
    if asset is None:
        asset = _read(p, allow_outside)
        if not any(asset.meshes[o.mesh] for o in asset.objects):
            raise MeshError(f"{p}: no triangle meshes to draw"
                            + (f" (left out: {left_out(asset.ignored)})" if asset.ignored else ""))
        if asset.ignored:
            warnings.warn(f"{p.name}: left out: {left_out(asset.ignored)}", MeshWarning, stacklevel=2)
        for k in [k for k in _ASSETS if k[0] == key[0]]:
            del _ASSETS[k]
        while len(_ASSETS) >= _ASSETS_KEPT:
            del _ASSETS[next(iter(_ASSETS))]
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
            m = self.root if skinned else self.root @ obj.world(world)
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
                return mesh, self.root if sk else self.root @ obj.world(world)

            anims[first_index + k] = ObjectAnim(pose, f"{self.digest()}|object{k}")
        return anims

    def light_nodes(self) -> list[tuple[int, int]]:
        """(node, light index) of the scene's nodes that carry a KHR_lights_punctual light, in scene order."""
        return [(i, self.asset.nodes[i].light) for i in self.asset.order  # type: ignore[misc]
                if self.asset.nodes[i].light is not None]

    def lights_at(self, t: float) -> list[Any]:
        """The file's lights (lights.Light) placed by their nodes' world matrices at time t, under `root`."""
        placed = self.light_nodes()
        if not placed:
            return []
        world, _ = self.asset.pose(t, self.anim)
        out = []
        for node, li in placed:
            light = replace(self.asset.lights[li], matrix=self.root @ world[node])
            fields = self.anim.value("light", li, t) if self.anim is not None else {}
            if fields:  # KHR_animation_pointer: colour, intensity, range, cone angles at t
                outer = float(fields.get("spot/outerConeAngle", light.outer_cone))
                inner = min(float(fields.get("spot/innerConeAngle", light.inner_cone)), outer * (1.0 - 1e-6))
                light = replace(light, color=tuple(float(c) for c in fields.get("color", light.color)),
                                intensity=float(fields.get("intensity", light.intensity)), inner_cone=inner,
                                outer_cone=outer, range=None if light.kind == "directional" else (
                                    float(fields["range"]) if "range" in fields else light.range))
            out.append(light)
        return out

    def lights_move(self) -> bool:
        moving, _ = self.asset.moving(self.anim)
        return any(node in moving or (self.anim is not None and self.anim.animates("light", li))
                   for node, li in self.light_nodes())

    def camera_names(self) -> list[tuple[str, int]]:
        """(name, camera index) of the cameras placed on nodes, by camera index."""
        return [(self.asset.cameras[c].name, c) for c, _ in self.asset.camera_nodes()]

    def camera_params(self, camera_index: int, t: float, center: np.ndarray, radius: float) -> dict[str, Any]:
        """Camera(...) keyword arguments for glTF camera `camera_index` at time t (see `camera_params`)."""
        cam = self.asset.cameras[camera_index]
        if cam.kind not in ("perspective", "orthographic"):
            raise PipelineError(f"{self.asset.path.name}: camera '{cam.name}' is of type {cam.kind!r}, neither "
                                "perspective nor orthographic; choose another (--camera NAME|INDEX, `camera:`)")
        node = dict(self.asset.camera_nodes())[camera_index]
        moving, _ = self.asset.moving(self.anim)
        world, _ = self.asset.pose(t if node in moving else 0.0, self.anim)
        fields = self.anim.value("camera", camera_index, t) if self.anim is not None else {}
        if fields:  # KHR_animation_pointer: yfov (a zoom), ymag, znear, zfar at t
            cam = replace(cam, **{k: float(v) for k, v in fields.items()})
            if cam.kind == "perspective" and cam.znear <= 0.0:
                cam = replace(cam, znear=1e-6)
            if cam.zfar is not None and cam.zfar <= cam.znear:
                cam = replace(cam, zfar=cam.znear * 1.001 + 1e-9)
        return camera_params(self.root @ world[node], cam, center, radius)

    def camera_moves(self, camera_index: int) -> bool:
        node = dict(self.asset.camera_nodes())[camera_index]
        return node in self.asset.moving(self.anim)[0] or (
            self.anim is not None and self.anim.animates("camera", camera_index))

    def find_camera(self, which: str | int | None) -> int | None:
        """A camera index by name or index; None: the first perspective or orthographic camera placed on a node
        (None if there is none; cameras of other types skipped are noted)."""
        placed = self.camera_names()
        if which is None:
            for name, ci in placed:
                if self.asset.cameras[ci].kind in ("perspective", "orthographic"):
                    return ci
                warnings.warn(f"{self.asset.path.name}: camera '{name}' is of type {self.asset.cameras[ci].kind!r} "
                              "(neither perspective nor orthographic): skipped", MeshWarning, stacklevel=2)
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
    scene; yfov spans the image's height whatever its shape, as glTF defines it (`Camera.fov_vertical`), and an
    orthographic camera's ymag half of it."""
    eye = world[:3, 3].copy()
    nz, ny = float(np.linalg.norm(world[:3, 2])), float(np.linalg.norm(world[:3, 1]))
    if not (nz > 1e-12 and ny > 1e-12 and np.all(np.isfinite(world))):
        raise PipelineError(f"camera '{cam.name}': its node's world matrix is degenerate (zero scale or not finite)")
    fwd = -world[:3, 2] / nz
    up = world[:3, 1] / ny
    d = float(np.dot(np.asarray(center) - eye, fwd))
    if not d > 0.0:
        d = max(radius, 1.0)
    near = cam.znear
    far = cam.zfar
    if far is None:  # infinite in the file: hug the scene
        dist = float(np.linalg.norm(np.asarray(center) - eye))
        far = max(dist + 1.05 * max(radius, 1e-6), near * 1e3)
    if cam.kind == "orthographic":  # znear may be 0 and zfar is required
        return {"eye": eye, "target": eye + fwd * d, "up": up, "near": near, "far": far, "fov_vertical": True,
                "projection": "orthographic", "ortho_half": cam.ymag}
    return {"eye": eye, "target": eye + fwd * d, "up": up, "fov_y_deg": math.degrees(cam.yfov), "near": near,
            "far": max(far, near * 1.001), "fov_vertical": True}


def gltf_mesh(path: str | Path, allow_outside: bool = False) -> Mesh:
    """The whole file as one static mesh at t = 0 (world transforms applied): for `mesh:` paths."""
    from .meshes import merge_meshes

    asset = load_asset(path, allow_outside)
    inst = GltfInstance(asset, np.eye(4), asset.animation(None, note=False))
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


def load_any_mesh(path: str | Path, allow_outside: bool = False) -> Mesh:
    """`meshes.load_mesh`, and glTF files as one static mesh (`gltf_mesh`; `allow_outside`: its buffers and
    images may lie outside its folder, for a trusted file)."""
    from .meshes import load_mesh

    if Path(path).suffix.lower() in GLTF_EXTENSIONS:
        return gltf_mesh(path, allow_outside)
    return load_mesh(path)
