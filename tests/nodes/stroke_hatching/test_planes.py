"""stroke_hatching on flat faces (module planes): the planes of a mesh and their directions by hand, and a box's
hatching checked against the rasterizer's own object-space positions: every stroke straight on the screen, and
lying on one line of its face, the lines of a face a whole number of gaps apart."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from nodegraph_nodes._shared import planes as shared
from nodegraph_nodes.stroke_hatching import planes as pl

from nodegraph.values import LINE_KINDS
from tests.helpers import run_minimal


def box(lo, hi, base: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned box: 8 corners, 12 outward triangles."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = np.array([(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)], np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    f = []
    for a, b, c, d in quads:
        f += [(a, b, c), (a, c, d)]
    return v, np.array(f, np.int64) + base


def planes_of(v: np.ndarray, f: np.ndarray) -> shared.Planes:
    from nodegraph.scene.meshes import Mesh

    mesh = Mesh("t", v, f)
    return shared.mesh_planes(mesh.vertices, mesh.faces, mesh.weld()[0])


def test_a_box_has_six_planes_hatched_along_their_longer_side():
    v, f = box((0, 0, 0), (2.0, 1.0, 0.5))
    p = planes_of(v, f)
    assert len(p) == 6 and p.flat_vertices.all()
    for n, a, c in zip(p.normal, p.along, p.across, strict=True):
        axis = int(np.argmax(np.abs(n)))
        assert np.isclose(abs(n[axis]), 1.0) and abs(a @ n) < 1e-12 and abs(c @ n) < 1e-12
        assert np.isclose(abs(a @ c), 0.0, atol=1e-12)
        # the longer side of each face: x (length 2) on the z and y faces, y (1 against 0.5) on the x faces
        want = 1 if axis == 0 else 0
        assert np.isclose(abs(a[want]), 1.0), (n, a)
    # offsets: n . p = d on each face
    for k, (n, d) in enumerate(zip(p.normal, p.offset, strict=True)):
        on = np.abs(v @ n - d) < 1e-9
        assert on.sum() == 4
        assert (p.face_plane == k).sum() == 2 and on[f[p.face_plane == k]].all()


def test_a_square_face_is_hatched_level():
    v, f = box((0, 0, 0), (1.0, 1.0, 1.0))
    p = planes_of(v, f)
    for n, a in zip(p.normal, p.along, strict=True):
        if abs(n[1]) > 0.5:  # top and bottom: along x
            assert np.isclose(abs(a[0]), 1.0)
        else:  # the sides: horizontal
            assert abs(a[1]) < 1e-12


def test_touching_boxes_share_their_coplanar_faces():
    """Two boxes side by side (a sofa's cushions): their tops, bottoms, fronts and backs lie in four shared
    planes; the faces they touch by have opposite normals and stay apart: 6 + 6 - 4 planes."""
    va, fa = box((0, 0, 0), (1.0, 0.5, 1.0))
    vb, fb = box((1.0, 0, 0), (2.0, 0.5, 1.0), base=8)
    p = planes_of(np.r_[va, vb], np.r_[fa, fb])
    assert len(p) == 8
    top = np.flatnonzero(p.normal[:, 1] > 0.5)
    assert len(top) == 1 and np.isclose(abs(p.along[top[0], 0]), 1.0)  # the shared top runs along both (2 x 1)


def test_planes_facing_one_way_share_a_direction():
    """A staircase of six boxes, each 1.5 wide and 0.3 to 1.8 tall, all facing +z: hatched each by its own
    outline, the tallest riser (1.8 high) would run vertical and the rest horizontal. Faces turned the same way
    share the direction of all their outlines together: every riser horizontal (x)."""
    parts = [box((0.0, 0.0, -0.3 * i), (1.5, 0.3 * (i + 1), -0.3 * i + 0.3), base=8 * i) for i in range(6)]
    p = planes_of(np.concatenate([v for v, _ in parts]), np.concatenate([f for _, f in parts]))
    risers = np.flatnonzero(p.normal[:, 2] > 0.99)
    assert len(risers) == 6
    assert np.allclose(np.abs(p.along[risers, 0]), 1.0)
    alone = planes_of(*box((0.0, 0.0, 0.0), (1.5, 1.8, 0.3)))
    front = int(np.flatnonzero(alone.normal[:, 2] > 0.99)[0])
    assert np.isclose(abs(alone.along[front, 1]), 1.0)  # the tallest alone: vertical


def icosphere() -> tuple[np.ndarray, np.ndarray]:
    from nodegraph.scene.primitives import sphere

    m = sphere(1.0, 3)
    return np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)


def test_a_sphere_has_no_plane_and_a_small_facet_is_left_to_the_field():
    v, f = icosphere()
    assert len(planes_of(v, f)) == 0
    area = 4 * np.pi  # about the sphere's
    for side, planes in ((np.sqrt(0.002 * area), 0), (np.sqrt(0.05 * area), 1)):
        sq = np.array([(3, 0, 0), (3 + side, 0, 0), (3 + side, side, 0), (3, side, 0)], np.float64)
        p = planes_of(np.r_[v, sq], np.r_[f, np.array([(0, 1, 2), (0, 2, 3)]) + len(v)])
        assert len(p) == planes, side  # under MIN_AREA (0.5 %) of the mesh's area: not a plane of its own
    assert not p.flat_vertices[: len(v)].any() and p.flat_vertices[len(v):].all()


def test_valuation():
    np.testing.assert_array_equal(pl.valuation(np.array([1, 2, 3, 4, -8, 12, 0])), [0, 1, 0, 2, 3, 2, pl.MAX_LEVEL])


def floor_view(size: int = 200):
    """A floor (y = 0, |x| <= 4, -30 <= z <= -0.5) seen from 1 unit above it, looking 10 degrees down: its
    pixels and their points by ray casting in float64, and the model-view-projection."""
    eye = np.array([0.0, 1.0, 0.0])
    fwd = np.array([0.0, -np.sin(np.radians(10)), -np.cos(np.radians(10))])
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    view = np.eye(4)
    view[:3, :3] = np.stack([right, up, -fwd])
    view[:3, 3] = -view[:3, :3] @ eye
    f = 1.0 / np.tan(np.radians(30))
    near, far = 0.05, 100.0
    proj = np.array([[f, 0, 0, 0], [0, f, 0, 0], [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)],
                     [0, 0, -1, 0]])
    ys, xs = np.mgrid[0:size, 0:size] + 0.5
    nx, ny = xs / size * 2 - 1, ys / size * 2 - 1  # rows bottom-up, as the G-buffer
    rays = (nx[..., None] / f) * right + (ny[..., None] / f) * up + fwd
    t = -eye[1] / np.where(rays[..., 1] < 0, rays[..., 1], -1e-300)
    hit = eye + t[..., None] * rays
    on = (rays[..., 1] < 0) & (np.abs(hit[..., 0]) <= 4) & (hit[..., 2] <= -0.5) & (hit[..., 2] >= -30)

    def cast(xy: np.ndarray) -> np.ndarray:
        """Window positions (n, 2) to their points on the floor."""
        r = (xy[:, :1] / size * 2 - 1) / f * right + (xy[:, 1:] / size * 2 - 1) / f * up + fwd
        return eye + (-eye[1] / r[:, 1:2]) * r

    return on, hit, proj @ view, cast


def test_receding_plane_lines_keep_their_spacing():
    """Lines running away from the eye on a floor converge on the screen; each point keeps one grid's lines,
    0.5-2 x the spacing apart (where the lines crowd, every other line stops: several nested grids are in use),
    and every line lies at a whole number of the finest gap, on the plane."""
    size, spacing = 200, 6.0
    on, hit, mvp, cast = floor_view(size)
    lines = pl.plane_lines(hit[on], np.array([0.0, 1.0, 0.0]), 0.0, np.array([0.0, 0.0, 1.0]),
                           np.array([1.0, 0.0, 0.0]), on.astype(np.int64), 1, np.flatnonzero(on), mvp, (size, size),
                           spacing, 30.0, 1.0, 4.0)
    assert len(lines) > 10
    pts = np.concatenate(lines)
    owner = np.repeat(np.arange(len(lines)), [len(q) for q in lines])
    from scipy.spatial import cKDTree

    near = []
    tree = cKDTree(pts)
    for k, q in enumerate(lines):
        d, idx = tree.query(q[2:-2], k=40)
        other = owner[idx] != k
        first = np.argmax(other, axis=1)
        found = other.any(axis=1)
        near.append(d[np.arange(len(d)), first][found])
    gaps = np.concatenate(near)
    lo, hi = np.percentile(gaps, [5, 95])
    assert lo >= 0.45 * spacing and hi <= 2.1 * spacing, (lo, hi)
    # several nested grids are in use: the lines' indices m (x = m G) have several 2-adic valuations
    # the lines' x on the floor (their u), cast back from the window in float64, are whole multiples of a gap
    xs = np.array([np.median(cast(q)[:, 0]) for q in lines])
    spread = max(np.ptp(cast(q)[:, 0]) for q in lines)
    assert spread < 1e-6  # each stroke is one line of the floor
    d = np.diff(np.sort(xs))
    unit = d[d > 1e-6].min()
    assert np.allclose(xs / unit, np.round(xs / unit), atol=1e-4)
    assert np.isclose(np.log2(30.0 / unit), np.round(np.log2(30.0 / unit)))  # the ladder: diagonal x 2^-j
    m = np.round(xs / unit).astype(np.int64)
    assert len(np.unique(pl.valuation(m[m != 0]))) >= 3


def box_obj(path: Path) -> Path:
    v, f = box((-1.0, -0.6, -0.4), (1.0, 0.6, 0.4))
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in v) + "".join(f"f {a + 1} {b + 1} {c + 1}\n"
                                                                           for a, b, c in f))
    return path


def _box_hatching(gl, scene: Path, planes: bool):
    nodes = ("  gbuf:\n    type: rasterize\n  curv:\n    type: curvature\n  hatch:\n    type: stroke_hatching\n"
             "    in: {curvature: curv.out, linear_depth: gbuf.linear_depth, normal: gbuf.normal, "
             "object_id: gbuf.object_id, position: gbuf.position}\n"
             f"    params: {{white: 1.0, cross_below: 0.0, spacing: [4, 9], planes: {str(planes).lower()}}}\n")
    ex, res = run_minimal(gl, nodes, {"s": "hatch.strokes"}, size=(200, 200), scene=str(scene))
    return res.values[("hatch", "strokes")], ex.plan.pipeline.scene


def chord_deviation(q: np.ndarray) -> float:
    """The largest distance (px) of a polyline's samples from the chord between its ends."""
    a, b = q[0], q[-1]
    d = b - a
    n = np.array([-d[1], d[0]]) / max(np.hypot(*d), 1e-12)
    return float(np.abs((q - a) @ n).max())


def test_a_box_is_hatched_with_straight_lines_on_its_faces(gl, tmp_path: Path):
    """References: the position buffer the rasterizer wrote, read at each sample (`pos`), says which face a stroke
    lies on; its samples' window positions cast as rays (float64, from the camera's matrices) onto that face's
    plane say where on it. Every stroke is straight on the screen, lies on one face (one coordinate at the box's
    half size), and runs along one line of it (the coordinate across the lines constant to 1e-6); on each face
    those lines are a whole number of the finest gap apart. With planes off, the streamlines of the corners'
    blended directions curve."""
    scene = box_obj(tmp_path / "box.obj")
    s, sc = _box_hatching(gl, scene, True)
    assert len(s) > 10 and (s["kind"] == LINE_KINDS.index("hatching")).all()
    half = np.array([1.0, 0.6, 0.4])
    p = shared.mesh_planes(*box((-1.0, -0.6, -0.4), (1.0, 0.6, 0.4)), np.arange(8))
    cam = sc.camera_at(0)
    inv = np.linalg.inv(cam.projection_matrix(1.0) @ cam.view_matrix() @ np.asarray(sc.objects[0].transform))

    def cast(xy: np.ndarray, n: np.ndarray, d: float) -> np.ndarray:
        ndc = np.c_[xy / 200.0 * 2 - 1]
        a = np.c_[ndc, -np.ones(len(xy)), np.ones(len(xy))] @ inv.T
        b = np.c_[ndc, np.ones(len(xy)), np.ones(len(xy))] @ inv.T
        a, b = a[:, :3] / a[:, 3:], b[:, :3] / b[:, 3:]
        t = (d - a @ n) / ((b - a) @ n)
        return a + t[:, None] * (b - a)

    faces_seen = set()
    by_face: dict[int, list[float]] = {}
    for q, pos in zip(s.polylines, np.split(s["pos"].astype(np.float64), s.starts[1:-1]), strict=True):
        assert chord_deviation(q.astype(np.float64)) < 0.5
        inner = pos[1:-1] if len(pos) > 4 else pos  # the ends' pixels may straddle an edge
        on = np.abs(np.abs(inner) - half) < 0.01
        axis = int(np.argmax(on.mean(0)))
        assert on[:, axis].mean() > 0.9, pos
        k = int(np.flatnonzero((np.abs(p.normal[:, axis]) > 0.5) & (np.sign(p.normal[:, axis]) ==
                                                                     np.sign(np.median(inner[:, axis]))))[0])
        faces_seen.add(k)
        u = cast(q.astype(np.float64), p.normal[k], p.offset[k]) @ p.across[k]
        assert np.ptp(u) < 1e-6, (k, np.ptp(u))
        by_face.setdefault(k, []).append(float(np.median(u)))
    assert len(faces_seen) == 3  # the three faces the default view shows
    assert max(len(us) for us in by_face.values()) >= 3
    for k, us in by_face.items():
        us = np.sort(np.array(us))
        gaps = np.diff(us)
        if not (gaps > 1e-6).any():
            continue
        unit = gaps[gaps > 1e-6].min()
        assert np.allclose(us / unit, np.round(us / unit), atol=1e-4), (k, us / unit)
    curved, _ = _box_hatching(gl, scene, False)
    long = [q.astype(np.float64) for q in curved.polylines if len(q) > 30]
    assert max(chord_deviation(q) for q in long) > 2.0


def test_a_mesh_without_planes_is_hatched_as_before(gl, tmp_path: Path):
    from tests.nodes.stroke_hatching.test_stroke_hatching import cylinder_obj

    scene = cylinder_obj(tmp_path / "cyl.obj")
    a, b = _box_hatching(gl, scene, True)[0], _box_hatching(gl, scene, False)[0]
    assert len(a) > 5 and np.array_equal(a.xy, b.xy) and np.array_equal(a.starts, b.starts)


def test_plane_hatching_is_the_same_far_from_the_origin(tmp_path: Path, gl):
    """A small box written as OBJ text at the origin and moved by 1e5 and 1e6: the same hatching strokes (within
    1e-3 px). The lines are counted from the mesh's centre; counted from the origin they fell elsewhere on the
    faces and thinned differently (147 strokes against 124 at 1e5)."""
    from nodegraph import pipeline as pipes
    from nodegraph.executor import Executor
    from nodegraph.scene.primitives import box as prim_box

    m = prim_box((0.2, 0.1, 0.06))
    direction = np.array([1.0, 0.6, -0.8])
    root = Path(__file__).resolve().parents[3]
    got = {}
    for offset in (0.0, 1e5, 1e6):
        path = tmp_path / f"box_{offset:g}.obj"
        path.write_text("".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n"
                                for x, y, z in np.asarray(m.vertices) + direction * offset)
                        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in m.faces))
        pipe = pipes.load(root / "pipelines" / "plotter_lines.yaml", size=(160, 160), scene=str(path))
        got[offset] = Executor(pipe, None, gl=gl, requested=[("hatch", "strokes")]).run().values[("hatch", "strokes")]
    assert len(got[0.0]) > 20
    for offset in (1e5, 1e6):
        assert np.array_equal(got[offset].starts, got[0.0].starts), offset
        assert np.abs(got[offset].xy.astype(np.float64) - got[0.0].xy).max() < 1e-3, offset


def wall_view(size: int = 200):
    """A wall (z = 0, |x|, |y| <= 1.5) seen head-on from 5 units away: its pixels and points by ray casting in
    float64, and the model-view-projection."""
    f = 1.0 / np.tan(np.radians(20))
    near, far = 0.05, 100.0
    proj = np.array([[f, 0, 0, 0], [0, f, 0, 0], [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)],
                     [0, 0, -1, 0]])
    view = np.eye(4)
    view[2, 3] = -5.0
    ys, xs = np.mgrid[0:size, 0:size] + 0.5
    hit = np.stack([(xs / size * 2 - 1) / f * 5.0, (ys / size * 2 - 1) / f * 5.0, np.zeros(xs.shape)], -1)
    on = (np.abs(hit[..., 0]) <= 1.5) & (np.abs(hit[..., 1]) <= 1.5)
    return on, hit, proj @ view


def test_plane_lines_follow_the_tone_pixel_by_pixel():
    """A wall lit unevenly (a point light): the wanted spacing 4 px on its left half, 12 px on its right, and no
    hatching in its top quarter (brighter than `white`). The vertical lines lie 2-8 px apart on the left and 6-24
    px on the right (half to twice the spacing), and none is drawn in the top quarter."""
    size = 200
    on, hit, mvp = wall_view(size)
    local = np.where(np.arange(size)[None, :] < size // 2, 4.0, 12.0) * np.ones((size, 1))
    local[int(size * 0.75):] = np.inf
    lines = pl.plane_lines(hit[on], np.array([0.0, 0.0, 1.0]), 0.0, np.array([0.0, 1.0, 0.0]),
                           np.array([1.0, 0.0, 0.0]), on.astype(np.int64), 1, np.flatnonzero(on), mvp, (size, size),
                           8.0, 4.25, 1.0, 4.0, None, local)
    assert lines
    pts = np.concatenate(lines)
    assert pts[:, 1].max() < size * 0.75 + 1
    xs = np.sort([float(np.median(q[:, 0])) for q in lines if np.median(q[:, 1]) < size * 0.5])
    left, right = np.diff(xs[xs < size / 2 - 6]), np.diff(xs[xs > size / 2 + 6])
    assert len(left) > 5 and len(right) > 2
    assert left.min() >= 2.0 and left.max() <= 8.0, left
    assert right.min() >= 6.0 and right.max() <= 24.0, right


def test_no_hatch_line_hugs_a_plane_edge():
    """With each pixel's distance to its plane's edge given: on a strip 6 px tall, lines along it would lie within
    a few pixels of its outline (a doubled, heavy edge) and are left out; on the whole wall, lines crossing it keep
    their ends at its edges."""
    from scipy.ndimage import distance_transform_edt

    size = 200
    on, hit, mvp = wall_view(size)
    strip = on & (np.abs(np.arange(size) - 100.5)[:, None] < 3)

    def lines(mask: np.ndarray, along: np.ndarray, across: np.ndarray, with_edge: bool) -> list[np.ndarray]:
        edge = distance_transform_edt(mask) if with_edge else None
        return pl.plane_lines(hit[mask], np.array([0.0, 0.0, 1.0]), 0.0, along, across, mask.astype(np.int64), 1,
                              np.flatnonzero(mask), mvp, (size, size), 8.0, 4.25, 1.0, 4.0, None, None, edge)

    x, y = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    assert lines(strip, x, y, False)  # without the rule the strip gets lines along it
    assert not lines(strip, x, y, True)
    crossing = lines(on, y, x, True)
    assert len(crossing) > 10
    rows = np.flatnonzero(on.any(axis=1))
    ends = np.concatenate([q[:, 1] for q in crossing])
    assert ends.min() <= rows.min() + 2 and ends.max() >= rows.max() - 1
