"""`sketchgraph serve` in a real headless Chromium (Debian's, driven by Playwright), against a server the test
starts itself (a `sketchgraph serve` process on 127.0.0.1, a free port, a copy of a shipped pipeline in a
temporary folder) and stops. Screenshots go to $SKETCHGRAPH_SERVE_SHOTS where set (docs/serve.md's pictures).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
import yaml

from nodegraph.tools.serve.yamledit import set_params

ROOT = Path(__file__).resolve().parents[3]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


# -- writing values back (no browser) -------------------------------------------------------------------
TEXT = """\
# a comment at the top
pipeline: t   # trailing comment
nodes:
  a:
    type: x
    params: {k: 1, m: [1, 2]}   # flow mapping
  b:
    type: y
    params:
      # inside a block mapping
      mat: [[0.010, 0.0],
            [0.0, 0.010]]     # spans two lines
      s: hello

      t: 2
  c: {type: z}
outputs:
  image: b.out
"""


def test_set_params_keeps_comments_and_order():
    out = set_params(TEXT, {"a": {"k": 2.5, "new": True}, "b": {"mat": [[0.02, 0], [0, 0.02]], "s": "a b",
                                                                 "u": [1, 2]}, "c": {"w": 3}})
    doc = yaml.safe_load(out)
    assert doc["nodes"]["a"]["params"] == {"k": 2.5, "m": [1, 2], "new": True}
    assert doc["nodes"]["b"]["params"] == {"mat": [[0.02, 0], [0, 0.02]], "s": "a b", "t": 2, "u": [1, 2]}
    assert doc["nodes"]["c"] == {"type": "z", "params": {"w": 3}}
    for comment in ("# a comment at the top", "# trailing comment", "# flow mapping", "# inside a block mapping",
                    "# spans two lines"):
        assert comment in out
    assert list(doc["nodes"]["b"]["params"]) == ["mat", "s", "t", "u"]  # order kept, the new one last
    # untouched lines are byte for byte the same
    assert out.splitlines()[0:3] == TEXT.splitlines()[0:3]
    assert out.endswith("outputs:\n  image: b.out\n")


def test_set_params_refuses_a_missing_node():
    from nodegraph.errors import PipelineError

    with pytest.raises(PipelineError, match="node 'zz'"):
        set_params(TEXT, {"zz": {"k": 1}})


# -- the page in Chromium ------------------------------------------------------------------------------------
def _shots() -> Path | None:
    where = os.environ.get("SKETCHGRAPH_SERVE_SHOTS")
    return Path(where) if where else None


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (Debian: apt-get install chromium); the serve page is not checked")
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        pytest.skip("playwright is not installed (pip install playwright); the serve page is not checked")
    folder = tmp_path_factory.mktemp("serve")
    pipe = folder / "nienhaus_sketchy.yaml"
    shutil.copy(ROOT / "pipelines" / "nienhaus_sketchy.yaml", pipe)
    proc = subprocess.Popen([sys.executable, "-m", "nodegraph.cli", "serve", str(pipe), "--port", "0", "--size",
                             "400x400", "--no-cache", "--out-dir", str(folder)], cwd=folder, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    line = proc.stdout.readline()
    m = re.search(r"(http://127\.0\.0\.1:(\d+)/)\?token=(\S+)", line)
    if m is None:
        proc.kill()
        pytest.fail(f"serve printed no address: {line!r} {proc.stdout.read()}")
    try:
        yield {"url": m.group(0), "base": m.group(1), "port": int(m.group(2)), "token": m.group(3), "file": pipe}
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()


@pytest.fixture(scope="module")
def page(served):
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=["--no-sandbox"])
        pg = browser.new_page(viewport={"width": 1500, "height": 900})
        errors: list[str] = []
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(served["url"])
        pg.wait_for_function("window.sg && window.sg.lastImage && window.sg.lastImage.port === 'sprite.color'",
                             timeout=30000)
        yield pg
        browser.close()
        assert not errors, errors


def _state(pg) -> dict:
    return pg.evaluate("window.sg.state")


def _shot(pg, name: str) -> None:
    where = _shots()
    if where is not None:
        where.mkdir(parents=True, exist_ok=True)
        pg.evaluate("document.getElementById('graph-pane').scrollLeft = 0")
        pg.screenshot(path=str(where / name))


@pytest.mark.slow
def test_graph_lists_every_node(page, served):
    spec = yaml.safe_load(served["file"].read_text())
    shown = set(page.eval_on_selector_all("[data-node]", "els => els.map(e => e.dataset.node)"))
    assert shown == set(spec["nodes"])
    state = _state(page)
    types = {n["id"]: n["type"] for n in state["nodes"]}
    assert types == {nid: n["type"] for nid, n in spec["nodes"].items()}
    for nid in spec["nodes"]:  # the first run computed every node that does work, once
        assert page.text_content(f'[data-node="{nid}"] .type') == spec["nodes"][nid]["type"]
    assert {n["id"]: n["computes"] for n in state["nodes"] if n["status"] == "computed"} == \
        {"gbuf": 1, "edges": 1, "noise": 1, "sketch": 1}
    # the columns wrap to the pane's width: nothing to scroll sideways, every node box inside the pane
    fits = page.evaluate("""() => { const p = document.getElementById('graph-pane'), r = p.getBoundingClientRect();
        const boxes = [...document.querySelectorAll('#graph [data-node] rect')].map(e => e.getBoundingClientRect());
        return { over: p.scrollWidth - p.clientWidth, inside: boxes.every(b => b.right <= r.right + 0.5),
                 bands: Number(document.getElementById('graph').dataset.bands) }; }""")
    columns = 1 + max(n["col"] for n in state["nodes"])
    assert fits["over"] <= 0 and fits["inside"] and fits["bands"] >= 1, fits
    assert fits["bands"] > 1 or columns <= 2  # the default 1500-px page fits two columns a band
    page.set_viewport_size({"width": 2400, "height": 900})  # a wider pane: one band, drawn again on the resize
    page.wait_for_function("document.getElementById('graph').dataset.bands === '1'", timeout=5000)
    page.set_viewport_size({"width": 1500, "height": 900})
    page.wait_for_function(f"document.getElementById('graph').dataset.bands === '{fits['bands']}'", timeout=5000)


@pytest.mark.slow
def test_click_a_port_shows_its_buffer(page):
    page.click('[data-port="gbuf.normal"]')
    page.wait_for_function("window.sg.lastImage.port === 'gbuf.normal'", timeout=10000)
    img = page.evaluate("window.sg.lastImage")
    assert (img["width"], img["height"]) == (400, 400)  # the box is larger: sent at the buffer's own size
    assert "normal" in page.inner_text("#note")
    # the canvas shows it: not all one colour
    spread = page.evaluate("""() => { const c = document.getElementById('view'); const d = c.getContext('2d')
        .getImageData(0, 0, c.width, c.height).data; let lo = 255, hi = 0;
        for (let i = 0; i < d.length; i += 4) { lo = Math.min(lo, d[i]); hi = Math.max(hi, d[i]); }
        return hi - lo; }""")
    assert spread > 100
    # the value under the cursor, from the server's read-back: a unit normal in the middle of the cloister
    box = page.locator("#view").bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.wait_for_function("window.sg.probe && window.sg.probe.values", timeout=10000)
    vals = page.evaluate("window.sg.probe.values")
    assert abs(sum(v * v for v in vals[:3]) - 1.0) < 0.02
    # the canvas there shows that normal as n/2 + 1/2 in 8 bits: the PNG the page decoded kept the values
    shown = page.evaluate("""([x, y]) => { const c = document.getElementById('view');
        const r = c.getBoundingClientRect(), px = Math.floor(x - r.left), py = Math.floor(y - r.top);
        return Array.from(c.getContext('2d').getImageData(px, py, 1, 1).data); }""",
                          [box["x"] + box["width"] / 2, box["y"] + box["height"] / 2])
    assert shown[3] == 255
    assert all(abs(shown[k] - round((vals[k] * 0.5 + 0.5) * 255)) <= 1 for k in range(3)), (shown, vals)
    _shot(page, "serve-normals.png")
    first = page.evaluate("window.sg.lastImage")
    page.click('[data-port="sprite.color"]')
    page.wait_for_function("window.sg.lastImage.port === 'sprite.color'", timeout=10000)
    # looking again: the view drawn before is kept by the server, and the page holds its decoded picture, so the
    # server answers with the header alone
    page.click('[data-port="gbuf.normal"]')
    page.wait_for_function("window.sg.lastImage.port === 'gbuf.normal'", timeout=10000)
    again = page.evaluate("window.sg.lastImage")
    assert again["cached"] and again["reuse"] and again["sum"] == first["sum"]
    assert not first["reuse"]  # (drawn on the click, or in idle time before it: `cached` either way is right)
    again_px = page.evaluate("""([x, y]) => { const c = document.getElementById('view');
        const r = c.getBoundingClientRect(), px = Math.floor(x - r.left), py = Math.floor(y - r.top);
        return Array.from(c.getContext('2d').getImageData(px, py, 1, 1).data); }""",
                             [box["x"] + box["width"] / 2, box["y"] + box["height"] / 2])
    assert again_px == shown
    page.click('[data-port="sprite.color"]')
    page.wait_for_function("window.sg.lastImage.port === 'sprite.color'", timeout=10000)


@pytest.mark.slow
def test_two_panel_offsets_keep_their_shape_and_probe_both_panels(page):
    """The sketch's offsets (xy | zw, two colour wheels side by side) are shown at the two panels' own aspect,
    and a point of the right panel probes the same buffer pixel as the left panel's."""
    page.click('[data-port="sketch.offsets"]')
    page.wait_for_function("window.sg.lastImage.port === 'sketch.offsets'", timeout=15000)
    img = page.evaluate("window.sg.lastImage")
    full_w, full_h = 2 * 400 + 4, 400
    assert abs(img["width"] / img["height"] - full_w / full_h) < 0.02, img  # not squashed into the square
    assert page.inner_text("#note").startswith(f"{full_w}×{full_h} shown at")
    box = page.locator("#view").bounding_box()
    s = min(box["width"] / full_w, box["height"] / full_h)
    ox, oy = (box["width"] - full_w * s) / 2, (box["height"] - full_h * s) / 2
    for picture_x, buffer_x in ((100, 100), (404 + 250, 250)):  # left panel, right panel
        page.mouse.move(box["x"] + ox + (picture_x + 0.5) * s, box["y"] + oy + 200.5 * s)
        # (the mouse moves to whole CSS pixels, about 1.2 buffer pixels at this scale: within one pixel)
        page.wait_for_function(f"window.sg.probe && Math.abs(window.sg.probe.x - {buffer_x}) <= 1 && "
                               "window.sg.probe.values", timeout=10000)
        probe = page.evaluate("window.sg.probe")
        assert abs(probe["y"] - 200) <= 1 and len(probe["values"]) == 4
    page.click('[data-port="sprite.color"]')
    page.wait_for_function("window.sg.lastImage.port === 'sprite.color'", timeout=10000)


def test_a_two_panel_picture_fits_the_box_as_a_whole():
    import numpy as np

    from nodegraph.tools.serve.engine import View, draw, panels

    host = np.random.default_rng(3).normal(size=(60, 100, 4)).astype(np.float32)
    assert panels(100, "vector2") == (2, 1) and panels(100, "vector2", "r") == (1, 0) and panels(100, "color") == (1, 0)
    img, _, kind = draw(host, "offsets", "", View(width=150, height=300))
    assert kind == "vector2" and img.shape[:2] == (45, 151)  # each panel at 0.75 of 100 x 60, and the gap
    img, _, _ = draw(host, "offsets", "", View(width=1000, height=1000))
    assert img.shape[:2] == (60, 201)  # shown whole
    img, _, kind = draw(host, "offsets", "", View(width=150, height=300, mode="r"))
    assert kind == "grey" and img.shape[:2] == (60, 100)  # one channel: one panel


@pytest.mark.slow
def test_slider_rerenders_only_what_it_reaches(page):
    before = page.evaluate("window.sg.lastImage.sum")
    counts = {n["id"]: n["computes"] for n in _state(page)["nodes"]}
    page.click('[data-node="edges"] .type')
    slider = page.locator('input[type=range][data-param="normal_threshold"]')
    slider.wait_for()
    seq0 = page.evaluate("window.sg.seq")
    for v in ("0.3", "0.25", "0.2", "0.15"):  # a drag: values arrive faster than they render, and coalesce
        slider.fill(v)
    seq = page.evaluate("window.sg.seq")
    assert seq == seq0 + 4
    page.wait_for_function(f"window.sg.lastImage.seq === {seq} && window.sg.state.seq === {seq}", timeout=20000)
    state = _state(page)
    assert state["edits"] == {"edges": {"normal_threshold": 0.15}}
    after = {n["id"]: n["computes"] for n in state["nodes"]}
    # what the change reaches: edges and the sketch that reads it; never the G-buffer or the noise
    runs = after["edges"] - counts["edges"]
    assert 1 <= runs <= 4 and after["sketch"] - counts["sketch"] == runs
    assert after["gbuf"] == counts["gbuf"] and after["noise"] == counts["noise"]
    assert page.evaluate("window.sg.lastImage.sum") != before
    assert page.evaluate("window.sg.timings.length") >= 1
    _shot(page, "serve-page.png")


@pytest.mark.slow
def test_save_parameters_keeps_comments(page, served):
    text = served["file"].read_text()
    page.click("#save")
    for _ in range(200):  # a hang bound in polls of 50 ms
        if served["file"].read_text() != text:
            break
        time.sleep(0.05)
    new = served["file"].read_text()
    assert yaml.safe_load(new)["nodes"]["edges"]["params"]["normal_threshold"] == 0.15
    old_lines, new_lines = text.splitlines(), new.splitlines()
    assert len(old_lines) == len(new_lines)
    changed = [(a, b) for a, b in zip(old_lines, new_lines, strict=True) if a != b]
    assert changed == [("    params: {normal_threshold: 0.4, depth_threshold: 0.03, width: 2}",
                        "    params: {normal_threshold: 0.15, depth_threshold: 0.03, width: 2}")]
    page.wait_for_function("window.sg.state.notice === null || Object.keys(window.sg.state.edits).length === 0",
                           timeout=10000)
    counts = {n["id"]: n["computes"] for n in _state(page)["nodes"]}
    time.sleep(0.6)  # the server sees the file change; the same keys: nothing computes again
    assert {n["id"]: n["computes"] for n in _state(page)["nodes"]} == counts


@pytest.mark.slow
def test_broken_yaml_shows_the_located_error_then_clears(page, served):
    path = served["file"]
    good = path.read_text()
    path.write_text(good.replace("type: edge_detect", "type: edge_detekt"))
    page.wait_for_selector("#error:not([hidden])", timeout=10000)
    error = page.inner_text("#error")
    line = next(i for i, s in enumerate(good.splitlines(), 1) if "edge_detect" in s)
    assert re.search(rf"nienhaus_sketchy\.yaml:{line}:\d+", error), error
    assert "edge_detekt" in error and "\n" not in error
    _shot(page, "serve-error.png")
    path.write_text(good)
    page.wait_for_selector("#error[hidden]", state="attached", timeout=10000)
    assert _state(page)["error"] is None


@pytest.mark.slow
def test_controls_from_the_schema_and_the_frame_slider(page):
    page.click('[data-node="sketch"] .type')
    page.wait_for_selector('[data-param="edge_matrix"]')
    assert page.locator('[data-param="edge_matrix"] input[type=number]').count() == 4  # 2x2 matrix fields
    assert page.get_attribute('[data-param="edge_color"]', "type") == "color"  # RGB in 0..1: a colour picker
    assert page.evaluate("document.querySelector('[data-param=\"edge_color\"]').value") == "#1a1a1f"  # 0.1, 0.12
    # the cloister turns on an orbit (6 degrees a frame): a frame slider over one turn
    assert _state(page)["frames"] == {"start": 0, "end": 59, "fps": 24.0, "kind": "orbit"}
    before = page.evaluate("window.sg.lastImage.sum")
    page.locator("#frame").fill("5")
    page.wait_for_function("window.sg.state.frame === 5 && window.sg.lastImage.at > 0", timeout=20000)
    page.wait_for_function(f"window.sg.lastImage.sum !== {before}", timeout=20000)
    page.locator("#frame").fill("0")
    page.wait_for_function("window.sg.state.frame === 0", timeout=20000)


@pytest.mark.slow
def test_requests_without_the_token_are_refused(served):
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    base, token, port = served["base"], served["token"], served["port"]

    def status(url: str, headers: dict | None = None) -> int:
        try:
            with urllib.request.urlopen(urllib.request.Request(url, headers=headers or {}), timeout=5) as r:
                return r.status
        except urllib.error.HTTPError as exc:
            return exc.code

    assert status(f"{base}api/state?token={token}") == 200
    assert status(f"{base}api/state") == 403
    assert status(f"{base}?token=wrong") == 403
    assert status(f"{base}static/app.js") == 403
    assert status(f"{base}api/state?token={token}", {"Origin": "http://evil.example"}) == 403
    assert status(f"{base}api/state?token={token}", {"Host": f"evil.example:{port}"}) == 403
    ws = f"ws://127.0.0.1:{port}/ws"
    for url, origin in ((ws, None), (f"{ws}?token=wrong", None), (f"{ws}?token={token}", "http://evil.example")):
        with pytest.raises(InvalidStatus) as info:
            connect(url, origin=origin, open_timeout=5).close()
        assert info.value.response.status_code == 403
    with connect(f"{ws}?token={token}", origin=f"http://127.0.0.1:{port}", open_timeout=5) as conn:
        assert json.loads(conn.recv(timeout=5))["type"] == "state"


# -- drawing and statistics against float64 references (no browser) -------------------------------------------
def test_fast_colour_path_matches_a_float64_reference():
    import numpy as np

    from nodegraph.tools.serve.engine import _fast_rgba8

    rng = np.random.default_rng(3)
    host = rng.random((37, 53, 4), dtype=np.float32)
    out = _fast_rgba8(host)
    ref = np.rint(np.clip(host[::-1, :, :3].astype(np.float64), 0, 1) * 255)  # row 0 at the top
    assert out.shape == (37, 53, 4) and (out[:, :, 3] == 255).all()
    assert np.abs(out[:, :, :3].astype(np.int64) - ref).max() <= 1  # float32 rounding near .5 only
    assert (out[:, :, :3] == ref).mean() > 0.99
    host[5, 7, 1] = np.inf  # anything not plain colour goes the exact way
    assert _fast_rgba8(host) is None
    assert _fast_rgba8(rng.random((4, 4, 4), dtype=np.float32) * 3) is None


def test_channel_stats_match_float64():
    import numpy as np

    from nodegraph.tools.serve.engine import channel_stats

    host = np.random.default_rng(4).normal(size=(31, 17, 4)).astype(np.float32)
    flat = host.reshape(-1, 4).astype(np.float64)
    for k, s in enumerate(channel_stats(host)):
        assert (s["min"], s["max"]) == (flat[:, k].min(), flat[:, k].max())
        assert abs(s["mean"] - flat[:, k].mean()) < 1e-12
    host[0, 0, 2] = np.nan
    assert channel_stats(host)[2]["nan"] == 1


# -- the view as sent: 8-bit drawings against viz's float drawing, PNG bytes against an independent decoder -----
def _viz_u8(kind, a):
    import numpy as np

    from nodegraph.tools import viz

    img, note = viz._DRAW[kind](a)
    return np.rint(np.clip(img.astype(np.float64), 0, 1) * 255).astype(np.uint8), note


def test_fast_whole_drawings_match_viz():
    import numpy as np

    from nodegraph.tools.serve.engine import _FAST_WHOLE, Indexed

    rng = np.random.default_rng(7)
    cases = []
    for kind, c in (("grey", 1), ("depth", 1), ("normals", 4), ("normals", 3), ("position", 4)):
        a = rng.random((29, 41, c), dtype=np.float32)
        cases.append((kind, a))
        cases.append((kind, a * 6 - 2))  # outside 0..1: normalised (grey), clipped (normals)
    d = rng.random((29, 41, 1), dtype=np.float32)
    d[:7] = 1.0  # far plane and
    d[:, :5] = 0.0  # cleared depth: no surface, drawn in the background colour
    cases.append(("depth", d))
    cases.append(("depth", np.ones((9, 8, 1), np.float32)))  # no surface at all: all of it counts
    for kind, c in (("vector", 2), ("vector2", 4)):  # colour wheels: float32 angles, hues looked up in a table
        v = (rng.random((29, 41, c), dtype=np.float32) * 2 - 1) * 0.01
        v[3, 4] = 0.0  # no direction: black
        v[0, 0, 0], v[0, 0, 1] = -0.01, 0.0  # arctan2's +-pi: cyan either way
        cases.append((kind, v))
    ids = rng.integers(0, 9, (29, 41, 1)).astype(np.float32)
    ids[0, :3] = 8.4  # rounded to the nearest id
    cases.append(("ids", ids))
    pos = rng.normal(size=(29, 41, 4)).astype(np.float32)
    pos[:, :, 3] = rng.random((29, 41)) > 0.3  # alpha: covered or not
    cases += [("position", pos), ("position", pos[:, :, :3].copy())]
    for kind, a in cases:
        flipped = a[::-1]  # as `draw` passes it: row 0 at the top
        got, note = _FAST_WHOLE[kind](flipped)
        want, want_note = _viz_u8(kind, flipped)
        if isinstance(got, Indexed):
            got = got.rgb()
        if got.ndim == 2:
            got = np.repeat(got[:, :, None], 3, axis=2)
        assert note == want_note
        # viz rounds its float32 values; float64 rounding of the same values differs only exactly at .5
        assert np.abs(got[:, :, :3].astype(int) - want).max() <= 1, kind
        assert (got[:, :, :3] == want).mean() > 0.99, kind
        if got.shape[2] == 4:
            assert (got[:, :, 3] == 255).all()
    bad = rng.random((6, 5, 4), dtype=np.float32)
    bad[2, 3, 3] = np.nan  # anything not finite goes viz's way (NaN painted magenta)
    assert all(_FAST_WHOLE[k](bad if k in ("normals", "vector2", "position") else bad[:, :, 3:] if k != "vector"
                              else bad[:, :, 2:]) is None for k in _FAST_WHOLE)


def test_view_png_decodes_to_what_was_drawn():
    import io

    import numpy as np

    image = pytest.importorskip("PIL.Image")
    from nodegraph.tools.serve.engine import _DEPTH_PALETTE, Indexed, encode_png

    rng = np.random.default_rng(8)
    pictures = [rng.integers(0, 256, (37, 23), dtype=np.uint8),  # grey
                rng.integers(0, 256, (37, 23, 3), dtype=np.uint8),  # RGB
                rng.integers(0, 256, (37, 23, 4), dtype=np.uint8),  # RGBA
                np.zeros((1, 1, 3), np.uint8)]
    smooth = np.add.outer(np.arange(64), np.arange(48)).astype(np.uint8)  # the "up" filter's case
    pictures.append(np.dstack([smooth, smooth.T[:48, :64].T, 255 - smooth]))
    for pic in pictures:
        got = np.asarray(image.open(io.BytesIO(encode_png(pic))))
        assert got.shape == pic.shape and (got == pic).all()
    index = rng.integers(0, 256, (19, 31), dtype=np.uint8)
    got = np.asarray(image.open(io.BytesIO(encode_png(Indexed(index, _DEPTH_PALETTE)))).convert("RGB"))
    assert (got == _DEPTH_PALETTE[index]).all()
    assert (_DEPTH_PALETTE[0] == [13, 18, 46]).all()  # viz.BACKGROUND (0.05, 0.07, 0.18) in 8 bits
    assert (_DEPTH_PALETTE[1:, 0] == np.arange(1, 256)).all()


def test_view_cache_drops_old_values_and_the_least_recent(monkeypatch, tmp_path):
    from nodegraph.tools.serve import engine as eng

    e = eng.Engine(tmp_path / "p.yaml", open_pipeline=lambda _: None)
    monkeypatch.setattr(eng, "VIEW_CACHE_BYTES", 250)
    a, b = ("n", "a"), ("n", "b")
    e._keep_view((a, "k1", "auto"), {}, b"x" * 100)
    e._keep_view((a, "k1", "r"), {}, b"x" * 100)  # another drawing of the same value: both kept
    assert len(e._views) == 2 and e._views_bytes == 200
    e._keep_view((a, "k2", "auto"), {}, b"x" * 100)  # the port's value changed: its older drawings go
    assert list(e._views) == [(a, "k2", "auto")] and e._views_bytes == 100
    e._keep_view((b, "k1", "auto"), {}, b"x" * 100)
    e._keep_view((b, "k1", "r"), {}, b"x" * 100)  # over the budget: the least recently kept goes first
    assert list(e._views) == [(b, "k1", "auto"), (b, "k1", "r")] and e._views_bytes == 200


# -- the idle prefetch, in process (the render thread and GL, no browser) --------------------------------------
def _engine(tmp_path, size="96x96"):
    from nodegraph.gpu import gl as glmod
    from nodegraph.render import open_pipeline
    from nodegraph.tools.serve.engine import Engine

    glmod.get()  # the process's context current on this (the main) thread, as the rest of the suite leaves it:
    # the engine's render thread makes a context of its own

    pipe = tmp_path / "nienhaus_sketchy.yaml"
    shutil.copy(ROOT / "pipelines" / "nienhaus_sketchy.yaml", pipe)

    def load(extra):
        return open_pipeline(str(pipe), extra, size, None, out_dir=tmp_path, allow_outside=False)

    return Engine(pipe, open_pipeline=load, roots=[tmp_path])


def _wait(cond, what, polls=3000):
    """Poll `cond` every 20 ms, at most `polls` times (a hang bound counted in polls, not read off the clock: a
    busy machine takes longer between polls but is allowed as many)."""
    for _ in range(polls):
        if cond():
            return
        time.sleep(0.02)
    assert cond(), f"gave up waiting for {what} after {polls} polls"


def _client(e):
    """Client 1 of engine `e`, its messages collected: returns images(port), the image headers sent for `port`."""
    import threading

    got: list = []
    lock = threading.Lock()

    def send(msg):
        with lock:
            got.append(msg[0] if isinstance(msg, tuple) else msg)

    def images(port):
        with lock:
            return [m for m in got if m.get("type") == "image" and m.get("port") == port]

    e.add_client(1, send)
    return images


class _HeldClock:
    """The serve engine's `time` with `monotonic` held where the test puts it (the rest real): its quiet period
    passes only when the test moves the clock on."""

    def __init__(self) -> None:
        self.now = time.monotonic()
        self.perf_counter, self.sleep, self.time = time.perf_counter, time.sleep, time.time

    def monotonic(self) -> float:
        return self.now


def test_prefetch_makes_a_later_view_a_read_back(tmp_path, monkeypatch):
    from nodegraph.tools.serve import engine as engine_module
    from nodegraph.tools.serve.engine import QUIET_S

    e = _engine(tmp_path)
    images = _client(e)
    e.start()
    try:
        _wait(lambda: e.result is not None and images("sprite.color"), "the first image")
        made = {(n, p) for n, p in e._made}
        assert ("gbuf", "normal") not in made  # a port the ordinary run does not make
        _wait(lambda: e._prefetch_next() is None, "the first prefetch")
        counts = dict(e.counts)
        clock = _HeldClock()
        monkeypatch.setattr(engine_module, "time", clock)
        e.submit(1, {"op": "set", "node": "edges", "param": "normal_threshold", "value": 0.2, "seq": 1})
        _wait(lambda: e.seq == 1 and len(images("sprite.color")) >= 2, "the change's image")
        # the change alone computes what it reaches, and plans only the ordinary ports of those nodes
        assert {n: e.counts[n] - counts.get(n, 0) for n in e.counts} == {"gbuf": 0, "edges": 1, "noise": 0,
                                                                       "sketch": 1}  # (sprite passes through)
        assert ("edges", "profile") not in e.result.values
        assert ("gbuf", "normal") in e.result.values  # prefetched before, and the change left gbuf's key alone
        pre = dict(e.prefetch_counts)
        assert e._prefetch_next() is not None and e._prefetch_due() == e._last_msg + QUIET_S
        time.sleep(2 * QUIET_S)  # real time passes, the engine's does not: nothing before the quiet period
        assert e.prefetch_counts == pre and e._prefetch_next() is not None
        with e._lock:
            clock.now += QUIET_S
            e._lock.notify_all()
        _wait(lambda: e._prefetch_next() is None, "the prefetch after the change")
        # the prefetch computed again only the changed nodes with ports the ordinary run does not make
        assert {n: e.prefetch_counts.get(n, 0) - pre.get(n, 0) for n in ("gbuf", "noise", "edges", "sketch")} \
            == {"gbuf": 0, "noise": 0, "edges": 1, "sketch": 1}
        assert e.counts == {**counts, "edges": counts["edges"] + 1, "sketch": counts["sketch"] + 1}
        # (the compute counts the page shows: the ordinary runs only)
        runs, pre = dict(e.counts), dict(e.prefetch_counts)
        ex = e._ex
        for port in ("edges.profile", "gbuf.normal", "sketch.offsets"):
            n = len(images(port))
            e.submit(1, {"op": "view", "port": port, "width": 96, "height": 96})
            _wait(lambda port=port, n=n: len(images(port)) > n, f"the view of {port}")
            head = images(port)[-1]
            assert not head.get("empty") and not head.get("ran"), head
        assert e.counts == runs and e.prefetch_counts == pre and e._ex is ex  # nothing ran again
        st = e.state()
        assert not st["prefetch"]["pending"]
        assert st["prefetch"]["memory_bytes"] > st["prefetch"]["memory_run_bytes"] > 0
        assert {n["id"]: n["computes"] for n in st["nodes"]} == {n: runs.get(n, 0) for n in e.pipe.nodes}
    finally:
        e.stop()


def test_idle_drawing_makes_a_first_view_a_kept_picture(tmp_path):
    e = _engine(tmp_path)
    images = _client(e)
    e.start()
    try:
        e.submit(1, {"op": "view", "port": "sprite.color", "width": 96, "height": 96})  # the page's box
        _wait(lambda: e.result is not None and images("sprite.color"), "the first image")
        _wait(lambda: e._prefetch_next() is None and e._predraw_next() is None, "the idle drawing")
        host_before = set(e._host)
        for port in ("gbuf.normal", "edges.profile"):
            assert tuple(port.split(".")) not in host_before  # drawn without keeping the read-back
            e.submit(1, {"op": "view", "port": port, "width": 96, "height": 96})
            _wait(lambda port=port: images(port), f"the view of {port}")
            head = images(port)[-1]
            assert head["cached"] and head["encode_ms"] == 0.0 and not head.get("ran"), head
            assert head["width"] == 96 and head["height"] == 96
    finally:
        e.stop()


def test_a_texture_array_strip_is_reduced_before_it_is_coloured():
    import numpy as np

    from nodegraph.tools import viz
    from nodegraph.tools.serve.engine import View, draw_array

    colours = np.array([[0.2, 0.4, 0.6, 1.0], [0.9, 0.1, 0.3, 1.0], [0.5, 0.5, 0.5, 1.0]], np.float32)
    host = np.broadcast_to(colours[:, None, None, :], (3, 200, 100, 4)).copy()  # 3 layers, each one colour
    host[1, :100] = [0.0, 0.0, 0.0, 1.0]  # layer 1: its lower half (GL order: row 0 at the bottom) black
    img, note, kind, full = draw_array(host, "color", "", View(width=61, height=400))
    assert full == (3 * 102 - 2, 200) and kind == "strip" and note == "3 layers (color)"
    # the strip fits the box's width, scale 61 / 304: tiles 40 x 20 px, gaps of 1 px (2 x 0.2 rounded up to a pixel);
    # 3 tiles of 20 and 2 gaps are 62 px, one too many, so the tiles give way to 19 px
    th, tw, g = 40, 19, 1
    assert img.shape == (th, 3 * (tw + g) - g, 3)
    for i in (0, 2):
        want = np.broadcast_to(colours[i, :3], (th, tw, 3))
        np.testing.assert_allclose(img[:, i * (tw + g):i * (tw + g) + tw], want, atol=1e-6)
    tile = img[:, tw + g:2 * tw + g]  # shown top-down: the upper half the layer's colour, the lower half black
    upper = np.broadcast_to(colours[1, :3], (th // 2 - 1, tw, 3))
    np.testing.assert_allclose(tile[: th // 2 - 1], upper, atol=1e-6)
    np.testing.assert_allclose(tile[th // 2 + 1:], 0.0, atol=1e-6)
    np.testing.assert_allclose(img[:, tw:tw + g], np.broadcast_to(viz.SHEET_BG, (th, g, 3)))  # the gap
    assert draw_array(host, "color", "", View(width=400, height=400)) is None  # shown whole: the exact path
    many = np.zeros((32, 256, 256, 1), np.float32)  # 32 layers in rows of 16 into an 800-px box: within it
    strip = draw_array(many, "tones", "", View(width=800, height=800))[0]
    assert strip.shape[1] <= 800 and strip.shape[0] <= 800


def test_the_render_thread_sees_the_command_line_options(tmp_path):
    """--front, --animation, the lens: options that take effect as they are parsed reach the render thread."""
    import threading

    from nodegraph.errors import PipelineError
    from nodegraph.scene import views
    from nodegraph.tools.serve.engine import Engine

    seen: list = []
    opened = threading.Event()

    def load(extra):
        seen.append((views.FRONT.get(), views.LENS.get(), views.ANIMATION.get()))
        opened.set()
        raise PipelineError("stop here")

    e = Engine(tmp_path / "p.yaml", open_pipeline=load, roots=[tmp_path])
    with views.facing("-x"), views.lens("orthographic", None, 2.0), views.playing("walk", None):
        e.start()
    try:
        assert opened.wait(30)
    finally:
        e.stop()
    assert seen[0] == ("-x", ("orthographic", None, 2.0), "walk")
