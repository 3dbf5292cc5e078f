"""glTF files that are valid (the Khronos validator reports no error in them) are read, not refused: bounds
written in float32's shortest digits, WebP textures (EXT_texture_webp), extensions on a primitive that the file
does not require, a GLB binary chunk longer than its buffer, a buffer without data that nothing reads. Each was
found refused by running the validator's own test files and real exporters' files through the reader; the files
here are built in code (tests/gltf_files.py)."""

from __future__ import annotations

import copy
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest

from nodegraph.errors import MeshError
from nodegraph.scene import gltf, info
from tests import gltf_files as gf


@pytest.fixture(autouse=True)
def _fresh_cache():
    gltf._ASSETS.clear()
    yield
    gltf._ASSETS.clear()


def _load(path: Path) -> gltf.GltfAsset:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gltf.load_asset(path)


def _faces(asset: gltf.GltfAsset) -> list[list[list[int]]]:
    return [[p.faces.tolist() for p in prims] for prims in asset.meshes]


# --- bounds -----------------------------------------------------------------------------------------------


def _quad_with_bounds(path: Path, lo: list[float], hi: list[float]) -> Path:
    """A triangle whose POSITION holds float32 0.1, 0.3 and 0.7, with the declared min and max written as given."""
    doc, blob = gf.sink_parts()
    pos = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.3, 0.7]], np.float32)
    doc["accessors"][0].update(min=lo, max=hi)
    view = doc["bufferViews"][doc["accessors"][0]["bufferView"]]
    blob = bytearray(blob)
    blob[view["byteOffset"]:view["byteOffset"] + pos.nbytes] = pos.tobytes()
    doc["accessors"][0]["count"] = 3
    doc["accessors"][1]["count"] = 3  # the box's indices: its first triangle only (0, 1, 3)
    doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"]]["count"] = 3
    blob[doc["bufferViews"][1]["byteOffset"] + 2 * 2:doc["bufferViews"][1]["byteOffset"] + 2 * 3] = \
        struct.pack("<H", 2)
    return gf.write_parts(path, doc, bytes(blob))


@pytest.mark.parametrize("digits", ["shortest", "%.9g", "exact"])
def test_bounds_in_float32s_own_digits_are_the_data(tmp_path, digits):
    """A writer that prints float32 0.1 as 0.1 (its shortest digits: Rust's serde, C++'s to_chars(float)) or with 9
    significant digits declares the float32 value, as the validator reads it; its float64 reading differs."""
    data_max = np.array([0.1, 0.3, 0.7], np.float32)
    hi = {"shortest": [0.1, 0.3, 0.7], "%.9g": [float(f"{v:.9g}") for v in data_max],
          "exact": [float(v) for v in data_max]}[digits]
    asset = _load(_quad_with_bounds(tmp_path / "b.glb", [0, 0, 0], hi))
    assert asset.meshes[0][0].positions[1] == pytest.approx([np.float32(0.1), 0, 0])


def test_bounds_one_float32_step_off_are_refused(tmp_path):
    off = float(np.nextafter(np.float32(0.3), np.float32(1)))
    with pytest.raises(MeshError, match=f"accessor 0 declares max {off!r} for component 1; its data has "
                       "0.30000001192092896"):
        _load(_quad_with_bounds(tmp_path / "b.glb", [0, 0, 0], [0.1, off, 0.7]))
    gltf._ASSETS.clear()
    with pytest.raises(MeshError, match="declares min -1e-07 for component 0"):
        _load(_quad_with_bounds(tmp_path / "c.glb", [-1e-7, 0, 0], [0.1, 0.3, 0.7]))


# --- WebP -------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("lossless,channels,chunk", [(True, 3, b"VP8L"), (False, 3, b"VP8 "), (False, 4, b"VP8X"),
                                                     (True, 4, b"VP8L")])
def test_webp_size_from_each_kind_of_header(lossless, channels, chunk):
    rgb = np.random.default_rng(3).integers(0, 256, (17, 301, channels), dtype=np.uint8)
    data = gf.webp_bytes(rgb, lossless=lossless)
    assert data[12:16] == chunk
    assert gltf._image_size(data) == ("webp", 301, 17)
    assert gltf._image_size(data[:24]) == ("webp", 0, 0)  # cut inside the size fields: broken, not a guess


def test_webp_texture_in_a_data_uri_gives_the_mean_colour(tmp_path):
    blue = gf.webp_bytes(np.full((8, 8, 3), (0, 0, 255), np.uint8))
    doc, blob = gf.sink_parts(texture=blue)
    doc["images"][0]["mimeType"] = "image/webp"
    color = _load(gf.write_parts(tmp_path / "w.gltf", doc, blob, "data")).meshes[0][0].color
    assert color == pytest.approx((0.0, 0.0, 0.7354), abs=1e-3)  # the factor 0.5 times blue, as display values


def test_a_broken_webp_is_noted_and_its_factor_drawn(tmp_path):
    good = gf.webp_bytes(np.full((8, 8, 3), (0, 0, 255), np.uint8))
    for i, image in enumerate((good[: len(good) // 2], good[:30] + b"\xff" * (len(good) - 30))):
        doc, blob = gf.sink_parts(texture=image)
        doc["images"][0]["mimeType"] = "image/webp"
        gltf._ASSETS.clear()
        with pytest.warns(gltf.MeshWarning, match="base colour texture 0"):
            asset = gltf.load_asset(gf.write_parts(tmp_path / f"w{i}.glb", doc, blob))
        assert asset.meshes[0][0].color == pytest.approx((0.7354, 0.7354, 0.7354), abs=1e-3)


def test_a_webp_header_over_the_pixel_limit_is_refused_before_decoding(tmp_path, monkeypatch):
    canvas = b"VP8X" + struct.pack("<I", 10) + b"\0\0\0\0" + (20_000 - 1).to_bytes(3, "little") * 2
    bomb = b"RIFF" + struct.pack("<I", 4 + len(canvas)) + b"WEBP" + canvas
    doc, blob = gf.sink_parts(texture=bomb)
    doc["images"][0]["mimeType"] = "image/webp"

    def no_decoding(*a, **k):
        raise AssertionError("an image over the limit was handed to the decoder")

    monkeypatch.setattr(gltf._Reader, "_decode_pixels", no_decoding)
    with pytest.raises(MeshError, match="20000x20000 pixels: the limit is"):
        _load(gf.write_parts(tmp_path / "bomb.glb", doc, blob))


# --- extensions on a primitive ----------------------------------------------------------------------------


def test_an_extension_the_file_does_not_require_leaves_the_primitive_drawn(tmp_path):
    doc, blob = gf.sink_parts()
    plain = _faces(_load(gf.write_parts(tmp_path / "plain.glb", doc, blob)))
    doc = copy.deepcopy(doc)
    doc["meshes"][0]["primitives"][0]["extensions"] = {"EXT_mesh_features": {"featureIds": [{"featureCount": 1}]}}
    doc["extensionsUsed"] = ["EXT_mesh_features"]
    with pytest.warns(gltf.MeshWarning, match="extension EXT_mesh_features") as caught:
        asset = gltf.load_asset(gf.write_parts(tmp_path / "features.glb", doc, blob))
    assert "compressed" not in str(caught[0].message)
    assert _faces(asset) == plain


def test_draco_is_read_from_its_uncompressed_copy(tmp_path):
    """KHR_draco_mesh_compression not required, with the primitive's own accessors holding an uncompressed copy:
    the copy is read (here the stream's bufferView is not even a Draco stream)."""
    doc, blob = gf.sink_parts()
    plain = _faces(_load(gf.write_parts(tmp_path / "plain.glb", doc, blob)))
    doc = copy.deepcopy(doc)
    doc["meshes"][0]["primitives"][0]["extensions"] = {
        "KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}}
    doc["extensionsUsed"] = ["KHR_draco_mesh_compression"]
    assert _faces(_load(gf.write_parts(tmp_path / "copy.glb", doc, blob))) == plain
    assert "left_out" not in info.info(tmp_path / "copy.glb")["meshes"][0]


@pytest.mark.parametrize("name,required", [("box.glb", True), ("box.gltf", False)])
def test_a_draco_stream_is_decoded(tmp_path, name, required):
    """A primitive whose positions, texture coordinates and indices are only in its Draco stream: decoded (the
    file may require the extension), vertex for vertex what DracoPy decodes and within the 14-bit quantization of
    the box it encoded; its texture coordinates reach the surface."""
    path, points, faces = gf.draco_box(tmp_path / name, required=required)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # read, not noted as left out
        asset = gltf.load_asset(path)
    prim = asset.meshes[0][0]
    assert np.array_equal(prim.positions, points) and np.array_equal(prim.faces, faces)
    assert np.abs(prim.positions - gf.BOX_V).max() < 1.0 / (1 << 13)
    assert prim.faces.tolist() == gf.BOX_F.tolist()  # order kept
    assert info.extension_does("KHR_draco_mesh_compression")["does"] == "used"


def test_a_broken_draco_stream_is_one_line(tmp_path):
    cases = {"garbage": b"DRACO" + b"\x00" * 40, "not_draco": b"\x89PNG" + b"\x00" * 60}
    for label, stream in cases.items():
        bad, *_ = gf.draco_box(tmp_path / f"{label}.glb", stream=stream)
        gltf._ASSETS.clear()
        with pytest.raises(MeshError, match=r"KHR_draco_mesh_compression: its Draco stream does not decode") as err:
            _load(bad)
        assert "\n" not in str(err.value)
    import DracoPy

    other = DracoPy.encode(gf.BOX_V[:6], np.array([[0, 1, 2], [3, 4, 5]], np.uint32), preserve_order=True)
    bad, *_ = gf.draco_box(tmp_path / "other.glb", stream=other)  # a stream of another mesh: 6 vertices, no uv
    with pytest.raises(MeshError, match="holds .*; accessor 0 declares 8 x 3|Draco attribute"):
        _load(bad)


# --- buffers ----------------------------------------------------------------------------------------------


def test_a_glb_binary_chunk_longer_than_its_buffer_is_read(tmp_path):
    doc, blob = gf.sink_parts()
    plain = _faces(_load(gf.write_parts(tmp_path / "plain.glb", doc, blob)))
    longer = tmp_path / "longer.glb"
    longer.write_bytes(gf.glb_bytes(doc, blob + b"\0" * 16))  # byteLength stays len(blob)
    assert _faces(_load(longer)) == plain


def test_a_buffer_without_data_is_refused_only_where_read(tmp_path):
    doc, blob = gf.sink_parts()
    doc = copy.deepcopy(doc)
    doc["buffers"].append({"byteLength": 64})  # no uri, not the GLB chunk: a placeholder nothing reads
    assert len(_load(gf.write_parts(tmp_path / "spare.gltf", doc, blob, "data")).objects) == 3
    gltf._ASSETS.clear()
    doc["buffers"][1]["byteLength"] = 96
    doc["bufferViews"].append({"buffer": 1, "byteLength": 96})
    doc["accessors"][0]["bufferView"] = len(doc["bufferViews"]) - 1  # the box's positions (8 x 12 bytes) in it
    with pytest.raises(MeshError, match=r"buffers\[1\]: has no uri and is not the GLB binary chunk") as err:
        _load(gf.write_parts(tmp_path / "read.gltf", doc, blob, "data"))
    assert "\n" not in str(err.value)


def test_an_index_accessor_without_a_buffer_view_is_zeros(tmp_path):
    """The spec's accessor without a bufferView holds zeros: as indices, degenerate triangles, left out."""
    doc, blob = gf.sink_parts()
    doc = copy.deepcopy(doc)
    del doc["accessors"][1]["bufferView"]
    doc["accessors"][1].pop("byteOffset", None)
    asset = _load(gf.write_parts(tmp_path / "zeros.glb", doc, blob))
    assert asset.meshes[0][0].faces.shape == (0, 3) and len(asset.meshes[1][0].faces) > 0

