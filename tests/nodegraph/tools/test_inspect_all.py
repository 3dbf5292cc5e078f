"""`inspect --all`: visualisations per type, statistics, the contact sheet, the page, exact EXRs."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nodegraph.cli import main
from nodegraph.tools import viz

ROOT = Path(__file__).resolve().parents[3]
NIENHAUS = ROOT / "pipelines" / "nienhaus_sketchy.yaml"


# -- visualisations (no GL) ------------------------------------------------------------------------------
def test_classify_by_port_and_channels():
    assert viz.classify("depth", 1) == "depth"
    assert viz.classify("linear_depth", 1) == "depth"
    assert viz.classify("object_id", 1) == "ids"
    assert viz.classify("out", 1) == "grey"
    assert viz.classify("out", 2) == "vector"
    assert viz.classify("normal_depth", 4) == "normals"
    assert viz.classify("offsets", 4) == "vector2"
    assert viz.classify("force", 2) == "vector"
    assert viz.classify("position", 4) == "position"
    assert viz.classify("color", 4) == "color"


def test_depth_normalised_over_surface_range_with_background():
    d = np.array([[0.5, 0.75], [1.0, np.nan]], np.float32)[:, :, None]  # GL order: row 0 = bottom
    p = viz.visualize_texture(d, "depth")
    img = p.image[::-1]  # back to GL order
    assert p.kind == "depth" and "0.5..0.75" in p.note
    assert np.allclose(img[0, 0], 1.0)  # nearest: brightest
    assert np.allclose(img[0, 1], 0.12)  # farthest surface: darkest grey
    assert np.allclose(img[1, 0], viz.BACKGROUND)  # exactly 1: no surface
    assert np.allclose(img[1, 1], viz.NONFINITE)


def test_normals_and_grey():
    n = np.zeros((1, 3, 4), np.float32)
    n[0, 0, :3] = (1, 0, 0)
    n[0, 1, :3] = (0, -1, 0)
    img = viz.visualize_texture(n, "normal").image
    assert np.allclose(img[0, 0], (1, 0.5, 0.5)) and np.allclose(img[0, 1], (0.5, 0, 0.5))
    assert np.allclose(img[0, 2], (0.5, 0.5, 0.5))
    g = viz.visualize_texture(np.array([[[0.25], [0.75]]], np.float32), "edges")
    assert np.allclose(g.image[0, :, 0], (0.25, 0.75)) and g.note == "grey, 0..1"
    g = viz.visualize_texture(np.array([[[-2.0], [2.0]]], np.float32), "out")
    assert np.allclose(g.image[0, :, 0], (0.0, 1.0)) and "normalized" in g.note


def test_colour_wheel_direction_and_magnitude():
    v = np.array([[[1, 0], [0, 1], [-1, 0], [0, -0.5], [0, 0]]], np.float32)
    p = viz.visualize_texture(v, "offset")
    img = p.image[0]
    assert np.allclose(img[0], (1, 0, 0))  # +x: red
    assert np.allclose(img[2], (0, 1, 1))  # -x: cyan
    assert img[1, 1] > img[1, 2] and img[1, 0] > 0.4  # +y: yellow-green
    assert np.isclose(img[3].max(), 0.5)  # half the peak magnitude: half as bright
    assert np.allclose(img[4], 0)
    assert "max 1" in p.note
    two = viz.visualize_texture(np.concatenate([v, -v], axis=2), "offsets")
    assert two.kind == "vector2" and two.image.shape[1] > 2 * v.shape[1]


def test_texture_array_strip_and_ids():
    arr = np.random.default_rng(1).random((3, 4, 5, 1)).astype(np.float32)
    p = viz.visualize_array(arr, "tones", gap=2)
    assert p.kind == "strip" and p.image.shape == (4, 3 * 5 + 2 * 2, 3)
    assert np.allclose(p.image[:, :5, 0], arr[0, ::-1, :, 0])
    ids = viz.visualize_texture(np.array([[[0], [1], [2]]], np.float32), "object_id")
    assert np.allclose(ids.image[0, 0], 0) and not np.allclose(ids.image[0, 1], ids.image[0, 2])


def test_stats_resize_and_text():
    a = np.array([[[1.0, 0.0], [np.nan, 2.0]], [[3.0, np.inf], [5.0, 4.0]]], np.float32)
    s = viz.channel_stats(a)
    assert (s[0].min, s[0].max, s[0].mean, s[0].nan) == (1.0, 5.0, 3.0, 1)
    assert (s[1].max, s[1].inf) == (4.0, 1)
    img = np.arange(16, dtype=np.float32).reshape(4, 4)
    assert np.allclose(viz.resize_area(img, 2, 2), [[2.5, 4.5], [10.5, 12.5]])
    canvas = np.zeros((9, 40, 3), np.float32)
    viz.draw_text(canvas, "A1.", 1, 1)
    assert canvas.sum() > 0 and canvas[0].sum() == 0
    sheet = viz.contact_sheet([viz.Cell(np.ones((10, 20, 3), np.float32), ["x"]), viz.Cell(None, ["y"])], cell=32)
    assert sheet.shape[2] == 3 and sheet.shape[1] >= 2 * 32


# -- inspect --all (GL) ----------------------------------------------------------------------------------
@pytest.fixture
def inspected(gl, tmp_path, cache_dir):
    out = tmp_path / "insp"
    r = CliRunner().invoke(main, ["inspect", str(NIENHAUS), "--all", "-o", str(out), "--size", "40x32"])
    assert r.exit_code == 0, r.output
    return out


def test_inspect_all_writes_every_planned_output(inspected):
    stats = json.loads((inspected / "stats.json").read_text())
    order = [n["node"] for n in stats["nodes"]]
    assert order == ["gbuf", "edges", "noise", "sketch", "sprite"]  # topological
    ports = [(n["node"], p["port"]) for n in stats["nodes"] for p in n["ports"]]
    assert ("gbuf", "normal_depth") in ports and ("sketch", "color") in ports and ("sprite", "color") in ports
    for node, port in ports:
        assert (inspected / f"{node}.{port}.png").exists()
        assert (inspected / f"{node}.{port}.exr").exists()
    formats = {(n["node"], p["port"]): p["format"] for n in stats["nodes"] for p in n["ports"]}
    assert formats[("noise", "out")] == "RG16F"  # the format its consumer asks for, not the declared RG32F
    views = {(n["node"], p["port"]): p["view"] for n in stats["nodes"] for p in n["ports"]}
    assert views[("gbuf", "depth")] == "depth" and views[("noise", "out")] == "vector"
    assert views[("edges", "out")] == "grey" and views[("gbuf", "normal_depth")] == "normals"
    edges = next(p for n in stats["nodes"] for p in n["ports"] if n["node"] == "edges")
    assert edges["stats"][0]["nan"] == 0 and 0 <= edges["stats"][0]["min"] <= edges["stats"][0]["max"] <= 1
    sheet = viz.read_png(inspected / "contact_sheet.png")
    assert sheet.shape[0] > 32 and sheet.shape[1] > 40


def test_inspect_page_links_resolve(inspected):
    text = (inspected / "index.html").read_text()
    srcs = re.findall(r'(?:src|href)="([^"#:]+)"', text)
    assert srcs and all((inspected / s).exists() for s in srcs)
    for node in ("gbuf", "edges", "noise", "sketch", "sprite"):
        assert f'id="node-{node}"' in text
    assert text.index('id="node-gbuf"') < text.index('id="node-sprite"')


def test_inspect_all_exr_is_exact(inspected, cache_dir, tmp_path):
    from nodegraph import imageio
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor

    pipe = pl.load(NIENHAUS, size=(40, 32))
    ex = Executor(pipe, None, requested=[pipe.outputs["image"]])
    try:
        ref = ex.run(0).values[pipe.outputs["image"]].read()
    finally:
        ex.close()
    got = imageio.read(inspected / "sprite.color.exr")
    assert np.array_equal(got, ref)


def test_inspect_all_rejects_a_port(gl, tmp_path):
    r = CliRunner().invoke(main, ["inspect", str(NIENHAUS), "edges.out", "--all", "-o", str(tmp_path)])
    assert r.exit_code == 2 and "--all" in r.output
