"""rasterize.spin: the turn in the picture's plane of the surface under each pixel since frame 0, against angles
computed by hand: a box turning about the view axis, a camera rolling, a box turning about an axis in the
picture's plane (no turn), a skinned bar bending (each end's joint angle); and object_noise turning its pairs and
sketch its shifts by it (against the float64 references, and the same as without it at frame 0)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pygltflib as g
import pytest
from nodegraph_nodes.object_noise import ObjectNoise
from nodegraph_nodes.sketch import Sketch
from nodegraph_nodes.sketch.reference import sketch as sketch_ref

import nodegraph as ng
from nodegraph.node import derive_seed
from nodegraph.scene import scene as sc
from tests import gltf_files as gf
from tests.helpers import inspect_probe

W, H = 96, 80
FPS = 24.0
PROBE = """pipeline: spin-probe
size: [96, 80]
scene: builtin:box
seed: 3
nodes:
  gbuf: {type: rasterize, params: {enlarge: 0.05}}
  noise:
    type: object_noise
    in: {position: gbuf.position}
    params: {scale: 3.0, octaves: 1, mode: fbm}
  tnoise:
    type: object_noise
    in: {position: gbuf.position, spin: gbuf.spin}
    params: {scale: 3.0, octaves: 1, mode: fbm}
  plain: {type: rasterize}
  edges:
    type: edge_detect
    in: {normal_depth: plain.normal_depth}
  sketch:
    type: sketch
    in: {edges: edges.out, shade: plain.color, offset: noise.out, spin: gbuf.spin}
    params: {edge_matrix: [[0.03, 0.012], [0.0, 0.02]], shade_matrix: [[-0.02, 0.004], [-0.01, -0.012]]}
outputs:
  image: sketch.color
"""
PROBE_PARAMS = Sketch.Params(edge_matrix=((0.03, 0.012), (0.0, 0.02)), shade_matrix=((-0.02, 0.004), (-0.01, -0.012)))


def scene_file(path: Path, axis: tuple[float, float, float] | None, roll: float = 0.0) -> Path:
    """A 1.6 x 0.6 x 0.4 box turning 90 degrees about `axis` over 1 s (None: still), seen by a camera at z = 6
    looking down -Z that rolls `roll` degrees about its view axis over the same second."""
    b = gf.Builder()
    box = b.node(mesh=b.mesh(gf.BOX_V * np.float32([1.6, 0.6, 0.4]), gf.BOX_F), name="box")
    b.doc.cameras.append(g.Camera(type="perspective", name="cam",
                                  perspective=g.Perspective(yfov=0.6, znear=1.0, zfar=20.0)))
    cam = b.node(camera=0, name="cam_node", translation=[0.0, 0.0, 6.0])
    if axis is not None:
        b.animate(box, "rotation", [0.0, 1.0], np.array([gf.quat_axis(axis, 0), gf.quat_axis(axis, 90)]))
    if roll:
        b.animate(cam, "rotation", [0.0, 1.0], np.array([gf.quat_axis((0, 0, 1), 0), gf.quat_axis((0, 0, 1), roll)]))
    return b.save(path)


def run(tmp_path: Path, scene: Path, frame: int, ports: tuple[str, ...]) -> dict[str, np.ndarray]:
    return dict(zip(ports, inspect_probe(tmp_path, PROBE, scene, (W, H), [(p, frame) for p in ports]), strict=True))


def angles(spin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The covered pixels' angles in degrees, and the covered mask."""
    covered = np.linalg.norm(spin[..., :2], axis=-1) > 0
    return np.degrees(np.arctan2(spin[..., 1], spin[..., 0]))[covered], covered


@pytest.mark.parametrize("axis,roll,turn", [((0, 0, 1), 0.0, 1.0), (None, 30.0, -1.0 / 3.0)],
                         ids=["object", "camera-roll"])
def test_spin_of_a_turn_about_the_view_axis(gl, tmp_path, axis, roll, turn):
    """A box turning about the view axis turns in the picture by its angle; a camera rolling turns the picture the
    other way: 90 * t degrees and -30 * t at t = frame / 24."""
    frame = 9
    out = run(tmp_path, scene_file(tmp_path / "s.glb", axis, roll), frame, ("gbuf.spin", "gbuf.position"))
    a, covered = angles(out["gbuf.spin"])
    assert np.array_equal(covered, out["gbuf.position"][..., 3] > 0) and covered.sum() > 300
    np.testing.assert_allclose(a, 90.0 * turn * frame / FPS, atol=1e-3)
    np.testing.assert_allclose(np.linalg.norm(out["gbuf.spin"][covered], axis=-1), 1.0, atol=1e-6)


def test_a_turn_about_an_axis_in_the_pictures_plane_is_no_spin(gl, tmp_path):
    """Turning about +Y (in the picture's plane) maps the picture's axes by [[cos, 0], [0, 1]]: the nearest
    rotation is none."""
    out = run(tmp_path, scene_file(tmp_path / "s.glb", (0, 1, 0)), 15, ("gbuf.spin",))
    a, covered = angles(out["gbuf.spin"])
    assert covered.sum() > 300
    np.testing.assert_allclose(a, 0.0, atol=1e-3)


def noise_reference(out: dict[str, np.ndarray], path: Path, frame: int, node_id: str = "noise",
                    spin: bool = False) -> np.ndarray:
    """object_noise's float64 reference at the read-back positions (seed 3), turned by the read-back spin where
    `spin`."""
    node = ObjectNoise(node_id, ObjectNoise.Params(scale=3.0, octaves=1, mode="fbm"))
    scene = sc.load_scene(str(path)).at(frame)
    return node.reference(out["gbuf.position"], derive_seed(3, node_id, 0), scene,
                          out["gbuf.spin"] if spin else None)


def sketch_reference(out: dict[str, np.ndarray], spin: bool = True) -> dict[str, np.ndarray]:
    """sketch's float64 reference on the read-back maps (inspect gives rows top-down; the reference's row 0 is the
    bottom, as the GPU's), its shifts turned by the read-back spin where `spin`."""
    p = PROBE_PARAMS
    up = {k: v[::-1] for k, v in out.items()}
    ref = sketch_ref(up["edges.out"][..., 0], up["plain.color"], up["noise.out"][..., :2],
                     np.asarray(p.shade_matrix), [(np.asarray(p.edge_matrix), p.edge_color)],
                     spin=up["gbuf.spin"] if spin else None)
    return {k: v[::-1] for k, v in ref.items()}


SKETCH_PORTS = ("gbuf.spin", "gbuf.position", "noise.out", "tnoise.out", "edges.out", "plain.color",
                "sketch.offsets", "sketch.color")


def test_frame_zero_and_a_still_scene_have_no_spin(gl, tmp_path):
    for path, frame in ((scene_file(tmp_path / "a.glb", (0, 0, 1)), 0), (scene_file(tmp_path / "b.glb", None), 7)):
        out = run(tmp_path, path, frame, SKETCH_PORTS)
        a, covered = angles(out["gbuf.spin"])
        assert covered.sum() > 300 and not out["gbuf.spin"][~covered].any()
        np.testing.assert_allclose(a, 0.0, atol=1e-4)
        # no turn: the shifts as without spin
        # (the noise is stored as half for the sketch's RG16F input)
        np.testing.assert_allclose(out["noise.out"][..., :2], noise_reference(out, path, frame), atol=5e-4)
        np.testing.assert_allclose(out["tnoise.out"], noise_reference(out, path, frame, "tnoise"), atol=2e-5)
        np.testing.assert_allclose(out["sketch.offsets"], sketch_reference(out, spin=False)["offsets"], atol=1e-4)


def test_spin_of_a_skinned_bend(gl, tmp_path):
    """gf.skinned_bar: joint 1 turns about +Z (the view axis here) at 90 degrees a second; vertices bound to
    joint 1 alone (x >= 1.5 in the rest pose) turn with it, those bound to joint 0 alone (x <= 0.5) do not; in
    between the blend of the two skin matrices, its nearest rotation, between the two angles."""
    path = gf.skinned_bar(tmp_path / "bar.glb")
    frame = 12  # 45 degrees
    scene = sc.load_scene(str(path))
    cam = scene.at(frame).camera_at(frame)
    view = np.asarray(cam.view_matrix())[:3, :3]
    # the camera of the file: what the picture's plane is; the joint turns about +Z in the world
    rz = np.array([[math.cos(math.pi / 4), -math.sin(math.pi / 4), 0], [math.sin(math.pi / 4),
                   math.cos(math.pi / 4), 0], [0, 0, 1]])
    m = view @ rz @ view.T
    want = math.degrees(math.atan2(m[1, 0] - m[0, 1], m[0, 0] + m[1, 1]))
    out = run(tmp_path, path, frame, ("gbuf.spin", "gbuf.position"))
    spin, rest = out["gbuf.spin"], out["gbuf.position"]
    a, covered = angles(spin)
    x = rest[..., 0][covered]
    assert (x < 0.4).sum() > 20 and (x > 1.6).sum() > 20
    np.testing.assert_allclose(a[x < 0.4], 0.0, atol=1e-3)
    np.testing.assert_allclose(a[x > 1.6], want, atol=1e-3)
    assert abs(want) > 10.0
    mid = a[(x > 0.6) & (x < 1.4)]
    assert mid.size and (mid > min(0.0, want) - 1e-3).all() and (mid < max(0.0, want) + 1e-3).all()


def test_object_noise_turns_its_pairs_by_the_spin(gl, tmp_path):
    """GPU against the float64 reference: the noise at the position, turned by the angle in `spin`."""
    frame = 9
    path = scene_file(tmp_path / "s.glb", (0, 0, 1))
    out = run(tmp_path, path, frame, ("gbuf.spin", "gbuf.position", "tnoise.out"))
    np.testing.assert_allclose(out["tnoise.out"], noise_reference(out, path, frame, "tnoise", spin=True), atol=2e-5)
    covered = out["gbuf.position"][..., 3] > 0
    turned = np.radians(90.0 * frame / FPS)
    plain = noise_reference(out, path, frame, "tnoise")[covered]
    rot = np.array([[math.cos(turned), -math.sin(turned)], [math.sin(turned), math.cos(turned)]])
    np.testing.assert_allclose(out["tnoise.out"][covered], plain @ rot.T, atol=2e-5)
    assert np.abs(out["tnoise.out"][covered] - plain).max() > 0.05


def test_sketch_turns_its_shifts_by_the_spin(gl, tmp_path):
    """GPU against the float64 reference: each shift through its (sheared) matrix, then turned in pixels by the
    angle in `spin` (96 x 80: not square); the box turns 90 degrees a second about the view axis."""
    frame = 9
    path = scene_file(tmp_path / "s.glb", (0, 0, 1))
    out = run(tmp_path, path, frame, SKETCH_PORTS)
    ref = sketch_reference(out)
    np.testing.assert_allclose(out["sketch.offsets"], ref["offsets"], atol=1e-4)
    err = np.abs(out["sketch.color"] - ref["color"])
    assert np.percentile(err, 99) < 1e-2 and err.max() < 5e-2, err.max()  # llvmpipe's 8-bit bilinear weights
    covered = out["gbuf.position"][..., 3] > 0
    turned = np.radians(90.0 * frame / FPS)
    rot = np.array([[math.cos(turned), -math.sin(turned)], [math.sin(turned), math.cos(turned)]])
    plain = sketch_reference(out, spin=False)["offsets"]
    for k in (0, 2):  # the edge shift and the shade shift, in pixels
        px, plain_px = out["sketch.offsets"][..., k:k + 2] * [W, H], plain[..., k:k + 2] * [W, H]
        np.testing.assert_allclose(px[covered], plain_px[covered] @ rot.T, atol=0.01)
        np.testing.assert_allclose(px[~covered], plain_px[~covered], atol=0.01)  # nothing drawn: not turned
        assert np.abs(px[covered] - plain_px[covered]).max() > 0.5


def test_a_sketch_turning_in_the_pictures_plane_keeps_its_wobble(gl, tmp_path):
    """The film setting of nienhaus_sketchy, its edge matrix sheared and x3 so the wobble reads, on a box turning
    50 degrees about the view axis, with and without `spin` into its sketch: with it the last frame is the first
    turned by 50 degrees (read back by turning the picture, bilinearly), its difference well under the one
    without (the shifts keep the picture's axes while the lines turn under them); `spin` into the noise instead
    turns the pairs but not the matrix's shear, and lands in between."""
    from scipy.ndimage import map_coordinates

    film = (Path(__file__).resolve().parents[3] / "pipelines" / "film" / "nienhaus_sketchy.yaml").read_text()
    plain_in = "in: {edges: edges.out, shade: gbuf.color, offset: noise.out, depth: gbuf.depth}"
    assert plain_in in film
    b = gf.Builder()
    box = b.node(mesh=b.mesh(gf.BOX_V * np.float32([1.2, 0.5, 0.3]), gf.BOX_F), name="bar")
    b.doc.cameras.append(g.Camera(type="perspective", name="cam",
                                  perspective=g.Perspective(yfov=0.7, znear=1.0, zfar=20.0)))
    b.node(camera=0, name="cam_node", translation=[0.0, 0.0, 4.0])
    b.animate(box, "rotation", [0.0, 11 / FPS], np.array([gf.quat_axis((0, 0, 1), 0), gf.quat_axis((0, 0, 1), 50)]))
    scene = b.save(tmp_path / "bar.glb")
    n = 256  # measured: 0.48 (noise spin 0.78) of the screen-axis difference at 256 px (thin lines resample worse
    # at smaller sizes)
    yy, xx = np.mgrid[0:n, 0:n] + 0.5 - n / 2  # rows down from the top
    th = math.radians(50.0)
    # the pixel (x, y up) of the last frame shows what the first showed at its position turned back by 50 degrees
    x, y = xx, -yy
    src_x, src_y = math.cos(th) * x + math.sin(th) * y, -math.sin(th) * x + math.cos(th) * y
    diffs = {}
    noise_in = "in: {position: enlarged.position}"
    assert noise_in in film
    for name, text in (("spin", film.replace(plain_in, plain_in[:-1] + ", spin: enlarged.spin}")), ("screen", film),
                       ("noise spin", film.replace(noise_in, noise_in[:-1] + ", spin: enlarged.spin}"))):
        path = tmp_path / f"{name}.yaml"
        path.write_text(text.replace("[[0.010, 0.0], [0.0, 0.010]]", "[[0.03, 0.012], [0.004, 0.02]]"))
        with ng.Session(cache=False) as session:
            pipe = session.load(path, scene=str(scene), size=(n, n))
            first, last = (pipe.render("image", frame=f, dtype="float32")[..., :3].mean(axis=2) for f in (0, 11))
        turned = map_coordinates(first, [-src_y + n / 2 - 0.5, src_x + n / 2 - 0.5], order=1, mode="nearest")
        diffs[name] = float(np.abs(turned - last).mean())
    assert diffs["spin"] < 0.6 * diffs["screen"], diffs
    # turning the noise pair before the sheared matrix leaves the shear on the screen: part of the way only
    assert diffs["spin"] < 0.75 * diffs["noise spin"] and diffs["noise spin"] < 0.9 * diffs["screen"], diffs


def test_alpha_mask_cut_outs_are_cut_in_the_spin_pass(gl, tmp_path):
    """A glTF quad whose texture's alpha is 1, 0, 0.78, 0.39 by column (cutoff 0.5): spin covers the kept columns
    only, pixel for pixel as the G-buffer's object ids do."""
    tex = np.zeros((4, 4, 4), np.uint8)
    tex[..., :3] = 128
    tex[..., 3] = np.array([[255, 0, 200, 100]] * 4, np.uint8)
    path = gf.textured_quad(tmp_path / "mask.gltf", tex, alpha_mode="MASK", cutoff=0.5)
    probe = tmp_path / "probe.yaml"
    probe.write_text(PROBE.replace("params: {enlarge: 0.05}", "params: {}"))
    with ng.Session(cache=False) as session:
        pipe = session.load(probe, scene=str(path), size=(64, 64))
        spin, ids = pipe.inspect("gbuf.spin", frame=0), pipe.inspect("gbuf.object_id", frame=0)[..., 0]
    a, covered = angles(spin)
    assert covered.sum() > 500 and np.array_equal(covered, ids > 0)
    np.testing.assert_allclose(a, 0.0, atol=1e-4)
