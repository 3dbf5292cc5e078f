"""mesh_lines and the Strokes schema: chaining by hand, the box's creases against its projected edges, borders
between objects, the cache round trip of every attribute, the layered SVG read back (layers, page size in mm)
and the command line writing one SVG a frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from nodegraph_nodes.mesh_lines import extract

from nodegraph.cache import Cache
from nodegraph.output.svg import layered_svg, parse_page, per_stroke_mean, read_layers
from nodegraph.values import LINE_KINDS, STROKE_ATTRS, Strokes
from tests.helpers import run_minimal


def test_chain_follows_valence_two_and_stops_at_junctions():
    # a path 0-1-2-3 given out of order and reversed, a triangle loop 10-11-12, a Y junction at 20
    key = np.array([[2, 1], [0, 1], [2, 3], [10, 11], [12, 11], [10, 12], [20, 21], [20, 22], [20, 23]])
    half, off = extract.chain(key, np.zeros(len(key), np.uint8))
    chains = []
    for a, b in zip(off[:-1], off[1:], strict=True):
        h = half[a:b]
        nodes = [key[h[0] >> 1, h[0] & 1]] + [key[x >> 1, 1 - (x & 1)] for x in h]
        chains.append(nodes)
    as_sets = sorted(tuple(int(v) for v in c) for c in chains)
    assert ([0, 1, 2, 3] in chains or [3, 2, 1, 0] in chains)
    loops = [c for c in chains if c[0] == c[-1]]
    assert len(loops) == 1 and sorted(loops[0][:-1]) == [10, 11, 12]
    assert sum(len(c) == 2 and 20 in c for c in chains) == 3, as_sets  # the junction's arms stay apart
    assert len(chains) == 5


def _chains_of(key, p, turn):
    half, off = extract.chain(key, np.zeros(len(key), np.uint8), p, turn)
    return [[int(key[half[a] >> 1, half[a] & 1])] + [int(key[x >> 1, 1 - (x & 1)]) for x in half[a:b]]
            for a, b in zip(off[:-1], off[1:], strict=True)]


def test_chain_goes_straight_on_at_junctions():
    # node positions: a cross at 0 (arms 1, 2 along x and 3, 4 along y, 4 bent 30 degrees), a T at 10 (bar 11-10-12
    # along x, stem 13 along y), a Y at 20 with arms 120 degrees apart (every pair turns by 60 degrees)
    pos = {0: (0, 0), 1: (1, 0), 2: (-1, 0), 3: (0, 1), 4: (np.sin(np.radians(30)), -np.cos(np.radians(30))),
           10: (5, 0), 11: (4, 0), 12: (6, 0), 13: (5, 1),
           20: (9, 0), 21: (10, 0), 22: (9 - 0.5, np.sqrt(0.75)), 23: (9 - 0.5, -np.sqrt(0.75))}
    key = np.array([[0, 1], [2, 0], [0, 3], [4, 0], [10, 11], [12, 10], [10, 13], [20, 21], [22, 20], [20, 23]])
    p = np.array([[[*pos[a], 0.0], [*pos[b], 0.0]] for a, b in key], np.float64)
    chains = [c if c[0] <= c[-1] else c[::-1] for c in _chains_of(key, p, 60.0)]
    assert sorted(chains) == sorted([[1, 0, 2], [3, 0, 4], [11, 10, 12], [10, 13], [20, 21], [20, 22], [20, 23]])
    # 0 degrees: every junction ends its chains (as without positions)
    assert len(_chains_of(key, p, 0.0)) == len(key) == len(_chains_of(key, None, 60.0))
    # a 25-degree limit keeps the cross's bent arm (30 degrees) apart
    assert sorted(len(c) for c in _chains_of(key, p, 25.0)) == [2] * 6 + [3, 3]


def test_chain_keeps_kinds_apart():
    key = np.array([[0, 1], [1, 2]])
    half, off = extract.chain(key, np.array([1, 2], np.uint8))
    assert len(off) - 1 == 2


def box_run(size=200, hidden=False):
    nodes = ("  gbuf:\n    type: rasterize\n  lines:\n    type: mesh_lines\n    in: {linear_depth: gbuf.linear_depth}\n"
             f"    params: {{contours: false, hidden: {str(hidden).lower()}, min_length: 0}}\n")
    ex, res = run_minimal(None, nodes, {"s": "lines.strokes"}, size=(size, size), scene="builtin:box")
    return ex, res.values[("lines", "strokes")]


def test_box_creases_are_its_projected_edges():
    ex, s = box_run(hidden=True)
    sc = ex.pipeline.scene
    cam = sc.camera_at(0)
    mvp = cam.projection_matrix(1.0) @ cam.view_matrix() @ np.asarray(sc.objects[0].transform)
    bits = np.arange(8)
    corners = (np.stack([bits & 1, (bits >> 1) & 1, (bits >> 2) & 1], 1) - 0.5)
    edges = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
    h = np.c_[corners, np.ones(8)] @ mvp.T
    xy = (h[:, :2] / h[:, 3:4] * 0.5 + 0.5) * 200
    # the hidden corner: the one farthest from the eye; its three edges are hidden, the other nine visible
    far = int(np.argmax(np.linalg.norm(corners - np.linalg.inv(cam.view_matrix())[:3, 3], axis=1)))
    vis_len = sum(np.linalg.norm(xy[a] - xy[b]) for a, b in edges if far not in (a, b))
    hid_len = sum(np.linalg.norm(xy[a] - xy[b]) for a, b in edges if far in (a, b))
    kinds, vis, lens = s.stroke_attr("kind"), s.stroke_attr("visible"), s.lengths()
    assert set(kinds.tolist()) == {LINE_KINDS.index("crease")}
    # visibility cuts leave at most one sample spacing (1 px) per cut; corners are where visible and hidden meet
    assert abs(lens[vis].sum() - vis_len) < 8.0, (lens[vis].sum(), vis_len)
    assert abs(lens[~vis].sum() - hid_len) < 8.0, (lens[~vis].sum(), hid_len)
    # every sample lies on its face (barycentric sum 1) at its object position
    V, F = sc.objects[0].mesh.vertices, sc.objects[0].mesh.faces
    p = np.einsum("kc,kcd->kd", s["bary"].astype(float), V[F[s["face"]]])
    assert np.allclose(p, s["pos"], atol=1e-5) and np.allclose(s["bary"].sum(1), 1.0, atol=1e-5)
    hv = np.c_[s["pos"].astype(float), np.ones(s.n_vertices)] @ mvp.T
    assert np.allclose((hv[:, :2] / hv[:, 3:4] * 0.5 + 0.5) * 200, s.xy, atol=1e-3)


def test_hidden_strokes_are_off_by_default():
    _, s = box_run()
    assert len(s) > 0 and s["visible"].all()


def test_boundaries_shared_by_two_objects_become_one_border():
    quad_a = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    quad_b = quad_a + [1, 0, 0]
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    segs = []
    for V in (quad_a, quad_b):
        wid = np.arange(4)
        ef = extract.edge_faces(faces, 4)
        nrm = np.tile([0, 0, 1.0], (2, 1))
        face_g = extract.face_facing(V, faces, nrm, np.array([0, 0, 5, 1.0]))
        segs.append(extract.creases_and_boundaries(V, faces, nrm, wid, ef, face_g, 60.0))
    out = extract.mark_borders(segs, [np.eye(4), np.eye(4)], 1e-9)
    kinds = [np.bincount(s.kind, minlength=len(LINE_KINDS)) for s in out]
    b, d = LINE_KINDS.index("boundary"), LINE_KINDS.index("border")
    assert kinds[0][b] == 3 and kinds[0][d] == 1 and kinds[1][b] == 3 and kinds[1][d] == 0


def test_strokes_schema_and_cache_round_trip(tmp_path: Path):
    rng = np.random.default_rng(3)
    n = 7
    attrs = {name: (rng.random((n, *shape)) * 3).astype(dt) for name, (dt, shape, _) in STROKE_ATTRS.items()}
    s = Strokes.from_arrays(rng.random((n, 2)) * 50, [0, 3, 3, 7], (64, 48), 1.5, (0.2, 0.3, 0.4), attrs)
    assert len(s) == 3 and [len(p) for p in s.polylines] == [3, 0, 4]
    ref = [np.sum(np.hypot(*np.diff(p.astype(np.float64), axis=0).T)) if len(p) > 1 else 0.0 for p in s.polylines]
    assert np.allclose(s.lengths(), ref)
    cache = Cache(tmp_path / "c")
    key = "cd" + "0" * 62
    assert cache.store_value(key, "strokes", s, {"node": "n", "type": "t", "version": 1, "params": {},
                                                 "package": "0"})
    cache.flush()
    got = cache.load(key, "strokes").data
    assert np.array_equal(got.xy, s.xy) and np.array_equal(got.starts, s.starts) and got.size == (64, 48)
    for name in STROKE_ATTRS:
        assert np.array_equal(got[name], s[name], equal_nan=True), name
    sub = s.subset(np.array([True, False, True]))
    assert len(sub) == 2 and sub.n_vertices == 7
    with pytest.raises(ValueError, match="do not index"):
        Strokes.from_arrays(np.zeros((3, 2)), [0, 2], (4, 4))
    with pytest.raises(ValueError, match="unknown stroke attributes"):
        Strokes.from_arrays(np.zeros((2, 2)), [0, 2], (4, 4), attrs={"colour": np.zeros(2)})


def test_layered_svg_layers_and_page():
    _, s = box_run(hidden=True)
    text = layered_svg(s)
    layers = read_layers(text)
    assert set(layers) == {"crease", "crease hidden"}
    vis = s.stroke_attr("visible")
    assert len(layers["crease"]) == int(vis.sum()) and len(layers["crease hidden"]) == int((~vis).sum())
    first = layers["crease"][0]
    i = int(np.flatnonzero(vis)[0])
    exp = s.polylines[i].astype(np.float64) * [1, -1] + [0, 200]
    assert np.allclose(first, exp, atol=0.006)
    page = parse_page("A4")
    text = layered_svg(s, page)
    assert 'width="210mm"' in text and 'height="297mm"' in text and 'viewBox="0 0 210 297"' in text
    pts = np.concatenate([np.concatenate(v) for v in read_layers(text).values()])
    scale = (210 - 20) / 200  # the square drawing fits the page's width inside 10 mm margins
    exp_all = np.concatenate(s.polylines).astype(np.float64) * [scale, -scale] + [10, 297 / 2 + 100 * scale]
    assert np.abs(np.sort(pts, axis=0) - np.sort(exp_all, axis=0)).max() < 0.01
    assert f'stroke-width="{s.width * scale:.4g}"' in text
    assert parse_page("150x100mm").width_mm == 150
    with pytest.raises(Exception, match="--page"):
        parse_page("B5")


@pytest.mark.slow
def test_per_stroke_mean_matches_numpy_with_empty_strokes():
    rng = np.random.default_rng(3)
    lens = rng.integers(0, 5, 200)
    lens[[0, 17, -1]] = 0
    starts = np.r_[0, np.cumsum(lens)]
    values = rng.random(starts[-1]).astype(np.float32)
    got = per_stroke_mean(values, starts)
    for i, (a, b) in enumerate(zip(starts[:-1], starts[1:], strict=True)):
        if b > a:
            assert got[i] == pytest.approx(float(np.mean(values[a:b].astype(np.float64))), rel=1e-12)
        else:
            assert np.isnan(got[i])


def test_run_writes_one_svg_a_frame(tmp_path: Path):
    from nodegraph.cli import main

    out = tmp_path / "f_####.svg"
    r = CliRunner().invoke(main, ["run", "pipelines/plotter_lines.yaml", "--size", "160x160", "--frames", "0:3",
                                  "-o", str(out), "--no-cache", "-q", "--page", "A3"])
    assert r.exit_code == 0, r.output
    files = sorted(tmp_path.glob("f_*.svg"))
    assert [f.name for f in files] == ["f_0000.svg", "f_0001.svg", "f_0002.svg"]
    text = files[0].read_text()
    assert 'inkscape:label="contour"' in text and 'width="297mm" height="420mm"' in text


def test_feature_kinds_come_from_feature_lines_segments():
    """Suggestive contours through mesh_lines: strokes of that kind exist on the torus (its inner half carries
    them, tests/nodes/feature_lines), their samples on their faces; without curvature: one clear error."""
    nodes = ("  gbuf:\n    type: rasterize\n  curv:\n    type: curvature\n    params: {smoothing: 0}\n"
             "  lines:\n    type: mesh_lines\n    in: {linear_depth: gbuf.linear_depth, curvature: curv.out}\n"
             "    params: {contours: false, creases: false, boundaries: false, suggestive: true}\n")
    ex, res = run_minimal(None, nodes, {"s": "lines.strokes"}, size=(200, 200), scene="builtin:torus")
    s = res.values[("lines", "strokes")]
    assert len(s) > 0 and set(s.stroke_attr("kind").tolist()) == {LINE_KINDS.index("suggestive")}
    mesh = ex.pipeline.scene.objects[0].mesh
    p = np.einsum("kc,kcd->kd", s["bary"].astype(float), mesh.vertices[mesh.faces[s["face"]]])
    assert np.allclose(p, s["pos"], atol=1e-4)
    from nodegraph.errors import SketchgraphError

    bare = nodes.replace(", curvature: curv.out", "")
    with pytest.raises(SketchgraphError, match="need the curvature input"):
        run_minimal(None, bare, {"s": "lines.strokes"}, size=(64, 64), scene="builtin:torus")


def test_layered_svg_writes_a_point_repeated_by_rounding_once():
    xy = np.array([[10.0, 20.0], [10.001, 20.002], [12.0, 20.0], [12.0, 20.0], [15.0, 25.0],  # 2 repeats
                   [30.0, 30.0], [30.002, 30.001]], np.float32)  # a stroke that rounds to one point
    attrs = {"kind": np.full(7, LINE_KINDS.index("contour"), np.int8), "visible": np.ones(7, bool)}
    s = Strokes.from_arrays(xy, [0, 5, 7], (40, 40), 1.0, attrs=attrs)
    paths = read_layers(layered_svg(s))["contour"]
    assert len(paths) == 1
    np.testing.assert_allclose(paths[0], [[10, 20], [12, 20], [15, 15]], atol=0.006)


def _prism(sides: int = 8, radius: float = 1.0, height: float = 2.0):
    """A prism along +Y: corners at angles 360 k / sides (one at +X), sides split into two triangles, capped
    by fans, wound outward."""
    from nodegraph.scene.meshes import Mesh

    a = 2.0 * np.pi * np.arange(sides) / sides
    ring = np.stack([radius * np.cos(a), np.zeros(sides), -radius * np.sin(a)], axis=1)
    V = np.concatenate([ring, ring + (0.0, height, 0.0), [(0.0, 0.0, 0.0), (0.0, height, 0.0)]])
    k, k1 = np.arange(sides), (np.arange(sides) + 1) % sides
    F = np.concatenate([np.stack([k, k1, k1 + sides], 1), np.stack([k, k1 + sides, k + sides], 1),
                        np.stack([np.full(sides, 2 * sides), k1, k], 1),
                        np.stack([np.full(sides, 2 * sides + 1), k + sides, k1 + sides], 1)])
    m = Mesh("prism", V, F)
    centre = V[F].mean(axis=1) - (0.0, height / 2, 0.0)
    assert (np.einsum("ij,ij->i", m.face_normals(), centre) > 0).all()  # outward
    return m


def _two_boxes():
    from nodegraph.scene import primitives
    from nodegraph.scene.meshes import Mesh, merge_meshes

    def box(lo, hi):
        b = primitives.box(1.0)
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        return Mesh("box", (b.vertices + 0.5) * (hi - lo) + lo, b.faces)

    return merge_meshes([box((-0.8, 0.3, -0.45), (0.8, 0.85, -0.25)), box((-0.8, 0.08, -0.45), (0.8, 0.3, 0.43))],
                        "two")


def test_no_interpolated_contours_across_flat_faces():
    """Two touching boxes (a sofa's back on its seat): the corners' averaged normals lean over the creases, so
    n . v interpolated over a side crosses zero inside it. A box's outline is its creases: no contour at all."""
    from nodegraph_nodes._shared.planes import planar
    from nodegraph_nodes.mesh_lines import object_segments, topology

    m = _two_boxes()
    weld, nw, _ = topology(m)
    d = np.array([[x, y, z] for x in (-1, 0, 1) for y in (0.5, 1) for z in (-1, 0, 1) if (x, z) != (0, 0)], float)
    eyes = [np.r_[5.0 * e / np.linalg.norm(e), 1.0] for e in d]
    N = m.vertex_normals().astype(np.float64)
    across = sum(len(extract.contours(m.vertices, m.faces, N, weld, nw, e)) for e in eyes)
    assert across > 0  # what the sofa drew: lines along its sides' diagonals
    assert planar(m, weld).all()
    for e in eyes:
        s = object_segments(m, e)
        assert not (s.kind == extract.KIND["contour"]).any()
        assert (s.kind == extract.KIND["crease"]).sum() > 0


def test_a_capped_cylinders_contours_are_its_generators():
    """A 48-sided capped cylinder, its rims shared by sides and caps at 90 degrees (sharp). Vertex normals averaged
    over a rim lean toward the cap, so n . v interpolated over the sides crossed zero along a slanted path (38
    segments spiralling over the side seen from (3, 3.5, 4)), beside the rim's crease near the top. With normals
    parted at sharp edges (`extract.corner_normals`) the contours are the two generators where the radial normal
    is perpendicular to the view: at angles phi +- acos(R / rho) about the axis (analytic), 4 segments."""
    from nodegraph_nodes.mesh_lines import object_segments

    m = _prism(48)
    for eye in (np.array([3.0, 3.5, 4.0, 1.0]), np.array([0.5, 2.5, -3.0, 1.0]), np.array([-2.0, -1.0, 0.5, 1.0])):
        s = object_segments(m, eye)
        c = s.select(s.kind == extract.KIND["contour"])
        p = c.p.reshape(-1, 3)
        theta = np.degrees(np.arctan2(p[:, 2], p[:, 0]))
        phi, rho = np.degrees(np.arctan2(eye[2], eye[0])), np.hypot(eye[0], eye[2])
        truth = phi + np.array([-1.0, 1.0]) * np.degrees(np.arccos(1.0 / rho))
        off = np.abs((theta[:, None] - truth[None, :] + 180.0) % 360.0 - 180.0).min(axis=1)
        assert len(c) == 4 and off.max() < 0.5, (len(c), off.max())  # the facets' interpolation: under 0.1 deg here
        nearest = np.abs((theta[:, None] - truth[None, :] + 180.0) % 360.0 - 180.0).argmin(axis=1)
        for k in (0, 1):  # each generator runs from rim to rim
            y = p[nearest == k, 1]
            assert np.isclose(y.min(), 0.0) and np.isclose(y.max(), 2.0), (k, y)


def test_close_flicker_fills_short_hidden_runs_inside_a_chain():
    """Hidden runs of at most FLICKER (2) samples between visible samples of one chain become visible; longer runs,
    runs at a chain's end, runs that reach another chain and samples not `among` stay."""
    st = np.array([1, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 1], np.int8)
    off = np.array([0, 13, 16])
    got = extract.close_flicker(st, off, np.ones(16, bool))
    assert got.tolist() == [1, 1, 1, 1, 1, 1, 1, 0, 0, 0, 1, 1, 1, 1, 1, 1]
    assert extract.close_flicker(np.array([1, 0, 1, 0, 1, 1], np.int8), np.array([0, 3, 6]),
                                 np.ones(6, bool)).tolist() == [1, 1, 1, 0, 1, 1]  # index 3 starts chain 2
    among = np.ones(16, bool)
    among[1] = False
    assert extract.close_flicker(st, off, among)[1] == 0
    assert extract.close_flicker(np.array([0, 1, 0], np.int8), np.array([0, 3]), np.ones(3, bool)).tolist() == [0, 1, 0]


def test_bridge_outline_fills_short_runs_beside_a_visible_silhouette():
    """A chain of 12 samples along y = 0.5 on a 20 x 8 buffer covered below y = 1 (so every sample is beside the
    outline), its samples 4-7 hidden or dropped: drawn where a visible silhouette sample lies within reach of each,
    not where the silhouette there is hidden or too far, nor over a run longer than `most`."""
    far = extract.outline_far(np.where(np.arange(8)[:, None] < 1, 5.0, 0.0) * np.ones((8, 20), np.float32))
    xy = np.c_[np.arange(12) + 2.5, np.full(12, 0.5)]
    sm = extract.Samples(np.zeros((12, 3)), np.zeros(12, np.int64), np.zeros((12, 3)), np.ones(12, np.uint8),
                         np.ones(12, bool), xy, np.full(12, 5.0), np.array([0, 12]))
    state = np.ones(12, np.int8)
    state[4:8] = [0, -1, 0, 0]
    sil = extract.Samples(np.zeros((12, 3)), np.zeros(12, np.int64), np.zeros((12, 3)), np.ones(12, np.uint8),
                          np.ones(12, bool), xy + [0.0, 1.5], np.full(12, 5.0), np.array([0, 12]))
    interp = np.ones(12, bool)
    got = extract.bridge_outline(sm, state, interp, sil, np.ones(12, np.int8), 3.0, 12, far, 0.01)
    assert (got == 1).all()
    hidden_sil = np.ones(12, np.int8)
    hidden_sil[2:10] = -1  # no visible silhouette within 3 px of samples 5-6
    assert (extract.bridge_outline(sm, state, interp, sil, hidden_sil, 3.0, 12, far, 0.01)[4:8] != 1).any()
    assert (extract.bridge_outline(sm, state, interp, sil, np.ones(12, np.int8), 3.0, 3, far, 0.01)[4:8] != 1).all()


def test_a_capped_cones_sides_are_one_stroke_each(tmp_path):
    """A 32-sided capped cone (planar quads on its sides, sharp rims): each side's contour lies within a pixel of
    the outline on the faces turned away, where the depth buffer holds the faces turned toward the viewer, and a
    sample or two at a time tested hidden: without `close_flicker` each side came in 5-10 pieces at 400 px. Now
    two contour strokes at 256, 400 and 800 px."""
    n = 32
    a = 2 * np.pi * np.arange(n) / n
    prof = [(0.8, 0.0), (0.6, 0.4), (0.4, 0.8), (0.2, 1.2)]
    V = np.concatenate([np.c_[r * np.cos(a), np.full(n, y), -r * np.sin(a)] for r, y in prof]
                       + [[[0, 0, 0], [0, 1.2, 0]]])
    F = [[i * n + k, i * n + (k + 1) % n, (i + 1) * n + (k + 1) % n] for i in range(3) for k in range(n)]
    F += [[i * n + k, (i + 1) * n + (k + 1) % n, (i + 1) * n + k] for i in range(3) for k in range(n)]
    F += [[4 * n, (k + 1) % n, k] for k in range(n)] + [[4 * n + 1, 3 * n + k, 3 * n + (k + 1) % n] for k in range(n)]
    path = tmp_path / "cone.obj"
    path.write_text("".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in V)
                    + "".join(f"f {i + 1} {j + 1} {k + 1}\n" for i, j, k in F))
    nodes = "  gbuf:\n    type: rasterize\n  lines:\n    type: mesh_lines\n    in: {linear_depth: gbuf.linear_depth}\n"
    for size in (256, 400, 800):
        _, res = run_minimal(None, nodes, {"s": "lines.strokes"}, size=(size, size), scene=str(path))
        st = res.values[("lines", "strokes")]
        first = st.starts[:-1]
        contour = (st["kind"][first] == LINE_KINDS.index("contour")) & st["visible"][first]
        assert contour.sum() == 2, (size, int(contour.sum()))


def test_corner_normals_match_a_flood_fill():
    """extract.corner_normals (Mesh.render_arrays' smoothing groups) against the reference's flood fill in plain
    Python, on the capped cylinder, the two boxes and a coarse rock; where no sharp edge parts a vertex they are
    its welded vertex normal."""
    from nodegraph.scene.meshes import Mesh
    from tests.nodes.mesh_lines import reference as ref
    from tests.nodes.mesh_lines.test_mesh_lines_outline import icosphere

    rng = np.random.default_rng(5)
    v, f = icosphere(1)
    rock = Mesh("rock", v * (1 + 0.25 * rng.standard_normal(len(v)))[:, None], f)
    for m in (_prism(48), _two_boxes(), rock):
        at, normals = extract.corner_normals(m, 60.0)
        got = m.vertex_normals().astype(np.float64)[m.faces].reshape(-1, 3)
        got[at] = normals
        want = ref.corner_normals(m.vertices, m.faces, m.weld()[0], 60.0).reshape(-1, 3)
        assert len(at) and np.abs(got - want).max() < 1e-5, m.name
    assert len(extract.corner_normals(_prism(48), 100.0)[0]) == 0  # nothing sharp: the vertex normals throughout


def test_a_faceted_prism_outlines_on_its_edges():
    """An octagonal prism seen across its axis: its sides meet at 45 degrees, under the 60 degree crease angle,
    so its outline is no crease. Its faces are planar (the sides meet at more than the 40 degree render split),
    so the contour is the two side edges between faces turned toward and away from the eye: x = +-1, z = 0."""
    from nodegraph_nodes.mesh_lines import object_segments

    m = _prism()
    for eye in (np.array([0.0, 0.3, 1.0, 0.0]), np.array([0.0, 3.0, 10.0, 1.0])):  # orthographic, perspective
        s = object_segments(m, eye)
        c = s.select(s.kind == extract.KIND["contour"])
        assert len(c) == 2, len(c)
        p = c.p.reshape(-1, 3)
        assert np.allclose(np.abs(p[:, 0]), 1.0) and np.allclose(p[:, 2], 0.0)
        assert sorted(np.round(p[:, 1], 6).tolist()) == [0.0, 0.0, 2.0, 2.0]
        assert (s.kind == extract.KIND["crease"]).sum() > 0  # the caps' rims
    # with creases off, the rims' outline parts are drawn as contours instead of being lost
    s = object_segments(m, np.array([0.0, 0.3, 1.0, 0.0]), creases=False)
    assert (s.kind == extract.KIND["contour"]).sum() > 2


def _loop_samples(n: int = 40, square: bool = False) -> extract.Samples:
    """One closed chain of n + 1 samples round a circle (or a square, corners at samples 0, n/4, ...) of radius
    20 px; the last sample repeats the first."""
    t = np.linspace(0.0, 2.0 * np.pi, n + 1)
    xy = np.stack([20 * np.cos(t), 20 * np.sin(t)], axis=1) + 50.0
    if square:
        xy = np.concatenate([np.linspace(a, b, n // 4, endpoint=False)
                             for a, b in zip([(70, 50), (50, 70), (30, 50), (50, 30)],
                                             [(50, 70), (30, 50), (50, 30), (70, 50)], strict=True)] + [[(70, 50)]])
    k = len(xy)
    return extract.Samples(np.c_[xy, np.zeros(k)], np.zeros(k, np.int64), np.zeros((k, 3)), np.ones(k, np.uint8),
                           np.ones(k, bool), xy.astype(np.float64), np.ones(k), np.array([0, k]))


def test_a_closed_loop_cut_once_is_one_stroke_through_its_start():
    """A closed chain hidden over samples 10-15 is one visible stroke from 16 round through the chain's start to 9,
    not two meeting at the start (which sketchy_strokes would taper, and overshoot, at an arbitrary point); a
    loop whose closing point is a sharp corner stays cut there, and a loop seen whole is one stroke."""
    sm = _loop_samples()
    state = np.ones(41, np.int8)
    state[10:16] = 0
    idx, off = extract.split(sm, state, 100.0, 0.0, False)
    assert len(off) == 2 and idx.tolist() == list(range(16, 41)) + list(range(1, 10))
    idx, off = extract.split(sm, np.ones(41, np.int8), 100.0, 0.0, False)
    assert len(off) == 2 and idx.tolist() == list(range(41))
    sq = _loop_samples(square=True)
    state = np.ones(len(sq.xy), np.int8)
    state[15:18] = 0
    idx, off = extract.split(sq, state, 80.0, 0.0, False)
    strokes = [idx[a:b].tolist() for a, b in zip(off[:-1], off[1:], strict=True)]
    assert strokes == [list(range(0, 11)), list(range(10, 15)), list(range(18, 21)), list(range(20, 31)),
                       list(range(30, 41))]  # cut at every corner, the chain's start among them
