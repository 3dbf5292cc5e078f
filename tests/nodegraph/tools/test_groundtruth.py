"""The line-drawing ground truth (nodegraph.tools.bench.groundtruth) against hand-computed geometry."""

from __future__ import annotations

import numpy as np
import pytest

from nodegraph.scene.meshes import Mesh
from nodegraph.scene.primitives import box, plane
from nodegraph.scene.scene import Camera, Scene, SceneObject, load_scene, translation
from nodegraph.tools.bench.groundtruth import feature_edges, line_drawing, precision_recall
from nodegraph.tools.bench.measure import gbuffer, release


def _kinds(fe):
    return {k: len(v) for k, v in fe.edges.items()}


def test_box_feature_edges_from_a_general_direction():
    mesh = box((1.0, 1.0, 1.0))
    fe = feature_edges(mesh, np.array([3.0, 2.0, 4.0]), crease_angle=40.0)
    # 12 box edges: the outline hexagon (6) between a front and a back face; the other 6 are creases
    # (3 seen, 3 hidden behind); face diagonals are flat and no line at all
    assert _kinds(fe) == {"silhouette": 6, "crease": 6, "boundary": 0, "nonmanifold": 0}
    assert fe.n_inconsistent == 0
    # a crease threshold above 90 degrees leaves only the silhouettes
    assert _kinds(feature_edges(mesh, np.array([3.0, 2.0, 4.0]), crease_angle=95.0))["crease"] == 0


def test_open_plane_has_boundary_edges_only():
    fe = feature_edges(plane(2.0, 3), np.array([0.3, 5.0, 0.2]))
    assert _kinds(fe) == {"silhouette": 0, "crease": 0, "boundary": 12, "nonmanifold": 0}


def test_a_flipped_face_is_neither_crease_nor_silhouette():
    mesh = box((1.0, 1.0, 1.0))
    faces = np.array(mesh.faces)
    faces[0] = faces[0][::-1]  # one triangle wound the other way
    flipped = Mesh("flipped", mesh.vertices, faces)
    eye = np.array([3.0, 2.0, 4.0])
    fe = feature_edges(flipped, eye)
    assert fe.n_inconsistent == 3
    assert _kinds(fe) == _kinds(feature_edges(mesh, eye))


def test_split_seams_are_welded_not_boundaries():
    m = box((1.0, 1.0, 1.0))
    v = np.asarray(m.vertices)[np.asarray(m.faces).ravel()]  # every corner its own vertex: a triangle soup
    soup = Mesh("soup", v, np.arange(len(v)).reshape(-1, 3))
    assert _kinds(feature_edges(soup, np.array([3.0, 2.0, 4.0]))) == {"silhouette": 6, "crease": 6, "boundary": 0,
                                                                     "nonmanifold": 0}


def _box_scene():
    return load_scene("builtin:box")


def _projected_visible_box_edges(scene, size):
    """The 9 visible box edges in pixels, computed independently: faces facing the eye, edges they bound."""
    lo, hi = scene.objects[0].world_bounds()
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    cam = scene.camera_at(0)
    front = []
    for axis in range(3):
        for val, side in ((lo[axis], -1), (hi[axis], 1)):
            idx = {i for i, c in enumerate(corners) if np.isclose(c[axis], val)}
            if side * (cam.eye[axis] - val) > 0:
                front.append(idx)
    segs = []
    for i in range(8):
        for j in range(i + 1, 8):
            if np.count_nonzero(~np.isclose(corners[i], corners[j])) == 1 and any({i, j} <= f for f in front):
                segs.append((i, j))
    w, h = size
    ndc = cam.project(corners, w / h)
    px = np.c_[(ndc[:, 0] * 0.5 + 0.5) * w, (ndc[:, 1] * 0.5 + 0.5) * h]
    return [(px[i], px[j]) for i, j in segs]


def _dist_to_segments(points, segs):
    d = np.full(len(points), np.inf)
    for a, b in segs:
        ab = b - a
        t = np.clip(((points - a) @ ab) / (ab @ ab), 0, 1)
        d = np.minimum(d, np.linalg.norm(points - (a + t[:, None] * ab), axis=1))
    return d


def test_box_line_drawing_matches_the_analytic_projection(gl):
    size = (320, 240)
    scene = _box_scene()
    g = gbuffer(gl, scene, size, ("linear_depth",))
    gt = line_drawing(scene, size, g["linear_depth"].read())
    release(gl, g)
    segs = _projected_visible_box_edges(scene, size)
    assert len(segs) == 9
    ys, xs = np.nonzero(gt.lines)
    d = _dist_to_segments(np.c_[xs + 0.5, ys + 0.5], segs)
    assert d.max() <= 0.75, "every ground-truth pixel lies on a visible box edge"
    for a, b in segs:  # and every visible edge is drawn along its whole length
        pts = a + np.linspace(0.02, 0.98, 60)[:, None] * (b - a)
        # (a point on a pixel border may be drawn on either side of it)
        hit = [any(gt.lines[int(y + dy), int(x + dx)] for dx in (-0.05, 0.05) for dy in (-0.05, 0.05))
               for x, y in pts]
        assert np.mean(hit) == 1.0
    assert gt.by_kind["silhouette"].sum() > 0 and gt.by_kind["crease"].sum() > 0


def test_hidden_lines_are_removed_by_the_depth_buffer(gl):
    size = (200, 200)
    near_box = SceneObject(box((1.0, 1.0, 1.0)), translation((0.0, 0.0, 1.5)), name="front")
    far_box = SceneObject(box((0.6, 0.6, 0.6)), np.eye(4), name="behind")
    cam = Camera(eye=(0.0, 0.0, 6.0), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov_y_deg=30.0, near=1.0,
                 far=20.0)
    scene = Scene("occlusion", (near_box, far_box), cam)
    g = gbuffer(gl, scene, size, ("linear_depth",))
    depth = g["linear_depth"].read()
    release(gl, g)
    both = line_drawing(scene, size, depth)
    alone = line_drawing(Scene("alone", (far_box,), cam), size, depth)
    assert alone.lines.sum() == 0, "the small box is entirely behind the big one"
    assert both.lines.sum() > 0
    # the hidden box drawn on its own depth buffer is visible
    g = gbuffer(gl, Scene("alone", (far_box,), cam), size, ("linear_depth",))
    assert line_drawing(Scene("alone", (far_box,), cam), size, g["linear_depth"].read()).lines.sum() > 0
    release(gl, g)


def test_edges_crossing_the_near_plane_are_clipped_there():
    from nodegraph.tools.bench.groundtruth import _sample_edges

    cam = Camera(eye=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), up=(0.0, 1.0, 0.0), fov_y_deg=60.0, near=0.1,
                 far=20.0)
    size = (100, 100)
    p0 = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 2.0]])  # behind the eye
    p1 = np.array([[0.0, -0.5, -5.0], [0.0, 0.0, 1.0]])  # in front / behind as well
    x, y, z, which = _sample_edges(p0, p1, cam.view_matrix(), cam.projection_matrix(1.0), size, cam.near, 0.25)
    assert set(which.tolist()) == {0}, "the edge wholly behind the near plane is dropped"
    assert z.min() == pytest.approx(cam.near, rel=1e-5) and z.max() == pytest.approx(5.0)
    assert np.isfinite(x).all() and np.isfinite(y).all()
    # the segment runs down the middle column to (0, -0.5, -5); its clipped end lies far below the image
    assert np.allclose(x, 50.0)
    assert y.max() == pytest.approx(50.0 * (1.0 - 0.1 / np.tan(np.radians(30.0))))
    assert y.min() < 0.0


def test_precision_recall_with_one_pixel_tolerance():
    truth = np.zeros((20, 20), bool)
    truth[10, 2:18] = True
    assert precision_recall(truth, truth)["f1"] == 1.0
    one_off = np.roll(truth, 1, axis=0)
    pr = precision_recall(one_off, truth, 1)
    assert pr["precision"] == 1.0 and pr["recall"] == 1.0
    two_off = np.roll(truth, 2, axis=0)
    assert precision_recall(two_off, truth, 1)["f1"] == 0.0
    half = truth.copy()
    half[10, 10:] = False
    pr = precision_recall(half, truth, 1)
    assert pr["precision"] == 1.0 and pr["recall"] == pytest.approx(9 / 16)
    empty = np.zeros_like(truth)
    assert precision_recall(empty, empty)["f1"] == 1.0
    assert precision_recall(empty, truth)["recall"] == 0.0
    with pytest.raises(ValueError):
        precision_recall(truth[:10], truth)
