"""Small glTF files built in code with pygltflib, for the tests: an animated box, two clips on two boxes, a
walking box figure, a morphing sphere, a two-bone skinned bar, a morphing quad and a file with two cameras
(and an orthographic one); and, for the hostile-input tests, a file
that uses most of what the reader reads as raw parts (JSON dict, binary buffer) to break, GLB bytes with any
header field, and PNG/JPEG/WebP bytes (or headers alone)."""

from __future__ import annotations

import base64
import json
import math
import struct
import zlib
from pathlib import Path

import numpy as np
import pygltflib as g

FLOAT, UBYTE, USHORT, UINT = 5126, 5121, 5123, 5125
BOX_V = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)], np.float32)
# outward, counter-clockwise; vertex index bits (x, y, z)
BOX_F = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], np.uint16)


class Builder:
    """Accumulates a binary buffer and a document; `save(path)` writes .glb, or .gltf with the buffer as
    a data URI (`external=False`) or beside it in a .bin file."""

    def __init__(self) -> None:
        self.doc = g.GLTF2(scene=0, scenes=[g.Scene(nodes=[])])
        self.blob = bytearray()

    def accessor(self, data: np.ndarray, kind: str, ctype: int = FLOAT, normalized: bool = False,
                 minmax: bool = False) -> int:
        arr = np.ascontiguousarray(data)
        while len(self.blob) % 4:
            self.blob += b"\0"
        self.doc.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=arr.nbytes))
        self.blob += arr.tobytes()
        count = arr.shape[0]
        acc = g.Accessor(bufferView=len(self.doc.bufferViews) - 1, componentType=ctype, count=count, type=kind,
                         normalized=normalized)
        if minmax:
            flat = arr.reshape(count, -1).astype(np.float64)
            acc.min, acc.max = flat.min(axis=0).tolist(), flat.max(axis=0).tolist()
        self.doc.accessors.append(acc)
        return len(self.doc.accessors) - 1

    def mesh(self, vertices: np.ndarray, faces: np.ndarray, color: tuple[float, ...] | None = None,
             mode: int = 4, **attrs: int) -> int:
        pos = self.accessor(np.asarray(vertices, np.float32), "VEC3", minmax=True)
        idx = self.accessor(np.asarray(faces).reshape(-1), "SCALAR",
                            USHORT if np.asarray(faces).dtype == np.uint16 else UINT)
        prim = g.Primitive(attributes=g.Attributes(POSITION=pos, **attrs), indices=idx, mode=mode)
        if color is not None:
            self.doc.materials.append(g.Material(pbrMetallicRoughness=g.PbrMetallicRoughness(
                baseColorFactor=list(color) + [1.0])))
            prim.material = len(self.doc.materials) - 1
        self.doc.meshes.append(g.Mesh(primitives=[prim]))
        return len(self.doc.meshes) - 1

    def node(self, root: bool = True, **kw: object) -> int:
        self.doc.nodes.append(g.Node(**kw))
        i = len(self.doc.nodes) - 1
        if root:
            self.doc.scenes[0].nodes.append(i)
        return i

    def animate(self, node: int, path: str, times: list[float], values: np.ndarray, interpolation: str = "LINEAR",
                name: str = "anim", clip: int = 0) -> None:
        """A channel in animation `clip` (made, named `name`, when it does not exist yet)."""
        kind = {"translation": "VEC3", "scale": "VEC3", "rotation": "VEC4", "weights": "SCALAR"}[path]
        t = self.accessor(np.asarray(times, np.float32), "SCALAR", minmax=True)
        v = self.accessor(np.asarray(values, np.float32).reshape(-1, 4 if kind == "VEC4" else 3 if kind == "VEC3"
                                                                  else 1), kind)
        while len(self.doc.animations) <= clip:
            self.doc.animations.append(g.Animation(name=name))
        an = self.doc.animations[clip]
        an.samplers.append(g.AnimationSampler(input=t, output=v, interpolation=interpolation))
        an.channels.append(g.AnimationChannel(sampler=len(an.samplers) - 1,
                                              target=g.AnimationChannelTarget(node=node, path=path)))

    def save(self, path: Path, external: bool = True) -> Path:
        path = Path(path)
        if path.suffix == ".glb":
            self.doc.buffers = [g.Buffer(byteLength=len(self.blob))]
            self.doc.set_binary_blob(bytes(self.blob))
            self.doc.save_binary(str(path))
        elif external:
            bin_path = path.with_suffix(".bin")
            bin_path.write_bytes(bytes(self.blob))
            self.doc.buffers = [g.Buffer(uri=bin_path.name, byteLength=len(self.blob))]
            path.write_text(self.doc.to_json())
        else:
            uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.blob)).decode()
            self.doc.buffers = [g.Buffer(uri=uri, byteLength=len(self.blob))]
            path.write_text(self.doc.to_json())
        return path


def quat_axis(axis: tuple[float, float, float], degrees: float) -> list[float]:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    h = math.radians(degrees) / 2
    return [*(a * math.sin(h)).tolist(), math.cos(h)]


def animated_box(path: Path, external: bool = True) -> Path:
    """A unit box moving from x = 0 to x = 2 over 1 s (LINEAR), and a still box at z = -3."""
    b = Builder()
    m = b.mesh(BOX_V, BOX_F, color=(0.5, 0.2, 0.1))
    box = b.node(mesh=m, name="mover")
    b.node(mesh=b.mesh(BOX_V, BOX_F), name="still", translation=[0.0, 0.0, -3.0])
    b.animate(box, "translation", [0.0, 1.0], np.array([[0, 0, 0], [2, 0, 0]]))
    return b.save(path, external)


def two_clips(path: Path, shared: bool = False) -> Path:
    """Two unit boxes and two clips: 'slide' moves box 'a' from x = 0 to x = 2 over 1 s; 'lift' moves box 'b'
    (at z = -3) from y = 0 to y = 4 over 2 s. `shared`: 'lift' also moves 'a', from x = 10 to x = 12 over 2 s
    (the same channel as 'slide')."""
    b = Builder()
    m = b.mesh(BOX_V, BOX_F, color=(0.5, 0.2, 0.1))
    a = b.node(mesh=m, name="a")
    box_b = b.node(mesh=m, name="b", translation=[0.0, 0.0, -3.0])
    b.animate(a, "translation", [0.0, 1.0], np.array([[0, 0, 0], [2, 0, 0]]), name="slide", clip=0)
    b.animate(box_b, "translation", [0.0, 2.0], np.array([[0, 0, -3], [0, 4, -3]]), name="lift", clip=1)
    if shared:
        b.animate(a, "translation", [0.0, 2.0], np.array([[10, 0, 0], [12, 0, 0]]), clip=1)
    return b.save(path)


def walking_figure(path: Path, distance: float = 12.0, seconds: float = 2.0) -> Path:
    """A box figure 1.8 high (torso, head, two legs; feet at y = 0) walking along +x: its root node moves
    from x = 0 to x = `distance` over `seconds` (LINEAR)."""
    b = Builder()
    parts = {"torso": ((0.0, 1.15, 0.0), (0.4, 0.7, 0.25)), "head": ((0.0, 1.65, 0.0), (0.25, 0.3, 0.25)),
             "leg_l": ((-0.1, 0.4, 0.0), (0.15, 0.8, 0.15)), "leg_r": ((0.1, 0.4, 0.0), (0.15, 0.8, 0.15))}
    verts, faces = [], []
    for centre, size in parts.values():
        faces.append(BOX_F.astype(np.uint32) + 8 * len(verts))
        verts.append(BOX_V * np.asarray(size, np.float32) + np.asarray(centre, np.float32))
    m = b.mesh(np.concatenate(verts), np.concatenate(faces).astype(np.uint32), color=(0.6, 0.6, 0.6))
    fig = b.node(mesh=m, name="figure")
    b.animate(fig, "translation", [0.0, seconds], np.array([[0, 0, 0], [distance, 0, 0]]), name="walk")
    return b.save(path)


def sphere_vertices(subdiv: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """A unit UV sphere (8 x 16 quads split in two; poles shared), outward counter-clockwise."""
    rows, cols = 4 * subdiv, 8 * subdiv
    v = [[0.0, 1.0, 0.0]]
    for i in range(1, rows):
        th = math.pi * i / rows
        for k in range(cols):
            ph = 2 * math.pi * k / cols
            v.append([math.sin(th) * math.sin(ph), math.cos(th), math.sin(th) * math.cos(ph)])
    v.append([0.0, -1.0, 0.0])
    f = [[0, 1 + k, 1 + (k + 1) % cols] for k in range(cols)]
    for i in range(rows - 2):
        for k in range(cols):
            a, b_ = 1 + i * cols + k, 1 + i * cols + (k + 1) % cols
            c, d = a + cols, b_ + cols
            f += [[a, c, d], [a, d, b_]]
    last = len(v) - 1
    f += [[last, last - cols + (k + 1) % cols, last - cols + k] for k in range(cols)]
    return np.array(v, np.float32), np.array(f, np.uint32)


def morphing_sphere(path: Path, grow: float = 4.0, seconds: float = 1.0) -> Path:
    """A unit sphere whose morph target 0 moves every vertex out by (grow - 1) times its position: weight 0 -> 1
    over `seconds` grows it to radius `grow` (about its centre at the origin)."""
    b = Builder()
    v, f = sphere_vertices()
    pos = b.accessor(v, "VEC3", minmax=True)
    tgt = b.accessor((v * (grow - 1.0)).astype(np.float32), "VEC3", minmax=True)
    idx = b.accessor(f.reshape(-1), "SCALAR", UINT)
    b.doc.meshes.append(g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=pos), indices=idx,
                                                       targets=[{"POSITION": tgt}])], weights=[0.0]))
    ball = b.node(mesh=0, name="ball")
    b.animate(ball, "weights", [0.0, seconds], np.array([0.0, 1.0]), name="grow")
    return b.save(path)


def bar_vertices() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A bar along +x from 0 to 2: 5 rings of 4 vertices at x = 0, 0.5, 1, 1.5, 2 (y, z = +-0.1); joint 0
    weights 1 up to x = 0.5, 0.5/0.5 at x = 1, joint 1 from x = 1.5."""
    xs = [0.0, 0.5, 1.0, 1.5, 2.0]
    ring = [(0.1, 0.1), (-0.1, 0.1), (-0.1, -0.1), (0.1, -0.1)]
    v = np.array([[x, y, z] for x in xs for y, z in ring], np.float32)
    faces = []
    for i in range(len(xs) - 1):
        for k in range(4):
            a, b_, c, d = 4 * i + k, 4 * i + (k + 1) % 4, 4 * (i + 1) + (k + 1) % 4, 4 * (i + 1) + k
            faces += [[a, b_, c], [a, c, d]]
    faces += [[0, 2, 1], [0, 3, 2], [16, 17, 18], [16, 18, 19]]
    w1 = np.repeat([0.0, 0.0, 0.5, 1.0, 1.0], 4)
    weights = np.stack([1 - w1, w1, np.zeros_like(w1), np.zeros_like(w1)], axis=1).astype(np.float32)
    joints = np.tile(np.array([0, 1, 0, 0], np.uint8), (len(v), 1))
    return v, np.array(faces, np.uint16), joints, weights


def skinned_bar(path: Path) -> Path:
    """Joint 1 (at x = 1, child of joint 0 at the origin) turns from 0 to 90 degrees about +Z over 1 s."""
    b = Builder()
    v, f, joints, weights = bar_vertices()
    j_acc = b.accessor(joints, "VEC4", UBYTE)
    w_acc = b.accessor(weights, "VEC4")
    m = b.mesh(v, f, color=(0.3, 0.5, 0.7), JOINTS_0=j_acc, WEIGHTS_0=w_acc)
    j1 = len(b.doc.nodes) + 1
    j0 = b.node(name="j0", children=[j1])
    b.node(root=False, name="j1", translation=[1.0, 0.0, 0.0])
    ibm = np.stack([np.eye(4), np.array([[1, 0, 0, -1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)])
    ibm_acc = b.accessor(ibm.transpose(0, 2, 1).astype(np.float32).reshape(2, 16), "MAT4")
    b.doc.skins.append(g.Skin(joints=[j0, j1], inverseBindMatrices=ibm_acc))
    b.node(mesh=m, skin=0, name="bar")
    b.animate(j1, "rotation", [0.0, 1.0], np.array([quat_axis((0, 0, 1), 0), quat_axis((0, 0, 1), 90)]))
    return b.save(path)


def skinned_tube(path: Path, rings: int = 33, segments: int = 16, radius: float = 0.25, bend: float = 90.0,
                 seconds: float = 1.0) -> Path:
    """A closed tube along +x from 0 to 2 (`rings` rings of `segments` vertices, capped), skinned to joint 0
    at the origin and joint 1 at x = 1 (weights blend smoothly over 0.6 < x < 1.4); joint 1 turns from 0
    to `bend` degrees about +Z over `seconds`, so the tube bends like an elbow."""
    b = Builder()
    xs = np.linspace(0.0, 2.0, rings)
    ang = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    v = [[x, radius * math.cos(a), radius * math.sin(a)] for x in xs for a in ang] + [[0.0, 0, 0], [2.0, 0, 0]]
    f = []
    for i in range(rings - 1):
        for k in range(segments):
            k1 = (k + 1) % segments
            a, b_, c, d = i * segments + k, i * segments + k1, (i + 1) * segments + k1, (i + 1) * segments + k
            f += [[a, b_, c], [a, c, d]]
    c0, c1 = rings * segments, rings * segments + 1
    last = (rings - 1) * segments
    f += [[c0, (k + 1) % segments, k] for k in range(segments)]
    f += [[c1, last + k, last + (k + 1) % segments] for k in range(segments)]
    verts = np.array(v, np.float32)
    s_ = np.clip((verts[:, 0] - 0.6) / 0.8, 0.0, 1.0)
    w1 = s_ * s_ * (3 - 2 * s_)
    weights = np.stack([1 - w1, w1, np.zeros_like(w1), np.zeros_like(w1)], axis=1).astype(np.float32)
    joints = np.tile(np.array([0, 1, 0, 0], np.uint8), (len(verts), 1))
    m = b.mesh(verts, np.array(f, np.uint32), color=(0.55, 0.6, 0.75), JOINTS_0=b.accessor(joints, "VEC4", UBYTE),
               WEIGHTS_0=b.accessor(weights, "VEC4"))
    j1 = len(b.doc.nodes) + 1
    j0 = b.node(name="j0", children=[j1])
    b.node(root=False, name="j1", translation=[1.0, 0.0, 0.0])
    ibm = np.stack([np.eye(4), np.array([[1, 0, 0, -1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)])
    b.doc.skins.append(g.Skin(joints=[j0, j1], inverseBindMatrices=b.accessor(
        ibm.transpose(0, 2, 1).astype(np.float32).reshape(2, 16), "MAT4")))
    b.node(mesh=m, skin=0, name="tube")
    b.animate(j1, "rotation", [0.0, seconds], np.array([quat_axis((0, 0, 1), 0), quat_axis((0, 0, 1), bend)]))
    return b.save(path)


def morphing_quad(path: Path) -> Path:
    """A unit quad in the XY plane; target 0 lifts vertex 2 by +1 in z; weight 0 -> 1 over 1 s."""
    b = Builder()
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    delta = np.zeros((4, 3), np.float32)
    delta[2, 2] = 1.0
    pos = b.accessor(v, "VEC3", minmax=True)
    tgt = b.accessor(delta, "VEC3", minmax=True)
    idx = b.accessor(np.array([0, 1, 2, 0, 2, 3], np.uint16), "SCALAR", USHORT)
    b.doc.meshes.append(g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=pos), indices=idx,
                                                       targets=[{"POSITION": tgt}])], weights=[0.0]))
    quad = b.node(mesh=0, name="quad")
    b.animate(quad, "weights", [0.0, 1.0], np.array([0.0, 1.0]))
    return b.save(path)


def two_cameras(path: Path) -> Path:
    """A box and three cameras: 'front' at z = 5 (yfov 0.8), 'side' at x = 5 turned +90 deg about Y, 'top'
    orthographic."""
    b = Builder()
    b.node(mesh=b.mesh(BOX_V, BOX_F), name="box")
    b.doc.cameras += [g.Camera(type="perspective", name="front",
                               perspective=g.Perspective(yfov=0.8, znear=0.1, zfar=50.0)),
                      g.Camera(type="perspective", name="side", perspective=g.Perspective(yfov=0.6, znear=0.5)),
                      g.Camera(type="orthographic", name="top",
                               orthographic=g.Orthographic(xmag=2, ymag=2, znear=0.1, zfar=10))]
    b.node(camera=0, name="front_node", translation=[0.0, 0.0, 5.0])
    b.node(camera=1, name="side_node", translation=[5.0, 0.0, 0.0], rotation=quat_axis((0, 1, 0), 90))
    b.node(camera=2, name="top_node", translation=[0.0, 5.0, 0.0], rotation=quat_axis((1, 0, 0), -90))
    return b.save(path)


# --- raw parts, for the hostile-input tests (tests/nodegraph/test_gltf_hostile.py) -----------------------


def png_bytes(rgb: np.ndarray) -> bytes:
    """A PNG (8-bit RGB or RGBA, no filtering) of the (h, w, 3 or 4) uint8 array, written here with zlib."""
    h, w, nch = rgb.shape
    raw = b"".join(b"\0" + np.ascontiguousarray(rgb[y], np.uint8).tobytes() for y in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6 if nch == 4 else 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def webp_bytes(rgb: np.ndarray, lossless: bool = True) -> bytes:
    """A WebP of the (h, w, 3 or 4) uint8 array, written by OpenImageIO (libwebp): lossless (a VP8L chunk) or lossy
    (VP8, or VP8X with alpha)."""
    import tempfile

    import OpenImageIO as oiio

    h, w, nch = rgb.shape
    spec = oiio.ImageSpec(w, h, nch, oiio.UINT8)
    spec.attribute("compression", "lossless" if lossless else "webp")
    spec.attribute("oiio:UnassociatedAlpha", 1)
    with tempfile.TemporaryDirectory() as folder:
        name = str(Path(folder) / "image.webp")
        out = oiio.ImageOutput.create(name)
        assert out is not None and out.open(name, spec), oiio.geterror()
        out.write_image(np.ascontiguousarray(rgb, np.uint8))
        out.close()
        return Path(name).read_bytes()


def draco_box(path: Path, required: bool = True, stream: bytes | None = None) -> tuple[Path, np.ndarray, np.ndarray]:
    """A box whose positions, texture coordinates and indices are only in a KHR_draco_mesh_compression stream
    (encoded by DracoPy, order kept, 14-bit positions); `stream` replaces the stream's bytes (broken ones).
    Returns the path, and the positions and faces as Draco decodes them (quantized)."""
    import DracoPy

    uv = (BOX_V[:, :2] + 0.5).astype(np.float64)
    data = DracoPy.encode(BOX_V, BOX_F.astype(np.uint32), tex_coord=uv, preserve_order=True, quantization_bits=14)
    decoded = DracoPy.decode(data)
    ids = {a["attribute_type"]: a["unique_id"] for a in decoded.attributes}  # 0: position, 3: texture coordinate
    b = Builder()
    blob = data if stream is None else stream
    b.blob += blob
    b.doc.bufferViews.append(g.BufferView(buffer=0, byteOffset=0, byteLength=len(blob)))
    n = len(BOX_V)
    b.doc.accessors += [
        g.Accessor(componentType=FLOAT, count=n, type="VEC3", min=BOX_V.min(0).tolist(), max=BOX_V.max(0).tolist()),
        g.Accessor(componentType=FLOAT, count=n, type="VEC2"),
        g.Accessor(componentType=USHORT, count=BOX_F.size, type="SCALAR")]
    prim = g.Primitive(attributes=g.Attributes(POSITION=0, TEXCOORD_0=1), indices=2, extensions={
        "KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": ids[0], "TEXCOORD_0": ids[3]}}})
    b.doc.meshes.append(g.Mesh(primitives=[prim]))
    b.node(mesh=0, name="box")
    b.doc.extensionsUsed = ["KHR_draco_mesh_compression"]
    if required:
        b.doc.extensionsRequired = ["KHR_draco_mesh_compression"]
    path = b.save(path)
    doc = json.loads(Path(path).read_text()) if path.suffix == ".gltf" else None
    if doc is not None:  # pygltflib writes "byteOffset": 0 into accessors without a bufferView
        for acc in doc["accessors"]:
            acc.pop("byteOffset", None)
        path.write_text(json.dumps(doc))
    return path, np.asarray(decoded.points, np.float64), np.asarray(decoded.faces, np.int64)


def png_header(width: int, height: int) -> bytes:
    """A PNG whose header claims width x height and whose pixel data is a few bytes (a decompression bomb's
    shape: nothing of it is decoded when the header is refused)."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + ihdr
            + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr) & 0xFFFFFFFF)
            + struct.pack(">I", 10) + b"IDAT" + zlib.compress(b"\0" * 64)[:10] + b"\0\0\0\0")


def jpeg_header(width: int, height: int) -> bytes:
    """The start of a baseline JPEG: SOI, an APP0 segment, and a frame header (SOF0) claiming width x height."""
    app0 = b"JFIF\0\x01\x01\0\0\x01\0\x01\0\0"
    sof = struct.pack(">BHHB", 8, height, width, 3) + b"\x01\x11\0\x02\x11\0\x03\x11\0"
    return (b"\xff\xd8" + b"\xff\xe0" + struct.pack(">H", len(app0) + 2) + app0
            + b"\xff\xc0" + struct.pack(">H", len(sof) + 2) + sof + b"\xff\xd9")


def sink_parts(texture: bytes | None = None) -> tuple[dict, bytes]:
    """(JSON document as a dict, binary buffer) of a small file that uses most of what the reader reads: a
    box with a textured material (the image in a bufferView; `texture` defaults to a 2x2 red PNG), a skinned
    bar on two joints with a rotation animation, a morphing quad with a weights animation and a sparse
    morph target, a camera on a node, a matrix node, and a child node. Buffer 0 has no uri (as in a .glb)."""
    b = Builder()
    box = b.mesh(BOX_V, BOX_F, color=(0.5, 0.5, 0.5))
    img = texture if texture is not None else png_bytes(np.full((2, 2, 3), (255, 0, 0), np.uint8))
    while len(b.blob) % 4:
        b.blob += b"\0"
    b.doc.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(b.blob), byteLength=len(img)))
    b.blob += img
    b.doc.images.append(g.Image(bufferView=len(b.doc.bufferViews) - 1, mimeType="image/png"))
    b.doc.samplers.append(g.Sampler(magFilter=9729, minFilter=9729))
    b.doc.textures.append(g.Texture(source=0, sampler=0))
    b.doc.materials[0].pbrMetallicRoughness.baseColorTexture = g.TextureInfo(index=0)
    b.node(mesh=box, name="box", translation=[0.0, 0.0, -3.0], children=[1])
    b.node(root=False, name="child", matrix=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 2, 0, 1])

    v, f, joints, weights = bar_vertices()
    bar = b.mesh(v, f, JOINTS_0=b.accessor(joints, "VEC4", UBYTE), WEIGHTS_0=b.accessor(weights, "VEC4"))
    j1 = len(b.doc.nodes) + 1
    j0 = b.node(name="j0", children=[j1])
    b.node(root=False, name="j1", translation=[1.0, 0.0, 0.0])
    ibm = np.stack([np.eye(4), np.array([[1, 0, 0, -1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)])
    b.doc.skins.append(g.Skin(joints=[j0, j1], inverseBindMatrices=b.accessor(
        ibm.transpose(0, 2, 1).astype(np.float32).reshape(2, 16), "MAT4")))
    b.node(mesh=bar, skin=0, name="bar")
    b.animate(j1, "rotation", [0.0, 1.0], np.array([quat_axis((0, 0, 1), 0), quat_axis((0, 0, 1), 90)]))

    quad_v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    pos = b.accessor(quad_v, "VEC3", minmax=True)
    idx = b.accessor(np.array([0, 1, 2, 0, 2, 3], np.uint8), "SCALAR", UBYTE)
    sp_idx = b.accessor(np.array([2], np.uint16), "SCALAR", USHORT)
    sp_val = b.accessor(np.array([[0, 0, 1]], np.float32), "VEC3")
    target = g.Accessor(componentType=FLOAT, count=4, type="VEC3", min=[0, 0, 0], max=[0, 0, 1], sparse=g.Sparse(
        count=1, indices=g.AccessorSparseIndices(bufferView=b.doc.accessors[sp_idx].bufferView, componentType=USHORT),
        values=g.AccessorSparseValues(bufferView=b.doc.accessors[sp_val].bufferView)))
    b.doc.accessors.append(target)
    b.doc.meshes.append(g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=pos), indices=idx,
                                                       targets=[{"POSITION": len(b.doc.accessors) - 1}])],
                               weights=[0.0]))
    quad = b.node(mesh=len(b.doc.meshes) - 1, name="quad")
    b.animate(quad, "weights", [0.0, 1.0], np.array([0.0, 1.0]))

    b.doc.cameras.append(g.Camera(type="perspective", name="cam",
                                  perspective=g.Perspective(yfov=0.8, znear=0.1, zfar=100.0)))
    b.node(camera=0, name="cam_node", translation=[0.0, 0.0, 8.0])
    # the box's texture coordinates come last, so that the indices above stay put
    b.doc.meshes[box].primitives[0].attributes.TEXCOORD_0 = b.accessor((BOX_V[:, :2] + 0.5).astype(np.float32),
                                                                       "VEC2")
    return _parts(b)


def _parts(b: Builder) -> tuple[dict, bytes]:
    """The builder's document as a JSON dict with one buffer without a uri (as in a .glb), and its buffer."""
    b.doc.buffers = [g.Buffer(byteLength=len(b.blob))]
    doc = json.loads(b.doc.to_json())
    # pygltflib writes "byteOffset": 0 into accessors without a bufferView; the spec has no byteOffset there
    for acc in doc["accessors"]:
        if "bufferView" not in acc:
            acc.pop("byteOffset", None)
    return doc, bytes(b.blob)


def extension_parts() -> tuple[dict, bytes]:
    """(JSON document as a dict, binary buffer) of a small file that uses the extensions the reader reads beyond
    the core: an instanced box (EXT_mesh_gpu_instancing, three instances), a hidden node with a child
    (KHR_node_visibility), a Draco-compressed box (KHR_draco_mesh_compression), a WebP base colour texture
    (EXT_texture_webp, with a PNG fallback), a point light and a camera on nodes, and one clip of
    KHR_animation_pointer channels: a node's translation, the camera's yfov and the light's intensity. Buffer 0
    has no uri (as in a .glb)."""
    import DracoPy

    b = Builder()
    box = b.mesh(BOX_V, BOX_F, color=(0.5, 0.5, 0.5))
    t = b.accessor(np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0]], np.float32), "VEC3")
    r = b.accessor(np.array([quat_axis((0, 0, 1), a) for a in (0, 30, 60)], np.float32), "VEC4")
    sc = b.accessor(np.array([[1, 1, 1], [0.5, 0.5, 0.5], [1, 2, 1]], np.float32), "VEC3")
    b.node(mesh=box, name="instanced", extensions={"EXT_mesh_gpu_instancing": {"attributes": {
        "TRANSLATION": t, "ROTATION": r, "SCALE": sc}}})
    b.node(mesh=box, name="hidden", translation=[0.0, -3.0, 0.0], children=[2],
           extensions={"KHR_node_visibility": {"visible": False}})
    b.node(root=False, mesh=box, name="under_hidden", translation=[1.0, 0.0, 0.0])
    # a Draco box: its accessors have no bufferView; the stream has its own
    uv = (BOX_V[:, :2] + 0.5).astype(np.float64)
    stream = DracoPy.encode(BOX_V, BOX_F.astype(np.uint32), tex_coord=uv, preserve_order=True)
    ids = {a["attribute_type"]: a["unique_id"] for a in DracoPy.decode(stream).attributes}
    while len(b.blob) % 4:
        b.blob += b"\0"
    b.doc.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(b.blob), byteLength=len(stream)))
    b.blob += stream
    b.doc.accessors += [g.Accessor(componentType=FLOAT, count=8, type="VEC3", min=[-0.5] * 3, max=[0.5] * 3),
                        g.Accessor(componentType=FLOAT, count=8, type="VEC2"),
                        g.Accessor(componentType=USHORT, count=36, type="SCALAR")]
    n = len(b.doc.accessors)
    # the WebP texture (its PNG fallback as `source`) on the Draco box's material
    png = png_bytes(np.full((2, 2, 3), (255, 0, 0), np.uint8))
    webp = webp_bytes(np.full((2, 2, 3), (0, 0, 255), np.uint8))
    for mime, data in (("image/png", png), ("image/webp", webp)):
        while len(b.blob) % 4:
            b.blob += b"\0"
        b.doc.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(b.blob), byteLength=len(data)))
        b.blob += data
        b.doc.images.append(g.Image(bufferView=len(b.doc.bufferViews) - 1, mimeType=mime))
    b.doc.textures.append(g.Texture(source=0, extensions={"EXT_texture_webp": {"source": 1}}))
    b.doc.materials.append(g.Material(pbrMetallicRoughness=g.PbrMetallicRoughness(
        baseColorTexture=g.TextureInfo(index=0))))
    b.doc.meshes.append(g.Mesh(primitives=[g.Primitive(
        attributes=g.Attributes(POSITION=n - 3, TEXCOORD_0=n - 2), indices=n - 1, material=len(b.doc.materials) - 1,
        extensions={"KHR_draco_mesh_compression": {"bufferView": len(b.doc.bufferViews) - 3, "attributes": {
            "POSITION": ids[0], "TEXCOORD_0": ids[3]}}})]))
    mover = b.node(mesh=len(b.doc.meshes) - 1, name="draco", translation=[0.0, 0.0, -2.0])
    b.doc.cameras.append(g.Camera(type="perspective", perspective=g.Perspective(yfov=0.8, znear=0.1, zfar=50.0)))
    b.node(camera=0, name="cam", translation=[0.0, 0.0, 8.0])
    b.node(name="lamp", translation=[0.0, 3.0, 2.0], extensions={"KHR_lights_punctual": {"light": 0}})
    b.doc.extensions = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 2.0}]}}
    times = b.accessor(np.array([0.0, 1.0], np.float32), "SCALAR", minmax=True)
    move = b.accessor(np.array([[0, 0, -2], [1, 0, -2]], np.float32), "VEC3")
    fov = b.accessor(np.array([0.8, 0.5], np.float32), "SCALAR")
    dim = b.accessor(np.array([2.0, 0.5], np.float32), "SCALAR")
    samplers, channels = [], []
    for out, ptr in ((move, f"/nodes/{mover}/translation"), (fov, "/cameras/0/perspective/yfov"),
                     (dim, "/extensions/KHR_lights_punctual/lights/0/intensity")):
        samplers.append(g.AnimationSampler(input=times, output=out))
        channels.append(g.AnimationChannel(sampler=len(samplers) - 1, target=g.AnimationChannelTarget(
            path="pointer", extensions={"KHR_animation_pointer": {"pointer": ptr}})))
    b.doc.animations.append(g.Animation(name="pointers", samplers=samplers, channels=channels))
    b.doc.extensionsUsed = ["EXT_mesh_gpu_instancing", "KHR_node_visibility", "KHR_draco_mesh_compression",
                            "EXT_texture_webp", "KHR_lights_punctual", "KHR_animation_pointer"]
    return _parts(b)


def glb_bytes(doc: dict, blob: bytes | None, version: int = 2, magic: bytes = b"glTF", length: int | None = None,
              json_type: int = 0x4E4F534A, bin_type: int = 0x004E4942) -> bytes:
    """A GLB of the document and binary chunk, each header field given (for broken ones)."""
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    out = struct.pack("<II", len(text), json_type) + text
    if blob is not None:
        data = blob + b"\0" * (-len(blob) % 4)
        out += struct.pack("<II", len(data), bin_type) + data
    total = 12 + len(out)
    return magic + struct.pack("<II", version, total if length is None else length) + out


def write_parts(path: Path, doc: dict, blob: bytes, how: str = "glb") -> Path:
    """Write the parts as `how`: "glb" (buffer 0 the binary chunk), "data" (.gltf with a data URI) or
    "external" (.gltf with `<stem>.bin` beside it); the document is not changed in place."""
    doc = json.loads(json.dumps(doc))
    path = Path(path)
    if how == "glb":
        path.write_bytes(glb_bytes(doc, blob))
        return path
    if how == "data":
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
    else:
        path.with_suffix(".bin").write_bytes(blob)
        doc["buffers"][0]["uri"] = path.with_suffix(".bin").name
    path.write_text(json.dumps(doc))
    return path


def lit_quad(path: Path, lights: list[dict], light_nodes: list[dict], color: tuple[float, float, float] = (1, 1, 1),
             animate_light: tuple[list[float], np.ndarray] | None = None) -> Path:
    """A 2 x 2 quad in the XY plane facing +Z (a fan about a centre vertex, so the point above the centre is a
    vertex) and KHR_lights_punctual `lights` (written by hand as the extension's JSON) on nodes whose keyword
    arguments are `light_nodes` (each with `light`: the light's index); `animate_light`: (times, translations) of
    the first light node."""
    b = Builder()
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0], [0, 0, 0]], np.float32)
    f = np.array([[4, 0, 1], [4, 1, 2], [4, 2, 3], [4, 3, 0]], np.uint16)
    b.node(mesh=b.mesh(v, f, color), name="quad")
    first = None
    for kw in light_nodes:
        kw = dict(kw)
        index = kw.pop("light")
        node = b.node(extensions={"KHR_lights_punctual": {"light": index}}, **kw)
        first = node if first is None else first
    b.doc.extensions = {"KHR_lights_punctual": {"lights": lights}}
    b.doc.extensionsUsed = ["KHR_lights_punctual"]
    if animate_light is not None and first is not None:
        b.animate(first, "translation", animate_light[0], animate_light[1])
    return b.save(path)


# -- colour: a textured quad and a vertex-coloured quad, seen straight on by a camera that the quad fills -------
QUAD_V = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
QUAD_F = np.array([[0, 1, 2], [0, 2, 3]], np.uint16)
QUAD_UV = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)  # glTF's uv (0, 0) is the image's top left
NEAREST, LINEAR = 9728, 9729


def _quad_camera(b: Builder) -> None:
    """A camera at z = 2 looking down -z with yfov 2 atan(1/2): the quad (-1..1 in x and y) fills a square image."""
    b.doc.cameras.append(g.Camera(type="perspective", perspective=g.Perspective(
        yfov=2 * math.atan(0.5), znear=0.5, zfar=10.0, aspectRatio=1.0)))
    b.node(camera=len(b.doc.cameras) - 1, translation=[0.0, 0.0, 2.0], name="front")


def textured_quad(path: Path, texels: np.ndarray, transform: dict | None = None, alpha_mode: str | None = None,
                  cutoff: float | None = None, factor: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0),
                  wrap: int = 10497, webp: np.ndarray | None = None, webp_required: bool = False) -> Path:
    """The quad with the (h, w, 3 or 4) uint8 image as its base colour texture (NEAREST filters, `wrap` both ways),
    its top-left corner at uv (0, 0); `transform`: a KHR_texture_transform object; `alpha_mode`, `cutoff`.
    `webp`: a second image, stored as a lossless WebP and named by the texture's EXT_texture_webp (the first
    image is then its PNG fallback), `webp_required` lists the extension as required."""
    b = Builder()
    pos = b.accessor(QUAD_V, "VEC3", minmax=True)
    uv = b.accessor(QUAD_UV, "VEC2")
    idx = b.accessor(QUAD_F.reshape(-1), "SCALAR", USHORT)
    images = [("image/png", png_bytes(np.asarray(texels, np.uint8)))]
    if webp is not None:
        images.append(("image/webp", webp_bytes(np.asarray(webp, np.uint8))))
    for mime, data in images:
        while len(b.blob) % 4:
            b.blob += b"\0"
        b.doc.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(b.blob), byteLength=len(data)))
        b.blob += data
        b.doc.images.append(g.Image(bufferView=len(b.doc.bufferViews) - 1, mimeType=mime))
    b.doc.samplers.append(g.Sampler(magFilter=NEAREST, minFilter=NEAREST, wrapS=wrap, wrapT=wrap))
    b.doc.textures.append(g.Texture(source=0, sampler=0))
    if webp is not None:
        b.doc.textures[0].extensions = {"EXT_texture_webp": {"source": 1}}
        b.doc.extensionsUsed.append("EXT_texture_webp")
        if webp_required:
            b.doc.extensionsRequired.append("EXT_texture_webp")
    info = g.TextureInfo(index=0)
    if transform is not None:
        info.extensions = {"KHR_texture_transform": transform}
        b.doc.extensionsUsed.append("KHR_texture_transform")
    mat = g.Material(pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=list(factor),
                                                                 baseColorTexture=info), doubleSided=True)
    if alpha_mode is not None:
        mat.alphaMode = alpha_mode
    if cutoff is not None:
        mat.alphaCutoff = cutoff
    b.doc.materials.append(mat)
    prim = g.Primitive(attributes=g.Attributes(POSITION=pos, TEXCOORD_0=uv), indices=idx, material=0)
    b.doc.meshes.append(g.Mesh(primitives=[prim]))
    b.node(mesh=0, name="quad")
    _quad_camera(b)
    return b.save(path)


def vertex_color_quad(path: Path, colors: np.ndarray, ctype: int = FLOAT) -> Path:
    """The quad with COLOR_0 = `colors` ((4, 3) or (4, 4) in 0..1; as normalised `ctype` integers unless FLOAT) at
    its corners (-1,-1), (1,-1), (1,1), (-1,1), and no material."""
    b = Builder()
    c = np.asarray(colors, np.float64)
    data = c.astype(np.float32) if ctype == FLOAT else np.rint(c * {UBYTE: 255, USHORT: 65535}[ctype]).astype(
        np.uint8 if ctype == UBYTE else np.uint16)
    if ctype == UBYTE and c.shape[1] == 3:  # VEC3 of bytes: 4-byte aligned elements need a stride; use VEC4
        raise ValueError("byte colours as VEC4")
    col = b.accessor(data, "VEC4" if c.shape[1] == 4 else "VEC3", ctype, normalized=ctype != FLOAT)
    pos = b.accessor(QUAD_V, "VEC3", minmax=True)
    idx = b.accessor(QUAD_F.reshape(-1), "SCALAR", USHORT)
    prim = g.Primitive(attributes=g.Attributes(POSITION=pos, COLOR_0=col), indices=idx)
    b.doc.meshes.append(g.Mesh(primitives=[prim]))
    b.node(mesh=0, name="quad")
    _quad_camera(b)
    return b.save(path)


def colored_box(path: Path, color: tuple[float, float, float]) -> Path:
    """The unit box with a baseColorFactor of `color` (linear), turned 30 degrees about y."""
    b = Builder()
    b.node(mesh=b.mesh(BOX_V, BOX_F, color=color), name="box", rotation=quat_axis((0, 1, 0), 30))
    return b.save(path)


# -- `sketchgraph scene info`: one file holding one of most things, each with a known answer ------------------
INFO_BASE_PNG = png_bytes(np.arange(4 * 2 * 3, dtype=np.uint8).reshape(2, 4, 3) * 10)  # 4 wide, 2 high
INFO_NORMAL_PNG = png_bytes(np.full((2, 2, 3), (128, 128, 255), np.uint8))


def info_sampler(path: Path) -> Path:
    """Meshes: 'box' (12 triangles, 8 vertices) on nodes 'a' and 'b', 'dots' (3 POINTS) on node 'dots', 'spare'
    (a quad) on no node. Material 0 ('paint', BLEND): baseColorFactor (0.2, 0.4, 0.6, 1) x texture 0 (a 4x2 PNG),
    normalTexture 1 (a 2x2 PNG), KHR_materials_emissive_strength. Animations: 'slide' (node a's translation,
    0..2 s), 'spin' (node b's rotation and scale, 0..0.5 s). Cameras: 0 'plan' orthographic (xmag 3, ymag 2) on
    'plan_node', 1 'eye' perspective (yfov 0.6) on 'eye_node', 2 'spare_cam' on no node. A point light 'bulb'
    (colour (1, 0.5, 0.25), intensity 40) on node 'lamp'; KHR_lights_punctual is required."""
    b = Builder()
    uv = b.accessor((BOX_V[:, :2] + 0.5).astype(np.float32), "VEC2")
    box = b.mesh(BOX_V, BOX_F, color=(0.2, 0.4, 0.6), TEXCOORD_0=uv)
    b.doc.meshes[box].name = "box"
    for png in (INFO_BASE_PNG, INFO_NORMAL_PNG):
        while len(b.blob) % 4:
            b.blob += b"\0"
        b.doc.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(b.blob), byteLength=len(png)))
        b.blob += png
        b.doc.images.append(g.Image(bufferView=len(b.doc.bufferViews) - 1, mimeType="image/png"))
        b.doc.textures.append(g.Texture(source=len(b.doc.images) - 1))
    mat = b.doc.materials[0]
    mat.name, mat.alphaMode = "paint", "BLEND"
    mat.pbrMetallicRoughness.baseColorTexture = g.TextureInfo(index=0)
    mat.normalTexture = g.NormalMaterialTexture(index=1)
    mat.extensions = {"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}}
    dots = b.mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([0, 1, 2], np.uint16), mode=0)
    b.doc.meshes[dots].name = "dots"
    spare = b.mesh(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32),
                   np.array([[0, 1, 2], [0, 2, 3]], np.uint16))
    b.doc.meshes[spare].name = "spare"
    a = b.node(mesh=box, name="a")
    bb = b.node(mesh=box, name="b", translation=[0.0, 0.0, -3.0])
    b.node(mesh=dots, name="dots")
    b.doc.cameras += [g.Camera(type="orthographic", name="plan",
                               orthographic=g.Orthographic(xmag=3, ymag=2, znear=0.1, zfar=20)),
                      g.Camera(type="perspective", name="eye", perspective=g.Perspective(yfov=0.6, znear=0.1)),
                      g.Camera(type="perspective", name="spare_cam", perspective=g.Perspective(yfov=1.0, znear=1))]
    b.node(camera=0, name="plan_node", translation=[0.0, 8.0, 0.0], rotation=quat_axis((1, 0, 0), -90))
    b.node(camera=1, name="eye_node", translation=[0.0, 0.0, 8.0])
    b.node(name="lamp", translation=[0.0, 3.0, 0.0], extensions={"KHR_lights_punctual": {"light": 0}})
    b.doc.extensions = {"KHR_lights_punctual": {"lights": [
        {"name": "bulb", "type": "point", "color": [1.0, 0.5, 0.25], "intensity": 40.0}]}}
    b.doc.extensionsUsed = ["KHR_lights_punctual", "KHR_materials_emissive_strength"]
    b.doc.extensionsRequired = ["KHR_lights_punctual"]
    b.animate(a, "translation", [0.0, 2.0], np.array([[0, 0, 0], [2, 0, 0]]), name="slide")
    an = g.Animation(name="spin")
    for path_, values in (("rotation", np.array([quat_axis((0, 1, 0), 0), quat_axis((0, 1, 0), 90)])),
                          ("scale", np.array([[1, 1, 1], [2, 2, 2]]))):
        t = b.accessor(np.array([0.0, 0.5], np.float32), "SCALAR", minmax=True)
        v = b.accessor(values.astype(np.float32), "VEC4" if path_ == "rotation" else "VEC3")
        an.samplers.append(g.AnimationSampler(input=t, output=v))
        an.channels.append(g.AnimationChannel(sampler=len(an.samplers) - 1,
                                              target=g.AnimationChannelTarget(node=bb, path=path_)))
    b.doc.animations.append(an)
    return b.save(path)


def skinned_parts(path: Path) -> Path:
    """Two tubes on one skin (joint 0 at the origin, joint 1 at x = 1 turning 0 -> 90 degrees about +Z over 1 s,
    as `skinned_tube`): 'morphing' (mesh 0) also has a morph target lifting every vertex by x/2 in +y, its weight
    0 -> 1 over 1 s; 'plain' (mesh 1) is the same tube moved 0.6 in z. For the batched posing of several parts."""
    b = Builder()
    rings, segments = 9, 12
    xs = np.linspace(0.0, 2.0, rings)
    ang = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    v = np.array([[x, 0.2 * math.cos(a), 0.2 * math.sin(a)] for x in xs for a in ang], np.float32)
    f = []
    for i in range(rings - 1):
        for k in range(segments):
            k1 = (k + 1) % segments
            a, b_, c, d = i * segments + k, i * segments + k1, (i + 1) * segments + k1, (i + 1) * segments + k
            f += [[a, b_, c], [a, c, d]]
    faces = np.array(f, np.uint16)
    s_ = np.clip((v[:, 0] - 0.6) / 0.8, 0.0, 1.0)
    w1 = s_ * s_ * (3 - 2 * s_)
    weights = np.stack([1 - w1, w1, np.zeros_like(w1), np.zeros_like(w1)], axis=1).astype(np.float32)
    joints = np.tile(np.array([0, 1, 0, 0], np.uint8), (len(v), 1))
    delta = np.zeros_like(v)
    delta[:, 1] = v[:, 0] / 2
    for name, offset, morph in (("morphing", 0.0, True), ("plain", 0.6, False)):
        verts = v + np.array([0.0, 0.0, offset], np.float32)
        m = b.mesh(verts, faces, JOINTS_0=b.accessor(joints, "VEC4", UBYTE), WEIGHTS_0=b.accessor(weights, "VEC4"))
        if morph:
            b.doc.meshes[m].primitives[0].targets = [{"POSITION": b.accessor(delta, "VEC3", minmax=True)}]
            b.doc.meshes[m].weights = [0.0]
        b.doc.meshes[m].name = name
    j1 = len(b.doc.nodes) + 1
    j0 = b.node(name="j0", children=[j1])
    b.node(root=False, name="j1", translation=[1.0, 0.0, 0.0])
    ibm = np.stack([np.eye(4), np.array([[1, 0, 0, -1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)])
    b.doc.skins.append(g.Skin(joints=[j0, j1], inverseBindMatrices=b.accessor(
        ibm.transpose(0, 2, 1).astype(np.float32).reshape(2, 16), "MAT4")))
    morphing = b.node(mesh=0, skin=0, name="morphing")
    b.node(mesh=1, skin=0, name="plain")
    b.animate(j1, "rotation", [0.0, 1.0], np.array([quat_axis((0, 0, 1), 0), quat_axis((0, 0, 1), 90)]))
    b.animate(morphing, "weights", [0.0, 1.0], np.array([0.0, 1.0]))
    return b.save(path)
