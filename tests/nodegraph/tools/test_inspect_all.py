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
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor
    from nodegraph.output import imageio

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


# -- drawn at the size it is shown (no GL) ---------------------------------------------------------------
def _area_means(d: np.ndarray, height: int, width: int, weight: np.ndarray | None = None):
    """float64 reference: per shown pixel, the mean over its integer span (of the weighted pixels) and the
    weighted share, by explicit loops."""
    h, w = d.shape[:2]
    mean = np.zeros((height, width, d.shape[2]))
    share = np.zeros((height, width))
    for i in range(height):
        for j in range(width):
            y0, y1 = i * h // height, (i + 1) * h // height
            x0, x1 = j * w // width, (j + 1) * w // width
            block = d[y0:y1, x0:x1].astype(np.float64).reshape(-1, d.shape[2])
            wt = (np.ones(len(block), bool) if weight is None else weight[y0:y1, x0:x1].reshape(-1))
            share[i, j] = wt.mean()
            if wt.any():
                mean[i, j] = block[wt].mean(axis=0)
    return mean, share


def test_shown_grey_and_colour_are_area_average_then_colourise(rng):
    from nodegraph.tools.inspect_all import shown_texture

    a = (rng.random((30, 45, 1)) * 6.0 - 2.0).astype(np.float32)  # beyond 0..1: normalised
    panel = shown_texture(a, "out", box=10)  # 45 wide -> 10 x round(30 * 10 / 45) = 7
    mean, _ = _area_means(a[::-1], 7, 10)
    g = (mean[:, :, 0] - mean.min()) / (mean.max() - mean.min())
    assert panel.kind == "grey" and panel.image.shape == (7, 10, 3)
    np.testing.assert_allclose(panel.image, np.repeat(g[:, :, None], 3, axis=2), atol=2e-6)

    c = rng.random((20, 20, 4)).astype(np.float32)
    panel = shown_texture(c, "color", box=6)  # 20 -> 6: spans of 3 and 4 pixels
    mean, _ = _area_means(c[::-1], 6, 6)
    np.testing.assert_allclose(panel.image, mean[:, :, :3], atol=2e-6)


def test_shown_vector_wheel_on_averaged_vectors(rng):
    import colorsys

    from nodegraph.tools.inspect_all import shown_texture

    v = (rng.random((16, 24, 2)) * 2 - 1).astype(np.float32)
    panel = shown_texture(v, "offset", box=8)
    mean, _ = _area_means(v[::-1], 5, 8)
    mag = np.hypot(mean[:, :, 0], mean[:, :, 1])
    want = np.array([[colorsys.hsv_to_rgb((np.arctan2(y, x) / (2 * np.pi)) % 1.0, 1.0, m / mag.max())
                      for (x, y), m in zip(row, mrow, strict=True)] for row, mrow in zip(mean, mag, strict=True)])
    assert panel.kind == "vector"
    np.testing.assert_allclose(panel.image, want, atol=1e-5)


def test_shown_depth_mixes_background_and_nonfinite_by_share():
    from nodegraph.tools.inspect_all import shown_texture

    d = np.ones((8, 8, 1), np.float32)  # background everywhere ...
    d[0:4, 0:4, 0] = np.linspace(0.2, 0.6, 16).reshape(4, 4)  # ... but a surface in one corner
    d[5, 6, 0] = np.nan
    panel = shown_texture(d, "depth", box=4)  # 2x2 spans
    disp = d[::-1]
    finite = np.isfinite(disp[:, :, 0])
    surface = finite & (disp[:, :, 0] != 0) & (disp[:, :, 0] != 1)
    mean, s_share = _area_means(np.where(surface[:, :, None], disp, 0), 4, 4, surface)
    _, f_share = _area_means(disp, 4, 4, finite)
    vals = mean[:, :, 0][s_share > 0]
    lo, hi = vals.min(), vals.max()
    g = 0.12 + 0.88 * (1 - np.clip((mean[:, :, 0] - lo) / (hi - lo), 0, 1))
    bg = f_share - s_share
    want = (g[:, :, None] * s_share[:, :, None] + bg[:, :, None] * viz.BACKGROUND
            + (1 - f_share)[:, :, None] * viz.NONFINITE)
    assert panel.kind == "depth"
    np.testing.assert_allclose(panel.image, want, atol=2e-6)
    assert np.allclose(panel.image[0, 3], viz.BACKGROUND)  # top right: background only


def test_shown_ids_are_sampled_not_averaged():
    from nodegraph.tools.inspect_all import shown_texture

    ids = np.zeros((6, 6, 1), np.float32)
    ids[:, 3:] = 7.0
    panel = shown_texture(ids, "ids", box=2)
    assert panel.kind == "ids" and panel.image.shape == (2, 2, 3)
    assert np.all(panel.image[:, 0] == 0) and np.all(panel.image[:, 1] > 0)  # id 0 black, id 7 a colour


def test_fast_channel_stats_match_float64(rng):
    from nodegraph.tools.inspect_all import channel_stats

    a = (rng.random((17, 23, 3)) * 100 - 50).astype(np.float32)
    fast, ref = channel_stats(a), viz.channel_stats(a)
    for f, r in zip(fast, ref, strict=True):
        assert (f.name, f.min, f.max, f.nan, f.inf) == (r.name, r.min, r.max, r.nan, r.inf)
        assert abs(f.mean - r.mean) <= 1e-12 * max(1.0, abs(r.mean))
    a[3, 4, 1] = np.nan
    assert channel_stats(a)[1].nan == 1  # not finite: the float64 path


def test_host_copy_is_what_a_read_back_gives(gl):
    from nodegraph.executor import as_read

    rng = np.random.default_rng(3)
    data = rng.random((5, 7, 4)).astype(np.float32) * 1.5 - 0.25
    data[0, 0] = [0.5 / 255, 1.5 / 255, 2.5 / 255, 1.0]  # exact ties of the 8-bit conversion
    for fmt, c in (("R8", 1), ("RGBA8", 4), ("R16F", 1), ("RGBA16F", 4), ("RG32F", 2), ("RGBA32F", 4)):
        arr = np.ascontiguousarray(data[:, :, :c])
        tex = gl.upload(arr, fmt)
        try:
            assert np.array_equal(as_read(arr, fmt), tex.read()), fmt
        finally:
            gl.release(tex)


def test_inspect_all_from_the_cache_writes_the_same_files(gl, tmp_path, cache_dir):
    """The second run loads every output from the disk cache and uses the copies it loaded (no read-back):
    the same exact values and the same pictures as the run that computed them."""
    outs = []
    for name in ("a", "b"):
        out = tmp_path / name
        r = CliRunner().invoke(main, ["inspect", str(NIENHAUS), "--all", "-o", str(out), "--size", "40x32"])
        assert r.exit_code == 0, r.output
        outs.append(out)
    stats = json.loads((outs[1] / "stats.json").read_text())
    assert {n["status"] for n in stats["nodes"]} <= {"disk", "pass-through"}
    files = sorted(p.name for p in outs[0].iterdir() if p.suffix in (".png", ".exr"))
    assert files and files == sorted(p.name for p in outs[1].iterdir() if p.suffix in (".png", ".exr"))
    from nodegraph.output import imageio

    for f in files:
        if f.endswith(".png"):
            assert (outs[0] / f).read_bytes() == (outs[1] / f).read_bytes(), f
        else:
            assert np.array_equal(imageio.read(outs[0] / f), imageio.read(outs[1] / f)), f
