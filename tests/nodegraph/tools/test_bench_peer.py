"""`sketchgraph bench peer` without Blender: the one-line skip where bpy is absent, the view handed to Blender
against sketchgraph's framing (pure Python), and the schedule, median and ratio bookkeeping (a stub worker stands
in for Blender). No timing is asserted."""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import nodegraph as ng
from nodegraph.cli import main
from nodegraph.errors import SketchgraphError
from nodegraph.output.svg import read_layers
from nodegraph.scene.scene import mesh_scene
from nodegraph.tools.bench import peer


def _no_bpy(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(peer, "bpy_importable_here", lambda: False)
    monkeypatch.delenv(peer.VENV_ENV, raising=False)


def _box_obj(path: Path, ext: tuple[float, float, float] = (1.0, 1.5, 3.0), at=(0.3, -0.2, 1.0)) -> Path:
    """An OBJ of a box off the origin, longest along Z."""
    lo, hi = np.asarray(at), np.asarray(at) + np.asarray(ext)
    v = [[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    lines = [f"v {x} {y} {z}" for x, y, z in v] + [f"f {a + 1} {b + 1} {c + 1} {d + 1}" for a, b, c, d in quads]
    path.write_text("\n".join(lines) + "\n")
    return path


# -- without bpy -----------------------------------------------------------------------------------------------------
def test_without_bpy_the_command_prints_one_line_and_exits_0(monkeypatch: pytest.MonkeyPatch):
    _no_bpy(monkeypatch)
    res = CliRunner().invoke(main, ["bench", "peer", "--rounds", "1"])
    assert res.exit_code == 0, res.output
    assert res.output == peer.SKIP_LINE + "\n"
    assert "bpy==5.0.1" in peer.SKIP_LINE and "SKETCHGRAPH_PEER_VENV" in peer.SKIP_LINE


def test_a_venv_without_bpy_is_no_blender(monkeypatch: pytest.MonkeyPatch, tmp_path: Path):
    _no_bpy(monkeypatch)
    monkeypatch.setenv(peer.VENV_ENV, str(tmp_path / "no-such-venv"))
    assert peer.find_blender_python() is None
    res = CliRunner().invoke(main, ["bench", "peer"])
    assert (res.exit_code, res.output) == (0, peer.SKIP_LINE + "\n")


def test_an_explicit_python_without_bpy_is_an_error(monkeypatch: pytest.MonkeyPatch):
    _no_bpy(monkeypatch)
    if peer._finds_bpy(sys.executable):
        pytest.skip("this Python imports bpy")
    with pytest.raises(SketchgraphError, match="cannot import bpy"):
        peer.find_blender_python(sys.executable)


# -- the view Blender is given ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(("size", "up"), [((800, 800), None), ((800, 600), "z"), ((600, 800), "z")])
def test_the_exported_camera_is_sketchgraphs_framing(tmp_path: Path, size: tuple[int, int], up: str | None):
    path = _box_obj(tmp_path / "tall.obj")
    pipe = ng.load("nienhaus_sketchy", scene=str(path), size=size, session=ng.Session(cache=False), up=up)  # no GL
    view = peer.peer_view(pipe.pipeline.scene, path, size)
    framed = mesh_scene(path, up=up)  # the framing on its own: stood up, the default view, fitted to the picture
    for k, v in framed.camera.params().items():
        np.testing.assert_allclose(view["camera"][k], v, rtol=1e-12, atol=1e-12)
    # the file's vertices through the object matrix are the mesh sketchgraph draws
    raw = np.array([[float(x) for x in s.split()[1:]] for s in path.read_text().splitlines() if s.startswith("v ")])
    m = np.asarray(view["object_matrix"])
    np.testing.assert_allclose(raw @ m[:3, :3].T + m[:3, 3], framed.objects[0].world_vertices(), atol=1e-9)
    if up == "z":  # `--up z`: the file's +Z is sketchgraph's up
        assert view["up_axis"] == "z"
        np.testing.assert_allclose(m[:3, :3] @ [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], atol=1e-12)
    # Blender's camera model (lens over the fitted sensor side, look-at matrix) projects the bounding box's corners
    # and centre where sketchgraph's camera does, for wide, square and tall images
    got = peer.project_blender(view["probe_points"], view["blender_camera"], size)
    ndc = framed.camera.project(view["probe_points"], aspect=size[0] / size[1])[:, :2]
    np.testing.assert_allclose(got, ndc * 0.5 + 0.5, atol=1e-9)
    assert peer.camera_match_px(view["probe_expected"], got, size) < 1e-6
    cam = view["blender_camera"]
    assert cam["sensor_fit"] == ("VERTICAL" if size[0] >= size[1] else "HORIZONTAL")
    assert (cam["clip_start"], cam["clip_end"]) == (framed.camera.near, framed.camera.far)


def test_the_file_to_world_matrix_is_solved_from_the_vertices():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(50, 3))
    turn = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])  # +Z -> +Y (a Z-up file stood up)
    m = peer.file_to_world(v, v @ turn.T + [0.5, -2.0, 1.0])
    np.testing.assert_allclose(m[:3, :3], turn, atol=1e-12)
    np.testing.assert_allclose(m[:3, 3], [0.5, -2.0, 1.0], atol=1e-12)
    assert peer.up_of(m) == "z" and peer.up_of(np.eye(4)) == "y"
    assert peer.up_of(np.diag([1.0, -1.0, -1.0, 1.0])) == "-y"
    with pytest.raises(SketchgraphError, match="vertices"):
        peer.file_to_world(v, v[:-1])
    with pytest.raises(SketchgraphError, match="affine"):
        peer.file_to_world(v, v**2)


def test_the_sun_comes_from_sketchgraphs_view_space_light(tmp_path: Path):
    path = _box_obj(tmp_path / "tall.obj")
    scene = ng.load("nienhaus_sketchy", scene=str(path), session=ng.Session(cache=False)).pipeline.scene
    view = peer.peer_view(scene, path, (800, 800))
    r, u, f = scene.camera.basis()
    light = np.asarray(view["light"])
    back_in_view = np.array([light @ r, light @ u, -(light @ f)])  # view space: x right, y up, z toward the viewer
    np.testing.assert_allclose(back_in_view, scene.light_direction, atol=1e-12)
    rot = np.asarray(view["sun_rotation"])
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rot) == pytest.approx(1.0)
    np.testing.assert_allclose(rot[:, 2], light, atol=1e-12)  # the sun's +Z (it shines along -Z) toward the light


def test_the_look_at_matrix_is_a_blender_camera():
    m = peer.look_at_matrix([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    np.testing.assert_allclose(m, np.eye(4) + np.array([[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 5.0], [0, 0, 0, 0]]))
    cam = peer.blender_camera({"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 90.0,
                               "near": 1.0, "far": 9.0}, (800, 400))
    assert cam["lens_mm"] == pytest.approx(cam["sensor_mm"] / 2.0)  # tan(45 degrees) = 1
    # a point at the top edge of a 90-degree vertical view, and one at the right edge of the wide image
    np.testing.assert_allclose(peer.project_blender([[0, 1, 4], [2, 0, 4]], cam, (800, 400)), [[0.5, 1.0], [1.0, 0.5]])


# -- the bookkeeping ------------------------------------------------------------------------------------------------
def test_the_schedule_interleaves_and_turns_round():
    rounds = peer.schedule(["p"], ["cycles", "workbench"], 3)
    pairs = [("sketchgraph:p", "blender:cycles"), ("sketchgraph:p", "blender:workbench")]
    assert rounds == [pairs, pairs[::-1], pairs]
    runs = [[w for pair in r_pairs for w in peer.order_of(pair, r)] for r, r_pairs in enumerate(rounds)]
    assert runs[0] == ["sketchgraph:p", "blender:cycles", "sketchgraph:p", "blender:workbench"]
    assert runs[1] == ["blender:workbench", "sketchgraph:p", "blender:cycles", "sketchgraph:p"]
    for run in runs:  # sides alternate: never two renders of one side in a row within a round
        assert all(a.split(":")[0] != b.split(":")[0] for a, b in zip(run, run[1:], strict=False) if a != b)


def test_medians_and_ratios():
    seconds = {"sketchgraph:p": [0.2, 0.4, 0.3, 0.1], "blender:cycles": [8.0, 12.0, 9.0, 10.0]}
    paired = {"blender:cycles/sketchgraph:p": [40.0, 30.0, 30.0, 100.0]}
    out = peer.summarize(seconds, paired)
    assert out["median_s"] == {"sketchgraph:p": pytest.approx(0.25), "blender:cycles": pytest.approx(9.5)}
    r = out["ratios"]["blender:cycles/sketchgraph:p"]
    assert r["ratio"] == pytest.approx(9.5 / 0.25)
    assert r["ratio_paired_median"] == pytest.approx(35.0)
    assert peer.camera_match_px([[0.5, 0.5], [0.0, 0.0]], [[0.5, 0.5], [0.003, 0.004]], (1000, 1000)) == \
        pytest.approx(5.0)


STUB_WORKER = """
import json, sys
def say(d): print(json.dumps({"ok": True, **d}), flush=True)
say({"op": "ready", "import_s": 0.01, "version": "stub"})
times = iter([0.5, 1.5, 1.0, 2.0, 3.0] * 100)
for line in sys.stdin:
    req = json.loads(line)
    if req["op"] == "quit": say({}); break
    if req["op"] == "load": say({"import_s": 0.1, "setup_s": 0.01, "bounds": [[0, 0, 0], [1, 1, 1]],
                                "projected": [[0.5, 0.5]] * len(req["probe_points"]), "faces": 12})
    elif req["op"] == "render": say({"render_s": next(times)})
    elif req["op"] == "info": say({"version": "stub", "gpu_backend": "none"})
    else: say({"path": req.get("path", "")})
"""


@pytest.mark.slow  # a worker process and renders
def test_the_interleaved_run_records_every_render_and_its_ratios(gl, tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    stub = tmp_path / "stub_worker.py"
    stub.write_text(STUB_WORKER)
    monkeypatch.setattr(peer, "WORKER", stub)
    mesh = _box_obj(tmp_path / "tall.obj")
    out = tmp_path / "peer.json"
    monkeypatch.setattr(peer, "find_blender_python", lambda explicit=None: sys.executable)
    res = CliRunner().invoke(main, ["bench", "peer", "--mesh", str(mesh), "--rounds", "3", "--size", "64x48",
                                    "--no-cold", "--json", str(out)])
    assert res.exit_code == 0, res.output
    b = json.loads(out.read_text())
    m = b["meshes"]["tall"]
    assert b["blender"]["version"] == "stub" and m["camera_match_px"] > 0  # the stub projects nothing
    sg, cy, wb = "sketchgraph:nienhaus_sketchy", "blender:cycles", "blender:workbench"
    assert len(m["seconds"][sg]) == 6 and len(m["seconds"][cy]) == len(m["seconds"][wb]) == 3  # 3 rounds x 2 pairs
    for way, values in m["seconds"].items():
        assert m["median_s"][way] == statistics.median(values)
    for setup in (cy, wb):
        r = m["ratios"][f"{setup}/{sg}"]
        assert r["ratio"] == pytest.approx(m["median_s"][setup] / m["median_s"][sg])
    assert set(m["first_render_s"]) == {sg, cy, wb}
    assert "tall" in res.output and "cycles" in res.output


@pytest.mark.slow  # a worker process and renders
@pytest.mark.parametrize("lone", [False, True])
def test_lone_times_a_single_render_after_the_pause(gl, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, lone: bool):
    stub = tmp_path / "stub_worker.py"
    stub.write_text(STUB_WORKER)
    monkeypatch.setattr(peer, "WORKER", stub)
    monkeypatch.setattr(peer, "find_blender_python", lambda explicit=None: sys.executable)
    monkeypatch.setattr(peer, "SETTLE_S", 0.0)
    renders = []
    real = peer.SketchgraphSide.render
    monkeypatch.setattr(peer.SketchgraphSide, "render", lambda self, *a: renders.append(a) or real(self, *a))
    out = tmp_path / "peer.json"
    res = CliRunner().invoke(main, ["bench", "peer", "--mesh", str(_box_obj(tmp_path / "tall.obj")), "--rounds", "2",
                                    "--size", "32x24", "--no-cold", "--json", str(out), *(["--lone"] if lone else [])])
    assert res.exit_code == 0, res.output
    b = json.loads(out.read_text())
    timed = len(b["meshes"]["tall"]["seconds"]["sketchgraph:nienhaus_sketchy"])
    assert timed == 4  # 2 rounds x 2 setups
    # the first (uncounted) render, then each timed render alone or after one more in a row
    assert len(renders) == 1 + timed * (1 if lone else 2)
    assert b["back_to_back"] == (0 if lone else peer.BACK_TO_BACK)
    assert ("lone render" in res.output) == lone


def test_a_pipeline_output_of_strokes_is_timed_with_its_svg(gl, tmp_path: Path):
    assert peer.split_pipeline("plotter_lines:lines") == ("plotter_lines", "lines")
    assert peer.split_pipeline("nienhaus_sketchy") == ("nienhaus_sketchy", None)
    mesh = _box_obj(tmp_path / "tall.obj")
    side = peer.SketchgraphSide((64, 48), None, None)
    try:
        side.load("tall", mesh, "plotter_lines:lines")
        assert side.render("tall", "plotter_lines:lines") > 0
        written = side.folder / "tall.svg"
        assert written.is_file() and set(read_layers(written.read_text())) >= {"crease"}
        picture = side.picture("tall", "plotter_lines:lines", tmp_path / "pictures")
        assert picture.suffix == ".svg" and picture.read_text() == written.read_text()
    finally:
        side.close()
