"""Broken mesh files and scene values: one line each, never a hang, never the file's contents."""

from __future__ import annotations

import os
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest

from nodegraph.errors import MeshError, PipelineError
from nodegraph.scene.meshes import MeshWarning, clear_mesh_cache, load_mesh
from tests.nodegraph.faultkit import assert_one_line_error, cli, cli_subprocess, tiny_pipeline

SECRET = "do-not-echo-this-secret"
TRI = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]


def binary_stl(tris: list, header: bytes = b"binary", count: int | None = None) -> bytes:
    out = header.ljust(80, b" ")[:80] + struct.pack("<I", len(tris) if count is None else count)
    for t in tris:
        out += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *v) for v in t) + b"\0\0"
    return out


def ply(n_vertex: object, n_face: object, body: bytes, fmt: str = "binary_little_endian") -> bytes:
    head = (f"ply\nformat {fmt} 1.0\nelement vertex {n_vertex}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {n_face}\nproperty list uchar int vertex_indices\nend_header\n")
    return head.encode() + body


PLY_BODY = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<B3i", 3, 0, 1, 2)


def _load_error(path: Path) -> str:
    clear_mesh_cache()
    with pytest.raises(MeshError) as info:
        load_mesh(path)
    msg = str(info.value)
    assert "\n" not in msg and SECRET not in msg and len(msg) < 600
    return msg


def test_binary_stl_with_solid_header_loads(tmp_path: Path) -> None:
    p = tmp_path / "a.stl"
    p.write_bytes(binary_stl([TRI, TRI[::-1]], header=b"solid exported by a CAD tool"))
    assert load_mesh(p).n_faces >= 1


@pytest.mark.slow  # 2.5 s: a CLI process
def test_solid_header_then_binary_garbage_is_refused_not_looped(tmp_path: Path) -> None:
    p = tmp_path / "b.stl"
    p.write_bytes(b"solid x\n" + bytes(np.random.default_rng(0).integers(0, 256, 400, dtype=np.uint8)))
    msg = _load_error(p)
    assert "starts like ASCII STL ('solid') but holds binary data" in msg
    # and through the CLI as a real process, with a timeout: libigl used to loop here forever
    out = cli_subprocess("run", tiny_pipeline(tmp_path), "--scene", p, "-o", tmp_path / "o.png", timeout=60)
    assert_one_line_error(out, "holds binary data")


def test_binary_stl_with_wrong_triangle_count(tmp_path: Path) -> None:
    p = tmp_path / "c.stl"
    p.write_bytes(binary_stl([TRI] * 3, count=4_000_000_000))
    msg = _load_error(p)
    assert "declares 4000000000 triangles, so expected 84 + 50 x 4000000000 = 200000000084 bytes, found 234" in msg


def test_ascii_stl_still_loads(tmp_path: Path) -> None:
    p = tmp_path / "d.stl"
    p.write_text("solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                 "endloop\nendfacet\nendsolid t\n")
    assert load_mesh(p).n_faces == 1


@pytest.mark.parametrize("n_vertex,n_face,needle", [
    (10**11, 1, "header declares 100000000000 'vertex' rows"),
    (3, 4_000_000_000, "header declares 4000000000 'face' rows"),
    ("abc", 1, "expected a count of 0 to 10^12 rows, found 'abc'"),
    ("-5", 1, "found '-5'"),
])
def test_ply_garbage_counts_refused_before_allocating(tmp_path: Path, n_vertex: object, n_face: object,
                                                      needle: str) -> None:
    p = tmp_path / "e.ply"
    p.write_bytes(ply(n_vertex, n_face, PLY_BODY))
    assert needle in _load_error(p)


def test_ply_ascii_garbage_count(tmp_path: Path) -> None:
    p = tmp_path / "f.ply"
    p.write_bytes(ply(10**9, 1, b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", fmt="ascii"))
    assert "header declares 1000000000 'vertex' rows" in _load_error(p)


def test_ply_valid_still_loads(tmp_path: Path) -> None:
    p = tmp_path / "g.ply"
    p.write_bytes(ply(3, 1, PLY_BODY))
    assert load_mesh(p).n_faces == 1


@pytest.mark.parametrize("coord,needle", [
    ("1e39", "beyond float32 range"),
    ("1e300", "beyond float32 range"),
    ("nan", "NaN/Inf"),
    ("inf", "NaN/Inf"),
])
def test_obj_coordinates_the_gpu_cannot_hold(tmp_path: Path, coord: str, needle: str) -> None:
    p = tmp_path / "h.obj"
    p.write_text(f"v {coord} 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert needle in _load_error(p)


def test_coordinates_so_far_out_that_float64_loses_the_shape(tmp_path: Path) -> None:
    p = tmp_path / "far.obj"
    p.write_text("v 1e20 0 0\nv 1e20 1e7 0\nv 1e20 0 1e7\nf 1 2 3\n")  # 1e7 across at 1e20
    assert "even float64 keeps too few digits of its shape" in _load_error(p)


def test_far_from_the_origin_for_its_size_loads(tmp_path: Path) -> None:
    """Drawn relative to its own centre (nodegraph/scene/origin.py), a mesh is not limited by float32 where it lies:
    0.1 across at 1e6 (refused before, as 2^20 times its size), and 1e23 across at 1e30, load."""
    p = tmp_path / "far.obj"
    p.write_text("v 1000000 0 0\nv 1000000.1 0 0\nv 1000000 0.1 0\nf 1 2 3\n")
    m = load_mesh(p)
    assert m.vertices[1, 0] == 1000000.1  # read as float64, every digit
    q = tmp_path / "huge.obj"
    q.write_text("v 1e30 0 0\nv 1.0000001e30 0 0\nv 1e30 1e23 0\nf 1 2 3\n")
    assert load_mesh(q).n_faces == 1


def test_far_but_fine_mesh_loads(tmp_path: Path) -> None:
    p = tmp_path / "ok.obj"
    p.write_text("v 1000 0 0\nv 1001 0 0\nv 1000 1 0\nf 1 2 3\n")
    assert load_mesh(p).n_faces == 1


def test_text_file_as_obj_never_echoes_it(tmp_path: Path) -> None:
    p = tmp_path / "notes.obj"
    p.write_text(f"{SECRET} line\n" * 5000)
    _load_error(p)
    out = cli("run", tiny_pipeline(tmp_path), "--scene", p, "-o", tmp_path / "o.png")
    line = assert_one_line_error(out, "no vertices could be read")
    assert SECRET not in out.stderr + out.stdout and len(line) < 400


def test_reader_warnings_are_summarised_not_echoed(tmp_path: Path) -> None:
    p = tmp_path / "mixed.obj"
    p.write_text(f"{SECRET}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    clear_mesh_cache()
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        mesh = load_mesh(p)
    assert mesh.n_faces == 1
    texts = [str(w.message) for w in rec if issubclass(w.category, MeshWarning)]
    assert texts and all(SECRET not in t for t in texts)


@pytest.mark.parametrize("kind", ["dev_zero", "fifo", "dir", "long", "missing"])
def test_non_regular_mesh_and_scene_inputs(tmp_path: Path, kind: str) -> None:
    for ext in (".obj", ".yaml"):
        p = tmp_path / f"in{ext}"
        if kind == "dev_zero":
            p.symlink_to("/dev/zero")
        elif kind == "fifo":
            os.mkfifo(p)
        elif kind == "dir":
            p.mkdir()
        elif kind == "long":
            p = tmp_path / ("z" * 3000 + ext)
        out = cli("run", tiny_pipeline(tmp_path), "--scene", p, "-o", tmp_path / "o.png")
        line = assert_one_line_error(out)
        assert len(line) < 500
        want = {"dev_zero": "character device", "fifo": "FIFO", "dir": "folder", "long": "File name too long",
                "missing": "not found"}[kind]
        assert want in line


def test_scene_object_mesh_that_is_dev_zero(tmp_path: Path) -> None:
    (tmp_path / "zero.obj").symlink_to("/dev/zero")
    scene = tmp_path / "s.yaml"
    scene.write_text("objects:\n  - mesh: zero.obj\n")
    out = cli("run", tiny_pipeline(tmp_path, scene="s.yaml"), "-o", tmp_path / "o.png")
    assert_one_line_error(out, f"{scene}:2:11:", "character device")


@pytest.mark.parametrize("field,value", [
    ("rotate", "[0, .nan, 0]"), ("translate", "[.inf, 0, 0]"), ("scale", "-.inf"), ("scale", "[1, .nan, 1]"),
    ("translate", "[1e400, 0, 0]"),
])
def test_scene_transform_must_be_finite(tmp_path: Path, field: str, value: str) -> None:
    scene = tmp_path / "s.yaml"
    scene.write_text(f"objects:\n  - primitive: {{type: box}}\n    transform: {{{field}: {value}}}\n")
    from nodegraph.scene.scene import scene_from_yaml

    with pytest.raises(PipelineError) as info:
        scene_from_yaml(scene)
    msg = str(info.value)
    assert msg.startswith(f"{scene}:3:") and f"transform.{field}" in msg
    assert "finite" in msg or "positive" in msg


def test_camera_values_must_be_finite(tmp_path: Path) -> None:
    scene = tmp_path / "s.yaml"
    scene.write_text("objects:\n  - primitive: {type: box}\ncamera: {eye: [0, 0, 5], target: [0, 0, 0], "
                     "far: .inf}\n")
    out = cli("run", tiny_pipeline(tmp_path, scene="s.yaml"), "-o", tmp_path / "o.png")
    assert_one_line_error(out, "camera.far", "finite")


def test_ply_triangle_strips_are_read(tmp_path: Path) -> None:
    """A 'tristrips' element (vertex_indices, -1 restarts a strip) gives triangles of one winding; joins with a
    repeated index are left out; a PLY of vertices alone says it is a point cloud."""
    grid = "".join(f"{x} {y} 0\n" for y in range(2) for x in range(4))  # 0..3 along the bottom, 4..7 above
    p = tmp_path / "strip.ply"
    p.write_text("ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
                 "element tristrips 1\nproperty list int int vertex_indices\nend_header\n" + grid
                 + "9 4 0 5 1 -1 6 2 7 3\n")
    m = load_mesh(p)
    assert m.n_faces == 4  # two strips of two triangles
    normals = m.face_normals()
    assert np.allclose(normals[:, 2], normals[0, 2]) and abs(normals[0, 2]) == pytest.approx(1.0)
    cloud = tmp_path / "cloud.ply"
    cloud.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "end_header\n0 0 0\n1 0 0\n0 1 0\n")
    with pytest.raises(MeshError, match="no faces: 3 vertices and no 'face' or 'tristrips' element"):
        load_mesh(cloud)
