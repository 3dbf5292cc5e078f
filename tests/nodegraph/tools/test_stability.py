"""What each node does where its method breaks (the break points come from `bench accuracy --families
stability`, see docs/stability.md): a warning, a fallback or a clear error; never NaN, a hang or a crash."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest
from nodegraph_nodes.curvature.accuracy import ellipsoid_truth, torus_mesh
from nodegraph_nodes.curvature.principal import DirectionSource, Reason, compute_curvature

from nodegraph.errors import MeshError
from nodegraph.scene.meshes import Mesh, MeshWarning, clear_mesh_cache, load_mesh
from nodegraph.scene.primitives import plane, sphere
from nodegraph.tools.bench.measure import gbuffer, release, scene_for
from nodegraph.tools.bench.stability import (
    broken_mesh_cases,
    edge_scores,
    linearize_window_depth,
    outlines_resolved,
    reference_truth,
    rod_scene,
    single_object_scene,
    with_camera,
)
from tests.conftest import SHARED_MESHES, shared_mesh

SIZE = (320, 320)


def _finite_unit_tangent(res) -> None:
    for a in (res.kmin, res.kmax, res.dmin, res.dmax, res.normal, res.confidence):
        assert np.isfinite(a).all()
    assert np.allclose(np.linalg.norm(res.dmin, axis=1), 1.0)
    assert np.allclose(np.einsum("ij,ij->i", res.dmin, res.normal), 0.0, atol=1e-9)
    assert ((res.confidence >= 0) & (res.confidence <= 1)).all()


# -- depth precision ---------------------------------------------------------------------------------
def test_linear_depth_holds_where_window_depth_breaks(gl):
    """far/near 1e5: 16-bit window depth has lost the edges; the float32 linear depth that edge_detect
    reads (rasterize.normal_depth.w, written by the vertex stage) still finds them."""
    base = replace(scene_for(str(shared_mesh("spot.obj"))), orbit=None)
    truth = reference_truth(gl, base, SIZE)
    scene = with_camera(base, near=base.camera.far / 1e5)
    g = gbuffer(gl, scene, SIZE, ("normal_depth", "depth"))
    linear = edge_scores(gl, scene, SIZE, truth, nd=g["normal_depth"])
    nd = g["normal_depth"].read()
    w16 = linearize_window_depth(g["depth"].read()[..., 0], scene.camera.near, scene.camera.far, bits=16)
    tex = gl.upload(np.concatenate([nd[..., :3], w16[..., None]], axis=2), "RGBA32F")
    window16 = edge_scores(gl, scene, SIZE, truth, nd=tex)
    gl.release(tex)
    release(gl, g)
    assert linear["f1"] >= 0.9 and window16["f1"] < 0.5, (linear, window16)


@pytest.mark.parametrize("ratio", [1e6, 1e9])
def test_extreme_near_far_ratio_gives_finite_buffers_and_edges(gl, ratio):
    base = replace(scene_for(str(shared_mesh("spot.obj"))), orbit=None)
    scene = with_camera(base, near=base.camera.far / ratio)
    g = gbuffer(gl, scene, SIZE, ("normal_depth", "depth", "linear_depth"))
    assert all(np.isfinite(t.read()).all() for t in g.values())
    s = edge_scores(gl, scene, SIZE, np.zeros(SIZE[::-1], bool), nd=g["normal_depth"])
    release(gl, g)
    assert s["finite"]


# -- scale ---------------------------------------------------------------------------------------------
def _spot_scaled(s: float) -> Mesh:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mesh(shared_mesh("spot.obj"))
    return Mesh("spot", m.vertices * s, m.faces)


def test_edges_are_scale_invariant_from_1e_minus_20_to_1e20(gl):
    f1 = {}
    for s in (1e-20, 1e-16, 1e-3, 1.0, 1e3, 1e20):
        scene = single_object_scene(_spot_scaled(s))
        truth = reference_truth(gl, scene, SIZE)
        assert truth.sum() > 500, f"scale {s:g}: the mesh is drawn (no absolute near-plane floor)"
        f1[s] = edge_scores(gl, scene, SIZE, truth)["f1"]
    assert max(f1.values()) - min(f1.values()) < 0.01, f1


@pytest.mark.parametrize("s", [1e-40, 1e40])
def test_past_the_float32_range_the_buffers_stay_finite(gl, s):
    scene = single_object_scene(_spot_scaled(s))
    g = gbuffer(gl, scene, SIZE, ("normal_depth", "depth", "linear_depth", "position", "normal"))
    assert all(np.isfinite(t.read()).all() for t in g.values())
    release(gl, g)


def test_curvature_is_scale_invariant():
    V, F = torus_mesh(48, 12)
    ref = compute_curvature(V, F)
    for s in (1e-20, 1e-9, 1e9, 1e20):
        res = compute_curvature(V * s, F)
        assert np.allclose(res.kmax * s, ref.kmax, rtol=1e-6, atol=1e-9)
        assert np.allclose(np.abs(np.einsum("ij,ij->i", res.dmin, ref.dmin)), 1.0, atol=1e-6)


# -- grazing angles and thin features -------------------------------------------------------------------
def test_grazing_floor_four_neighbour_holds_sobel_marks_false_edges(gl):
    from nodegraph.tools.bench.stability import sweep_grazing

    sweep = sweep_grazing(quick=True, size=320)
    at = {(p["series"], p["x"]): p for p in sweep["points"]}
    assert all(p["finite"] for p in sweep["points"])
    assert at[("floor, four_neighbour", 88.0)]["value"] >= 0.9
    assert at[("box face, four_neighbour", 89.53)]["value"] >= 0.85
    assert at[("floor, sobel", 88.0)]["precision"] < 0.5 <= at[("floor, sobel", 60.0)]["precision"]


def test_thin_rod_outlines_merge_and_vanish_without_nan(gl):
    size = 400
    found = {}
    for d in (8.0, 0.5):
        scene = rod_scene(d, size)
        truth = reference_truth(gl, scene, (size, size))
        nd = gbuffer(gl, scene, (size, size))["normal_depth"]
        from nodegraph_nodes.edge_detect import EdgeDetect

        from nodegraph.tools.bench.measure import NodeRunner

        e = NodeRunner(gl, (size, size), scene).run(EdgeDetect("e"), {"normal_depth": nd}, frozenset({"out"}))
        arr = e["out"].read()[..., 0]
        release(gl, e)
        gl.release(nd)
        assert np.isfinite(arr).all() and truth.sum() > 0
        found[d] = outlines_resolved(arr > 0.5, d)
    assert found[8.0] == 1.0 and found[0.5] == 0.0


def test_cow_legs_at_low_resolution(gl):
    scene = replace(scene_for(str(shared_mesh("cow.obj"))), orbit=None)
    for size in (50, 800):
        truth = reference_truth(gl, scene, (size, size))
        assert edge_scores(gl, scene, (size, size), truth)["f1"] >= 0.85


# -- curvature: noise, resolution, umbilics, flat -------------------------------------------------------
def test_curvature_under_heavy_vertex_noise_is_finite_with_low_confidence():
    V, F = torus_mesh(100, 25)
    edge = float(np.mean(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1)))
    noisy = V + 0.5 * edge * np.random.default_rng(3).normal(size=V.shape)
    clean = compute_curvature(V, F)
    res = compute_curvature(noisy, F)
    _finite_unit_tangent(res)
    assert res.confidence.mean() < clean.confidence.mean()
    assert res.counts["umbilic"] > clean.counts["umbilic"]


def test_too_coarse_torus_stays_finite():
    """3 vertices around the tube: past the resolution break. The quadric fit returns finite unit directions,
    but values 15x too large with full confidence and no warning (a finding, see docs/stability.md)."""
    V, F = torus_mesh(8, 3)
    res = compute_curvature(V, F)
    _finite_unit_tangent(res)
    assert res.counts["bad"] == 0 and res.counts["nonfinite"] == 0


def test_sphere_every_vertex_umbilic_with_defined_directions():
    s = sphere(1.0, 3)
    res = compute_curvature(s.vertices, s.faces)
    _finite_unit_tangent(res)
    assert (res.reason == Reason.UMBILIC).all()
    assert (res.source != DirectionSource.MEASURED).all()
    assert np.allclose(res.kmax, 1.0, atol=0.05)


def test_flat_plane_directions_from_the_fixed_frame():
    p = plane(2.0, 6)
    res = compute_curvature(p.vertices, p.faces)
    _finite_unit_tangent(res)
    assert np.allclose(res.kmin, 0.0, atol=1e-9) and np.allclose(res.kmax, 0.0, atol=1e-9)
    assert (res.source == DirectionSource.FIXED_FRAME).all()


def test_nearly_spherical_ellipsoid_measures_only_what_it_can():
    s = sphere(1.0, 4)
    abc = (1.5, 1.0, 1 / 1.5)
    V = np.asarray(s.vertices) * np.array(abc)
    res = compute_curvature(V, s.faces)
    _finite_unit_tangent(res)
    kmin, kmax, dmin, _ = ellipsoid_truth(V, abc)
    measured = res.source == DirectionSource.MEASURED
    assert measured.mean() > 0.9
    ang = np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", res.dmin, dmin))[measured], 0, 1)))
    assert np.percentile(ang, 95) < 10.0


# -- broken meshes ---------------------------------------------------------------------------------
@pytest.fixture
def broken(tmp_path):
    return broken_mesh_cases(tmp_path, SHARED_MESHES)


@pytest.mark.parametrize("name", ["nan_vertex.obj", "inf_vertex.obj", "empty.obj", "vertices_only.obj",
                                  "bad_index.obj", "only_degenerate.obj"])
def test_unusable_mesh_files_raise_a_mesh_error_naming_the_file(broken, name):
    clear_mesh_cache()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)
        with pytest.raises(MeshError) as err:
            load_mesh(broken[name])
    assert str(broken[name]) in str(err.value)


def test_degenerate_and_duplicate_faces_are_removed_with_one_warning(broken, gl):
    clear_mesh_cache()
    # a repeated index and a zero-area (collinear) face; the same face twice more, once rotated
    with pytest.warns(MeshWarning, match=r"removed 2 degenerate faces .* and 2 duplicate faces; 2 of 6") as rec:
        mesh = load_mesh(broken["degenerate_duplicate.obj"])
    assert len(rec) == 1 and mesh.n_faces == 2
    scene = single_object_scene(mesh)
    s = edge_scores(gl, scene, (200, 200), reference_truth(gl, scene, (200, 200)))
    assert s["finite"] and s["f1"] > 0.9


def test_curvature_rejects_nan_coordinates_clearly():
    V, F = torus_mesh(12, 6)
    V[3, 1] = np.nan
    with pytest.raises(MeshError, match="NaN/Inf"):
        compute_curvature(V, F)


@pytest.mark.parametrize("name, check", [
    ("teapot.obj", lambda t: t.n_boundary_edges > 0 and t.n_components > 1),
    ("suzanne.obj", lambda t: t.n_components == 4),
    ("stanford-bunny.obj", lambda t: t.n_boundary_edges > 0 and t.n_unreferenced == 0),  # 1113 unused: dropped
])
@pytest.mark.slow  # up to 1.7 s a mesh
def test_shared_broken_meshes_draw_and_measure(gl, name, check):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)
        mesh = load_mesh(shared_mesh(name))
    assert check(mesh.topology())
    scene = single_object_scene(mesh)
    truth = reference_truth(gl, scene, SIZE)
    s = edge_scores(gl, scene, SIZE, truth)
    assert s["finite"] and s["f1"] >= 0.85, s
    res = compute_curvature(mesh.vertices, mesh.faces)
    _finite_unit_tangent(res)
    assert res.counts["unreferenced"] == mesh.topology().n_unreferenced


# -- particles -------------------------------------------------------------------------------------
@pytest.mark.parametrize("params", [dict(drag=0.0), dict(randomness=1e9), dict(mass=1e-12),
                                    dict(drag=0.0, mass=1e-9, randomness=1e9, step=100.0)])
def test_particles_at_extremes_end_within_their_caps_with_finite_ink(params):
    core = pytest.importorskip("nodegraph_nodes.particle_sketch.core")
    yy, xx = np.mgrid[0:160, 0:160]
    depth = np.where((xx - 80.0) ** 2 + (yy - 80.0) ** 2 < 50.0**2, 0.4, 1.0)
    edges, ff = core.prepare(depth, 0.03)
    pp = core.ParticleParams(strokes=500, **params)
    res = core.simulate(edges, ff, pp, np.random.default_rng(0))
    # the run ends by its caps whatever the dynamics do (no drag, huge forces, no mass): at most `strokes`
    # particles, each drawing at most `max_steps` segments, and every segment counted is in a returned stroke
    assert res.launched <= pp.strokes
    assert len(res.strokes) <= res.launched
    assert all(2 <= len(s) <= pp.max_steps + 1 for s in res.strokes)
    assert res.steps == sum(len(s) - 1 for s in res.strokes) <= res.launched * pp.max_steps
    assert np.isfinite(res.sketch).all() and ((res.sketch >= 0) & (res.sketch <= 1)).all()
    assert all(np.isfinite(s).all() for s in res.strokes)
    cov, prec = core.coverage_precision(res.sketch, edges)
    assert 0.0 <= cov <= 1.0 and 0.0 <= prec <= 1.0
