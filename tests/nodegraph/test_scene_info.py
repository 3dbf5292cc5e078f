"""`sketchgraph scene info`: what a glTF file, a mesh file or a scene YAML holds, against files built here with
known contents; and image decoders kept quiet: each broken or missing texture is one line on stderr, never
OpenImageIO's or libpng's own text."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nodegraph.cli import main
from nodegraph.scene import info as si
from nodegraph.scene import primitives
from tests.gltf_files import INFO_BASE_PNG, INFO_NORMAL_PNG, info_sampler, png_bytes, sink_parts, write_parts

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def sampler(tmp_path: Path) -> Path:
    return info_sampler(tmp_path / "sampler.glb")


def test_gltf_meshes_materials_and_textures(sampler: Path):
    d = si.info(sampler)
    assert d["kind"] == "gltf" and d["summary"]["format"] == "GLB"
    by = {m["name"]: m for m in d["meshes"]}
    assert (by["box"]["triangles"], by["box"]["vertices"], by["box"]["nodes"]) == (12, 8, ["a", "b"])
    assert (by["dots"]["triangles"], by["dots"]["vertices"]) == (0, 3)
    assert (by["spare"]["triangles"], by["spare"]["nodes"]) == (2, [])
    assert by["box"]["sketchgraph"] == si.does("mesh")
    assert by["dots"]["sketchgraph"] == si.does("primitive.points_lines")
    assert by["spare"]["sketchgraph"] == si.does("mesh.unplaced")
    # drawn: the box on two nodes; the points and the unplaced quad are not
    assert (d["summary"]["drawn_objects"], d["summary"]["drawn_triangles"]) == (2, 24)
    (mat,) = d["materials"]
    assert (mat["name"], mat["base_color"], mat["base_color_texture"]) == ("paint", [0.2, 0.4, 0.6, 1.0], 0)
    assert (mat["other_textures"], mat["alpha_mode"]) == (["normal"], "BLEND")
    assert mat["extensions"] == ["KHR_materials_emissive_strength"]
    images = {im["index"]: im for im in d["images"]}
    assert (images[0]["format"], images[0]["width"], images[0]["height"]) == ("png", 4, 2)
    assert images[0]["bytes"] == len(INFO_BASE_PNG) and images[1]["bytes"] == len(INFO_NORMAL_PNG)
    assert (images[1]["width"], images[1]["height"]) == (2, 2)
    tex = d["textures"]
    assert (tex[0]["used_as"], tex[0]["sketchgraph"]) == (["base colour"], si.does("texture.base_color"))
    assert (tex[1]["used_as"], tex[1]["sketchgraph"]) == (["normal"], si.does("texture.other"))


def test_gltf_animations_cameras_lights_and_extensions(sampler: Path):
    d = si.info(sampler)
    slide, spin = d["animations"]
    assert (slide["name"], slide["channels"], slide["targets"], slide["seconds"]) == (
        "slide", 1, {"a": ["translation"]}, 2.0)
    assert (spin["name"], spin["channels"], spin["targets"], spin["seconds"]) == (
        "spin", 2, {"b": ["rotation", "scale"]}, 0.5)
    assert slide["sketchgraph"] == si.animation_does(0, [0, 1])
    assert spin["sketchgraph"] == si.animation_does(1, [0, 1])
    plan, eye, spare = d["cameras"]
    assert (plan["type"], plan["xmag"], plan["ymag"], plan["nodes"]) == ("orthographic", 3, 2, ["plan_node"])
    assert eye["yfov_deg"] == pytest.approx(math.degrees(0.6), abs=1e-3) and eye["nodes"] == ["eye_node"]
    assert spare["nodes"] == []
    # the default view is the first camera on a node, orthographic or perspective
    assert plan["sketchgraph"] == si.does("camera.default")
    assert eye["sketchgraph"] == si.does("camera.perspective")
    assert spare["sketchgraph"] == si.does("camera.unplaced")
    (bulb,) = d["lights"]
    assert (bulb["name"], bulb["type"], bulb["color"], bulb["intensity"], bulb["nodes"]) == (
        "bulb", "point", [1.0, 0.5, 0.25], 40.0, ["lamp"])
    assert bulb["sketchgraph"] == si.does("light")
    ext = {e["name"]: e for e in d["extensions"]}
    assert ext["KHR_lights_punctual"]["required"] and not ext["KHR_materials_emissive_strength"]["required"]
    assert ext["KHR_lights_punctual"]["sketchgraph"] == si.does("light")
    assert ext["KHR_materials_emissive_strength"]["sketchgraph"] == si.extension_does("KHR_materials_")
    assert si.extension_does("EXT_made_up")["why"] == "unknown to sketchgraph"
    assert any("POINTS" in note for note in d["left_out"])


def test_skins_and_morph_targets(tmp_path: Path):
    doc, blob = sink_parts()
    d = si.info(write_parts(tmp_path / "sink.glb", doc, blob))
    assert [(k["joints"], k["nodes"]) for k in d["skins"]] == [(2, ["bar"])]
    assert [(m["mesh"], m["targets"]) for m in d["morph_targets"]] == [("mesh2", 1)]
    assert d["skins"][0]["sketchgraph"] == si.does("skin")


def test_cli_prints_aligned_text_and_the_same_as_json(sampler: Path):
    runner = CliRunner()
    r = runner.invoke(main, ["scene", "info", str(sampler)])
    assert r.exit_code == 0, r.output
    lines = r.output.splitlines()
    cams = lines[lines.index("cameras (3)") + 1:lines.index("cameras (3)") + 4]
    assert [ln.split()[1] for ln in cams] == ["plan", "eye", "spare_cam"]
    col = {ln.index("on ") for ln in cams}  # the node column starts at one place on every row
    assert len(col) == 1
    assert "lights (1)" in lines and "extensions (2)" in lines
    r = runner.invoke(main, ["scene", "info", "--json", str(sampler)])
    assert json.loads(r.output) == json.loads(json.dumps(si.info(sampler)))


def _write_obj(path: Path, v: np.ndarray, f: np.ndarray) -> Path:
    path.write_text("".join(f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in v)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))
    return path


def test_mesh_file_size_up_and_health(tmp_path: Path):
    # an STL-style tall block (Z up, as STL files are): 2 x 1 x 4, from z = 0
    box = primitives.box((2.0, 4.0, 1.0))
    v = np.asarray(box.vertices)[:, [0, 2, 1]] * [1, -1, 1] + [0, 0, 2]  # y-up -> z-up, keeping handedness
    path = _write_obj(tmp_path / "block.obj", v, np.asarray(box.faces))
    d = si.info(path)
    s = d["summary"]
    assert (s["vertices"], s["faces"]) == (len(v), len(box.faces))
    assert s["bounds_min"] == pytest.approx([-1.0, -0.5, 0.0]) and s["bounds_max"] == pytest.approx([1.0, 0.5, 4.0])
    assert s["size"] == pytest.approx([2.0, 1.0, 4.0])
    assert s["format_up"] == "y" and d["health"] == []
    # a sphere with one face taken out: a hole in an otherwise closed surface
    sphere = primitives.sphere(1.0, 3)
    holed = _write_obj(tmp_path / "holed.obj", np.asarray(sphere.vertices), np.asarray(sphere.faces)[1:])
    h = si.info(holed)
    assert h["summary"]["faces"] == len(sphere.faces) - 1
    assert any("1 hole" in note for note in h["health"]), h["health"]
    text = si.format_info(h)
    assert "health:" in text and "1 hole" in text


def test_scene_yaml_lists_objects_and_their_sources(tmp_path: Path):
    sphere = primitives.sphere(1.0, 1)
    _write_obj(tmp_path / "ball.obj", np.asarray(sphere.vertices), np.asarray(sphere.faces))
    (tmp_path / "s.yaml").write_text(
        "objects:\n"
        "  - {mesh: ball.obj}\n"
        "  - {gltf: gone.glb, animation: walk, name: walker}\n"
        "  - {primitive: {type: box}, sketchy: false}\n"
        "camera: {view: front}\nfps: 30\n")
    d = si.info(tmp_path / "s.yaml")
    assert [(o["name"], o["kind"], o["source"], o["exists"]) for o in d["objects"]] == [
        ("ball", "mesh", "ball.obj", True), ("walker", "gltf", "gone.glb", False), ("box2", "primitive", "box", True)]
    assert d["objects"][1]["animation"] == "walk" and not d["objects"][2]["sketchy"]
    assert (d["summary"]["fps"], d["summary"]["camera"]) == (30.0, "view front")
    assert "(MISSING)" in si.format_info(d)


def test_errors_are_one_line(tmp_path: Path):
    runner = CliRunner()
    (tmp_path / "notes.txt").write_text("x")
    for target in (tmp_path / "none.glb", tmp_path / "notes.txt"):
        r = runner.invoke(main, ["scene", "info", str(target)])
        assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1 and r.output.startswith("error:")


# -- decoders kept quiet -------------------------------------------------------------------------------------------
NOISE = ("libpng", "OpenImageIO", "ImageBuf", "geterror", "JPEG error", "Traceback", "Assertion")


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, SKETCHGRAPH_CACHE_DIR=str(cwd / "cache"))
    code = "import sys\nsys.argv = ['sketchgraph', *sys.argv[1:]]\nfrom nodegraph.cli import main\nmain()\n"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=cwd, env=env,
                          timeout=600)


def _broken_png() -> bytes:
    """A PNG whose header and chunk CRCs are right but whose image data is cut short."""
    import struct
    import zlib

    good = png_bytes(np.full((16, 16, 3), 200, np.uint8))
    raw = zlib.compress(b"\0" * 40)
    idat = struct.pack(">I", len(raw)) + b"IDAT" + raw + struct.pack(">I", zlib.crc32(b"IDAT" + raw) & 0xFFFFFFFF)
    return good[:33] + idat + good[-12:]


@pytest.mark.slow
def test_a_broken_or_missing_texture_is_one_line(tmp_path: Path):
    pipe = str(ROOT / "pipelines" / "nienhaus_sketchy.yaml")
    doc, blob = sink_parts(_broken_png())
    broken = write_parts(tmp_path / "broken.glb", doc, blob)
    doc, blob = sink_parts()
    doc = json.loads(json.dumps(doc))
    doc["images"][0] = {"uri": "missing.png"}
    missing = write_parts(tmp_path / "missing.gltf", doc, blob, "external")
    r = _cli("run", pipe, "--scene", str(broken), "--size", "48x48", "-o", str(tmp_path / "b.png"), "-q",
             cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: broken.glb: ") and "texture 0" in lines[0], r.stderr
    r = _cli("run", pipe, "--scene", str(missing), "--size", "48x48", "-o", str(tmp_path / "m.png"), "-q",
             cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith("error: ") and "missing.png" in lines[0]
    r = _cli("scene", "info", str(broken), cwd=tmp_path)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert not any(word in r.stdout for word in NOISE)


def test_image_reads_say_one_line_and_the_decoder_nothing(tmp_path: Path):
    """libpng prints its errors to the process's stderr and OpenImageIO its unretrieved ones at exit; a
    subprocess shows both, had they been let through."""
    (tmp_path / "cut.png").write_bytes(png_bytes(np.full((32, 32, 3), 90, np.uint8))[:60])
    (tmp_path / "junk.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"not a png at all" * 4)
    (tmp_path / "junk.jpg").write_bytes(b"\xff\xd8\xff\xe0" + b"\0" * 40)
    code = ("import sys\nfrom nodegraph.output import imageio\nfrom nodegraph.errors import SketchgraphError\n"
            "for name in sys.argv[1:]:\n"
            "    try:\n        imageio.read(name)\n    except SketchgraphError as exc:\n        print(exc)\n")
    r = subprocess.run([sys.executable, "-c", code, "cut.png", "junk.png", "junk.jpg"], capture_output=True,
                       text=True, cwd=tmp_path, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stderr == "", r.stderr
    out = r.stdout.strip().splitlines()
    assert [ln.split(":")[0] for ln in out] == ["cut.png", "junk.png", "junk.jpg"]
    assert all("cannot read the image" in ln for ln in out)
