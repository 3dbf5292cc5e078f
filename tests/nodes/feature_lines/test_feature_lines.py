"""feature_lines: analytic surfaces (ellipsoid ridges on its principal planes, torus suggestive contours on
the analytic zeros of the radial curvature, none on a sphere), then the node through a pipeline."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes._shared import feature_lines as L
from nodegraph_nodes.curvature.principal import compute_curvature

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from tests.helpers import run_minimal

R_MAJOR, R_MINOR = 2.0, 0.5


def icosphere(level: int) -> tuple[np.ndarray, np.ndarray]:
    t = (1 + 5 ** 0.5) / 2
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    for _ in range(level):
        edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(edges, axis=0, return_inverse=True)
        mid = len(V) + inv.reshape(3, -1).T  # (m, 3): midpoints of edges 01, 12, 20
        M = (V[uniq[:, 0]] + V[uniq[:, 1]]) / 2
        V = np.concatenate([V, M])
        a, b, c = F.T
        ab, bc, ca = mid.T
        F = np.concatenate([np.stack(x, 1) for x in ([a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca])])
    return V / np.linalg.norm(V, axis=1, keepdims=True), F


def torus(nu: int = 300, nv: int = 80) -> tuple[np.ndarray, np.ndarray]:
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    u, v = i * 2 * np.pi / nu, j * 2 * np.pi / nv
    V = _torus_point(u, v).reshape(-1, 3)

    def idx(a, b):
        return (a % nu) * nv + b % nv

    a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
    return V, np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])


def _torus_point(u, v):
    ring = R_MAJOR + R_MINOR * np.cos(v)
    return np.stack([ring * np.cos(u), ring * np.sin(u), R_MINOR * np.sin(v)], -1)


def analytic_radial(u, v, eye):
    """kappa_r sin^2(theta) of the analytic torus (the quantity `lines.radial` measures): k = cos v/(R + r cos v)
    along the major circle, 1/r along the tube."""
    p = _torus_point(u, v)
    n = np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], -1)
    tu = np.stack([-np.sin(u), np.cos(u), 0 * u], -1)
    tv = np.stack([-np.sin(v) * np.cos(u), -np.sin(v) * np.sin(u), np.cos(v)], -1)
    view = eye - p
    view /= np.linalg.norm(view, axis=-1, keepdims=True)
    w = view - np.sum(view * n, -1, keepdims=True) * n
    return np.cos(v) / (R_MAJOR + R_MINOR * np.cos(v)) * np.sum(w * tu, -1) ** 2 + np.sum(w * tv, -1) ** 2 / R_MINOR


def ops_of(V, F):
    c = compute_curvature(V, F, 3)
    return L.mesh_ops(V, F, c.kmin, c.kmax, c.dmin, c.dmax, c.normal, c.confidence)


def test_ellipsoid_ridges_lie_on_its_principal_planes() -> None:
    axes = np.array([1.5, 1.0, 0.6])
    V, F = icosphere(5)
    ops = ops_of(V * axes, F)
    ext = L.extrema_data(ops)
    ridges = L.ridges(ops, ext, 3.0, "ridge")
    assert ridges.length() > 3.0  # the ridge lines exist (the principal ellipses are 4-8 units round)
    off_plane = np.abs(ridges.points.reshape(-1, 3) / axes).min(axis=1)  # distance to the nearest plane
    edge = np.linalg.norm(V[F[:, 1]] - V[F[:, 0]], axis=1).mean()
    assert np.percentile(off_plane, 100) < 0.05 * edge
    assert len(L.ridges(ops, ext, 3.0, "valley")) == 0  # convex: no valleys


def test_sphere_has_no_lines() -> None:
    V, F = icosphere(5)
    ops = ops_of(V, F)
    ext = L.extrema_data(ops)
    assert len(L.ridges(ops, ext, 3.0, "ridge")) == 0
    assert len(L.ridges(ops, ext, 3.0, "valley")) == 0
    assert len(L.suggestive_contours(ops, np.array([3.0, 2.0, 4.0]), 0.0, 0.0)) == 0


def test_torus_suggestive_contours_on_the_analytic_zero_of_radial_curvature() -> None:
    V, F = torus()
    ops = ops_of(V, F)
    eye = np.array([0.0, -6.0, 4.0])
    seg = L.suggestive_contours(ops, eye, 1e-4, 0.0)
    assert seg.length() > 1.0
    P = seg.points.reshape(-1, 3)
    u = np.arctan2(P[:, 1], P[:, 0])
    v = np.arctan2(P[:, 2], np.hypot(P[:, 0], P[:, 1]) - R_MAJOR)
    h = 1e-5
    f = analytic_radial(u, v, eye)
    fu = (analytic_radial(u + h, v, eye) - analytic_radial(u - h, v, eye)) / (2 * h) / (R_MAJOR + R_MINOR * np.cos(v))
    fv = (analytic_radial(u, v + h, eye) - analytic_radial(u, v - h, eye)) / (2 * h) / R_MINOR
    dist = np.abs(f) / np.hypot(fu, fv)  # distance to the analytic zero set, to first order
    edge = np.linalg.norm(V[F[:, 1]] - V[F[:, 0]], axis=1).mean()
    assert np.median(dist) < 0.05 * edge and np.percentile(dist, 99) < 0.25 * edge
    # D_w kappa_r > 0 analytically: a step toward the viewer (along w) raises kappa_r
    n = np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], -1)
    view = eye - P
    w = view - np.sum(view * n, -1, keepdims=True) * n
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    tu = np.stack([-np.sin(u), np.cos(u), 0 * u], -1)
    tv = np.stack([-np.sin(v) * np.cos(u), -np.sin(v) * np.sin(u), np.cos(v)], -1)
    du = np.sum(w * tu, 1) / (R_MAJOR + R_MINOR * np.cos(v))
    dv = np.sum(w * tv, 1) / R_MINOR
    e = 1e-3
    rise = analytic_radial(u + e * du, v + e * dv, eye) - analytic_radial(u - e * du, v - e * dv, eye)
    assert np.mean(rise > 0) > 0.9  # the rest: ends of lines, where D_w kappa_r -> 0


def test_torus_zero_set_with_positive_derivative_is_covered() -> None:
    """The converse: analytic suggestive-contour points seen from the eye lie near an extracted segment."""
    V, F = torus()
    ops = ops_of(V, F)
    eye = np.array([0.0, -6.0, 4.0])
    seg = L.suggestive_contours(ops, eye, 1e-4, 0.0)
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 720), np.linspace(-np.pi, np.pi, 720), indexing="ij")
    f = analytic_radial(u, v, eye)
    cross = np.sign(f[:, 1:]) != np.sign(f[:, :-1])
    uu, vv = u[:, 1:][cross], 0.5 * (v[:, 1:] + v[:, :-1])[cross]
    p = _torus_point(uu, vv)
    n = np.stack([np.cos(vv) * np.cos(uu), np.cos(vv) * np.sin(uu), np.sin(vv)], -1)
    view = eye - p
    cos_t = np.sum(n * view, 1) / np.linalg.norm(view, axis=1)
    # along w the radial curvature must rise (the kept side), and the point must face the eye
    w = view - np.sum(view * n, -1, keepdims=True) * n
    w /= np.linalg.norm(w, axis=1, keepdims=True)

    def at(q):
        return analytic_radial(np.arctan2(q[:, 1], q[:, 0]), np.arctan2(q[:, 2], np.hypot(q[:, 0], q[:, 1]) - R_MAJOR),
                               eye)

    good = (cos_t > 0.05) & (at(p + 1e-2 * w) - at(p - 1e-2 * w) > 0)
    assert good.sum() > 50
    mids = seg.points.mean(axis=1)
    d = np.min(np.linalg.norm(p[good][:, None, :] - mids[None, :, :], axis=2), axis=1)
    edge = np.linalg.norm(V[F[:, 1]] - V[F[:, 0]], axis=1).mean()
    assert np.mean(d < 2 * edge) > 0.95


NODES = """\
  g: {type: rasterize}
  curv: {type: curvature, params: {smoothing: 0}}
  e: {type: edge_detect, in: {normal_depth: g.normal_depth}}
  f: {type: feature_lines, in: {curvature: curv.out, normal_depth: g.normal_depth, edges: e.out}%s}
"""


def test_node_outputs_shapes_and_edges_combined(gl) -> None:
    outs = {"out": "f.out", "s": "f.suggestive", "r": "f.ridges", "v": "f.valleys", "e": "e.out"}
    _, res = run_minimal(gl, NODES % ", params: {ridge_threshold: 2, derivative_threshold: 0.1}", outs,
                         size=(96, 80), scene="builtin:torus")
    vals = {k: res.values[tuple(ref.split("."))].read()[..., 0] for k, ref in outs.items()}
    for k in ("out", "s", "r", "v"):
        assert vals[k].shape == (80, 96) and np.isfinite(vals[k]).all()
        assert vals[k].min() >= 0 and vals[k].max() <= 1
    assert vals["s"].max() > 0.5  # the torus's saddle region carries suggestive contours
    parts = np.maximum.reduce([vals["e"], vals["s"] * 1.0, vals["r"] * 0.8, vals["v"] * 0.8])
    assert np.abs(vals["out"] - parts).max() < 2e-3


def test_lines_behind_the_surface_are_hidden(gl) -> None:
    """Depth test: with a zero tolerance and the G-buffer of the scene, lines on back faces never show, and
    the suggestive lines drawn are where the G-buffer has the object."""
    _, res = run_minimal(gl, NODES % ", params: {derivative_threshold: 0.1}", {"s": "f.suggestive",
                         "nd": "g.normal_depth"}, size=(96, 80), scene="builtin:torus")
    s = res.values[("f", "suggestive")].read()[..., 0]
    nd = res.values[("g", "normal_depth")].read()[..., 3]
    on = s > 0.5
    assert on.any() and np.mean(nd[on] > 0) > 0.9


def test_bad_params_are_located() -> None:
    text = "pipeline: t\nsize: [8, 8]\nscene: builtin:box\nnodes:\n" + NODES % ", params: {width: 0}" + \
        "outputs:\n  o: f.out\n"
    with pytest.raises(PipelineError, match=r"t.yaml:\d+:\d+.*width"):
        pl.loads(text, "t.yaml")


def _two_boxes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A slab standing on a wider base, touching it along a line of the base's top (a sofa's back on its seat,
    kit-bashed): (V, F, weld ids), each box with 8 shared corners and 12 triangles."""
    from nodegraph.scene import primitives
    from nodegraph.scene.meshes import Mesh, merge_meshes

    def box(lo, hi):
        b = primitives.box(1.0)
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        return Mesh("box", (b.vertices + 0.5) * (hi - lo) + lo, b.faces)

    m = merge_meshes([box((-0.8, 0.3, -0.45), (0.8, 0.85, -0.25)), box((-0.8, 0.08, -0.45), (0.8, 0.3, 0.43))], "two")
    return m.vertices, m.faces, m.weld()[0]


def _plain_ops(V: np.ndarray, F: np.ndarray, weld: np.ndarray) -> L.MeshOps:
    n = len(V)
    return L.mesh_ops(V, F, np.zeros(n), np.zeros(n), np.tile((1.0, 0.0, 0.0), (n, 1)),
                      np.tile((0.0, 0.0, 1.0), (n, 1)), np.tile((0.0, 1.0, 0.0), (n, 1)), np.ones(n), weld=weld)


def test_planar_faces_by_hand() -> None:
    V, F, weld = _two_boxes()
    assert _plain_ops(V, F, weld).planar.all()  # every neighbour coplanar or across a 90° crease
    Vs, Fs = icosphere(3)
    assert not ops_of(Vs, Fs).planar.any()  # neighbours meet at about 3.7°
    # one corner of the base pulled out a little along its diagonal: the base's three sides that meet there
    # (x = 0.8, y = 0.3, z = 0.43) now bend across their own diagonals by more than PLANAR_DEG and less than
    # the crease; every other face keeps only coplanar or creased neighbours
    corner = np.array([0.8, 0.3, 0.43])
    moved = np.flatnonzero(np.all(np.isclose(V, corner), axis=1))
    Vb = V.copy()
    Vb[moved] += 0.02
    bent = _plain_ops(Vb, F, weld)
    base = np.arange(len(F)) >= 12
    on_side = np.zeros(len(F), dtype=bool)
    for k in range(3):
        on_side |= np.all(np.isclose(V[F][:, :, k], corner[k]), axis=1)
    assert (base & on_side).sum() == 6
    assert np.array_equal(bent.planar, ~(base & on_side))


def test_no_suggestive_contours_inside_planar_regions() -> None:
    """Two touching boxes, measured welded as the curvature node measures them: a plane has no suggestive
    contour, but the corners' curvature, measured across the creases, interpolated over the big triangles
    crosses zero inside them."""
    from dataclasses import replace

    V, F, weld = _two_boxes()
    ids, first = np.unique(weld, return_index=True)
    where = np.searchsorted(ids, weld)
    c = compute_curvature(V[first], where[F], 3)
    ops = L.mesh_ops(V, F, c.kmin[where], c.kmax[where], c.dmin[where], c.dmax[where], c.normal[where],
                     c.confidence[where], weld=weld)
    ops = L.smooth_curvature(ops, 0.01 * ops.diag, weld)
    d = np.array([[x, y, z] for x in (-1, 0, 1) for y in (0.5, 1) for z in (-1, 0, 1) if (x, z) != (0, 0)], float)
    eyes = 5.0 * d / np.linalg.norm(d, axis=1, keepdims=True)
    unmasked = replace(ops, planar=None)
    assert sum(L.suggestive_contours(unmasked, e, 2.0, 25.0).length() for e in eyes) > 0.5  # the stray lines
    assert sum(len(L.suggestive_contours(ops, e, 2.0, 25.0)) for e in eyes) == 0
    Vt, Ft = torus()
    assert not ops_of(Vt, Ft).planar.any()  # a smooth surface keeps every suggestive contour


def test_per_mesh_data_is_made_once_for_a_scene_of_many_objects(gl, monkeypatch) -> None:
    """The operators, smoothed curvature and ridges of a still mesh are made once and kept while the camera
    moves, for every object of the scene: the cloister has more distinct meshes than the 8 kept before, which
    made every frame compute them all again (40 of a 53 ms frame of repeated_edges at 400 px)."""
    import nodegraph as ng

    made = []
    real = L.mesh_ops
    monkeypatch.setattr(L, "mesh_ops", lambda *a, **k: made.append(1) or real(*a, **k))
    monkeypatch.setitem(gl.resources, "feature_lines.ops", {})  # nothing kept from earlier tests in this process
    with ng.Session(cache=False) as session:
        pipe = session.load("repeated_edges", size=(96, 96))  # the cloister, its camera orbiting
        pipe.render(frame=0)
        first = len(made)
        assert first > 8  # more meshes than the old bound
        for frame in (1, 2, 3):
            pipe.render(frame=frame)
    assert len(made) == first
