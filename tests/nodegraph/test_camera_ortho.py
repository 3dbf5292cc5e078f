"""Orthographic cameras: the projection against hand-computed NDC, glTF `orthographic` cameras (ymag as half the
image's height), scene YAML `type: orthographic` with `height`, the lens options (`--camera-type`, `--fov`,
`--zoom`), linear depth along the view axis, and every shipped pipeline drawn through an orthographic camera."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from nodegraph.scene import scene as sc
from nodegraph.scene import views
from tests import gltf_files as gf
from tests.helpers import ROOT


def _ortho(**kw) -> sc.Camera:
    base = {"eye": (0.0, 0.0, 5.0), "target": (0.0, 0.0, 0.0), "up": (0.0, 1.0, 0.0),
            "projection": "orthographic", "ortho_half": 2.0, "near": 1.0, "far": 9.0}
    return sc.Camera(**{**base, **kw})


# -- the projection, by hand ------------------------------------------------------------------------------
def test_orthographic_ndc_by_hand():
    cam = _ortho()
    # wide image (aspect 2): half height 2 (the shorter side), half width 4; depth 5 is the middle of [1, 9]
    ndc = cam.project([[1.0, 1.0, 0.0], [2.0, -2.0, -4.0], [-4.0, 0.5, 4.0]], aspect=2.0)
    assert ndc == pytest.approx(np.array([[0.25, 0.5, 0.0], [0.5, -1.0, 1.0], [-1.0, 0.25, -1.0]]), abs=1e-12)
    # tall image (aspect 0.5): the shorter side is the width, half width 2, half height 4
    assert cam.project([[1.0, 1.0, 0.0]], aspect=0.5)[0] == pytest.approx([0.5, 0.25, 0.0], abs=1e-12)
    # fov_vertical (glTF's ymag): the height whatever the shape
    tall = _ortho(fov_vertical=True)
    assert tall.project([[1.0, 1.0, 0.0]], aspect=0.5)[0] == pytest.approx([1.0, 0.5, 0.0], abs=1e-12)
    m = cam.projection_matrix(2.0)
    expected = np.array([[0.25, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, -2.0 / 8.0, -10.0 / 8.0], [0, 0, 0, 1.0]])
    assert m == pytest.approx(expected, abs=1e-15)


def test_oblique_orthographic_projection_by_hand():
    """Eye on (1, 1, 1) from the origin: NDC of a point is its offsets along right and up over the half sizes."""
    cam = _ortho(eye=(3.0, 3.0, 3.0), ortho_half=1.5, near=0.5, far=10.0)
    f = -np.ones(3) / math.sqrt(3.0)
    r = np.cross(f, [0.0, 1.0, 0.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    pts = np.array([[0.3, -0.2, 0.7], [1.0, 1.0, -1.0], [-0.5, 0.0, 0.25]])
    depth = (pts - cam.eye) @ f
    expected = np.c_[pts @ r / 1.5, pts @ u / 1.5, (depth - 0.5) / 9.5 * 2.0 - 1.0]
    assert cam.project(pts) == pytest.approx(expected, abs=1e-12)


def test_parallel_edges_stay_parallel():
    """The four edges of a cube along each axis project to equal screen vectors (perspective: they converge)."""
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    cam = _ortho(eye=(2.0, 1.5, 3.0))
    persp = sc.Camera(eye=(2.0, 1.5, 3.0), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), near=1.0, far=9.0)
    for axis in range(3):
        lo = corners[corners[:, axis] < 0]
        hi = lo.copy()
        hi[:, axis] = 0.5
        d = cam.project(hi, 1.5)[:, :2] - cam.project(lo, 1.5)[:, :2]
        assert np.abs(d - d[0]).max() < 1e-12
        dp = persp.project(hi, 1.5)[:, :2] - persp.project(lo, 1.5)[:, :2]
        assert np.abs(dp - dp[0]).max() > 1e-3


def test_camera_params_keep_perspective_keys():
    persp = sc.Camera(eye=(0.0, 0.0, 5.0), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0))
    assert set(persp.params()) == {"eye", "target", "up", "fov_y_deg", "near", "far"}
    assert _ortho().params()["projection"] == "orthographic" and _ortho().params()["ortho_half"] == 2.0
    assert np.array_equal(persp.toward_eye(), [0.0, 0.0, 5.0, 1.0])
    assert np.array_equal(_ortho().toward_eye(), [0.0, 0.0, 1.0, 0.0])


@pytest.mark.parametrize("kw, match", [
    ({"ortho_half": 0.0}, "half height"), ({"ortho_half": math.inf}, "half height"),
    ({"near": -1.0}, "near"), ({"near": 5.0, "far": 5.0}, "near"), ({"projection": "fisheye"}, "camera type"),
])
def test_bad_orthographic_cameras(kw, match):
    with pytest.raises(ValueError, match=match):
        _ortho(**kw)
    _ortho(near=0.0)  # a glTF orthographic camera may have znear 0


# -- the lens: --camera-type, --fov, --zoom ------------------------------------------------------------------
def test_lens_keeps_the_target_plane_and_zoom_scales():
    persp = sc.Camera(eye=(0.0, 0.0, 5.0), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov_y_deg=40.0,
                      near=1.0, far=9.0)
    half = 5.0 * math.tan(math.radians(20.0))
    ortho = persp.with_lens("orthographic")
    assert ortho.orthographic and ortho.ortho_half == pytest.approx(half, rel=1e-12)
    assert ortho.with_lens("perspective").fov_y_deg == pytest.approx(40.0, rel=1e-12)
    # a point on the target plane lands on the same pixel through both
    p = [[0.4, -0.3, 0.0]]
    assert ortho.project(p, 1.3)[0, :2] == pytest.approx(persp.project(p, 1.3)[0, :2], abs=1e-12)
    assert ortho.with_lens(zoom=2.0).ortho_half == pytest.approx(half / 2.0, rel=1e-12)
    zoomed = persp.with_lens(zoom=2.0)
    assert math.tan(math.radians(zoomed.fov_y_deg / 2)) == pytest.approx(math.tan(math.radians(20.0)) / 2, rel=1e-12)
    assert zoomed.project(p)[0, :2] == pytest.approx(2.0 * persp.project(p)[0, :2], abs=1e-12)
    wide = persp.with_lens(fov=90.0)  # the eye moves in so the target plane keeps its extent
    assert wide.fov_y_deg == 90.0 and wide.eye == pytest.approx([0.0, 0.0, half], abs=1e-12)
    assert wide.project(p)[0, :2] == pytest.approx(persp.project(p)[0, :2], abs=1e-12)
    with pytest.raises(ValueError, match="--fov sets a perspective"):
        ortho.with_lens(fov=30.0)


def test_lens_options_reach_loaded_scenes_and_reset_per_command():
    import click
    from click.testing import CliRunner

    seen = []

    @click.command()
    @views.click_options
    def probe(view, up, fill):
        seen.append(views.LENS.get())
        seen.append(sc.load_scene("builtin:box").camera)

    runner = CliRunner()
    assert runner.invoke(probe, ["--camera-type", "orthographic", "--zoom", "2"]).exit_code == 0
    assert seen[0] == ("orthographic", None, 2.0) and seen[1].orthographic
    plain = sc.load_scene("builtin:box").camera
    assert seen[1].ortho_half == pytest.approx(plain.target_half() / 2.0, rel=1e-12)
    assert runner.invoke(probe, []).exit_code == 0  # nothing given: nothing left from the run before
    assert seen[2] == (None, None, None) and not seen[3].orthographic
    bad = runner.invoke(probe, ["--zoom", "0"])
    assert bad.exit_code != 0 and "--zoom" in bad.output
    with views.lens("orthographic"), pytest.raises(PipelineError, match="--fov sets a perspective"):
        sc.with_lens(sc.load_scene("builtin:box"), None, 30.0, None)
    with views.lens("orthographic"):
        assert sc.load_scene("builtin:box").camera.orthographic
    assert not sc.load_scene("builtin:box").camera.orthographic


# -- glTF and scene YAML ----------------------------------------------------------------------------------------
def test_gltf_orthographic_camera(tmp_path):
    scene = sc.select_camera(sc.load_scene(str(gf.two_cameras(tmp_path / "cams.glb"))), "top")
    cam = scene.camera
    assert cam.orthographic and cam.fov_vertical and cam.ortho_half == 2.0 and (cam.near, cam.far) == (0.1, 10.0)
    assert cam.eye == pytest.approx([0.0, 5.0, 0.0]) and cam.basis()[2] == pytest.approx([0.0, -1.0, 0.0])


def _scene_yaml(tmp_path, camera: str) -> str:
    path = tmp_path / "s.yaml"
    path.write_text("objects:\n  - primitive: {type: box}\ncamera: " + camera + "\n")
    return str(path)


def test_scene_yaml_orthographic_camera(tmp_path):
    cam = sc.load_scene(_scene_yaml(tmp_path, "{type: orthographic, eye: [0, 0, 6], target: [0, 0, 0], "
                                              "height: 3}")).camera
    assert cam.orthographic and cam.ortho_half == 1.5 and cam.fov_vertical
    framed = sc.load_scene(_scene_yaml(tmp_path, "{type: orthographic, view: front}")).camera
    persp = sc.load_scene(_scene_yaml(tmp_path, "{view: front}")).camera
    assert framed.orthographic and framed.ortho_half == pytest.approx(persp.target_half(), rel=1e-12)


@pytest.mark.parametrize("camera, match", [
    ("{eye: [0, 0, 6], target: [0, 0, 0], height: 3}", "'height' sizes an orthographic camera"),
    ("{type: orthographic, eye: [0, 0, 6], target: [0, 0, 0], fov: 30}", "'fov' is a perspective camera's"),
    ("{type: orthographic, view: front, height: -1}", "greater than 0"),
    ("{type: orthogonal, view: front}", "orthographic"),
    ("{type: orthographic, eye: [0, 0, 6], target: [0, 0, 0], "
     "animate: {fov: [{time: 0, value: 30}, {time: 1, value: 40}]}}", "an orthographic camera has no field of view"),
])
def test_scene_yaml_orthographic_errors_are_one_line(tmp_path, camera, match):
    with pytest.raises(PipelineError, match=match) as info:
        sc.load_scene(_scene_yaml(tmp_path, camera))
    assert "\n" not in str(info.value)


# -- drawn ------------------------------------------------------------------------------------------------------
_GBUF = """pipeline: t
size: [{w}, {h}]
scene: {scene}
nodes:
  g: {{type: rasterize}}
outputs:
  id: g.object_id
  depth: g.linear_depth
"""


def _gbuffer(gl, scene_path: str, size: tuple[int, int], camera: str | None = None):
    pipe = pl.loads(_GBUF.format(w=size[0], h=size[1], scene=scene_path), "t.yaml")
    if camera is not None:
        pipe.scene = sc.select_camera(pipe.scene, camera)
    res = Executor(pipe, None, gl=gl).run()
    return res.values[("g", "object_id")].read()[..., 0], res.values[("g", "linear_depth")].read()[..., 0]


@pytest.mark.parametrize("size", [(64, 64), (96, 64), (64, 96)])
def test_gltf_orthographic_box_covers_the_hand_computed_pixels(gl, tmp_path, size):
    """The unit box seen from above by 'top' (ymag 2: the image's height spans 4 units): 1 unit is h / 4
    pixels in both directions, the box centred; its top face at y = 0.5 is 4.5 from the eye at y = 5."""
    w, h = size
    ids, depth = _gbuffer(gl, str(gf.two_cameras(tmp_path / "cams.glb")), size, "top")
    rows, cols = np.nonzero(ids > 0)
    px = h / 4.0
    assert abs(cols.min() - (w / 2 - px / 2)) <= 1 and abs(cols.max() + 1 - (w / 2 + px / 2)) <= 1
    assert abs(rows.min() - (h / 2 - px / 2)) <= 1 and abs(rows.max() + 1 - (h / 2 + px / 2)) <= 1
    assert depth[ids > 0] == pytest.approx(4.5, abs=1e-5)


def test_linear_depth_is_the_distance_along_the_view_axis(gl, tmp_path):
    """A plane y = 0 seen obliquely: at each pixel the depth is where the ray eye + right x + up y + t f
    (parallel rays) meets the plane, computed in float64."""
    path = tmp_path / "plane.yaml"
    path.write_text("objects:\n  - primitive: {type: plane, size: 6}\n"
                    "camera: {type: orthographic, eye: [0.5, 3, 4], target: [0, 0, 0], height: 2, near: 1, far: 12}\n")
    w, h = 48, 40
    ids, depth = _gbuffer(gl, str(path), (w, h))
    cam = sc.load_scene(str(path)).camera
    r, u, f = cam.basis()
    hy = 1.0
    hx = hy * w / h
    x = ((np.arange(w) + 0.5) / w * 2.0 - 1.0) * hx
    y = ((np.arange(h) + 0.5) / h * 2.0 - 1.0) * hy
    origin = cam.eye[None, None, :] + x[None, :, None] * r + y[:, None, None] * u
    t = -origin[..., 1] / f[1]
    assert ids.min() > 0  # the plane fills the picture
    assert depth == pytest.approx(t, rel=1e-5)
    assert depth.max() - depth.min() > 1.0  # and the depth varies over it


# -- every shipped pipeline, orthographic ------------------------------------------------------------------------
def _ink(img: np.ndarray) -> np.ndarray:
    rgb = img[..., :3].astype(np.float64)
    flat = rgb.reshape(-1, 3)
    values, counts = np.unique(np.round(flat, 2), axis=0, return_counts=True)
    paper = values[counts.argmax()]
    return np.abs(rgb - paper).max(axis=-1) > 0.15


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(p.stem for p in (ROOT / "pipelines").glob("*.yaml")))
def test_every_shipped_pipeline_draws_through_an_orthographic_camera(gl, name):
    """Drawn through an orthographic view of its own scene: finite, some ink, the ink inside the scene's
    projected box (grown by a tenth of the picture for sketchy overshoot), and not the perspective picture."""
    # plotter_lines' pen widths scale with the picture: under a pixel at 96 px they are drawn light, as ink should
    size = (240, 240) if name == "plotter_lines" else (96, 96)
    with views.lens("orthographic"):
        pipe = pl.load(ROOT / "pipelines" / f"{name}.yaml", size=size)
    assert pipe.scene.camera.orthographic
    out = pipe.outputs.get("image", next(iter(pipe.outputs.values())))  # the picture (plotter_lines: not its strokes)
    img = Executor(pipe, None, requested=[out], gl=gl).run().values[out].read()
    persp = pl.load(ROOT / "pipelines" / f"{name}.yaml", size=size)
    ref = Executor(persp, None, requested=[out], gl=gl).run().values[out].read()
    assert np.isfinite(img).all()
    ink = _ink(img)
    assert ink.mean() > 0.005, f"{name}: almost no ink ({ink.mean():.4f})"
    cam = pipe.scene.camera
    lo, hi = pipe.scene.bounds()
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    ndc = cam.project(corners, size[0] / size[1])
    rows, cols = np.nonzero(ink)
    margin = 0.1 * size[0]
    px_lo = (ndc[:, :2].min(axis=0) + 1.0) * 0.5 * np.array(size) - margin
    px_hi = (ndc[:, :2].max(axis=0) + 1.0) * 0.5 * np.array(size) + margin
    # textures read with row 0 at the bottom (OpenGL order), as NDC y counts
    in_x = (cols >= px_lo[0]) & (cols < px_hi[0])
    in_y = (rows >= px_lo[1]) & (rows < px_hi[1])
    assert (in_x & in_y).mean() > 0.97, f"{name}: ink outside the scene's box"
    assert not np.array_equal(img, ref)
