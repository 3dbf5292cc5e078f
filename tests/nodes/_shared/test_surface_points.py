"""surface_points: the points fixed on the surfaces that stroke_hatching's and particle_sketch's `surface` anchors
start from, against a float64 projection by hand."""

from __future__ import annotations

import numpy as np
from nodegraph_nodes._shared.surface_points import surface_points

from nodegraph import pipeline as pl
from nodegraph.executor import Executor

YAML = """pipeline: points
size: [160, 120]
scene: builtin:torus
nodes:
  gbuf: {type: rasterize}
outputs:
  depth: gbuf.linear_depth
  ids: gbuf.object_id
"""


def _buffers():
    pipe = pl.loads(YAML, "points.yaml")
    ex = Executor(pipe, None)
    try:
        res = ex.run(0).values
        depth = res[("gbuf", "linear_depth")].read()[..., 0].astype(np.float64)
        ids = np.rint(res[("gbuf", "object_id")].read()[..., 0]).astype(np.int64)
        return pipe.scene, depth, ids
    finally:
        ex.close()


def test_points_lie_on_the_surface_keep_only_filters_and_finer_cells_keep_every_point(gl):
    scene, depth, ids = _buffers()
    size = (160, 120)
    cam = scene.camera_at(0)
    view, proj = cam.view_matrix(), cam.projection_matrix(160 / 120)
    rows, keys = surface_points(scene, view, proj, depth, ids, size, 2.0, 0.02)
    assert len(rows) > 500 and keys.dtype == np.uint64
    assert np.all(np.diff(keys.astype(np.float64)) >= 0)  # in key order
    assert (rows[:, 2] == 1).all()
    # every point is visible: its pixel is the torus, and the depth buffer there is within 2 % of its own depth
    # (the points project inside the frame; the depth there by hand: view depth of the nearest surface point)
    ix, iy = rows[:, 0].astype(int), rows[:, 1].astype(int)
    assert ((rows[:, 0] >= 0) & (rows[:, 0] < 160) & (rows[:, 1] >= 0) & (rows[:, 1] < 120)).all()
    assert (ids[iy, ix] == 1).all()
    # a point lies on the surface: lifted back from its window position at the depth buffer's value there, it is
    # on builtin:torus (axis y, major radius 1, minor radius 0.35 in object space) up to the faceting and the
    # depth's change across a pixel (measured: median 0.005, at most 0.023; a pixel is about 0.03 here)
    d = depth[iy, ix]
    ndc = np.c_[rows[:, 0] / 80.0 - 1.0, rows[:, 1] / 60.0 - 1.0]
    eye = np.c_[ndc[:, 0] * d / proj[0, 0], ndc[:, 1] * d / proj[1, 1], -d, np.ones(len(d))]
    obj = eye @ np.linalg.inv(view @ np.asarray(scene.objects[0].transform, np.float64)).T
    x, y, z = obj[:, 0], obj[:, 1], obj[:, 2]
    off = np.abs(np.hypot(np.hypot(x, z) - 1.0, y) - 0.35)
    assert np.median(off) < 0.01 and off.max() < 0.05
    # `keep` leaves out the points whose pixel it does not keep, and the rest in the same order
    keep = np.zeros((120, 160), bool)
    keep[30:80, 40:120] = True
    kept, kept_keys = surface_points(scene, view, proj, depth, ids, size, 2.0, 0.02, keep=keep)
    want = keep[iy, ix]
    np.testing.assert_array_equal(kept, rows[want])
    np.testing.assert_array_equal(kept_keys, keys[want])
    # a point keeps its key when its face grows on screen: a finer cell keeps every coarser point
    finer, finer_keys = surface_points(scene, view, proj, depth, ids, size, 1.0, 0.02)
    by_key = dict(zip(finer_keys.tolist(), finer[:, :2].tolist(), strict=True))
    there = np.array([k in by_key for k in keys.tolist()])
    assert there.all()
    np.testing.assert_array_equal(np.array([by_key[k] for k in keys[there].tolist()]), rows[there, :2])
