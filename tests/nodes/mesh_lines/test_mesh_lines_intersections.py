"""Intersection lines (nodes/mesh_lines/intersect.py): the triangle pairs against libigl's own triangle-triangle
test, the candidate pairs against brute force, two interpenetrating spheres against their analytic circle (one
mesh, two objects, and through the node with visibility by ray casting), and parts that only touch."""

from __future__ import annotations

from pathlib import Path

import igl
import numpy as np
import pytest
from nodegraph_nodes.mesh_lines import extract, intersect

from nodegraph.scene import primitives
from nodegraph.scene.meshes import Mesh, merge_meshes
from nodegraph.values import LINE_KINDS
from tests.helpers import run_minimal
from tests.nodes.mesh_lines import reference

R, C = 1.0, 0.6  # two unit spheres centred at x = -C and +C cross on the circle x = 0, radius sqrt(R^2 - C^2)


def test_triangle_pairs_agree_with_libigl():
    rng = np.random.default_rng(3)
    k = 2000
    ta = rng.normal(size=(k, 3, 3))
    tb = rng.normal(size=(k, 3, 3)) * 0.8 + 0.2
    r = intersect.tri_tri_segments(ta, tb, 1.0)
    hit_rows = np.flatnonzero(r["hit"])
    assert 200 < len(hit_rows) < k  # both outcomes are exercised
    for i in range(k):
        hit, coplanar, src, dst = igl.tri_tri_intersection_test_3d(*(x[None] for x in (*ta[i], *tb[i])))
        assert bool(hit and not coplanar) == bool(r["hit"][i]), i
        if r["hit"][i]:
            p = r["p"][np.searchsorted(hit_rows, i)]
            ref = np.r_[src, dst]
            assert min(np.abs(p - ref).max(), np.abs(p[::-1] - ref).max()) < 1e-9


def _brute(lo_a, hi_a, lo_b, hi_b, same):
    out = set()
    for i in range(len(lo_a)):
        for j in range(i + 1 if same else 0, len(lo_b)):
            if np.all(lo_a[i] <= hi_b[j]) and np.all(lo_b[j] <= hi_a[i]):
                out.add((i, j))
    return out


@pytest.mark.parametrize("engine", ["auto", "numpy"])
def test_candidate_pairs_are_every_overlapping_box_once(engine):
    """Faces of very different sizes (a few spanning many cells: the coarser levels), within one set and across
    two: exactly the pairs whose boxes overlap, each once; the compiled pair loop and the NumPy one alike."""
    rng = np.random.default_rng(5)
    n = 400
    centre = rng.random((n, 3))
    size = rng.random(n) ** 4 * 0.6 + 0.01
    tri = centre[:, None, :] + rng.normal(size=(n, 3, 3)) * size[:, None, None]
    lo, hi = intersect.face_boxes(tri)
    got = intersect.candidate_pairs(lo, hi, engine=engine)
    assert len(got) == len({tuple(p) for p in got.tolist()})
    assert {tuple(p) for p in got.tolist()} == _brute(lo, hi, lo, hi, True)
    a, b = slice(0, 150), slice(150, n)
    got = intersect.candidate_pairs(lo[a], hi[a], lo[b], hi[b], engine=engine)
    assert {tuple(p) for p in got.tolist()} == _brute(lo[a], hi[a], lo[b], hi[b], False)


def test_the_compiled_pair_loop_gives_the_numpy_pairs_in_their_order():
    """intersect_jit.cell_pairs against _grid_pairs' NumPy loop: the same array (pairs and order), within one set
    and across two, with and without corner ids (pairs sharing one left out: exactly those, order kept), for boxes
    from tiny to spanning the scene (every grid level), and for a dense mesh's faces."""
    if intersect._jit() is None:
        pytest.skip("Numba cannot be imported here: only the NumPy pair loop runs")
    rng = np.random.default_rng(11)
    for _ in range(12):
        n = int(rng.integers(2, 2500))
        lo = rng.random((n, 3)) * 10
        hi = lo + rng.random((n, 3)) ** 4 * rng.choice([0.1, 1.0, 30.0], size=(n, 1))
        m = int(rng.integers(1, 400))
        lo_b = rng.random((m, 3)) * 10
        hi_b = lo_b + rng.random((m, 3)) ** 3 * 2
        ca, cb = rng.integers(0, 3 * n, (n, 3)), rng.integers(0, 3 * n, (m, 3))  # corner ids, some shared
        for args, kw in (((lo, hi), {}), ((lo, hi, lo_b, hi_b), {}), ((lo, hi), {"corners_a": ca}),
                         ((lo, hi, lo_b, hi_b), {"corners_a": ca, "corners_b": cb})):
            got = intersect.candidate_pairs(*args, **kw)
            np.testing.assert_array_equal(got, intersect.candidate_pairs(*args, engine="numpy", **kw))
            if kw:  # the pairs without a shared corner, in order
                every = intersect.candidate_pairs(*args, engine="numpy")
                c_b = kw.get("corners_b", ca)
                apart = ~(ca[every[:, 0]][:, :, None] == c_b[every[:, 1]][:, None, :]).any(axis=(1, 2))
                np.testing.assert_array_equal(got, every[apart])
    s = primitives.sphere(1.0, 5)
    lo, hi = intersect.face_boxes(s.vertices[s.faces])
    got = intersect.candidate_pairs(lo, hi)
    assert len(got) > 5 * len(s.faces)  # every face against its neighbours at least
    np.testing.assert_array_equal(got, intersect.candidate_pairs(lo, hi, engine="numpy"))


def _sphere(x: float, subdiv: int = 4) -> Mesh:
    s = primitives.sphere(R, subdiv)
    return Mesh("sphere", s.vertices + (x, 0.0, 0.0), s.faces)


def _on_circle(p: np.ndarray, tol: float) -> None:
    p = p.reshape(-1, 3)
    rho = np.hypot(p[:, 1], p[:, 2])
    assert np.abs(p[:, 0]).max() < tol, np.abs(p[:, 0]).max()
    assert np.abs(rho - np.sqrt(R * R - C * C)).max() < tol, np.abs(rho - 0.8).max()


def _one_closed_chain(segs: extract.Segs) -> None:
    half, off = extract.chain(segs.key, segs.kind, segs.p)
    assert len(off) == 2 and len(half) == len(segs)  # one chain through every segment
    first, last = half[0], half[-1]
    assert segs.key[first >> 1, first & 1] == segs.key[last >> 1, 1 - (last & 1)]  # closed


def test_two_spheres_cross_on_their_circle():
    """As one mesh (its parts pass through each other) and as two: the segments lie on the circle within the
    polyhedra's sag (edges about 0.08 long: under 0.002) and chain into one closed loop."""
    a, b = _sphere(-C), _sphere(C)
    both = merge_meshes([a, b], "two")
    weld, _ = both.weld()
    s = intersect.intersection_segs(both.vertices.astype(np.float64), both.faces, weld, 0)
    assert len(s) > 50 and (s.kind == extract.KIND["intersection"]).all()
    _on_circle(s.p, 0.01)
    _one_closed_chain(s)
    # the segments' barycentric coordinates put them on their faces
    tri = both.vertices[both.faces[s.face]].astype(np.float64)
    for k in range(2):
        assert np.allclose(np.einsum("sc,scd->sd", s.bary[:, k], tri), s.p[:, k], atol=1e-9)
    wa, _ = a.weld()
    wb, _ = b.weld()
    s2 = intersect.intersection_segs(a.vertices.astype(np.float64), a.faces, wa, 0, b.vertices.astype(np.float64),
                                     b.faces, wb)
    assert len(s2) == len(s)
    _on_circle(s2.p, 0.01)
    _one_closed_chain(s2)


def _scene_file(tmp_path: Path) -> Path:
    path = tmp_path / "spheres.yaml"
    path.write_text("objects:\n"
                    f"  - primitive: {{type: sphere, radius: {R}, subdiv: 4}}\n"
                    f"    transform: {{translate: [{-C}, 0, 0]}}\n"
                    f"  - primitive: {{type: sphere, radius: {R}, subdiv: 4}}\n"
                    f"    transform: {{translate: [{C}, 0, 0]}}\n"
                    "camera: {eye: [1.2, 1.6, 3.2], target: [0, 0, 0]}\n")
    return path


def test_node_draws_the_visible_arc_of_the_circle(tmp_path: Path):
    size = 200
    nodes = ("  gbuf:\n    type: rasterize\n  lines:\n    type: mesh_lines\n    in: {linear_depth: gbuf.linear_depth}\n"
             "    params: {hidden: true, min_length: 0}\n")
    ex, res = run_minimal(None, nodes, {"s": "lines.strokes"}, size=(size, size), scene=str(_scene_file(tmp_path)))
    s = res.values[("lines", "strokes")]
    kind = s["kind"]
    inter = kind == LINE_KINDS.index("intersection")
    assert inter.sum() > 100
    sc = ex.pipeline.scene
    cam = sc.camera_at(0)
    eye = np.linalg.inv(cam.view_matrix())[:3, 3]
    obj = s["obj"][inter]
    world = np.array([np.asarray(sc.objects[o].transform)[:3, 3] for o in obj]) + s["pos"][inter]
    _on_circle(world, 0.01)
    # projected: on the projected circle within a pixel
    t = np.linspace(0.0, 2.0 * np.pi, 4000)
    circle = np.stack([np.zeros_like(t), 0.8 * np.cos(t), 0.8 * np.sin(t), np.ones_like(t)], axis=1)
    h = circle @ (cam.projection_matrix(1.0) @ cam.view_matrix()).T
    cxy = (h[:, :2] / h[:, 3:4] * 0.5 + 0.5) * size
    gap = np.min(np.linalg.norm(s.xy[inter][:, None, :] - cxy[None], axis=2), axis=1)
    assert gap.max() < 1.0, gap.max()
    # visibility against ray casting
    vis = s["visible"][inter]
    ref = ~reference.scene_occluded(world.astype(np.float64), eye, sc)
    assert vis.any() and (~vis).any()
    assert (vis == ref).mean() > 0.95, (vis == ref).mean()
    # they differ only where the arc passes behind a silhouette at a grazing angle, within the node's depth
    # tolerance (1 % of the depth) and its one-pixel neighbourhood: near where the ray-cast visibility of the
    # circle itself changes
    ring = circle[::10, :3]
    seen = ~reference.scene_occluded(ring, eye, sc)
    turns = np.flatnonzero(seen != np.roll(seen, 1))
    assert len(turns) >= 2
    far = np.min(np.linalg.norm(s.xy[inter][vis != ref][:, None, :] - cxy[::10][turns][None], axis=2), axis=1)
    assert far.max(initial=0.0) < 12.0, far
    # and nothing of the kind without intersections
    nodes_off = nodes.replace("min_length: 0}", "min_length: 0, intersections: false}")
    _, res_off = run_minimal(None, nodes_off, {"s": "lines.strokes"}, size=(size, size),
                             scene=str(_scene_file(tmp_path)))
    off = res_off.values[("lines", "strokes")]
    assert not (off["kind"] == LINE_KINDS.index("intersection")).any()


def test_parts_that_only_touch_draw_no_intersection():
    """A box resting on another, two quads meeting at an edge at an angle (as two meshes: a glTF file's
    primitives), a box standing on a floor plane, and a clean torus: no intersection line."""
    def box(lo, hi):
        b = primitives.box(1.0)
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        return Mesh("box", (b.vertices + 0.5) * (hi - lo) + lo, b.faces)

    stacked = merge_meshes([box((-0.8, 0.3, -0.45), (0.8, 0.85, -0.25)), box((-0.8, 0.08, -0.45), (0.8, 0.3, 0.43))],
                           "stacked")
    w, _ = stacked.weld()
    assert len(intersect.intersection_segs(stacked.vertices.astype(np.float64), stacked.faces, w, 0)) == 0
    torus = primitives.torus(1.0, 0.3, 32, 16)
    w, _ = torus.weld()
    assert len(intersect.intersection_segs(torus.vertices.astype(np.float64), torus.faces, w, 0)) == 0
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    qa = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    qb = np.array([[1, 0, 0], [1.6, 0, 0.8], [1.6, 1, 0.8], [1, 1, 0.0]])
    ids = np.arange(4)
    assert len(intersect.intersection_segs(qa, faces, ids, 0, qb, faces, ids)) == 0
    floor = primitives.plane(4.0, 4)
    cube = box((-0.5, 0.0, -0.5), (0.5, 1.0, 0.5))
    wf, _ = floor.weld()
    wc, _ = cube.weld()
    assert len(intersect.intersection_segs(floor.vertices.astype(np.float64), floor.faces, wf, 0,
                                           cube.vertices.astype(np.float64), cube.faces, wc)) == 0
    # the same cube pushed 0.1 into the floor crosses it on a square
    sunk = cube.vertices.astype(np.float64) - (0.0, 0.1, 0.0)
    s = intersect.intersection_segs(floor.vertices.astype(np.float64), floor.faces, wf, 0, sunk, cube.faces, wc)
    p = s.p.reshape(-1, 3)
    assert len(s) > 0 and np.allclose(p[:, 1], 0.0) and np.allclose(np.abs(p[:, [0, 2]]).max(axis=1), 0.5)


def test_a_dense_uv_sphere_does_not_cross_itself_at_its_poles():
    """Round a UV sphere's pole the faces are slivers whose float32 corners stray from each other's planes by a
    rounding error: no crossing (a blind check found blobs of hundreds of short strokes at 200 x 100 and up)."""
    for n_u, n_v in ((200, 100), (96, 200)):
        m = primitives.uv_sphere(1.0, n_u, n_v)
        w, _ = m.weld()
        assert len(intersect.intersection_segs(m.vertices.astype(np.float64), m.faces, w, 0)) == 0, (n_u, n_v)


def test_a_box_sunk_a_hair_into_the_floor_draws_its_edge_once(tmp_path: Path):
    """Sunk 0.002 into a floor, a box crosses it 0.002 above its bottom edge: the intersection segments exist,
    but on the screen they lie on the box's bottom crease, which is drawn, so they are not drawn again; sunk 0.15,
    the junction is drawn."""
    nodes = ("  gbuf:\n    type: rasterize\n  lines:\n    type: mesh_lines\n    in: {linear_depth: gbuf.linear_depth}\n"
             "    params: {min_length: 0}\n")
    counts = {}
    for depth in (0.002, 0.15):
        path = tmp_path / f"sunk{depth}.yaml"
        path.write_text("objects:\n  - primitive: {type: plane, size: 4.0, subdiv: 4}\n"
                        f"  - primitive: {{type: box, size: 1.0}}\n    transform: {{translate: [0, {0.5 - depth}, 0],"
                        " rotate: [0, 25, 0]}\ncamera: {eye: [2.2, 2.0, 3.0], target: [0, 0.4, 0]}\n")
        ex, res = run_minimal(None, nodes, {"s": "lines.strokes"}, size=(240, 240), scene=str(path))
        s = res.values[("lines", "strokes")]
        sc = ex.pipeline.scene
        floor, box = (o.mesh for o in sc.objects)
        to_floor = np.linalg.inv(np.asarray(sc.objects[0].transform)) @ np.asarray(sc.objects[1].transform)
        vb = box.vertices.astype(np.float64) @ to_floor[:3, :3].T + to_floor[:3, 3]
        segs = intersect.intersection_segs(floor.vertices.astype(np.float64), floor.faces, floor.weld()[0], 0, vb,
                                           box.faces, box.weld()[0])
        assert len(segs) >= 4
        counts[depth] = int((s.stroke_attr("kind") == LINE_KINDS.index("intersection")).sum())
    assert counts[0.002] == 0 and counts[0.15] >= 1, counts


def test_inside_a_closed_part_agrees_with_the_winding_number():
    """solids.inside (ray parity through each closed part's AABB tree) against libigl's generalized winding number;
    an open part (a sphere with a face removed) hides nothing, and a point's own part is left out."""
    from nodegraph_nodes.mesh_lines import solids

    a, b = _sphere(0.0), _sphere(0.9)
    both = merge_meshes([a, b], "two")
    V, F = both.vertices.astype(np.float64), both.faces
    weld, nw = both.weld()
    p = solids.parts(V, F, weld, nw)
    assert p.closed.tolist() == [True, True]
    q = np.random.default_rng(4).uniform(-1.2, 2.1, (4000, 3))
    got = solids.inside(q, np.full(len(q), -1), V, F, p)
    wn = np.maximum(igl.winding_number(V[:len(a.vertices)], a.faces.astype(np.int64), q),
                    igl.winding_number(V[len(a.vertices):], b.faces.astype(np.int64), q))
    assert (got == (wn > 0.5)).all() and got.sum() > 500
    own = p.label[0]
    got_own = solids.inside(q, np.full(len(q), own), V, F, p)
    assert (got_own == (igl.winding_number(V[len(a.vertices):], b.faces.astype(np.int64), q) > 0.5)).all()
    holed = Mesh("holed", a.vertices, a.faces[1:])
    ph = solids.parts(holed.vertices.astype(np.float64), holed.faces, *holed.weld())
    assert not ph.closed.any()
    assert not solids.inside(q, np.full(len(q), -1), holed.vertices, holed.faces, ph).any()


SNOW = [((0.0, 0.0, 0.0), 1.0), ((0.0, 1.3, 0.0), 0.7), ((0.0, 2.2, 0.0), 0.45)]


@pytest.mark.parametrize("one_mesh", [False, True])
def test_contours_stop_at_the_junction_of_parts_pushed_into_each_other(tmp_path: Path, one_mesh: bool):
    """A snowman of three spheres (three objects, or one mesh file of three parts): no visible contour sample lies
    inside another sphere (by more than a facet's sag). Without the inside test, 15-20 samples did at each
    subdivision tried (2-5 px past each of the four junction corners on the outline)."""
    nodes = ("  gbuf:\n    type: rasterize\n  lines:\n    type: mesh_lines\n    in: {linear_depth: gbuf.linear_depth}\n"
             "    params: {min_length: 0}\n")
    spheres = [primitives.sphere(radius=r, subdiv=4) for _, r in SNOW]
    if one_mesh:
        mesh = merge_meshes([Mesh(f"s{i}", s.vertices + np.array(c, np.float32), s.faces)
                             for i, (s, (c, _)) in enumerate(zip(spheres, SNOW, strict=True))], "snow")
        path = tmp_path / "snow.obj"
        with path.open("w") as f:
            np.savetxt(f, mesh.vertices, fmt="v %.6f %.6f %.6f")
            np.savetxt(f, mesh.faces + 1, fmt="f %d %d %d")
    else:
        path = tmp_path / "snow.yaml"
        path.write_text("objects:\n" + "".join(
            f"  - primitive: {{type: sphere, radius: {r}, subdiv: 4}}\n    transform: {{translate: [0, {c[1]}, 0]}}\n"
            for c, r in SNOW) + "camera: {eye: [3.5, 2.5, 6.0], target: [0, 1.0, 0], fov: 35}\n")
    ex, res = run_minimal(None, nodes, {"s": "lines.strokes"}, size=(600, 600), scene=str(path))
    s = res.values[("lines", "strokes")]
    sc = ex.pipeline.scene
    vis = s["visible"].astype(bool) & (s["kind"] == LINE_KINDS.index("contour"))
    pos = s["pos"].astype(np.float64)
    if one_mesh:  # the file's spheres, where framing put them: each part's centre and radius from its vertices
        starts = np.cumsum([0] + [len(x.vertices) for x in spheres])
        V = sc.objects[0].mesh.vertices.astype(np.float64)
        centres = [V[a:b].mean(axis=0) for a, b in zip(starts[:-1], starts[1:], strict=True)]
        radii = [np.linalg.norm(V[a:b] - c, axis=1).mean() for (a, b), c in
                 zip(zip(starts[:-1], starts[1:], strict=True), centres, strict=True)]
        fstarts = np.cumsum([0] + [len(x.faces) for x in spheres])
        part = np.searchsorted(fstarts, s["face"], side="right") - 1
    else:
        for o, obj in enumerate(sc.objects):
            m = np.asarray(obj.transform, np.float64)
            pos[s["obj"] == o] = pos[s["obj"] == o] @ m[:3, :3].T + m[:3, 3]
        centres = [np.array(c) for c, _ in SNOW]
        radii = [r for _, r in SNOW]
        part = s["obj"]
    assert vis.sum() > 1000
    inside = np.zeros(len(pos), bool)
    for i, (c, r) in enumerate(zip(centres, radii, strict=True)):
        inside |= (part != i) & (np.linalg.norm(pos - c, axis=1) < r * (1 - 2e-3))
    assert not (vis & inside).any(), int((vis & inside).sum())


def test_self_crossings_come_back_from_the_mesh_store(tmp_path: Path, monkeypatch):
    """A mesh's crossings with itself are kept in the disk cache's mesh store: a later process (here: the node's
    in-memory cache emptied) reads the same segments; an entry that does not fit the mesh is found again."""
    import nodegraph_nodes.mesh_lines as ml

    from nodegraph.scene import meshstore

    monkeypatch.setattr(meshstore, "_root", tmp_path)
    mesh = merge_meshes([_sphere(0.0), _sphere(0.9)], "two")
    assert mesh.n_faces >= meshstore.MIN_FACES
    weld, nw, _ = ml.topology(mesh)
    monkeypatch.setattr(ml, "_SELF_CROSSINGS", ml._Kept(4_000_000))
    first = ml.self_crossings(mesh, weld, nw)
    assert len(first) > 50 and len(list(tmp_path.glob("*self_crossings*"))) == 1
    calls = []
    monkeypatch.setattr(ml.intersect, "intersection_segs", lambda *a, **k: calls.append(1))
    monkeypatch.setattr(ml, "_SELF_CROSSINGS", ml._Kept(4_000_000))
    again = ml.self_crossings(mesh, weld, nw)
    assert not calls
    for name in ml.SEG_FIELDS:
        assert np.array_equal(getattr(first, name), getattr(again, name)), name
    bad = {name: getattr(first, name) for name in ml.SEG_FIELDS}
    bad["face"] = bad["face"] + mesh.n_faces
    assert ml.stored_segs_fit({name: getattr(first, name) for name in ml.SEG_FIELDS}, mesh.n_faces)
    assert not ml.stored_segs_fit(bad, mesh.n_faces)
