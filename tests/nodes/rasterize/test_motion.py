"""rasterize.motion: where each pixel's surface point was in the previous frame, against float64 references: a
box moved and turned by keyframes, a moving glTF camera, a skinned bar bending (linear blend skinning by hand),
and disocclusion (nodegraph/output/motion.py visible_both) against a ray cast through the previous pose."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pygltflib as g
import pytest
from scipy.ndimage import binary_erosion

import nodegraph as ng
from nodegraph.output import motion as mo
from nodegraph.scene import scene as sc
from tests import gltf_files as gf
from tests.helpers import inspect_probe

W, H = 80, 64
FPS = 24.0
PROBE = """pipeline: motion-probe
size: [80, 64]
scene: builtin:box
nodes:
  gbuf: {type: rasterize}
outputs:
  image: gbuf.motion
"""


def _rot_y(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_z(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def boxes(path: Path, move_box: bool, move_camera: bool, span: tuple = ((-1, 0, 0), (1, 0, 0), 1.0)) -> Path:
    """A unit box (`move_box`: from span[0] to span[1] and a turn of 90 degrees about +Y over span[2] s), a still
    4 x 3 x 1 box centred at z = -3, and a camera at z = 6 looking down -Z (`move_camera`: to (1.5, 0.5, 6) and
    turned 10 degrees about +Y over 1 s)."""
    b = gf.Builder()
    m = b.mesh(gf.BOX_V, gf.BOX_F, color=(0.5, 0.2, 0.1))
    box = b.node(mesh=m, name="mover")
    b.node(mesh=b.mesh(gf.BOX_V, gf.BOX_F), name="still", translation=[0.0, 0.0, -3.0], scale=[4.0, 3.0, 1.0])
    b.doc.cameras.append(g.Camera(type="perspective", name="cam",
                                  perspective=g.Perspective(yfov=0.7, znear=1.0, zfar=20.0)))
    cam = b.node(camera=0, name="cam_node", translation=[0.0, 0.0, 6.0])
    if move_box:
        b.animate(box, "translation", [0.0, span[2]], np.array([span[0], span[1]]))
        b.animate(box, "rotation", [0.0, span[2]], np.array([gf.quat_axis((0, 1, 0), 0),
                                                              gf.quat_axis((0, 1, 0), 90)]))
    if move_camera:
        b.animate(cam, "translation", [0.0, 1.0], np.array([[0, 0, 6], [1.5, 0.5, 6]]))
        b.animate(cam, "rotation", [0.0, 1.0], np.array([gf.quat_axis((0, 1, 0), 0), gf.quat_axis((0, 1, 0), 10)]))
    return b.save(path)


def run(tmp_path: Path, scene: Path, frame: int, ports: tuple[str, ...]) -> dict[str, np.ndarray]:
    wanted = [(p.split("@")[0], frame - 1 if p.endswith("@prev") else frame) for p in ports]
    got = inspect_probe(tmp_path, PROBE, scene, (W, H), [(f"gbuf.{p}", f) for p, f in wanted])
    return {p: v for (p, _), v in zip(wanted, got, strict=True)}


def window(points: np.ndarray, cam) -> np.ndarray:
    """(n, 3) world points -> (n, 3) window x, y (pixels) and depth, float64."""
    clip = np.c_[points, np.ones(len(points))] @ (cam.projection_matrix(W / H) @ cam.view_matrix()).T
    ndc = clip[:, :3] / clip[:, 3:]
    return np.c_[(ndc[:, 0] * 0.5 + 0.5) * W, (ndc[:, 1] * 0.5 + 0.5) * H, ndc[:, 2] * 0.5 + 0.5]


def pixel_centres(mask: np.ndarray) -> np.ndarray:
    rows, cols = np.nonzero(mask)
    return np.c_[cols + 0.5, H - rows - 0.5]


def mover_matrix(t: float, move_box: bool, span: tuple = ((-1, 0, 0), (1, 0, 0), 1.0)) -> np.ndarray:
    m = np.eye(4)
    if move_box:
        s = t / span[2]
        m[:3, :3] = _rot_y(90.0 * s)
        m[:3, 3] = np.add(span[0], np.subtract(span[1], span[0]) * s)
    return m


STILL = np.diag([4.0, 3.0, 1.0, 1.0])
STILL[2, 3] = -3.0


@pytest.mark.parametrize("move_box,move_camera", [(True, False), (False, True), (True, True)],
                         ids=["rigid", "camera", "both"])
def test_motion_of_rigid_moves_and_camera_moves(gl, tmp_path, move_box, move_camera):
    path = boxes(tmp_path / "boxes.glb", move_box, move_camera)
    frame = 9
    out = run(tmp_path, path, frame, ("motion", "position", "object_id"))
    m, pos, oid = out["motion"], out["position"], out["object_id"][..., 0]
    prev_cam = sc.load_scene(str(path)).at(frame - 1).camera_at(frame - 1)
    # the camera by hand: translation and turn at t = 8/24
    t = (frame - 1) / FPS
    if move_camera:
        np.testing.assert_allclose(prev_cam.eye, [1.5 * t, 0.5 * t, 6.0], atol=1e-6)
    covered = m[..., 3] > 0
    assert np.array_equal(covered, oid > 0) and covered.sum() > 1000
    for index, model in ((1, mover_matrix(t, move_box)), (2, STILL)):
        sel = oid == index
        q = pos[sel][:, :3].astype(np.float64)
        want = window((np.c_[q, np.ones(len(q))] @ model.T)[:, :3], prev_cam)
        got = m[sel][:, :3].astype(np.float64)
        np.testing.assert_allclose(got[:, :2], want[:, :2], atol=5e-3)
        np.testing.assert_allclose(got[:, 2], want[:, 2], atol=2e-6)
    assert np.abs(m[covered][:, :2] - pixel_centres(covered)).max() > 0.3  # it did move


def test_frame_zero_and_a_still_scene_give_the_pixel_itself(gl, tmp_path):
    path = boxes(tmp_path / "boxes.glb", True, True)
    m = run(tmp_path, path, 0, ("motion",))["motion"]
    still = run(tmp_path, boxes(tmp_path / "still.glb", False, False), 5, ("motion", "depth"))
    for mm, depth in ((m, None), (still["motion"], still["depth"][..., 0])):
        cov = mm[..., 3] > 0
        assert cov.sum() > 1000 and not mm[~cov].any()  # background: all 0
        np.testing.assert_allclose(mm[cov][:, :2], pixel_centres(cov), atol=2e-3)
        if depth is not None:
            np.testing.assert_allclose(mm[cov][:, 2], depth[cov], atol=2e-6)
            assert mo.visible_both(mm, depth).all()
            img = np.random.default_rng(0).random((H, W))
            np.testing.assert_allclose(mo.warp(img, mm), img, atol=1e-5)


def _lbs(rest: np.ndarray, weights: np.ndarray, deg: float) -> np.ndarray:
    """The two-bone bar posed by hand: joint 0 the identity, joint 1 a turn of `deg` about +Z through (1, 0, 0)."""
    bent = (rest - [1.0, 0.0, 0.0]) @ _rot_z(deg).T + [1.0, 0.0, 0.0]
    return weights[:, :1] * rest + weights[:, 1:2] * bent


def test_motion_of_a_skinned_bend(gl, tmp_path):
    path = gf.skinned_bar(tmp_path / "bar.glb")
    frame = 12  # joint 1 at 45 degrees, 41.25 the frame before
    out = run(tmp_path, path, frame, ("motion", "position"))
    m, rest_pos = out["motion"], out["position"]
    v, faces, _, weights = gf.bar_vertices()
    v, weights, faces = v.astype(np.float64), weights.astype(np.float64), faces.astype(np.int64)
    covered = m[..., 3] > 0
    assert covered.sum() > 150
    r = rest_pos[covered][:, :3].astype(np.float64)  # the surface point in the rest pose
    # its triangle and barycentric coordinates there: the posed point is the same blend of the posed corners
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    best = np.full(len(r), -np.inf)
    bary = np.zeros((len(r), 3))
    tri = np.zeros(len(r), np.int64)
    for k in range(len(faces)):
        e1, e2, d = b[k] - a[k], c[k] - a[k], r - a[k]
        n = np.cross(e1, e2)
        off_plane = np.abs(d @ n) / np.linalg.norm(n)
        gram = np.array([[e1 @ e1, e1 @ e2], [e1 @ e2, e2 @ e2]])
        uv = np.linalg.solve(gram, np.stack([d @ e1, d @ e2]))
        bk = np.stack([1 - uv[0] - uv[1], uv[0], uv[1]], axis=1)
        score = np.where(off_plane < 1e-4, bk.min(axis=1), -np.inf)
        better = score > best
        best[better], bary[better], tri[better] = score[better], bk[better], k
    assert (best > -1e-3).all()

    def posed(deg: float) -> np.ndarray:
        corners = _lbs(v, weights, deg)[faces[tri]]  # (n, 3 corners, 3)
        return np.einsum("nk,nkj->nj", bary, corners)

    scene = sc.load_scene(str(path))
    now = window(posed(45.0), scene.at(frame).camera_at(frame))
    np.testing.assert_allclose(now[:, :2], pixel_centres(covered), atol=5e-3)  # the reference finds the point
    want = window(posed(90.0 * (frame - 1) / FPS), scene.at(frame - 1).camera_at(frame - 1))
    got = m[covered][:, :3].astype(np.float64)
    np.testing.assert_allclose(got[:, :2], want[:, :2], atol=5e-3)
    np.testing.assert_allclose(got[:, 2], want[:, 2], atol=2e-6)
    assert np.abs(got[:, :2] - now[:, :2]).max() > 1.0


def _hits_box(origin: np.ndarray, direction: np.ndarray, model: np.ndarray) -> np.ndarray:
    """Whether rays (world) meet the unit box placed by `model`; slab method in the box's own space, float64."""
    inv = np.linalg.inv(model)
    o = origin @ inv[:3, :3].T + inv[:3, 3]
    d = direction @ inv[:3, :3].T
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (-0.5 - o) / d, (0.5 - o) / d
    t_in = np.minimum(t1, t2).max(axis=-1)
    return (t_in <= np.maximum(t1, t2).min(axis=-1)) & (t_in > 0)


def test_disocclusion(gl, tmp_path):
    span = ((0, 0, 0), (-3, 3, 0), 3 / FPS)  # fast: what it uncovers of both the box and the background is pixels wide
    path = boxes(tmp_path / "boxes.glb", True, False, span)
    frame = 2
    out = run(tmp_path, path, frame, ("motion", "object_id", "depth@prev"))
    m, oid, prev_depth = out["motion"], out["object_id"][..., 0], out["depth"][..., 0]
    vis = mo.visible_both(m, prev_depth)
    cam = sc.load_scene(str(path)).camera_at(0)
    inv = np.linalg.inv(cam.projection_matrix(W / H) @ cam.view_matrix())
    px = pixel_centres(np.ones((H, W), bool))
    ndc = np.c_[px[:, 0] / W * 2 - 1, px[:, 1] / H * 2 - 1]
    near = np.c_[ndc, -np.ones(len(ndc)), np.ones(len(ndc))] @ inv.T
    far = np.c_[ndc, np.ones(len(ndc)), np.ones(len(ndc))] @ inv.T
    p0 = near[:, :3] / near[:, 3:]
    hidden_before = _hits_box(p0, far[:, :3] / far[:, 3:] - p0,
                              mover_matrix((frame - 1) / FPS, True, span)).reshape(H, W)  # the mover, in front of all
    sure_hidden = binary_erosion(hidden_before, iterations=2)
    sure_open = binary_erosion(~hidden_before, iterations=2)
    for where in (oid == 2, oid == 0):  # the still box and the background it uncovered
        assert (sure_hidden & where & binary_erosion(where, iterations=2)).sum() > 10
        assert not vis[sure_hidden & where].any()
        assert vis[sure_open & binary_erosion(where, iterations=2)].all()


def test_warp_and_visible_both_by_hand():
    # a 3 x 4 image; one pixel's point came from window (1.75, 2.0) of the previous frame: between columns 1 and 2
    # (centres 1.5, 2.5), between rows 0 and 1 from the top (window y 2.5 and 1.5)
    prev = np.arange(12, dtype=np.float64).reshape(3, 4)
    motion = np.zeros((3, 4, 4))
    motion[1, 1] = [1.75, 2.0, 0.5, 1.0]
    got = mo.warp(prev, motion)
    want = prev.copy()
    want[1, 1] = 0.5 * (0.75 * prev[0, 1] + 0.25 * prev[0, 2]) + 0.5 * (0.75 * prev[1, 1] + 0.25 * prev[1, 2])
    np.testing.assert_allclose(got, want)
    depth = np.ones((3, 4))
    depth[:2, 1:3] = 0.5
    vis = mo.visible_both(motion, depth)
    assert vis[1, 1] and not vis[:2, 1:3].ravel()[[0, 1, 3]].any() and vis[2].all()
    depth[0, 2] = 0.4  # the point is now behind a nearer surface there: hidden
    assert not mo.visible_both(motion, depth)[1, 1]
    assert mo.warping_error(prev + 1.0, prev, np.zeros((3, 4, 4)), np.ones((3, 4))) == pytest.approx(1.0)


def _moved(h: int, w: int, covered: np.ndarray, du: float, dv: float) -> np.ndarray:
    """A motion field whose covered pixels all came from (du, dv) px away (window x right, y up)."""
    rows, cols = np.mgrid[0:h, 0:w].astype(np.float64)
    m = np.zeros((h, w, 4))
    m[..., 0], m[..., 1], m[..., 2], m[..., 3] = cols + 0.5 + du, h - rows - 0.5 + dv, 0.5, 1.0
    m[~covered] = 0.0
    return m


def test_motion_boundaries_by_hand():
    # a block over columns 3-5 of a 6 x 8 image came from 3 px to the left; the sheet around it stays put. The
    # outline lies between columns 2 | 3 and 5 | 6: those four columns straddle it
    block = np.zeros((6, 8), bool)
    block[:, 3:6] = True
    m = _moved(6, 8, block, -3.0, 0.0)
    depth = np.where(block, 2.0, 0.0)
    want = np.zeros((6, 8), bool)
    want[:, [2, 3, 5, 6]] = True
    np.testing.assert_array_equal(mo.motion_boundaries(m, depth), want)
    # a surface filling the picture, sheared (u = 0.1 px per column) and sloping away by 4% of its depth a column:
    # smooth motion, no boundary; a step of 6% between rows 2 and 3 (a part in front of another): rows 2 and 3
    everywhere = np.ones((6, 8), bool)
    sheared = _moved(6, 8, everywhere, 0.0, 0.0)
    sheared[..., 0] += 0.1 * np.arange(8)
    slope = 2.0 * 1.04 ** np.arange(8)[None, :] * np.ones((6, 1))
    assert not mo.motion_boundaries(sheared, slope).any()
    step = slope.copy()
    step[3:] *= 1.06
    np.testing.assert_array_equal(mo.motion_boundaries(sheared, step).any(axis=1), [0, 0, 1, 1, 0, 0])
    assert mo.motion_boundaries(sheared, step)[2:4].all()
    # the warping error leaves the boundary out where the frame's depth is given. The block was over columns 0-2
    # (window depth 0.5) before; the sheet beside it changed by 1 on columns 2 and 6. Visible in both: the block
    # (18 px) and the sheet that was sheet (columns 6, 7: 12 px), of which column 6 (6 px) changed; off the
    # boundary only columns 4 and 7 count
    prev, prev_depth = np.zeros((6, 8)), np.ones((6, 8))
    prev_depth[:, :3] = 0.5
    frame = np.zeros((6, 8))
    frame[:, [2, 6]] = 1.0
    assert mo.visible_both(m, prev_depth).sum() == 30
    assert mo.warping_error(frame, prev, m, prev_depth) == pytest.approx(6 / 30)
    assert mo.warping_error(frame, prev, m, prev_depth, depth) == 0.0
    assert (mo.reliable(m, prev_depth, depth) == (mo.visible_both(m, prev_depth) & ~want)).all()


def test_alpha_mask_cut_outs_are_cut_in_the_motion_pass(gl, tmp_path):
    """A glTF quad whose texture's alpha is 1, 0, 0.78, 0.39 by column (cutoff 0.5): the motion pass covers the
    kept columns only, as the G-buffer does; the cut ones are background (all 0) there too."""
    tex = np.zeros((4, 4, 4), np.uint8)
    tex[..., :3] = 128
    tex[..., 3] = np.array([[255, 0, 200, 100]] * 4, np.uint8)
    path = gf.textured_quad(tmp_path / "mask.gltf", tex, alpha_mode="MASK", cutoff=0.5)
    probe = tmp_path / "probe.yaml"
    probe.write_text(PROBE)
    with ng.Session(cache=False) as session:  # square: the quad fills the picture (tests/gltf_files.py)
        pipe = session.load(probe, scene=str(path), size=(64, 64))
        m, ids = pipe.inspect("gbuf.motion", frame=0), pipe.inspect("gbuf.object_id", frame=0)[..., 0]
    w = m.shape[1] // 4
    for c, kept in enumerate((True, False, True, False)):
        block = (slice(2, -2), slice(w * c + 2, w * (c + 1) - 2))
        if kept:
            assert np.all(m[block][..., 3] == 1.0) and np.all(ids[block] > 0)
        else:
            assert not m[block].any() and not ids[block].any()
    assert np.array_equal(m[..., 3] > 0, ids > 0)  # pixel for pixel the G-buffer's coverage
    cov = m[..., 3] > 0
    np.testing.assert_allclose(m[cov][:, :2], pixel_centres(cov), atol=2e-3)
