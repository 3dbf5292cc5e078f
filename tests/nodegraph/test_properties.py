"""Property-based proof of the one-line error contract (Hypothesis, derandomised and bounded).

Generated inputs: mutations of the shipped pipelines (keys dropped or renamed, values of the wrong type,
random bytes, deep nesting, aliases), --set params, --size, --frames, and mesh files (valid and broken
OBJ, PLY, STL and OFF bytes). Every run of the CLI must end with exit status 0 and an image (valid input)
or exit status 2 and exactly one `error:` line on stderr (bad input); never a traceback, never a hang.

Set SKETCHGRAPH_PROPERTY_STATS=FILE to append the figures (inputs tried, outcomes) as JSON lines.
"""

from __future__ import annotations

import json
import os
import struct
import time
import tracemalloc
from collections import Counter
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from tests.nodegraph.faultkit import ROOT, assert_one_line_error, cli, cli_subprocess, tiny_pipeline

pytestmark = pytest.mark.slow  # about 20 s: Hypothesis runs the CLI and the mesh readers hundreds of times

SHIPPED = sorted((ROOT / "pipelines").glob("*.yaml"))
SETTINGS = dict(derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
STATS: dict[str, Counter] = {}


def _record(prop: str, outcome: str) -> None:
    STATS.setdefault(prop, Counter())[outcome] += 1


@pytest.fixture(scope="module", autouse=True)
def _write_stats():
    yield
    target = os.environ.get("SKETCHGRAPH_PROPERTY_STATS")
    if target:
        with open(target, "a") as fh:
            for prop, counts in STATS.items():
                fh.write(json.dumps({"property": prop, "tried": sum(counts.values()), **counts}) + "\n")


def _check(out, prop: str, image: Path | None = None) -> str:
    """Exit 0 with the image written, or the one-line error contract; returns and records which."""
    assert out.exception is None, f"uncaught {type(out.exception).__name__}: {out.exception}"
    assert "Traceback" not in out.stderr + out.stdout
    if out.code == 0:
        if image is not None:
            assert image.exists() and image.stat().st_size > 0
        _record(prop, "ok")
        return "ok"
    assert_one_line_error(out)
    _record(prop, "error")
    return "error"


# -- pipelines: mutations of the shipped files -------------------------------------------------------------

def _load_plain(p: Path) -> dict:
    return yaml.safe_load(p.read_text())


WRONG = st.one_of(st.none(), st.booleans(), st.integers(-10**30, 10**30), st.floats(allow_nan=True),
                  st.text(max_size=20), st.lists(st.integers(), max_size=3),
                  st.dictionaries(st.text(max_size=5), st.integers(), max_size=2))


@st.composite
def mutated_pipeline(draw: st.DrawFn) -> str:
    src = draw(st.sampled_from(SHIPPED))
    doc = _load_plain(src)
    doc["size"] = [16, 16]  # keep the valid ones cheap
    kind = draw(st.sampled_from(["drop", "rename", "wrong_type", "param", "bytes", "deep", "alias", "none"]))
    paths: list[tuple] = []

    def walk(node, path):
        if isinstance(node, dict):
            for k, v in node.items():
                paths.append((*path, k))
                walk(v, (*path, k))

    walk(doc, ())
    if kind in ("drop", "rename", "wrong_type") and paths:
        path = draw(st.sampled_from(paths))
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        if kind == "drop":
            del parent[path[-1]]
        elif kind == "rename":
            parent[str(path[-1]) + draw(st.sampled_from(["_", "x", "s"]))] = parent.pop(path[-1])
        else:
            parent[path[-1]] = draw(WRONG)
    elif kind == "param":
        nid = draw(st.sampled_from(sorted(doc["nodes"])))
        doc["nodes"][nid].setdefault("params", {})[draw(st.sampled_from(["scale", "octaves", "width", "x"]))] = \
            draw(WRONG)
    text = yaml.safe_dump(doc, sort_keys=False)
    if kind == "bytes":
        raw = bytearray(text.encode())
        for _ in range(draw(st.integers(1, 8))):
            raw.insert(draw(st.integers(0, len(raw))), draw(st.integers(0, 255)))
        return raw.decode("latin-1")  # written back as bytes below
    if kind == "deep":
        depth = draw(st.integers(10, 3000))
        text += "doc: " + "[" * depth + "]" * depth + "\n"
    if kind == "alias":
        width, levels = draw(st.integers(2, 10)), draw(st.integers(1, 9))
        text = text.replace("seed:", "x0: &a0 [1, 2]\n" + "".join(
            f"x{i}: &a{i} [{', '.join([f'*a{i - 1}'] * width)}]\n" for i in range(1, levels)) + "seed:", 1)
    return text


@settings(max_examples=150, **SETTINGS)
@given(text=mutated_pipeline())
def test_mutated_pipelines(tmp_path_factory: pytest.TempPathFactory, text: str) -> None:
    d = tmp_path_factory.mktemp("mut")
    p = d / "p.yaml"
    p.write_bytes(text.encode("latin-1", "replace") if any(ord(c) > 127 for c in text) else text.encode())
    out = cli("run", p, "-o", d / "o.png", "--no-cache", "--size", "16x16")
    if _check(out, "mutated pipelines", d / "o.png") == "ok":
        # the work a run may do is bounded by --size, whatever the mutation did to the file (a dropped or
        # mangled `size` included): what it drew is 16 x 16 pixels (the PNG's IHDR: width, height)
        assert _png_size(d / "o.png") == (16, 16)


def _png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR", head
    return struct.unpack(">II", head[16:24])


# -- params, sizes, frames ---------------------------------------------------------------------------------

@settings(max_examples=40, **SETTINGS)
@given(param=st.sampled_from(["normal_threshold", "depth_threshold", "width", "mode", "nope"]),
       value=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**20, 10**20),
                       st.text(max_size=12), st.just("[[[[[[[[[[[[]]]]]]]]]]]]"), st.just("{a: *b}")))
def test_set_params(tmp_path_factory: pytest.TempPathFactory, param: str, value: object) -> None:
    d = tmp_path_factory.mktemp("set")
    out = cli("run", ROOT / "pipelines" / "nienhaus_sketchy.yaml", "-o", d / "o.png", "--no-cache",
              "--size", "16x16", "--set", f"edges.{param}={value}")
    _check(out, "--set params", d / "o.png")


SIZE_TEXT = st.one_of(
    st.builds(lambda w, h: f"{w}x{h}", st.integers(-5, 40), st.integers(-5, 40)),
    st.builds(lambda w, h: f"{w}x{h}", st.integers(16000, 10**12), st.integers(1, 10**12)),
    st.text(alphabet="0123456789xX× -", max_size=12),
)


@settings(max_examples=40, **SETTINGS)
@given(size=SIZE_TEXT)
def test_sizes(tmp_path_factory: pytest.TempPathFactory, size: str) -> None:
    d = tmp_path_factory.mktemp("size")
    pipe = tiny_pipeline(d)
    out = cli("run", pipe, "-o", d / "o.png", "--no-cache", "--size", size)
    if _check(out, "--size", d / "o.png") == "ok" and size.strip():
        from nodegraph.pipeline import MAX_SIZE, parse_size

        w, h = parse_size(size)
        assert 1 <= w <= MAX_SIZE and 1 <= h <= MAX_SIZE


FRAMES_TEXT = st.one_of(
    st.builds(lambda a, b: f"{a}:{b}", st.integers(-3, 3), st.integers(-3, 4)),
    st.builds(lambda a, b, s: f"{a}:{b}:{s}", st.integers(-10**15, 10**15), st.integers(-10**15, 10**15),
              st.integers(0, 10**6)),
    st.text(alphabet="0123456789:- ", max_size=14),
)


@settings(max_examples=60, **SETTINGS)
@given(frames=FRAMES_TEXT)
@example(frames="0:1000000")  # MAX_FRAMES frames: the most it builds
@example(frames="0:5000000")  # a few times more: refused before anything is built
def test_frames(tmp_path_factory: pytest.TempPathFactory, frames: str) -> None:
    from nodegraph.errors import SketchgraphError
    from nodegraph.output.write import MAX_FRAMES, parse_frames

    parse_frames("0")  # its pattern compiled before memory is measured
    tracemalloc.start()
    try:
        got = parse_frames(frames)
    except SketchgraphError as exc:
        assert "\n" not in str(exc) and len(str(exc)) < 200
        _record("--frames (parse)", "error")
        got = []
    else:
        assert 1 <= len(got) <= MAX_FRAMES
        _record("--frames (parse)", "ok")
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    # the work is bounded by what it returns, not by the range asked for (up to 2e15 frames): a refused
    # range is never built, an accepted one is built once (a list of at most MAX_FRAMES ints, ~40 bytes each)
    assert peak <= 64 * 1024 + 64 * len(got), (frames, peak)
    if len(frames) < 6 or ":" not in frames:  # a few small ones through the CLI, rendering every frame
        d = tmp_path_factory.mktemp("frames")
        out = cli("run", tiny_pipeline(d), "-o", d / "f_####.png", "--no-cache", "--size", "8x8", "--frames", frames)
        _check(out, "--frames (cli)")


# -- mesh files -------------------------------------------------------------------------------------------

def _stl_binary(tris: list, header: bytes, count: int | None) -> bytes:
    out = header.ljust(80, b" ")[:80] + struct.pack("<I", len(tris) if count is None else count)
    for t in tris:
        out += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *v) for v in t) + b"\0\0"
    return out


TETRA = [((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
         ((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0))]
SPECIAL = st.sampled_from([float("nan"), float("inf"), -float("inf"), 1e39, 1e300, -3.5e38, 1e30, 0.0])


@st.composite
def triangles(draw: st.DrawFn) -> list:
    """A tetrahedron scaled and moved, and sometimes one coordinate replaced by a hostile value."""
    scale = draw(st.floats(0.01, 100))
    shift = draw(st.tuples(*[st.floats(-1000, 1000)] * 3))
    tris = [[tuple(c * scale + o for c, o in zip(v, shift, strict=True)) for v in t] for t in TETRA]
    if draw(st.integers(0, 2)) == 0:
        t, v, c = draw(st.integers(0, 3)), draw(st.integers(0, 2)), draw(st.integers(0, 2))
        point = list(tris[t][v])
        point[c] = draw(SPECIAL)
        tris[t][v] = tuple(point)
    return tris


TRIS = triangles()
MESH_PEAK_BASE, MESH_PEAK_PER_BYTE = 4 * 1024**2, 1024  # bytes allocated loading one mesh: ~0.3 MiB here


@st.composite
def mesh_file(draw: st.DrawFn) -> tuple[str, bytes]:
    fmt = draw(st.sampled_from(["obj", "ply", "stl", "off"]))
    tris = draw(TRIS)
    verts = [v for t in tris for v in t]
    if fmt == "obj":
        body = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in verts).replace("nan", "nan") + "".join(
            f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}\n" for i in range(len(tris)))
        data = body.encode()
    elif fmt == "off":
        data = (f"OFF\n{len(verts)} {len(tris)} 0\n" + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in verts)
                + "".join(f"3 {3 * i} {3 * i + 1} {3 * i + 2}\n" for i in range(len(tris)))).encode()
    elif fmt == "ply":
        n_v = draw(st.sampled_from([len(verts)] * 4 + [0, 10**13, "-1", "x", "1e9"]))
        n_f = draw(st.sampled_from([len(tris)] * 4 + [0, 10**13, 2**31]))
        binary = draw(st.booleans())
        head = (f"ply\nformat {'binary_little_endian' if binary else 'ascii'} 1.0\nelement vertex {n_v}\n"
                "property double x\nproperty double y\nproperty double z\nelement face "
                f"{n_f}\nproperty list uchar int vertex_indices\nend_header\n").encode()
        if binary:
            body = b"".join(struct.pack("<3d", *v) for v in verts) + b"".join(
                struct.pack("<B3i", 3, 3 * i, 3 * i + 1, 3 * i + 2) for i in range(len(tris)))
        else:
            body = ("".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in verts) + "".join(
                f"3 {3 * i} {3 * i + 1} {3 * i + 2}\n" for i in range(len(tris)))).encode()
        data = head + body
    else:
        finite = [[tuple(c if abs(c) < 3e38 else 0.0 for c in v) for v in t] for t in tris]
        header = draw(st.sampled_from([b"binary", b"solid name", b"  SOLID x"]))
        count = draw(st.sampled_from([None, None, None, 0, 1, 2**32 - 1]))
        data = _stl_binary(finite, header, count)
    damage = draw(st.sampled_from(["none", "none", "none", "truncate", "garbage", "append"]))
    if damage == "truncate":
        data = data[:draw(st.integers(0, len(data)))]
    elif damage == "garbage":
        raw = bytearray(data)
        for _ in range(draw(st.integers(1, 10))):
            if raw:
                raw[draw(st.integers(0, len(raw) - 1))] = draw(st.integers(0, 255))
        data = bytes(raw)
    elif damage == "append":
        data += draw(st.binary(min_size=1, max_size=64))
    return fmt, data


@pytest.fixture(scope="module")
def mesh_readers_imported(tmp_path_factory: pytest.TempPathFactory) -> None:
    """One valid file of each format loaded before any memory is measured: the readers' modules are imported
    on first use (several MiB), which is no part of loading one mesh."""
    from nodegraph.scene.meshes import clear_mesh_cache, load_mesh

    d = tmp_path_factory.mktemp("mesh-warm")
    verts = [v for t in TETRA for v in t]
    files = {"obj": ("".join(f"v {x} {y} {z}\n" for x, y, z in verts)
                     + "".join(f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}\n" for i in range(4))).encode(),
             "off": ("OFF\n12 4 0\n" + "".join(f"{x} {y} {z}\n" for x, y, z in verts)
                     + "".join(f"3 {3 * i} {3 * i + 1} {3 * i + 2}\n" for i in range(4))).encode(),
             "ply": ("ply\nformat ascii 1.0\nelement vertex 12\nproperty double x\nproperty double y\n"
                     "property double z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
                     + "".join(f"{x} {y} {z}\n" for x, y, z in verts)
                     + "".join(f"3 {3 * i} {3 * i + 1} {3 * i + 2}\n" for i in range(4))).encode(),
             "stl": _stl_binary(TETRA, b"binary", None)}
    for fmt, data in files.items():
        (d / f"m.{fmt}").write_bytes(data)
        clear_mesh_cache()
        load_mesh(d / f"m.{fmt}")


PLY_CLAIMING_2_31_FACES = (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                           b"property double z\nelement face 2147483648\nproperty list uchar int vertex_indices\n"
                           b"end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")


@settings(max_examples=300, **SETTINGS)
@given(mesh=mesh_file())
@example(mesh=("ply", PLY_CLAIMING_2_31_FACES))  # headers claiming more than the file holds, always tried
@example(mesh=("stl", _stl_binary(TETRA, b"binary", 2**32 - 1)))
def test_mesh_files_load_or_refuse(tmp_path_factory: pytest.TempPathFactory, mesh_readers_imported: None,
                                   mesh: tuple[str, bytes]) -> None:
    import warnings

    from nodegraph.errors import MeshError
    from nodegraph.scene.meshes import clear_mesh_cache, load_mesh

    fmt, data = mesh
    p = tmp_path_factory.mktemp("mesh") / f"m.{fmt}"
    p.write_bytes(data)
    clear_mesh_cache()
    tracemalloc.start()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            m = load_mesh(p)
        except MeshError as exc:
            msg = str(exc)
            assert "\n" not in msg and len(msg) < 600
            _record(f"mesh files ({fmt})", "error")
        else:
            import numpy as np

            assert np.isfinite(m.vertices).all() and np.abs(m.vertices).max() < 3.4e38 and m.n_faces > 0
            # what it built comes from the bytes in the file, never from a count a header claims (up to
            # 10^13 here): every vertex and face takes at least a byte of the file
            assert len(m.vertices) <= len(data) and m.n_faces <= len(data)
            _record(f"mesh files ({fmt})", "ok")
        finally:
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
    # and so does its work: the memory it allocated on the way (NumPy arrays included) is bounded by the file's
    # size, whatever the header claims (a claimed 2^31 faces would take 24 GiB)
    assert peak <= MESH_PEAK_BASE + MESH_PEAK_PER_BYTE * len(data), (fmt, len(data), peak)


@settings(max_examples=4, **SETTINGS)
@given(mesh=mesh_file())
def test_mesh_files_through_a_real_process(tmp_path_factory: pytest.TempPathFactory,
                                           mesh: tuple[str, bytes]) -> None:
    fmt, data = mesh
    d = tmp_path_factory.mktemp("meshproc")
    p = d / f"m.{fmt}"
    p.write_bytes(data)
    out = cli_subprocess("run", tiny_pipeline(d), "--scene", p, "-o", d / "o.png", "--no-cache", timeout=60)
    if out.code != 0:  # warnings may precede a success, never an error
        assert_one_line_error(out)
    _record("mesh files (subprocess)", "ok" if out.code == 0 else "error")


@pytest.mark.parametrize("case", ["stl_solid_binary", "alias_bomb", "deep_yaml"])
def test_hang_cases_in_a_real_process(tmp_path: Path, case: str) -> None:
    if case == "stl_solid_binary":
        m = tmp_path / "m.stl"
        m.write_bytes(b"solid x\n" + bytes(range(256)) * 4)
        args = ["run", tiny_pipeline(tmp_path), "--scene", m]
    elif case == "alias_bomb":
        p = tmp_path / "b.yaml"
        p.write_text("a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
            f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]\n" for i in range(1, 15)))
        args = ["run", p]
    else:
        p = tmp_path / "d.yaml"
        p.write_text("[" * 100_000 + "]" * 100_000)
        args = ["run", p]
    t0 = time.perf_counter()
    out = cli_subprocess(*args, "-o", tmp_path / "o.png", timeout=60)
    assert_one_line_error(out)
    _record("hang cases (subprocess)", f"error in {time.perf_counter() - t0:.1f} s")
