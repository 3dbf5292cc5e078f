"""Framing a bare mesh file: the up axis (format and shape), the front (symmetry and the head's lean), and
the named views (`--view`, `--up`, scene files' `view:` / `up:`, `ng.load(view=, up=)`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from nodegraph.scene import framing, primitives
from nodegraph.scene.meshes import Mesh, merge_meshes
from nodegraph.scene.scene import load_scene, translation

PIPE = """pipeline: t
size: [96, 96]
scene: {scene}
nodes:
  g: {{type: rasterize}}
outputs:
  image: g.normal_depth
"""


def _box(lo, hi) -> Mesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return primitives.box(hi - lo).transformed(translation((lo + hi) / 2))


def figure() -> Mesh:
    """A Y-up 'character' of boxes facing +Z: a flat base, feet and a nose pointing forward, arms, a head."""
    parts = [_box((-0.6, 0.0, -0.4), (0.6, 0.1, 0.4)),  # base
             _box((-0.3, 0.1, -0.12), (-0.08, 0.2, 0.35)), _box((0.08, 0.1, -0.12), (0.3, 0.2, 0.35)),  # feet
             _box((-0.3, 0.2, -0.15), (0.3, 1.1, 0.15)),  # body
             _box((-0.45, 0.55, -0.08), (-0.3, 1.05, 0.08)), _box((0.3, 0.55, -0.08), (0.45, 1.05, 0.08)),  # arms
             _box((-0.2, 1.1, -0.18), (0.2, 1.5, 0.18)),  # head
             _box((-0.05, 1.22, 0.18), (0.05, 1.34, 0.38))]  # nose
    return merge_meshes(parts, "figure")


def write_obj(path: Path, mesh: Mesh, matrix: np.ndarray | None = None) -> Path:
    v = mesh.vertices if matrix is None else mesh.transformed(matrix).vertices
    path.write_text("".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in v)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in mesh.faces))
    return path


def write_stl(path: Path, mesh: Mesh, matrix: np.ndarray) -> Path:
    m = mesh.transformed(matrix)
    lines = ["solid t"]
    for face in m.faces:
        corners = [f"vertex {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in m.vertices[face]]
        lines += ["facet normal 0 0 0", "outer loop", *corners]
        lines += ["endloop", "endfacet"]
    path.write_text("\n".join(lines + ["endsolid t"]) + "\n")
    return path


TO_Z_UP = np.linalg.inv(framing.up_rotation("z"))  # +Y -> +Z, +Z (the front) -> -Y, as Blender has it
TO_X_FRONT = np.array([[0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]], float)  # front +Z -> +X


def coverage(gl, scene: str, **kw) -> np.ndarray:
    pipe = pl.loads(PIPE.format(scene=scene), "t.yaml", **kw)
    return Executor(pipe, None, gl=gl).run().values[("g", "normal_depth")].read()[..., 3] > 0


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum()) / float((a | b).sum())


@pytest.fixture
def files(tmp_path: Path) -> dict[str, Path]:
    fig = figure()
    return {"y": write_obj(tmp_path / "fig_y.obj", fig), "z": write_obj(tmp_path / "fig_z.obj", fig, TO_Z_UP),
            "stl": write_stl(tmp_path / "fig_z.stl", fig, TO_Z_UP),
            "x_front": write_obj(tmp_path / "fig_xf.obj", fig, TO_X_FRONT)}


def test_up_is_detected_from_the_base_and_the_format(files) -> None:
    fig = figure()
    assert framing.detect_up(fig.vertices, fig.faces, ".obj") == "y"
    z = fig.transformed(TO_Z_UP)
    assert framing.detect_up(z.vertices, z.faces, ".obj") == "z"  # the flat base says so
    ball = primitives.sphere(1.0, 2)  # no base, no tall axis: the format decides
    assert framing.detect_up(ball.vertices, ball.faces, ".stl") == "z"
    assert framing.detect_up(ball.vertices, ball.faces, ".obj") == "y"
    for key in ("y", "z", "stl"):
        s = load_scene(str(files[key]))
        lo, hi = s.bounds()
        assert hi[1] - lo[1] == pytest.approx(1.5), key  # standing: the figure's height along +Y


def test_front_is_found_by_the_head(files) -> None:
    fig = figure()
    assert np.array_equal(framing.detect_front(fig.vertices, fig.faces), [0, 0, 1])
    turned = fig.transformed(TO_X_FRONT)
    assert np.array_equal(framing.detect_front(turned.vertices, turned.faces), [1, 0, 0])
    back = fig.transformed(TO_X_FRONT @ TO_X_FRONT)  # facing -Z
    assert np.array_equal(framing.detect_front(back.vertices, back.faces), [0, 0, -1])
    s = load_scene(str(files["x_front"]), view="front")
    d = s.camera.eye - s.camera.target
    assert d[0] > 0 and abs(d[1]) < 1e-9 and abs(d[2]) < 1e-9


def test_a_z_up_copy_is_drawn_like_the_y_up_original(gl, files) -> None:
    ref = coverage(gl, str(files["y"]))
    assert iou(coverage(gl, str(files["z"]), up="z"), ref) >= 0.95
    assert iou(coverage(gl, str(files["z"])), ref) >= 0.95  # auto
    assert iou(coverage(gl, str(files["stl"])), ref) >= 0.95  # auto, STL
    assert iou(coverage(gl, str(files["z"]), up="y"), ref) < 0.8  # taken as Y-up it lies on its back


def test_views_give_the_expected_silhouettes(gl, files) -> None:
    y = str(files["y"])
    front, back = coverage(gl, y, view="front"), coverage(gl, y, view="back")
    left, right = coverage(gl, y, view="left"), coverage(gl, y, view="right")
    assert iou(front, back[:, ::-1]) >= 0.9  # mirror images of each other
    assert iou(left, right[:, ::-1]) >= 0.9
    assert iou(front, left) < 0.8  # the figure is wider than deep
    rows = np.nonzero(front.any(axis=1))[0]
    assert front.sum() > 0 and rows.max() - rows.min() > 40  # standing: tall in the picture
    assert iou(right, right[:, ::-1]) < 0.97  # the side shows the nose and the feet: not its own mirror
    s = load_scene(y, view="top")
    assert np.allclose(s.camera.basis()[2], [0, -1, 0])
    tq = load_scene(y).camera  # default: three-quarter front, from above and to the right
    d = tq.eye - tq.target
    assert d[2] > 0 and d[1] > 0 and d[0] > 0


def test_framing_options_are_errors_where_they_do_not_apply(tmp_path: Path, files) -> None:
    with pytest.raises(PipelineError, match="own camera"):
        load_scene("builtin:box", view="front")
    with pytest.raises(PipelineError, match="up"):
        load_scene(str(files["y"]), up="w")
    scene = tmp_path / "s.yaml"
    scene.write_text(f"objects:\n  - mesh: {files['z']}\n")
    with pytest.raises(PipelineError, match="per mesh object"):
        load_scene(str(scene), up="z")


def test_scene_files_take_view_and_up(tmp_path: Path, files) -> None:
    scene = tmp_path / "s.yaml"
    scene.write_text(f"objects:\n  - mesh: {files['z']}\n    up: z\ncamera: {{view: front, fov: 30}}\n")
    s = load_scene(str(scene))
    lo, hi = s.bounds()
    assert hi[1] - lo[1] == pytest.approx(1.5)
    assert np.allclose(s.camera.basis()[2], [0, 0, -1]) and s.camera.fov_y_deg == 30
    scene.write_text(f"objects:\n  - mesh: {files['z']}\n    up: auto\n")
    assert load_scene(str(scene), view="left").camera.eye[0] < 0
    scene.write_text("objects:\n  - primitive: {type: box}\ncamera: {view: front, eye: [0, 0, 5]}\n")
    with pytest.raises(PipelineError, match="not both"):
        load_scene(str(scene))
    scene.write_text("objects:\n  - primitive: {type: box}\n    up: z\n")
    with pytest.raises(PipelineError, match="stands a mesh file up"):
        load_scene(str(scene))


def test_api_and_cli_take_view_and_up(gl, files, tmp_path: Path) -> None:
    from click.testing import CliRunner

    import nodegraph as ng
    from nodegraph.cli import main

    def cli(*args: str):
        return CliRunner().invoke(main, list(args), catch_exceptions=False)

    sketchy = str(Path(__file__).parents[2] / "pipelines" / "nienhaus_sketchy.yaml")
    pipe = ng.load(sketchy, scene=files["z"],
                   view="front", up="z", size=(64, 48))
    cam = pipe.pipeline.scene.camera
    assert np.allclose(cam.basis()[2], [0, 0, -1])
    assert pipe.set({"edges.width": 2}).pipeline.scene.camera.params() == cam.params()
    out = tmp_path / "o.png"
    r = cli("run", sketchy, "--scene", str(files["z"]), "--up", "z", "--view", "back",
            "--size", "64x48", "--no-cache", "-q", "-o", str(out))
    assert r.exit_code == 0, r.output
    assert out.exists()
    r = cli("run", sketchy, "--view", "front", "--no-cache", "-q", "-o", str(out))
    assert r.exit_code == 2 and "own camera" in r.output
