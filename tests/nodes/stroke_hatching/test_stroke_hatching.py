"""stroke_hatching: Jobard-Lefer separation checked in float64, density by tone, a cylinder's hatching along
its axis (its minimum-curvature direction), and hatching from surface-anchored seeds carried with a turning torus."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from nodegraph_nodes.stroke_hatching import concat, hatch, streamlines
from scipy.spatial import cKDTree

from nodegraph.values import LINE_KINDS, Strokes
from tests.helpers import run_minimal

W, H = 120, 90


def circle_field(x: float, y: float):
    """Circles around (60, 45): a line field with curved streamlines."""
    dx, dy = x - 60.0, y - 45.0
    r = np.hypot(dx, dy)
    if r < 3.0:
        return None
    return (-dy / r, dx / r)


def test_streamlines_keep_the_separation_distance():
    dsep = lambda x, y: 3.0 + 6.0 * x / W  # noqa: E731 - denser on the left
    ratio = 0.5
    h = streamlines.Hatcher((W, H), circle_field, dsep, 9.0, ratio, step=1.0, min_length=0.0)
    ys, xs = np.mgrid[2:H:4, 2:W:4]
    lines = h.run(np.c_[xs.ravel(), ys.ravel()].astype(float))
    assert len(lines) > 10
    pts = np.concatenate(lines)
    owner = np.repeat(np.arange(len(lines)), [len(q) for q in lines])
    d_test = ratio * (3.0 + 6.0 * pts[:, 0] / W)
    tree = cKDTree(pts)
    for i, j in tree.query_pairs(ratio * 9.0):
        if owner[i] != owner[j]:
            dist = np.hypot(*(pts[i] - pts[j]))
            assert dist >= min(d_test[i], d_test[j]) - 1e-9, (i, j, dist)
    # and the image is covered: no point of the region farther than d_sep + step from a streamline
    probe = np.c_[xs.ravel(), ys.ravel()].astype(float)
    probe = probe[np.hypot(probe[:, 0] - 60, probe[:, 1] - 45) > 8]
    gap, _ = tree.query(probe)
    assert np.percentile(gap, 95) <= 9.0 + 1.0


def test_darker_tones_get_denser_hatching():
    bright = np.tile(np.linspace(0.0, 0.8, W), (H, 1))  # dark on the left
    ids = np.ones((H, W), np.int64)
    t = np.zeros((H // 4 + 1, W // 4 + 1, 3))
    t[..., 0] = 1.0  # horizontal everywhere
    lines = hatch(t, bright, ids, (W, H), 3.0, 12.0, 0.9, 0.5, 1.0, 0.0, 4.0)
    pts = np.concatenate(lines)
    seg = np.concatenate([np.hypot(*np.diff(q, axis=0).T) for q in lines])
    mid = np.concatenate([0.5 * (q[1:] + q[:-1]) for q in lines])
    thirds = [(mid[:, 0] >= a) & (mid[:, 0] < a + W / 3) for a in (0, W / 3, 2 * W / 3)]
    density = [seg[m].sum() / (W / 3 * H) for m in thirds]
    assert density[0] > density[1] > density[2]
    # horizontal lines spaced about d_sep: density ~ 1 / d_sep (d_sep = 3 + 9 b, b the third's mean brightness)
    for dens, b in zip(density, (0.4 / 3, 0.4, 2 * 0.4 / 3 + 0.4), strict=True):
        assert 0.5 / (3 + 9 * b) < dens < 2.2 / (3 + 9 * b)
    assert len(pts)


def cylinder_obj(path: Path, segments: int = 64, rings: int = 24) -> Path:
    a = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    ys = np.linspace(-1.0, 1.0, rings)
    verts = [(0.5 * np.cos(t), y, 0.5 * np.sin(t)) for y in ys for t in a]
    faces = []
    for r in range(rings - 1):
        for s in range(segments):
            i0, i1 = r * segments + s, r * segments + (s + 1) % segments
            j0, j1 = i0 + segments, i1 + segments
            faces += [(i0, j0, i1), (i1, j0, j1)]
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in verts] + [f"f {a+1} {b+1} {c+1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_cylinder_hatching_runs_along_its_axis(gl, tmp_path: Path):
    scene = cylinder_obj(tmp_path / "cyl.obj")
    nodes = ("  gbuf:\n    type: rasterize\n  curv:\n    type: curvature\n  hatch:\n    type: stroke_hatching\n"
             "    in: {curvature: curv.out, linear_depth: gbuf.linear_depth, normal: gbuf.normal, "
             "object_id: gbuf.object_id, position: gbuf.position}\n"
             "    params: {white: 1.0, cross_below: 0.0, spacing: [3, 8]}\n")
    _, res = run_minimal(gl, nodes, {"s": "hatch.strokes"}, size=(160, 160), scene=str(scene))
    s = res.values[("hatch", "strokes")]
    assert len(s) > 5 and (s["kind"] == LINE_KINDS.index("hatching")).all()
    seg = np.concatenate([np.diff(q.astype(np.float64), axis=0) for q in s.polylines])
    length = np.hypot(*seg.T)
    # the axis (y) projects to the screen's vertical: the strokes' angle from vertical, length-weighted
    off = np.degrees(np.arccos(np.clip(np.abs(seg[:, 1]) / np.maximum(length, 1e-12), 0, 1)))
    share = length[off < 15.0].sum() / length.sum()
    assert share > 0.9, share
    # surface points from the position buffer lie on the cylinder (radius 0.5, |y| <= 1)
    pos = s["pos"].astype(np.float64)
    ok = np.isfinite(pos).all(axis=1)
    assert ok.mean() > 0.95
    assert np.abs(np.hypot(pos[ok, 0], pos[ok, 2]) - 0.5).max() < 0.01


def test_combined_puts_lines_first():
    a = Strokes([np.zeros((2, 2))], size=(10, 10), width=2.0, attrs={"kind": np.ones(2, np.uint8)})
    b = Strokes([np.ones((3, 2))], size=(10, 10), width=0.5)
    c = concat(a, b)
    assert len(c) == 2 and list(c.starts) == [0, 2, 5]
    np.testing.assert_array_equal(c["width"], [np.nan, np.nan, 0.5, 0.5, 0.5])
    assert concat(None, b) is b


def test_principal_direction_of_a_tensor():
    t = np.array([[0.25, np.sqrt(3) / 4, 0.75]])  # d = (1/2, sqrt(3)/2): d d^T
    np.testing.assert_allclose(np.abs(streamlines.principal(t)[0]), [0.5, np.sqrt(3) / 2], atol=1e-12)


HOLD_YAML = """pipeline: hold
size: [200, 200]
reference_size: 200
scene: builtin:torus
nodes:
  gbuf: {{type: rasterize}}
  curv: {{type: curvature}}
  hatch:
    type: stroke_hatching
    in: {{curvature: curv.out, linear_depth: gbuf.linear_depth, normal: gbuf.normal, object_id: gbuf.object_id,
         position: gbuf.position}}
    params: {{anchor: {anchor}}}
outputs:
  s: hatch.strokes
"""


def _turned_torus(deg: float):
    import dataclasses

    from nodegraph.scene.scene import load_scene

    base = load_scene("builtin:torus")
    a = np.radians(deg)
    x, y, z = np.array([1.0, 0.3, 0.0]) / np.hypot(1.0, 0.3)
    c, s, t = np.cos(a), np.sin(a), 1 - np.cos(a)
    m = np.eye(4)
    m[:3, :3] = [[c + x * x * t, x * y * t - z * s, x * z * t + y * s],
                 [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
                 [z * x * t - y * s, z * y * t + x * s, c + z * z * t]]
    obj = base.objects[0]
    return dataclasses.replace(base, objects=(dataclasses.replace(obj, transform=m @ np.asarray(obj.transform)),))


def _hatching(anchor: str, scene):
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor

    pipe = pl.loads(HOLD_YAML.format(anchor=anchor), "hold.yaml")
    pipe.scene = scene
    ex = Executor(pipe, None)
    try:
        return ex.run(0).values[("hatch", "strokes")]
    finally:
        ex.close()


def test_surface_anchored_hatching_holds_to_the_surface():
    """The torus turned by 3 degrees: frame 1's hatching samples carried to frame 2 by their object-space points
    (`pos`) and the exact projection (float64); the share of frame 2's samples within 1 px of them and back.
    Seeds fixed on the surface (anchor: surface) keep about 0.8 of the hatching in place, a screen grid about 0.4
    (measured 0.79 / 0.81 against 0.39 / 0.39); unturned, both give the same strokes again."""
    shares = {}
    for anchor in ("screen", "surface"):
        first, second = _turned_torus(0.0), _turned_torus(3.0)
        a, b = _hatching(anchor, first), _hatching(anchor, second)
        pos = a["pos"].astype(np.float64)
        assert np.isfinite(pos).all()
        cam = second.camera_at(0)
        mvp = cam.projection_matrix(1.0) @ cam.view_matrix() @ np.asarray(second.objects[0].transform)
        hom = np.c_[pos, np.ones(len(pos))] @ mvp.T
        carried = (hom[:, :2] / hom[:, 3:4] + 1) * 0.5 * 200
        there, _ = cKDTree(carried).query(b.xy.astype(np.float64))
        back, _ = cKDTree(b.xy.astype(np.float64)).query(carried)
        shares[anchor] = ((there < 1).mean(), (back < 1).mean())
    assert min(shares["surface"]) > 0.7, shares
    assert min(shares["surface"]) - max(shares["screen"]) > 0.2, shares
    again = _hatching("surface", _turned_torus(0.0))
    assert np.array_equal(again.xy, _hatching("surface", _turned_torus(0.0)).xy)


def _two_object_field(w: int = 96, h: int = 72, cell: float = 4.0):
    """A small scene for hatch(): circles around the middle (tensor of the tangent d d^T per cell), a brightness
    ramp, two objects (left and right halves, a background strip at the top) and a dead cell (zero tensor)."""
    rows, cols = int(np.ceil(h / cell)), int(np.ceil(w / cell))
    gy, gx = (np.mgrid[0:rows, 0:cols] + 0.5) * cell
    dx, dy = gx - w / 2, gy - h / 2
    r = np.maximum(np.hypot(dx, dy), 1e-9)
    t = np.stack([(dy / r) ** 2, -dx * dy / r ** 2, (dx / r) ** 2], axis=-1)
    t[rows // 2, cols // 2] = 0.0
    bright = np.tile(np.linspace(0.0, 0.9, w), (h, 1)) + np.linspace(0.0, 0.1, h)[:, None]
    ids = np.where(np.arange(w)[None, :] < w // 2, 1, 2).repeat(h, axis=0).astype(np.int64)
    ids[:6] = 0
    return t, bright, ids, (w, h)


def test_compiled_streamlines_equal_the_python_loop():
    """hatch's compiled loop (jit.hatch_lines) against the Python Hatcher, the reference: the same streamlines,
    sample for sample and bit for bit, for the queue of neighbour seeds and for fixed seeds, with short streamlines
    dropped (min_length) and seeds off the image and on the background."""
    t, bright, ids, size = _two_object_field()
    rng = np.random.default_rng(3)
    anchored = np.c_[rng.uniform(-5, size[0] + 5, 400), rng.uniform(-5, size[1] + 5, 400),
                     rng.integers(1, 3, 400)].astype(np.float64)
    cases = [dict(lo=3.0, hi=9.0, limit=0.8, stop_ratio=0.5, step=1.0, min_length=0.0, cell=4.0),
             dict(lo=2.0, hi=6.0, limit=0.95, stop_ratio=0.7, step=1.5, min_length=12.0, cell=4.0),
             dict(lo=4.0, hi=14.0, limit=0.6, stop_ratio=0.3, step=0.8, min_length=5.0, cell=4.0)]
    n_lines = 0
    for case in cases:
        for seeds in (None, anchored):
            ref = hatch(t, bright, ids, size, anchored=seeds, engine="python", **case)
            got = hatch(t, bright, ids, size, anchored=seeds, engine="jit", **case)
            assert len(got) == len(ref)
            for a, b in zip(got, ref, strict=True):
                assert a.dtype == np.float64 and np.array_equal(a, b)
            n_lines += len(ref)
    assert n_lines > 100


def test_hatch_engines_and_the_python_fallback(monkeypatch):
    import nodegraph_nodes.stroke_hatching as sh
    import pytest

    t, bright, ids, size = _two_object_field(40, 30)
    args = (t, bright, ids, size, 3.0, 9.0, 0.8, 0.5, 1.0, 0.0, 4.0)
    with pytest.raises(ValueError, match="engine"):
        hatch(*args, engine="fast")
    monkeypatch.setattr(sh, "_JIT", False)  # as where Numba cannot be imported
    with pytest.raises(RuntimeError, match="numba"):
        hatch(*args, engine="jit")
    fallback = hatch(*args)
    monkeypatch.undo()
    assert [q.tolist() for q in fallback] == [q.tolist() for q in hatch(*args, engine="jit")]


def test_the_field_fills_the_middle_of_a_large_face():
    """Directions only at the corners of a 400 px square (a flat face's vertices): smoothed by 10 px, the middle has
    no direction, and hatching left it bare (the patches on a box-built sofa). Filled, every cell has one, the
    cells the Gaussian reached are unchanged, and where all the corners agree the fill agrees with them."""
    corners = np.array([[4.0, 4.0], [396.0, 4.0], [4.0, 396.0], [396.0, 396.0]])
    along = np.tile((np.cos(0.5), np.sin(0.5)), (4, 1))
    plain = streamlines.tensor_field(corners, along, np.ones(4), (400, 400), 4.0, 10.0)
    everywhere = np.ones((100, 100), dtype=bool)
    filled = streamlines.tensor_field(corners, along, np.ones(4), (400, 400), 4.0, 10.0, fill=everywhere)
    trace = lambda t: t[..., 0] + t[..., 2]  # noqa: E731
    reached = trace(plain) > streamlines.EMPTY
    assert not reached[50, 50] and reached.mean() < 0.2
    assert (trace(filled) > streamlines.EMPTY).all()
    assert np.array_equal(filled[reached], plain[reached])
    d = streamlines.principal(filled)
    assert np.allclose(np.abs(d @ np.array([np.cos(0.5), np.sin(0.5)])), 1.0, atol=1e-9)
    half = everywhere.copy()
    half[:, 50:] = False  # only the cells an object covers are filled
    part = streamlines.tensor_field(corners, along, np.ones(4), (400, 400), 4.0, 10.0, fill=half)
    assert (trace(part)[:, :50] > streamlines.EMPTY).all() and np.array_equal(part[:, 50:], plain[:, 50:])
    nothing = streamlines.tensor_field(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), (40, 40), 4.0, 10.0,
                                       fill=np.ones((10, 10), dtype=bool))
    assert not nothing.any()  # no points: no field to spread
