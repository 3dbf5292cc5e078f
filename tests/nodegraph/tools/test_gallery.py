"""The gallery: every pipeline has an entry, builds are deterministic and incremental, verify catches
differences (bit for bit on this renderer, within a tolerance on another), and the page loads in a
real headless browser."""

from __future__ import annotations

import importlib
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from nodegraph.cache import Cache
from nodegraph.errors import SketchgraphError
from nodegraph.tools import gallery as gal
from nodegraph.tools import viz

ROOT = Path(__file__).resolve().parents[3]
PIPELINES = ROOT / "pipelines"

TINY = f"""\
cell: 48
tolerance: {{per_pixel: 0.1, outliers: 0.01, mean: 0.02}}
entries:
  - name: still
    pipeline: {PIPELINES / "nienhaus_sketchy.yaml"}
    size: [40, 32]
    doc: the cloister, small
  - name: orbit
    pipeline: {PIPELINES / "nienhaus_sketchy.yaml"}
    size: [24, 24]
    frames: "0:4:2"
  - name: sweep
    pipeline: {PIPELINES / "nienhaus_sketchy.yaml"}
    size: [24, 24]
    set: {{noise.octaves: 2}}
    wedge: {{edges.normal_threshold: [0.2, 0.8]}}
  - name: absent
    pipeline: {PIPELINES / "nienhaus_sketchy.yaml"}
    scene: {gal.SHARED / "meshes" / "no-such-mesh-here.obj"}
    size: [24, 24]
"""


@pytest.fixture
def tiny(tmp_path: Path) -> gal.Gallery:
    (tmp_path / "g").mkdir()
    f = tmp_path / "g" / "gallery.yaml"
    f.write_text(TINY)
    return gal.load(f)


def build(g: gal.Gallery, cache, **kw) -> gal.BuildReport:
    return gal.build(g, cache, progress=False, echo=lambda s: None, **kw)


def statuses(report: gal.BuildReport) -> dict[str, str]:
    return {r.name: r.status for r in report.results}


# -- the real gallery file -------------------------------------------------------------------------------
def test_every_pipeline_has_an_entry():
    g = gal.load(ROOT / "gallery" / "gallery.yaml")
    covered = {e.pipeline.resolve() for e in g.entries}
    missing = [p.name for p in sorted(PIPELINES.glob("*.yaml")) if p.resolve() not in covered]
    assert not missing, f"pipelines without a gallery entry: {missing}"
    for e in g.entries:  # default entries are found out by their scene's files; written ones say so
        uses = any(gal._inside(p, gal.SHARED) for p in e.scene_files())
        assert e.auto or e.shared == uses, f"entry {e.name}: mark it `shared: true` exactly when it uses ../shared"


# -- builds ----------------------------------------------------------------------------------------------
@pytest.mark.slow  # a browser / gallery builds
def test_builds_are_deterministic_and_incremental(gl, tiny, tmp_path):
    with gal.TemporaryCache() as fresh:
        cold = build(tiny, fresh, cold=True)
    assert statuses(cold) == {"still": "rendered", "orbit": "rendered", "sweep": "rendered", "absent": "skipped"}
    assert "no-such-mesh-here.obj" in next(r.note for r in cold.results if r.name == "absent")
    first = tiny.manifest_path.read_bytes()
    pictures = re.findall(r'<img class="\w+" src="([^"]+)"', (tiny.root / "index.html").read_text())
    m = json.loads(first)
    assert set(m["entries"]) == {"still", "orbit", "sweep"}
    still = m["entries"]["still"]
    assert still["seed"] == 7 and still["size"] == [40, 32] and still["scene"] == "builtin:cloister"
    assert still["params"]["edges"]["normal_threshold"] == 0.4 and len(still["pipeline_sha256"]) == 64
    assert set(still["files"]) == {"images/still/image.png", "images/still/intermediates.png"}
    assert set(m["entries"]["orbit"]["files"]) >= {"images/orbit/image_f0000.png", "images/orbit/image_f0002.png",
                                                   "images/orbit/frames.png"}
    assert {"images/sweep/wedge.png", "images/sweep/wedge_r0c1.png"} <= set(m["entries"]["sweep"]["files"])
    assert m["renderer"] and m["versions"]["numpy"] == np.__version__
    for rec in m["entries"].values():
        for rel, f in rec["files"].items():
            assert gal.file_sha256(tiny.root / rel) == f["sha256"]

    cache = Cache(tmp_path / "cache")
    again = build(tiny, cache, force=True)  # everything rendered again (a second cold cache)
    assert tiny.manifest_path.read_bytes() == first
    hits, misses = cache.hits, cache.misses
    warm = build(tiny, cache, force=True)  # rendered again from a warm node cache
    assert tiny.manifest_path.read_bytes() == first
    # every picture from the view cache: no node runs or loads, nothing misses
    assert all(s in ("view", "pass-through") for r in warm.results for s in r.node_status.values())
    assert cache.misses == misses and cache.hits > hits
    # the contact sheets too: their PNG bytes are records named by their cells, labels and layout
    drawn = []
    real_sheet = viz.contact_sheet
    viz.contact_sheet = lambda *a, **k: drawn.append(k.get("title")) or real_sheet(*a, **k)
    try:
        build(tiny, cache, force=True)
    finally:
        viz.contact_sheet = real_sheet
    assert drawn == [] and tiny.manifest_path.read_bytes() == first
    # without the view records (a node cache of node entries only) the same bytes again, nodes from the cache
    for f in cache.root.glob("*/*.npz"):
        if ".view-" in f.name or ".png-" in f.name:
            f.unlink()
    nodes_only = build(tiny, cache, force=True)
    assert tiny.manifest_path.read_bytes() == first
    # (an entry's pictures that an earlier entry's render drew again, same keys, come from the view cache)
    got = [s for r in nodes_only.results for s in r.node_status.values()]
    assert set(got) <= {"disk", "memory", "pass-through", "view"} and got.count("disk") > got.count("view")
    assert statuses(again) == statuses(warm) == statuses(cold)
    (tiny.root / "images" / "gone").mkdir()  # an entry that was removed from gallery.yaml
    incremental = build(tiny, cache)
    assert not (tiny.root / "images" / "gone").exists()
    assert tiny.manifest_path.read_bytes() == first
    assert statuses(incremental)["still"] == "up to date" and incremental.previous_cold_s == round(cold.total_s, 3)
    # the page shows the pictures in the same order whether an entry was just drawn or read from the manifest
    assert re.findall(r'<img class="\w+" src="([^"]+)"', (tiny.root / "index.html").read_text()) == pictures
    assert pictures.index("images/orbit/intermediates.png") < pictures.index("images/orbit/frames.png")
    assert "x faster" in gal.format_build(incremental)

    # a changed param re-renders that entry only
    tiny.entry("still").overrides.append("edges.width=1")
    changed = build(tiny, cache)
    assert statuses(changed)["still"] == "rendered" and statuses(changed)["orbit"] == "up to date"


def test_sheet_key_names_every_input_of_the_sheet():
    from nodegraph.tools.gallery.build import sheet_key

    def cells(img: np.ndarray, fmt: str = "R16F image") -> list[viz.Cell]:
        return [viz.Cell(img, ["a.out", fmt]), viz.Cell(None, ["b.out"])]

    img = np.zeros((4, 5, 3), np.float32)
    args = {"cells": cells(img), "cell": 48, "title": "t"}
    key = sheet_key(args)
    assert key == sheet_key({**args, "cells": cells(img.copy())})
    moved = img.copy()
    moved[1, 2, 0] = 0.5
    variants = [{**args, "cells": cells(moved)}, {**args, "cells": cells(img, "RGBA8 image")},
                {**args, "cells": cells(img.reshape(5, 4, 3))}, {**args, "cells": cells(img)[::-1]},
                {**args, "title": "u"}, {**args, "cell": 64}, {**args, "columns": 1}]
    assert len({key, *(sheet_key(v) for v in variants)}) == 1 + len(variants)


def test_verify(gl, tiny, tmp_path, monkeypatch):
    cache = Cache(tmp_path / "cache")
    build(tiny, cache)
    checks, info = gal.verify(tiny, None, progress=False)
    assert info["same_renderer"] and {c.name: c.status for c in checks} == {
        "still": "ok", "orbit": "ok", "sweep": "ok", "absent": "skipped"}
    assert all(f.how == "identical" for c in checks for f in c.files)

    # same renderer: a manifest that disagrees by one bit of one file fails, naming the entry
    m = json.loads(tiny.manifest_path.read_text())
    good = dict(m["entries"]["sweep"]["files"]["images/sweep/wedge_r0c0.png"])
    m["entries"]["sweep"]["files"]["images/sweep/wedge_r0c0.png"]["sha256"] = "0" * 64
    tiny.manifest_path.write_text(gal.manifest_text(m))
    checks, info = gal.verify(tiny, None, progress=False, only=["sweep", "still"])
    assert {c.name: c.status for c in checks} == {"sweep": "differs", "still": "ok"}
    text = gal.format_verify(checks, info)
    assert "DIFFERS  sweep" in text and "images/sweep/wedge_r0c0.png" in text and "1 differ (sweep)" in text

    # another renderer: within tolerance passes, beyond it fails with the numbers
    m["entries"]["sweep"]["files"]["images/sweep/wedge_r0c0.png"] = good
    tiny.manifest_path.write_text(gal.manifest_text(m))
    # verify asks its own module for the renderer (gal.verify is the function; the module is imported by name)
    monkeypatch.setattr(importlib.import_module("nodegraph.tools.gallery.verify"), "_renderer",
                        lambda: "Some Other GPU | 4.6")
    ref = tiny.root / "images/still/image.png"
    img = viz.read_png(ref)[..., :3]
    img[0, 0] = np.clip(img[0, 0] + 0.5, 0, 1)  # 1 pixel of 1280: within 1% outliers
    _recommit(tiny, m, ref, img)
    checks, info = gal.verify(tiny, None, progress=False, only=["still"])
    assert not info["same_renderer"] and checks[0].status == "ok", gal.format_verify(checks, info)
    assert any(f.how == "within tolerance" for f in checks[0].files)
    img[:8] = 1.0 - img[:8]  # a quarter of the image
    _recommit(tiny, m, ref, img)
    checks, info = gal.verify(tiny, None, progress=False, only=["still"])
    assert checks[0].status == "differs"
    f = next(f for f in checks[0].files if f.file == "images/still/image.png")
    assert f.how == "beyond tolerance" and f.max_abs > 0.5 and f.outliers > 0.1
    assert (tiny.out / "verify/images/still/image.diff.png").exists()
    assert "beyond tolerance" in gal.format_verify(checks, info)

    # the pipeline changed since the build: verify says what changed
    tiny.entry("still").overrides.append("edges.width=1")
    checks, _ = gal.verify(tiny, None, progress=False, only=["still"])
    assert checks[0].status == "differs" and "overrides" in checks[0].note and "keys of edges" in checks[0].note


def _recommit(g: gal.Gallery, m: dict, path: Path, img: np.ndarray) -> None:
    """Replace a committed image (as if built elsewhere) and record it in the manifest."""
    viz.write_png(path, img)
    rel = path.relative_to(g.root).as_posix()
    m["entries"]["still"]["files"][rel]["sha256"] = gal.file_sha256(path)
    g.manifest_path.write_text(gal.manifest_text(m))


def test_cli_verify_exit_status(gl, tiny, tmp_path):
    from click.testing import CliRunner

    from nodegraph.cli import main

    args = ["--gallery", str(tiny.file), "--only", "still", "-q"]
    r = CliRunner().invoke(main, ["gallery", "build", *args, "--cache-dir", str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    assert re.search(r"total \d+\.\d+ s", r.output) and "still" in r.output
    assert CliRunner().invoke(main, ["gallery", "verify", *args]).exit_code == 0
    (tiny.root / "images/still/image.png").write_bytes(b"not a png")
    r = CliRunner().invoke(main, ["gallery", "verify", *args])
    assert r.exit_code == 1 and "still" in r.output and "does not match the manifest" in r.output


# -- the page in a real browser --------------------------------------------------------------------------
def chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


def run_chromium(url: str, tmp: Path, *args: str) -> subprocess.CompletedProcess:
    exe = chromium()
    assert exe is not None
    profile = tmp / "profile"
    profile.mkdir(exist_ok=True)
    cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={profile}",
           "--enable-logging=stderr", "--v=0", "--virtual-time-budget=5000", *args, url]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=90)


@pytest.mark.slow  # a browser / gallery builds
def test_page_in_headless_chromium(gl, tiny, tmp_path):
    if chromium() is None:
        pytest.skip("chromium is not installed (Debian: apt-get install chromium); the page is not checked "
                    "in a browser here")
    build(tiny, Cache(tmp_path / "cache"))
    page = tiny.root / "index.html"
    text = page.read_text()
    srcs = re.findall(r'<img [^>]*src="([^"]+)"', text)
    assert len(srcs) >= 5 and all((tiny.root / s).exists() for s in srcs)
    url = page.as_uri()

    dom = run_chromium(url, tmp_path, "--dump-dom")
    assert dom.returncode == 0, dom.stderr[-2000:]
    console = [line for line in dom.stderr.splitlines() if ":CONSOLE" in line or "Uncaught" in line]
    assert not console, "console messages: " + "\n".join(console)
    m = re.search(r'<html[^>]*data-images="(\w+)"[^>]*data-image-count="(\d+)"', dom.stdout)
    assert m, "the page's load handler did not run: " + dom.stdout[:300]
    assert m.group(1) == "ok" and int(m.group(2)) == len(srcs)

    shot = tmp_path / "gallery.png"
    res = run_chromium(url, tmp_path, f"--screenshot={shot}", "--window-size=1200,1600", "--hide-scrollbars")
    assert res.returncode == 0 and shot.exists(), res.stderr[-2000:]
    img = viz.read_png(shot)
    assert img.shape[:2] == (1600, 1200) and img.std() > 0.05  # something was drawn


# -- wedges ----------------------------------------------------------------------------------------------
def test_wedge_axes():
    from nodegraph.errors import SketchgraphError
    from nodegraph.tools.wedge import axes_from, combinations, parse_axis

    a = parse_axis("edges.normal_threshold=0.2,0.4")
    assert a.values == (0.2, 0.4) and a.override(0.2) == "edges.normal_threshold=0.2"
    m = parse_axis("sketch.edge_matrix=[[[0.01, 0], [0, 0.01]], [[0.02, 0], [0, 0.02]]]")
    assert m.values[1] == [[0.02, 0], [0, 0.02]]
    cells = combinations(axes_from({"a.x": [1, 2, 3], "b.y": ["u", "v"]}))
    assert [(r, c) for r, c, _, _ in cells] == [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2)]
    assert cells[4][2] == ["a.x=2", 'b.y="v"'] and cells[4][3] == "a.x=2 b.y=v"
    for bad in ("noequals", "x=1", "a.b="):
        with pytest.raises(SketchgraphError):
            parse_axis(bad)
    with pytest.raises(SketchgraphError, match="one or two"):
        axes_from({"a.x": [1], "b.y": [2], "c.z": [3]})


def test_wedge_cli(gl, tmp_path, cache_dir):
    from click.testing import CliRunner

    from nodegraph.cli import main

    out = tmp_path / "w.png"
    r = CliRunner().invoke(main, ["wedge", str(PIPELINES / "nienhaus_sketchy.yaml"), "--size", "24x24",
                                  "--cell", "24", "-p", "edges.normal_threshold=0.2,0.8",
                                  "-p", "noise.scale=0.005,0.02", "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert "4 cells" in r.output
    lines = [line for line in r.output.splitlines() if "recomputed" in line]
    assert "gbuf" in lines[0] and "gbuf" not in lines[1]  # upstream of the swept params runs once
    sheet = viz.read_png(out)
    assert sheet.shape[1] > 2 * 24 and sheet.shape[0] > 2 * 24


def test_cold_empties_a_cache_dir_of_renderer_folders(tiny, tmp_path):
    root = tmp_path / "gc"
    (root / "renderer-0123456789abcdef" / "ab").mkdir(parents=True)
    (root / "renderer-0123456789abcdef" / "ab" / "abcd.out.RGBA8.exr").write_bytes(b"x")
    (root / "renderer-0123456789abcdef" / "ab" / ".tmp-1.exr").write_bytes(b"x")
    gal.node_cache(tiny, cache_dir=root, cold=True)  # a second --cold into the same folder works
    assert not (root / "renderer-0123456789abcdef").exists()
    (root / "notes").mkdir(parents=True)
    (root / "notes" / "todo.txt").write_text("mine")
    with pytest.raises(SketchgraphError, match="not cache entries"):
        gal.node_cache(tiny, cache_dir=root, cold=True)
    assert (root / "notes" / "todo.txt").exists()
