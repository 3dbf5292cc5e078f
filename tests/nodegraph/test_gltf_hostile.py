"""Hostile and broken glTF files (issue 34): URIs never leave the file's folder, every index, offset, stride,
count and type is checked against the spec and the actual bytes before use (one located line each), and
the work is bounded by the MAX_* limits of nodegraph/scene/gltf.py. Files are built in code
(tests/gltf_files.py); Hypothesis mutates a valid one."""

from __future__ import annotations

import base64
import builtins
import copy
import io
import json
import math
import os
import struct
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nodegraph.errors import MeshError, PipelineError, SketchgraphError
from nodegraph.scene import gltf
from nodegraph.scene import scene as sc
from tests import gltf_files as gf


@pytest.fixture(autouse=True)
def _fresh_cache():
    gltf._ASSETS.clear()
    yield
    gltf._ASSETS.clear()


def _load(path: Path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gltf.load_asset(path, **kw)


def _refused(path: Path, *fragments: str, **kw) -> str:
    with pytest.raises(MeshError) as err:
        _load(path, **kw)
    msg = str(err.value)
    assert "\n" not in msg, msg
    for f in fragments:
        assert f in msg, msg
    return msg


class _Opened:
    """Every path the process opens (os.open, open, io.open) while active: a file of which no byte may be
    read must not be in it."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch):
        self.paths: list[str] = []
        real_os_open, real_open = os.open, builtins.open

        def os_open(path, *a, **k):
            self.paths.append(os.path.realpath(os.fspath(path)) if not isinstance(path, int) else str(path))
            return real_os_open(path, *a, **k)

        def py_open(file, *a, **k):
            if not isinstance(file, int):
                self.paths.append(os.path.realpath(os.fspath(file)))
            return real_open(file, *a, **k)

        monkeypatch.setattr(os, "open", os_open)
        monkeypatch.setattr(builtins, "open", py_open)
        monkeypatch.setattr(io, "open", py_open)

    def touched(self, path: Path) -> bool:
        real = os.path.realpath(path)
        return any(p == real for p in self.paths)


# --- the security property: nothing outside the file's folder is read -----------------------------------


def _escapes(scene_dir: Path, outside: Path) -> dict[str, str]:
    """URI forms that lead to `outside` (a file in the parent of `scene_dir`) or elsewhere outside."""
    (scene_dir / "sub").mkdir()
    (scene_dir / "link.bin").symlink_to(outside)  # a file in the folder that is the outside file
    (scene_dir / "linkdir").symlink_to(outside.parent)  # a folder in the folder that is the outside one
    return {
        "dotdot": f"../{outside.name}",
        "dotdot_via_sub": f"sub/../../{outside.name}",
        "percent_dotdot": f"%2e%2e/{outside.name}",
        "percent_dotdot_upper": f"%2E%2E%2F{outside.name}",
        "absolute": str(outside),
        "percent_absolute": "%2F" + str(outside).lstrip("/").replace("/", "%2F"),
        "symlink_file": "link.bin",
        "symlink_dir": f"linkdir/{outside.name}",
        "file_scheme": f"file://{outside}",
        "etc_passwd": "/etc/passwd",
        "proc_environ": "/proc/self/environ",
        "nul_byte": f"box%00../{outside.name}",
        "other_scheme": "http://example.invalid/x.bin",
    }


ESCAPES = ["dotdot", "dotdot_via_sub", "percent_dotdot", "percent_dotdot_upper", "absolute", "percent_absolute",
           "symlink_file", "symlink_dir", "file_scheme", "etc_passwd", "proc_environ", "nul_byte", "other_scheme"]


def _scene_with_uri(scene_dir: Path, what: str, uri: str, container: str) -> Path:
    """A valid file whose buffer (what='buffer') or texture image (what='image') is at `uri`."""
    doc, blob = gf.sink_parts()
    if what == "buffer":
        if container == "glb":  # a GLB with no binary chunk, its buffer external
            doc["buffers"][0]["uri"] = uri
            path = scene_dir / "scene.glb"
            path.write_bytes(gf.glb_bytes(doc, None))
            return path
        path = gf.write_parts(scene_dir / "scene.gltf", doc, blob, "data")
        d = json.loads(path.read_text())
        d["buffers"][0]["uri"] = uri
        path.write_text(json.dumps(d))
        return path
    doc["images"][0] = {"uri": uri}
    if container == "glb":
        return gf.write_parts(scene_dir / "scene.glb", doc, blob, "glb")
    return gf.write_parts(scene_dir / "scene.gltf", doc, blob, "data")


@pytest.mark.parametrize("container", ["gltf", "glb"])
@pytest.mark.parametrize("what", ["buffer", "image"])
@pytest.mark.parametrize("form", ESCAPES)
def test_uris_never_leave_the_folder(tmp_path, monkeypatch, form, what, container):
    scene_dir = tmp_path / "scene"
    scene_dir.mkdir()
    doc, blob = gf.sink_parts()
    outside = tmp_path / ("secret.bin" if what == "buffer" else "secret.png")
    outside.write_bytes(blob if what == "buffer" else gf.png_bytes(np.zeros((2, 2, 3), np.uint8)))
    uri = _escapes(scene_dir, outside)[form]
    path = _scene_with_uri(scene_dir, what, uri, container)
    opened = _Opened(monkeypatch)
    msg = _refused(path, f"{'buffers' if what == 'buffer' else 'images'}[0].uri")
    assert any(k in msg for k in ("outside the folder", "absolute path", "scheme", "NUL")), msg
    for secret in (outside, Path("/etc/passwd"), Path("/proc/self/environ")):
        assert not opened.touched(secret), (form, opened.paths)


def test_outside_files_are_read_with_allow_outside(tmp_path):
    scene_dir = tmp_path / "scene"
    scene_dir.mkdir()
    doc, blob = gf.sink_parts()
    (tmp_path / "shared.bin").write_bytes(blob)
    for uri in ("../shared.bin", "%2e%2e/shared.bin", str(tmp_path / "shared.bin")):
        path = _scene_with_uri(scene_dir, "buffer", uri, "gltf")
        _refused(path, "buffers[0].uri")
        asset = _load(path, allow_outside=True)
        assert [o.name for o in asset.objects] == ["box", "bar", "quad"]
        assert asset.meshes[0][0].color == pytest.approx((0.7354, 0.0, 0.0), abs=1e-3)  # its red texture, read
        gltf._ASSETS.clear()
    # and through the scene loader, which threads the option down
    with pytest.raises(PipelineError, match="absolute path"):
        sc.load_scene(str(path))
    assert len(sc.load_scene(str(path), allow_outside=True).objects) == 3
    yaml = scene_dir / "scene.yaml"
    yaml.write_text(f"objects:\n  - gltf: {path.name}\n")
    with pytest.raises(PipelineError, match="absolute path"):
        sc.load_scene(str(yaml))
    assert len(sc.load_scene(str(yaml), allow_outside=True).objects) == 3


def test_percent_encoded_names_inside_the_folder_are_read(tmp_path):
    doc, blob = gf.sink_parts()
    (tmp_path / "my box.bin").write_bytes(blob)
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "tex ture.png").write_bytes(gf.png_bytes(np.full((2, 2, 3), (0, 255, 0), np.uint8)))
    doc["buffers"][0]["uri"] = "my%20box.bin"
    doc["images"][0] = {"uri": "sub/../sub/tex%20ture.png"}
    path = tmp_path / "ok.gltf"
    path.write_text(json.dumps(doc))
    asset = _load(path)
    assert asset.meshes[0][0].color == pytest.approx((0.0, 0.7354, 0.0), abs=1e-3)  # 0.5 x the green texture


@pytest.mark.parametrize("what", ["buffer", "image"])
@pytest.mark.parametrize("special", ["fifo", "directory", "dev_zero", "dev_null"])
def test_special_files_are_never_opened(tmp_path, monkeypatch, what, special):
    target = tmp_path / "special"
    if special == "fifo":
        os.mkfifo(target)  # opening it for reading would block: the test would hang
    elif special == "directory":
        target.mkdir()
    else:
        target.symlink_to("/dev/zero" if special == "dev_zero" else "/dev/null")
    path = _scene_with_uri(tmp_path, what, "special", "gltf")
    opened = _Opened(monkeypatch)
    # with allow_outside too, so that a symlink to /dev/... is refused for what it is, not where it is
    _refused(path, "special", "only regular files are read", allow_outside=True)
    assert not opened.touched(target)


def test_data_uri_length_is_checked_before_decoding(tmp_path, monkeypatch):
    doc, blob = gf.sink_parts()
    path = gf.write_parts(tmp_path / "long.gltf", doc, blob, "data")
    d = json.loads(path.read_text())
    d["buffers"][0]["uri"] += base64.b64encode(b"\0" * 3000).decode()  # more than byteLength
    path.write_text(json.dumps(d))

    def no_decoding(*a, **k):
        raise AssertionError("base64 decoded before the length check")

    monkeypatch.setattr(gltf.base64, "b64decode", no_decoding)
    _refused(path, "buffers[0].uri", "base64 characters")


def test_external_buffer_reads_only_its_byte_length(tmp_path, monkeypatch):
    doc, blob = gf.sink_parts()
    path = gf.write_parts(tmp_path / "big.gltf", doc, blob, "external")
    with open(path.with_suffix(".bin"), "ab") as f:
        f.write(b"\0" * (4 << 20))  # 4 MiB more than the buffer declares
    reads: list[int] = []
    real_read = os.read

    def counting_read(fd, n):
        out = real_read(fd, n)
        reads.append(len(out))
        return out

    monkeypatch.setattr(os, "read", counting_read)
    asset = _load(path)
    assert len(asset.objects) == 3
    assert sum(reads) <= path.stat().st_size + len(blob)  # the .gltf and byteLength bytes of the .bin
    # a buffer file shorter than its byteLength is refused before a byte of it is read
    path.with_suffix(".bin").write_bytes(blob[:100])
    gltf._ASSETS.clear()
    _refused(path, "buffers[0].uri", "has 100 bytes", f"byteLength {len(blob)}")


# --- validation: one located line per fault ----------------------------------------------------------------


def _set(doc: dict, where: str, value) -> None:
    """Set doc at a JSON path like 'meshes[0].primitives[0].attributes.POSITION' (value _DEL deletes)."""
    parts = []
    for p in where.split("."):
        name, *idx = p.replace("]", "").split("[")
        parts.append(name)
        parts.extend(int(i) for i in idx)
    obj = doc
    for p in parts[:-1]:
        obj = obj[p]
    if value is _DEL:
        del obj[parts[-1]]
    else:
        obj[parts[-1]] = value


_DEL = object()

# (JSON path, new value, what the message must say); the message also starts with the file name and the path
BAD_JSON = [
    ("meshes[0].primitives[0].attributes.POSITION", 99, "accessor 99 does not exist (17 accessors)"),
    ("meshes[0].primitives[0].attributes.POSITION", -1, "accessor -1 does not exist"),
    ("meshes[0].primitives[0].indices", -2, "accessor -2 does not exist"),
    ("meshes[0].primitives[0].material", 5, "material 5 does not exist (1 material)"),
    ("nodes[0].mesh", -1, "mesh -1 does not exist"),
    ("nodes[0].children[0]", 50, "node 50 does not exist"),
    ("nodes[4].skin", 1, "skin 1 does not exist"),
    ("nodes[6].camera", -1, "camera -1 does not exist"),
    ("scene", 3, "scene 3 does not exist"),
    ("scenes[0].nodes[0]", -1, "node -1 does not exist"),
    ("skins[0].joints[0]", 99, "node 99 does not exist"),
    ("skins[0].inverseBindMatrices", 1, "MAT4"),
    ("textures[0].source", 2, "image 2 does not exist"),
    ("textures[0].sampler", -1, "sampler -1 does not exist"),
    ("images[0].bufferView", 40, "bufferView 40 does not exist"),
    ("materials[0].pbrMetallicRoughness.baseColorTexture.index", 1, "texture 1 does not exist"),
    ("animations[0].channels[0].sampler", 7, "sampler 7 does not exist (2 samplers in animations[0])"),
    ("animations[0].channels[0].target.node", -1, "node -1 does not exist"),
    ("animations[0].samplers[0].input", 77, "accessor 77 does not exist"),
    ("accessors[0].bufferView", 99, "bufferView 99 does not exist"),
    ("bufferViews[0].buffer", 1, "buffer 1 does not exist (1 buffer)"),
    ("bufferViews[0].byteOffset", 10**6, "run past the end of buffers[0]"),
    ("bufferViews[0].byteLength", 10**6, "run past the end of buffers[0]"),
    ("bufferViews[0].byteOffset", -4, "out of range"),
    ("bufferViews[0].byteStride", 3, "multiple of 4 in 4..252"),
    ("bufferViews[0].byteStride", 256, "multiple of 4 in 4..252"),
    ("bufferViews[0].byteStride", 4, "less than the element size 12"),
    ("accessors[0].byteOffset", 80, "need 176 bytes; bufferViews[0] has 96"),
    ("accessors[0].byteOffset", 2, "not a multiple of the component size 4"),
    ("accessors[0].count", 0, "out of range"),
    ("accessors[0].count", 9, "need 108 bytes; bufferViews[0] has 96"),
    ("accessors[0].count", 2**40, "MAX_ACCESSOR_COUNT"),
    ("accessors[0].componentType", 5124, "not a glTF component type"),
    ("accessors[0].componentType", 5121, "POSITION takes float"),
    ("meshes[0].primitives[0].indices", 12, "indices must be SCALAR"),
    ("accessors[0].type", "VEC2", "accessors[0].min: expected 2 numbers, found 3"),
    ("accessors[0].type", "VEC4", "need 128 bytes"),
    ("accessors[0].type", "VEC7", "not an accessor type"),
    ("accessors[1].componentType", 5122, "indices takes unsigned byte"),
    ("accessors[1].componentType", 5126, "need 144 bytes"),
    ("accessors[1].normalized", True, "indices takes"),
    ("accessors[0].min", [0, 0], "expected 3 numbers"),
    ("accessors[0].max", [-1, -1, -1], "declares max -1.0 for component 0; its data has 0.5"),
    ("accessors[0].min", [-0.5, -0.5, -0.6], "declares min -0.6 for component 2"),
    ("accessors[9]", {"bufferView": 10, "componentType": 5126, "count": 4, "type": "VEC3"},
     "meshes[2].primitives[0].attributes.POSITION: accessor 9 has no min and max"),
    ("accessors[7].min", _DEL, "has no min and max (animation inputs need both)"),
    ("nodes[1].matrix", [1, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], "not an affine transform"),
    ("meshes[0].primitives[0].attributes.TEXCOORD_0", _DEL, "samples TEXCOORD_0, which the primitive does not have"),
    ("accessors[16].bufferView", 0, "holds several vertex attributes without a byteStride"),
    ("asset.generator", 5, "asset.generator: expected a string"),
    ("meshes[1].name", ["x"], "meshes[1].name: expected a string"),
    ("cameras[0].perspective.zfar", 0.05, "must be > znear"),
    ("cameras[0].perspective.znear", 0, "must be > 0"),
    ("cameras[0].perspective.yfov", 0, "in (0, pi)"),
    ("cameras[0].perspective.yfov", 3.5, "in (0, pi)"),
    ("extensionsRequired", ["EXT_not_a_thing"], "requires extension EXT_not_a_thing"),
    ("extensionsRequired", ["EXT_meshopt_compression"], "requires extension EXT_meshopt_compression"),
    ("asset.version", "1.0", "only glTF 2.x"),
    ("asset", _DEL, "'asset' is required"),
    ("nodes[1].children", [0], "is in a cycle"),
    ("nodes[2].children", [3, 1], "node 1 is already a child of node 0"),
    ("nodes[0].children", [0], "its own child"),
    ("nodes[1].matrix", [1, 0, 0], "expected 16 numbers"),
    ("nodes[0].rotation", [0, 0, 0, 0], "not a unit quaternion"),
    ("nodes[0].scale", [1, "x", 1], "expected a number"),
    ("meshes[0].primitives[0].mode", 9, "out of range"),
    ("meshes[1].primitives[0].attributes.WEIGHTS_0", _DEL, "JOINTS_0 and WEIGHTS_0 come together"),
    ("meshes[1].primitives[0].attributes.POSITION", 0, "different counts (8, 20)"),
    ("nodes[4].mesh", 0, "has a primitive without JOINTS_0"),
    ("meshes[0].primitives[0].attributes.FOO", 0, "not a glTF attribute name"),
    ("meshes[2].weights", [0.0, 1.0], "2 weights for 1 morph targets"),
    ("animations[0].channels[0].target.node", 1, "given by a matrix"),
    ("animations[0].channels[1].target.node", 0, "whose mesh has no morph targets"),
    ("animations[0].samplers[0].output", 3, "20 elements; 2 keys of rotation need 2"),
    ("animations[0].samplers[0].output", 12, "rotation output must be VEC4"),
    ("buffers[0].byteLength", 10, "run past the end of buffers[0] (byteLength 10)"),
    ("images[0].mimeType", "image/gif", "must be image/png, image/jpeg or image/webp"),
]


@pytest.mark.parametrize("where,value,expected", BAD_JSON, ids=[f"{w}={v!r}"[:60] for w, v, _ in BAD_JSON])
def test_invalid_documents_are_refused_with_their_json_path(tmp_path, where, value, expected):
    doc, blob = gf.sink_parts()
    doc = copy.deepcopy(doc)
    _set(doc, where, value)
    path = gf.write_parts(tmp_path / "bad.glb", doc, blob, "glb")
    msg = _refused(path, expected)
    assert msg.startswith("bad.glb: "), msg


def test_the_error_names_the_primitive_and_the_accessor_count(tmp_path):
    doc, blob = gf.sink_parts()
    doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 99
    path = gf.write_parts(tmp_path / "walk.gltf", doc, blob, "data")
    assert _refused(path) == ("walk.gltf: meshes[0].primitives[0].attributes.POSITION: accessor 99 does not exist "
                              "(17 accessors)")


def _patch_blob(blob: bytes, offset: int, data: bytes) -> bytes:
    return blob[:offset] + data + blob[offset + len(data):]


def test_data_faults_are_refused_before_use(tmp_path):
    doc, blob = gf.sink_parts()
    pos0 = doc["bufferViews"][0]["byteOffset"]  # the box's POSITION
    idx_view = doc["bufferViews"][doc["accessors"][1]["bufferView"]]
    cases = {
        "nan_position": (_patch_blob(blob, pos0, struct.pack("<f", math.nan)), "holds NaN or infinite values"),
        "inf_position": (_patch_blob(blob, pos0 + 4, struct.pack("<f", math.inf)), "holds NaN or infinite values"),
        "index_past_vertices": (_patch_blob(blob, idx_view["byteOffset"], struct.pack("<H", 8)),
                                "index 8 is out of range: 8 vertices"),
        "restart_index": (_patch_blob(blob, idx_view["byteOffset"], struct.pack("<H", 65535)), "out of range"),
    }
    times = doc["accessors"][doc["animations"][0]["samplers"][0]["input"]]
    tview = doc["bufferViews"][times["bufferView"]]
    cases["nan_time"] = (_patch_blob(blob, tview["byteOffset"], struct.pack("<f", math.nan)), "NaN")
    cases["times_not_increasing"] = (_patch_blob(blob, tview["byteOffset"], struct.pack("<ff", 0.5, 0.5)),
                                     "strictly increasing")
    doc_t = copy.deepcopy(doc)  # the times' declared bounds follow the patched data
    doc_t["accessors"][doc["animations"][0]["samplers"][0]["input"]].update(min=[0.5], max=[0.5])
    joints_view = doc["bufferViews"][doc["accessors"][doc["meshes"][1]["primitives"][0]["attributes"]["JOINTS_0"]]
                                     ["bufferView"]]
    cases["joint_past_skin"] = (_patch_blob(blob, joints_view["byteOffset"], bytes([7])), "uses joint 7")
    for name, (data, expected) in cases.items():
        use = doc_t if name in ("nan_time", "times_not_increasing") else doc
        path = gf.write_parts(tmp_path / f"{name}.glb", use, data, "glb")
        _refused(path, expected)
    doc_t["accessors"][doc["animations"][0]["samplers"][0]["input"]].update(min=[-1.0], max=[1.0])
    neg = gf.write_parts(tmp_path / "neg.glb", doc_t, _patch_blob(blob, tview["byteOffset"], struct.pack("<f", -1.0)),
                         "glb")
    _refused(neg, "is negative")
    weights = doc["bufferViews"][doc["accessors"][doc["meshes"][1]["primitives"][0]["attributes"]["WEIGHTS_0"]]
                                 ["bufferView"]]
    for data, expected in ((struct.pack("<ff", 0.7, 0.7), "sum to 1.39999998, not 1"),
                           (struct.pack("<f", -1.0), "negative")):
        _refused(gf.write_parts(tmp_path / "w.glb", doc, _patch_blob(blob, weights["byteOffset"], data)), expected)
    twice = _patch_blob(_patch_blob(blob, joints_view["byteOffset"] + 16 * 2, bytes([1, 1])),
                        weights["byteOffset"] + 32 * 2, struct.pack("<ff", 0.5, 0.5))  # vertex 8: joint 1 twice
    _refused(gf.write_parts(tmp_path / "t.glb", doc, twice), "names one joint twice")


GLB_FAULTS = {
    "version1": (dict(version=1), "GLB header: version 1"),
    "version3": (dict(version=3), "GLB header: version 3"),
    "length_short": (dict(length=100), "GLB chunk 0: length 4428 runs past the end of the file (80 bytes left)"),
    "length_tiny": (dict(length=12), "GLB header: length 12 but the file has"),
    "length_long": (dict(length=10**6), "GLB header: length 1000000"),
    "magic": (dict(magic=b"gltf"), "magic is b'gltf'"),
    "json_type": (dict(json_type=0x12345678), "the first chunk must be JSON"),
    "bin_type_json": (dict(bin_type=0x4E4F534A), "a second JSON chunk"),
}


@pytest.mark.parametrize("fault", list(GLB_FAULTS))
def test_glb_header_and_chunks(tmp_path, fault):
    doc, blob = gf.sink_parts()
    kw, expected = GLB_FAULTS[fault]
    path = tmp_path / "f.glb"
    path.write_bytes(gf.glb_bytes(doc, blob, **kw))
    _refused(path, expected)


def test_values_the_schema_leaves_open_are_noted_not_refused(tmp_path):
    """The schema lets an extension bring its own camera type, interpolation, channel path or GLB trailer: the
    file loads, and the one warning names what was left out."""
    doc, blob = gf.sink_parts()
    doc["cameras"].append({"type": "fisheye"})
    doc["animations"][0]["samplers"][1]["interpolation"] = "BOUNCE"
    doc["animations"][0]["channels"].append({"sampler": 0, "target": {"node": 3, "path": "colour"}})
    path = tmp_path / "open.glb"
    path.write_bytes(gf.glb_bytes(doc, blob) + b"junk")
    with pytest.warns(gltf.MeshWarning) as caught:
        asset = gltf.load_asset(path)
    text = str(caught[0].message)
    assert "'BOUNCE' (played as LINEAR)" in text and "'colour'" in text and "4 bytes after the GLB" in text
    assert [c.kind for c in asset.cameras] == ["perspective", "fisheye"] and len(asset.animations) == 1


def test_glb_chunk_lengths(tmp_path):
    doc, blob = gf.sink_parts()
    good = gf.glb_bytes(doc, blob)
    jlen = struct.unpack_from("<I", good, 12)[0]
    cases = {
        "json_len_odd": (good[:12] + struct.pack("<I", jlen + 1) + good[16:], "not a multiple of 4"),
        "json_len_past_end": (good[:12] + struct.pack("<I", len(good)) + good[16:], "runs past the end"),
        "truncated": (good[:-8], "length"),
        "trailing": (good + b"\0\0\0\0", "too short for a chunk header"),
        "bin_short": (gf.glb_bytes(doc, blob[:-8]), "the GLB binary chunk has"),
        "no_bin": (gf.glb_bytes(doc, None), "has no uri and is not the GLB binary chunk"),
        "tiny": (b"glTF\x02\0\0\0\x0c\0\0\0", "too short"),
    }
    for name, (data, expected) in cases.items():
        path = tmp_path / f"{name}.glb"
        if name in ("trailing", "truncated"):  # the header's length is honest: the chunks are what is wrong
            data = data[:8] + struct.pack("<I", len(data)) + data[12:]
        path.write_bytes(data)
        _refused(path, expected)


def test_json_faults(tmp_path):
    doc, blob = gf.sink_parts()
    good = json.dumps(doc)
    cases = {
        "nan_literal": (good.replace('"yfov": 0.8', '"yfov": NaN'), "NaN is not a JSON number"),
        "huge_number": (good.replace('"yfov": 0.8', '"yfov": 1e999'), "out of range"),
        "duplicate_key": (good.replace('"yfov": 0.8', '"yfov": 0.8, "yfov": 0.9'), "appears twice"),
        "not_json": ("{nodes: []}", "not valid JSON"),
        "deep": ("[" * 100_000 + "]" * 100_000, "JSON"),
        "top_array": ("[]", "expected an object at the top"),
        "bom": ("\ufeff" + good, "byte order mark"),
        "float_index": (good.replace('"mesh": 0', '"mesh": 0.0', 1), "expected an index"),
        "bool_index": (good.replace('"mesh": 0', '"mesh": true', 1), "expected an index"),
        "string_nodes": (good.replace('"nodes": [{', '"nodes": "x", "_": [{', 1), "nodes: expected an array"),
    }
    for name, (text, expected) in cases.items():
        path = tmp_path / f"{name}.glb"
        raw = text.encode("utf-8")
        raw += b" " * (-len(raw) % 4)
        data = struct.pack("<II", len(raw), 0x4E4F534A) + raw
        data += struct.pack("<II", len(blob), 0x004E4942) + blob
        path.write_bytes(b"glTF" + struct.pack("<II", 2, 12 + len(data)) + data)
        _refused(path, expected)


# --- limits: each refused with one line naming it, before the work ---------------------------------------


def test_limit_nodes_and_depth(tmp_path, monkeypatch):
    doc, blob = gf.sink_parts()
    monkeypatch.setattr(gltf, "MAX_NODES", 5)
    _refused(gf.write_parts(tmp_path / "n.glb", doc, blob), "7 nodes: the limit is 5 (MAX_NODES)")
    monkeypatch.setattr(gltf, "MAX_NODES", 100)
    monkeypatch.setattr(gltf, "MAX_DEPTH", 0)
    _refused(gf.write_parts(tmp_path / "d.glb", doc, blob), "1 levels below a root node", "(MAX_DEPTH)")


def test_limit_buffer_bytes_before_reading(tmp_path, monkeypatch):
    doc, blob = gf.sink_parts()
    path = gf.write_parts(tmp_path / "b.gltf", doc, blob, "external")
    d = json.loads(path.read_text())
    d["buffers"][0]["byteLength"] = 3 << 30  # 3 GiB declared; the file is small
    path.write_text(json.dumps(d))
    opened = _Opened(monkeypatch)
    _refused(path, "buffers[0].byteLength", "(MAX_BUFFER_BYTES)")
    assert not opened.touched(path.with_suffix(".bin"))


def test_limit_accessor_memory_before_allocation(tmp_path, monkeypatch):
    doc, blob = gf.sink_parts()
    path = gf.write_parts(tmp_path / "m.glb", doc, blob)
    monkeypatch.setattr(gltf, "MAX_DECODED_BYTES", 300)
    _refused(path, "(MAX_DECODED_BYTES)")
    # a sparse accessor without a bufferView asks for count x 3 zeros: its count is refused before NumPy is
    doc["accessors"][13]["count"] = 2**33
    monkeypatch.setattr(gltf, "MAX_DECODED_BYTES", 2 << 30)
    _refused(gf.write_parts(tmp_path / "z.glb", doc, blob), "accessors[13].count", "(MAX_ACCESSOR_COUNT)")


def test_limit_accessor_count(tmp_path, monkeypatch):
    doc, blob = gf.sink_parts()
    monkeypatch.setattr(gltf, "MAX_ACCESSOR_COUNT", 7)
    _refused(gf.write_parts(tmp_path / "c.glb", doc, blob), "accessors[0].count", "8 elements", "limit is 7")


@pytest.mark.parametrize("header,kind", [((100_000, 100_000), "png"), ((65_000, 65_000), "jpeg"),
                                         ((8193, 8192), "png")])
def test_limit_texture_pixels_from_the_header(tmp_path, monkeypatch, header, kind):
    image = gf.png_header(*header) if kind == "png" else gf.jpeg_header(*header)
    doc, blob = gf.sink_parts(texture=image)

    def no_decoding(*a, **k):
        raise AssertionError("decoded before the size check")

    monkeypatch.setattr(gltf._Reader, "_decode_pixels", no_decoding)
    msg = _refused(gf.write_parts(tmp_path / "t.glb", doc, blob), "images[0]", f"{header[0]}x{header[1]} pixels",
                   "(MAX_TEXTURE_PIXELS)")
    assert str(gltf.MAX_TEXTURE_PIXELS) in msg


def test_undecodable_texture_is_a_warning_not_an_error(tmp_path):
    doc, blob = gf.sink_parts(texture=b"GIF89a not a png")
    path = gf.write_parts(tmp_path / "t.glb", doc, blob)
    with pytest.warns(gltf.MeshWarning, match="base colour texture 0"):
        asset = gltf.load_asset(path)
    assert asset.meshes[0][0].color == pytest.approx((0.7354, 0.7354, 0.7354), abs=1e-3)


def test_a_broken_png_never_reaches_the_decoder(tmp_path, monkeypatch):
    """libpng prints its errors to stderr, past the one-line error: a PNG whose CRCs, data stream or rows are
    broken is found before decoding, and noted."""
    good = gf.png_bytes(np.full((4, 4, 3), 255, np.uint8))
    flipped = bytearray(good)
    flipped[45] ^= 0x40  # in the IDAT chunk: its CRC no longer matches
    for image in (bytes(flipped), good[:-16]):
        doc, blob = gf.sink_parts(texture=image)

        def no_decoding(*a, **k):
            raise AssertionError("a broken PNG was handed to the decoder")

        monkeypatch.setattr(gltf._Reader, "_decode_pixels", no_decoding)
        gltf._ASSETS.clear()
        with pytest.warns(gltf.MeshWarning, match="base colour texture 0"):
            gltf.load_asset(gf.write_parts(tmp_path / "p.glb", doc, blob))


def test_jpeg_textures_decode_and_a_truncated_one_is_noted(tmp_path):
    import OpenImageIO as oiio

    name = str(tmp_path / "blue.jpg")
    out = oiio.ImageOutput.create(name)
    out.open(name, oiio.ImageSpec(16, 16, 3, oiio.UINT8))
    out.write_image(np.full((16, 16, 3), (0, 0, 255), np.uint8))
    out.close()
    jpeg = Path(name).read_bytes()
    doc, blob = gf.sink_parts(texture=jpeg)
    doc["images"][0]["mimeType"] = "image/jpeg"
    color = _load(gf.write_parts(tmp_path / "j.glb", doc, blob)).meshes[0][0].color
    assert color[2] > 0.7 and color[0] < 0.05  # 0.5 x blue, up to JPEG's rounding
    gltf._ASSETS.clear()
    doc, blob = gf.sink_parts(texture=jpeg[: len(jpeg) // 2])
    doc["images"][0]["mimeType"] = "image/jpeg"
    with pytest.warns(gltf.MeshWarning, match="base colour texture 0"):
        asset = gltf.load_asset(gf.write_parts(tmp_path / "t.glb", doc, blob))
    assert asset.meshes[0][0].color == pytest.approx((0.7354, 0.7354, 0.7354), abs=1e-3)  # the factor alone


def test_limit_image_bytes(tmp_path, monkeypatch):
    doc, blob = gf.sink_parts()
    (tmp_path / "tex.png").write_bytes(gf.png_bytes(np.zeros((64, 64, 3), np.uint8)))
    doc["images"][0] = {"uri": "tex.png"}
    path = gf.write_parts(tmp_path / "i.glb", doc, blob)
    monkeypatch.setattr(gltf, "MAX_IMAGE_BYTES", 50)
    _refused(path, "images[0].uri", "(MAX_IMAGE_BYTES)")


def test_limit_json_size_and_objects(tmp_path, monkeypatch):
    doc, blob = gf.sink_parts()
    path = gf.write_parts(tmp_path / "j.gltf", doc, blob, "data")
    assert _load(path)  # its big data: URI does not count as JSON
    gltf._ASSETS.clear()
    monkeypatch.setattr(gltf, "MAX_JSON_BYTES", len(json.dumps(doc)) + 500)
    assert _load(path)
    gltf._ASSETS.clear()
    doc["extras"] = {"pad": "x" * 1000}
    _refused(gf.write_parts(tmp_path / "k.gltf", doc, blob, "data"), "(MAX_JSON_BYTES)")
    monkeypatch.setattr(gltf, "MAX_JSON_BYTES", 1 << 20)
    monkeypatch.setattr(gltf, "MAX_JSON_OBJECTS", 20)
    _refused(path, "more than 20 objects (MAX_JSON_OBJECTS)")


def test_limit_file_bytes(tmp_path, monkeypatch):
    doc, blob = gf.sink_parts()
    monkeypatch.setattr(gltf, "MAX_FILE_BYTES", 100)
    _refused(gf.write_parts(tmp_path / "f.glb", doc, blob), "(MAX_FILE_BYTES)")


def test_limit_objects_and_triangles(tmp_path, monkeypatch):
    doc, blob = gf.sink_parts()
    path = gf.write_parts(tmp_path / "o.glb", doc, blob)
    monkeypatch.setattr(gltf, "MAX_OBJECTS", 2)
    _refused(path, "3 primitives", "(MAX_OBJECTS)")
    monkeypatch.setattr(gltf, "MAX_OBJECTS", 10)
    monkeypatch.setattr(gltf, "MAX_DRAWN_TRIANGLES", 20)
    _refused(path, "the scene draws 50 triangles", "(MAX_DRAWN_TRIANGLES)")


# --- the hierarchy: linear work, cycles, two parents -------------------------------------------------------


class _CountingChildren(list):
    reads = 0

    def __getitem__(self, i):
        type(self).reads += 1
        return super().__getitem__(i)


@pytest.mark.parametrize("shape", ["chain", "flat", "tree"])
def test_hierarchy_walk_reads_each_node_once(shape):
    n = 100_001
    if shape == "chain":
        children = [[i + 1] for i in range(n - 1)] + [[]]
        roots = [0]
    elif shape == "flat":
        children = [[] for _ in range(n)]
        roots = list(range(n))
    else:  # each node i has children 3i+1..3i+3
        children = [[c for c in (3 * i + 1, 3 * i + 2, 3 * i + 3) if c < n] for i in range(n)]
        roots = [0]
    counted = _CountingChildren(children)
    _CountingChildren.reads = 0
    order, depth = gltf._walk(counted, roots, n, max_depth=n)
    assert len(order) == n and _CountingChildren.reads == n  # each node's children read once: linear
    assert sorted(order) == list(range(n))
    assert max(depth) == {"chain": n - 1, "flat": 0, "tree": 11}[shape]  # 3^0 + ... + 3^10 = 88,573 nodes


def _many_nodes(path: Path, n: int, chain: bool) -> Path:
    doc, blob = gf.sink_parts()
    doc = {k: v for k, v in doc.items() if k not in ("animations", "skins", "cameras")}
    doc["meshes"] = doc["meshes"][:1]
    nodes = [{"name": f"n{i}"} for i in range(n)]
    nodes[0]["mesh"] = 0
    if chain:
        for i in range(n - 1):
            nodes[i]["children"] = [i + 1]
        roots = [0]
    else:
        roots = list(range(n))
    doc["nodes"] = nodes
    doc["scenes"] = [{"nodes": roots}]
    return gf.write_parts(path, doc, blob)


@pytest.mark.slow  # 8.7 s
def test_100001_nodes_load_and_a_100001_chain_is_refused(tmp_path):
    asset = _load(_many_nodes(tmp_path / "flat.glb", 100_001, chain=False))
    assert len(asset.nodes) == 100_001 and len(asset.order) == 100_001 and len(asset.objects) == 1
    world, _ = asset.pose(0.0, None)
    assert world.shape == (100_001, 4, 4) and len(asset.levels) == 1  # one batched level
    _refused(_many_nodes(tmp_path / "chain.glb", 100_001, chain=True), "(MAX_DEPTH)")


def test_cycles_and_shared_children(tmp_path):
    doc, blob = gf.sink_parts()
    cyc = copy.deepcopy(doc)
    cyc["nodes"][0]["children"] = [1]
    cyc["nodes"][1]["children"] = [0]  # 0 -> 1 -> 0, and node 0 is also a scene root
    cyc["scenes"][0]["nodes"] = [2, 4]
    _refused(gf.write_parts(tmp_path / "cycle.glb", cyc, blob), "is in a cycle")
    two = copy.deepcopy(doc)
    two["nodes"][2]["children"] = [3, 1]  # node 1 is already node 0's child
    _refused(gf.write_parts(tmp_path / "two.glb", two, blob), "node 1 is already a child of node 0")
    child_root = copy.deepcopy(doc)
    child_root["scenes"][0]["nodes"].append(1)
    _refused(gf.write_parts(tmp_path / "root.glb", child_root, blob), "a scene lists root nodes")


# --- Hypothesis: mutated files load to finite, in-range arrays or are refused with one line -----------------

_BASE_DOC, _BASE_BLOB = gf.sink_parts()


def _paths(obj, prefix=()):
    """Every (path) to a value in the JSON tree."""
    out = []
    if isinstance(obj, dict):
        for k, v in obj.items():
            out.append((*prefix, k))
            out.extend(_paths(v, (*prefix, k)))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            out.append((*prefix, i))
            out.extend(_paths(v, (*prefix, i)))
    return out


_JSON_PATHS = [p for p in _paths(_BASE_DOC) if not (p[0] == "buffers" and p[-1] == "uri")]

_values = st.one_of(
    st.integers(-3, 20), st.sampled_from([255, 256, 65535, 65536, 2**31, 2**32, 2**63, -(2**31), 5120, 5121, 5122,
                                          5123, 5124, 5125, 5126, 34962, 34963]),
    st.floats(allow_nan=False, allow_infinity=False, width=32), st.sampled_from([0.0, -0.0, 1e38, -1e38, 3.2, 1e-40]),
    st.sampled_from(["SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4", "LINEAR", "STEP", "CUBICSPLINE",
                     "translation", "rotation", "scale", "weights", "image/png", "", "..", "../x.bin", "/etc/passwd",
                     "%2e%2e/x", "data:,", "data:application/octet-stream;base64,AAAA", "perspective",
                     "orthographic"]),
    st.none(), st.booleans(), st.builds(list), st.builds(dict), st.lists(st.integers(-2, 12), max_size=5),
    st.lists(st.floats(-2, 2, width=32), min_size=3, max_size=4))


@st.composite
def _json_mutation(draw, base=None, paths=None):
    """1-3 values of the document (`base`, default the sink file's) changed or deleted at its JSON `paths`."""
    doc = copy.deepcopy(_BASE_DOC if base is None else base)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(_JSON_PATHS if paths is None else paths))
        obj = doc
        try:
            for p in path[:-1]:
                obj = obj[p]
            if draw(st.integers(0, 5)) == 0 and isinstance(obj, dict):
                del obj[path[-1]]
            else:
                obj[path[-1]] = draw(_values)
        except (KeyError, IndexError, TypeError):
            pass  # an earlier mutation changed the tree under this path
    return doc


@st.composite
def _blob_mutation(draw, base=None):
    blob = bytearray(_BASE_BLOB if base is None else base)
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(blob) - 4))
        kind = draw(st.integers(0, 3))
        if kind == 0:
            blob[at:at + 4] = struct.pack("<f", draw(st.sampled_from([math.nan, math.inf, -math.inf, 1e38, -1e38])))
        elif kind == 1:
            blob[at:at + 2] = struct.pack("<H", draw(st.integers(0, 65535)))
        elif kind == 2:
            blob[at] = draw(st.integers(0, 255))
        else:
            blob[at:at + 4] = struct.pack("<I", draw(st.integers(0, 2**32 - 1)))
    return bytes(blob)


@st.composite
def _glb_mutation(draw):
    data = bytearray(gf.glb_bytes(_BASE_DOC, _BASE_BLOB))
    jlen = struct.unpack_from("<I", data, 12)[0]
    fields = {"version": 4, "length": 8, "json_len": 12, "json_type": 16, "bin_len": 20 + jlen, "bin_type": 24 + jlen}
    for _ in range(draw(st.integers(1, 2))):
        which = draw(st.sampled_from([*fields, "truncate", "append", "byte"]))
        if which == "truncate":
            if data:
                del data[draw(st.integers(0, len(data) - 1)):]
        elif which == "append":
            data += draw(st.binary(min_size=1, max_size=12))
        elif which == "byte":
            if data:
                data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
        elif fields[which] + 4 <= len(data):
            value = draw(st.one_of(st.integers(0, 8), st.sampled_from([len(data), len(data) - 4, len(data) + 4, jlen,
                                                                      jlen + 1, 0x4E4F534A, 0x004E4942, 2**32 - 1])))
            struct.pack_into("<I", data, fields[which], value)
    return bytes(data)


def _check_loads_sanely_or_refuses(path: Path) -> None:
    """The property: a MeshError of one line, or an asset whose arrays are finite and whose indices are in
    range; any other exception fails the test."""
    gltf._ASSETS.clear()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            asset = gltf.load_asset(path)
    except SketchgraphError as exc:
        assert "\n" not in str(exc) and str(exc).strip(), repr(exc)
        return
    for mesh in asset.meshes:
        for prim in mesh:
            n = len(prim.positions)
            assert np.all(np.isfinite(prim.positions))
            assert prim.faces.size == 0 or (prim.faces.min() >= 0 and prim.faces.max() < n)
            if prim.joints is not None:
                assert np.all(np.isfinite(prim.weights)) and prim.joints.min() >= 0
            if prim.targets is not None:
                assert prim.targets.shape[1:] == (n, 3) and np.all(np.isfinite(prim.targets))
    anims = [None, *asset.animations]
    for anim in anims:
        for t in (0.0, 0.5, 1.0):
            world, weights = asset.pose(t, anim)
            assert np.all(np.isfinite(world))
            inst = gltf.GltfInstance(asset, np.eye(4), anim)
            for _, mesh, matrix, color in inst.objects_at(t):
                assert np.all(np.isfinite(mesh.vertices)) and np.all(np.isfinite(matrix))
                assert all(0.0 <= c <= 1.0 for c in color)
    for cam in asset.cameras:
        if cam.kind == "perspective":
            assert 0 < cam.yfov < math.pi and cam.znear > 0 and (cam.zfar is None or cam.zfar > cam.znear)


_FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@pytest.mark.slow  # Hypothesis, 2.4 s
@_FUZZ
@given(doc=_json_mutation(), how=st.sampled_from(["glb", "data"]))
def test_fuzz_json(doc, how):
    buffers = doc.get("buffers")
    if not (isinstance(buffers, list) and buffers and isinstance(buffers[0], dict)):
        how = "glb"  # no buffer 0 to hold the data: URI
    with tempfile.TemporaryDirectory() as tmp:
        path = gf.write_parts(Path(tmp) / ("f.glb" if how == "glb" else "f.gltf"), doc, _BASE_BLOB, how)
        _check_loads_sanely_or_refuses(path)


@pytest.mark.slow  # Hypothesis, 2.4 s
@_FUZZ
@given(blob=_blob_mutation())
def test_fuzz_buffer_bytes(blob):
    with tempfile.TemporaryDirectory() as tmp:
        _check_loads_sanely_or_refuses(gf.write_parts(Path(tmp) / "f.glb", _BASE_DOC, blob))


@pytest.mark.slow  # Hypothesis, 1.7 s
@_FUZZ
@given(data=_glb_mutation())
def test_fuzz_glb_container(data):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "f.glb"
        path.write_bytes(data)
        _check_loads_sanely_or_refuses(path)


@pytest.mark.slow
@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(doc=_json_mutation(), blob=_blob_mutation())
def test_fuzz_json_and_bytes_together(doc, blob):
    with tempfile.TemporaryDirectory() as tmp:
        _check_loads_sanely_or_refuses(gf.write_parts(Path(tmp) / "f.glb", doc, blob))


def test_the_command_line_option_lets_a_trusted_file_read_outside(tmp_path):
    """--allow-outside-scene-dir: without it the run is one line naming the URI; with it the file renders."""
    import subprocess
    import sys

    scene_dir = tmp_path / "scene"
    scene_dir.mkdir()
    doc, blob = gf.sink_parts()
    (tmp_path / "shared.bin").write_bytes(blob)
    path = _scene_with_uri(scene_dir, "buffer", "../shared.bin", "gltf")
    base = [sys.executable, "-m", "nodegraph.cli", "run", "nienhaus_sketchy", "--scene", str(path), "--size", "48x40",
            "--no-cache"]
    refused = subprocess.run([*base, "-o", str(tmp_path / "a.png")], capture_output=True, text=True, timeout=300)
    assert refused.returncode == 2 and "buffers[0].uri" in refused.stderr
    assert "--allow-outside-scene-dir" in refused.stderr
    assert len([ln for ln in refused.stderr.splitlines() if ln.strip()]) == 1, refused.stderr
    assert not (tmp_path / "a.png").exists()
    ok = subprocess.run([*base, "--allow-outside-scene-dir", "-o", str(tmp_path / "b.png")], capture_output=True,
                        text=True, timeout=300)
    assert ok.returncode == 0, ok.stderr
    assert (tmp_path / "b.png").stat().st_size > 0


_DRACO_STREAM = None


@pytest.mark.slow  # Hypothesis, about 1 s
@_FUZZ
@given(edits=st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 255)), min_size=1, max_size=8),
       cut=st.one_of(st.none(), st.integers(0, 10_000)))
def test_fuzz_draco_stream(edits, cut):
    """A Draco stream with bytes changed or cut short: decoded into sane arrays or refused in one line (the
    decoder is Google's, through DracoPy; its counts are checked against the accessors before use)."""
    global _DRACO_STREAM
    with tempfile.TemporaryDirectory() as tmp:
        if _DRACO_STREAM is None:
            path, *_ = gf.draco_box(Path(tmp) / "good.glb")
            _DRACO_STREAM = gltf._Reader(path).buffer(0)
        stream = bytearray(_DRACO_STREAM)
        for at, value in edits:
            stream[at % len(stream)] = value
        if cut is not None:
            stream = stream[: cut % (len(stream) + 1)]
        path, *_ = gf.draco_box(Path(tmp) / "f.glb", stream=bytes(stream) or b"\0")
        _check_loads_sanely_or_refuses(path)


# the extensions read beyond the core (instancing, visibility, Draco, WebP, animation pointers), mutated likewise
_EXT_DOC, _EXT_BLOB = gf.extension_parts()
_EXT_PATHS = [p for p in _paths(_EXT_DOC) if not (p[0] == "buffers" and p[-1] == "uri")]


def test_the_extensions_file_loads_as_built(tmp_path):
    """The base of the two tests below: every extension in it is read (no warning) and does what it says."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        asset = gltf.load_asset(gf.write_parts(tmp_path / "ext.glb", _EXT_DOC, _EXT_BLOB))
    assert [o.name for o in asset.objects] == ["instanced[0]", "instanced[1]", "instanced[2]", "draco"]
    assert [p[0] for p in asset.animations[0].props] == [("camera", 0, "yfov"), ("light", 0, "intensity")]
    assert asset.meshes[1][0].surface.material.texture.pixels[0, 0].tolist() == [0, 0, 255, 255]  # the WebP's


@pytest.mark.slow  # Hypothesis, about 3 s
@_FUZZ
@given(doc=_json_mutation(_EXT_DOC, _EXT_PATHS), how=st.sampled_from(["glb", "data"]))
def test_fuzz_extensions_json(doc, how):
    buffers = doc.get("buffers")
    if not (isinstance(buffers, list) and buffers and isinstance(buffers[0], dict)):
        how = "glb"
    with tempfile.TemporaryDirectory() as tmp:
        path = gf.write_parts(Path(tmp) / ("f.glb" if how == "glb" else "f.gltf"), doc, _EXT_BLOB, how)
        _check_loads_sanely_or_refuses(path)


@pytest.mark.slow  # Hypothesis, about 2 s
@_FUZZ
@given(blob=_blob_mutation(_EXT_BLOB))
def test_fuzz_extensions_bytes(blob):
    with tempfile.TemporaryDirectory() as tmp:
        _check_loads_sanely_or_refuses(gf.write_parts(Path(tmp) / "f.glb", _EXT_DOC, blob))
