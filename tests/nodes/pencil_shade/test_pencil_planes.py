"""pencil_shade on flat faces (`planes`): a box's render vertices take their plane's direction, and its front face
is hatched one way all over, along its longer side as projected by the camera (checked against the camera's own
matrices), where the curvature directions measured at the corners turned the strokes from place to place."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.scene import primitives

ROOT = Path(__file__).resolve().parents[3]


def test_a_box_takes_its_planes_directions_and_a_sphere_none():
    from nodegraph_nodes._shared.planes import cached_planes
    from nodegraph_nodes.pencil_shade import plane_directions

    box = primitives.box((2.0, 1.0, 0.5))
    ra = box.render_arrays(40.0)
    dirs, on = plane_directions(box, ra)
    assert on.all() and len(on) == 24  # every corner of every face: one render vertex per face group
    planes = cached_planes(box)
    for f, tri in enumerate(np.asarray(ra.indices)):
        want = planes.along[planes.face_plane[f]]
        np.testing.assert_allclose(dirs[tri], np.tile(want, (3, 1)), atol=1e-6)
    assert plane_directions(primitives.sphere(1.0, 3), primitives.sphere(1.0, 3).render_arrays(40.0)) is None


def _shade(scene: Path, *overrides: str) -> tuple[np.ndarray, np.ndarray, object]:
    pipe = pl.load(ROOT / "pipelines" / "pencil.yaml", size=(320, 320), scene=str(scene),
                   overrides=["shade.layers=1", *overrides])
    res = Executor(pipe, None, requested=[("shade", "shade"), ("gbuf", "normal")]).run()
    return res.values[("shade", "shade")].read()[..., 0], res.values[("gbuf", "normal")].read(), pipe.scene


def _stroke_angles(shade: np.ndarray, face: np.ndarray, window: int = 24) -> np.ndarray:
    """The strokes' screen angle (radians, mod pi; x right, rows as stored) in each window of the face: across
    the dominant gradient of the structure tensor."""
    from scipy.ndimage import sobel, uniform_filter

    gx, gy = sobel(shade, 1), sobel(shade, 0)
    jxx, jxy, jyy = (uniform_filter(a * face, window) for a in (gx * gx, gx * gy, gy * gy))
    ys, xs = np.mgrid[window // 2:shade.shape[0]:window, window // 2:shade.shape[1]:window]
    keep = face[ys, xs]
    grad = 0.5 * np.arctan2(2 * jxy[ys, xs][keep], (jxx - jyy)[ys, xs][keep])
    return np.mod(grad + np.pi / 2, np.pi)


def _spread_deg(angles: np.ndarray) -> float:
    c = np.exp(2j * angles).mean()
    return float(np.degrees(0.5 * np.sqrt(-2 * np.log(abs(c)))))


@pytest.mark.slow  # two pencil renders
def test_a_box_face_is_hatched_one_way_along_its_longer_side(gl, tmp_path: Path):
    from scipy.ndimage import binary_erosion

    scene = tmp_path / "box.yaml"
    scene.write_text("scene: b\nobjects:\n  - primitive: {type: box, size: [2.4, 1.2, 1.0]}\n"
                     "camera: {eye: [1.6, 1.4, 4.2], target: [0, 0, 0], fov: 40}\n")
    spreads = {}
    for planes in (True, False):
        shade, normal, sc = _shade(scene, f"shade.planes={str(planes).lower()}")
        covered = normal[..., 3] > 0.5
        q = np.round(normal[..., :3] * 20).astype(int)
        keys, counts = np.unique(q[covered].reshape(-1, 3), axis=0, return_counts=True)
        front = binary_erosion(covered & (q == keys[np.argmax(counts)]).all(-1), iterations=6)
        assert front.sum() > 15000
        angles = _stroke_angles(shade, front)
        assert len(angles) > 20
        spreads[planes] = _spread_deg(angles)
        if planes:
            # the face's longer side is x: its direction on the screen at the face's centre, by the camera's matrices
            cam = sc.camera_at(0)
            mvp = cam.projection_matrix(1.0) @ cam.view_matrix()
            a, b = (mvp @ np.array([x, 0.0, 0.5, 1.0]) for x in (0.0, 0.1))
            d = b[:2] / b[3] - a[:2] / a[3]
            want = np.mod(np.arctan2(d[1], d[0]), np.pi)
            mean = np.mod(0.5 * np.angle(np.exp(2j * angles).mean()), np.pi)
            off = abs((mean - want + np.pi / 2) % np.pi - np.pi / 2)
            assert np.degrees(off) < 8.0, (np.degrees(mean), np.degrees(want))
    assert spreads[True] < 4.0 and spreads[False] > spreads[True] + 4.0, spreads
