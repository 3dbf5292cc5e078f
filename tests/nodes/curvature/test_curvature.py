"""curvature node: per-object arrays through the executor, analytic torus, sphere fallback, welding, keys."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from nodegraph_nodes._shared.curvature import FIELDS, object_field
from nodegraph_nodes.curvature import smooth_line_field
from nodegraph_nodes.curvature.principal import DirectionSource

from nodegraph import pipeline as pl
from nodegraph.cache import Cache
from nodegraph.errors import NodeError
from nodegraph.executor import Executor
from nodegraph.node import HashContext
from nodegraph.scene.meshes import Mesh
from nodegraph.scene.primitives import sphere
from nodegraph.scene.scene import Scene, SceneObject, compose, frame_camera
from tests.helpers import assert_outputs_as_planned, run_minimal

R_MAJOR, R_MINOR = 2.0, 0.5

TEXT = """\
pipeline: t
size: [32, 32]
scene: builtin:box
nodes:
  curv: {type: curvature}
outputs:
  out: curv.out
"""


def torus_grid(nu: int = 200, nv: int = 50, seam: bool = False) -> tuple[Mesh, np.ndarray, np.ndarray]:
    """Torus about +Z with outward normals; (u, v) per vertex. With `seam`, the grid does not wrap: the
    first row and column are repeated as separate vertices (as OBJ files split at texture seams)."""
    cu, cv = (nu + 1, nv + 1) if seam else (nu, nv)
    i, j = np.meshgrid(np.arange(cu), np.arange(cv), indexing="ij")
    u, v = i * 2 * np.pi / nu, j * 2 * np.pi / nv
    ring = R_MAJOR + R_MINOR * np.cos(v)
    V = np.stack([ring * np.cos(u), ring * np.sin(u), R_MINOR * np.sin(v)], -1).reshape(-1, 3)
    qi, qj = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")

    def idx(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return (a % cu) * cv + b % cv if not seam else a * cv + b

    a, b, c, d = idx(qi, qj), idx(qi + 1, qj), idx(qi + 1, qj + 1), idx(qi, qj + 1)
    F = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return Mesh("torus", V, F), u.ravel(), v.ravel()


def run_on(meshes: list[Mesh], overrides: list[str] = (), transforms: list[np.ndarray] | None = None, gl=None):
    pipe = pl.loads(TEXT, "t.yaml", overrides=list(overrides), load_scene=False)
    objs = tuple(SceneObject(m, transforms[i] if transforms else np.eye(4)) for i, m in enumerate(meshes))
    lo, hi = meshes[0].bounds()
    pipe.scene = Scene("t", objs, frame_camera(lo, hi))
    ex = Executor(pipe, None, gl=gl)
    return pipe, ex, ex.run().values[("curv", "out")]


@pytest.fixture(scope="module")
def torus_result():
    mesh, u, v = torus_grid()
    _, _, out = run_on([mesh])
    return mesh, u, v, out


def test_arrays_per_object_shapes_and_dtypes(torus_result):
    mesh, _, _, out = torus_result
    n = mesh.n_vertices
    assert int(out["objects"]) == 1
    for name in FIELDS:
        assert object_field(0, name) in out.data
    for name in ("kmin", "kmax", "confidence"):
        a = out[object_field(0, name)]
        assert a.shape == (n,) and a.dtype == np.float32 and np.isfinite(a).all()
    for name in ("dmin", "dmax", "normal"):
        a = out[object_field(0, name)]
        assert a.shape == (n, 3) and a.dtype == np.float32 and np.isfinite(a).all()
        np.testing.assert_allclose(np.linalg.norm(a, axis=1), 1.0, atol=1e-5)
    assert out[object_field(0, "source")].dtype == np.uint8


def test_torus_matches_analytic_after_smoothing(torus_result):
    # ~10k vertices; kmax = 1/r around the tube, kmin = cos v / (R + r cos v) along the major circle, and
    # dmin along the major circle: the node's smoothing must not move them
    mesh, u, v, out = torus_result
    assert mesh.n_vertices == 10_000
    kmax, kmin = out[object_field(0, "kmax")], out[object_field(0, "kmin")]
    k_major = np.cos(v) / (R_MAJOR + R_MINOR * np.cos(v))
    assert np.all(np.abs(kmax - 1 / R_MINOR) <= 0.05 / R_MINOR)
    big = np.abs(k_major) >= 0.05
    assert np.all(np.abs(kmin - k_major)[big] <= 0.05 * np.abs(k_major[big]))
    along = np.stack([-np.sin(u), np.cos(u), np.zeros_like(u)], 1)
    angle = np.degrees(np.arccos(np.clip(np.abs(np.sum(out[object_field(0, "dmin")] * along, 1)), 0, 1)))
    assert angle.max() < 10.0


def test_welding_makes_seams_invisible():
    mesh, u, v = torus_grid(100, 40, seam=True)
    _, _, out = run_on([mesh])
    _, _, raw = run_on([mesh], ["curv.weld=false"])
    along = np.stack([-np.sin(u), np.cos(u), np.zeros_like(u)], 1)
    angle = np.degrees(np.arccos(np.clip(np.abs(np.sum(out[object_field(0, "dmin")] * along, 1)), 0, 1)))
    assert angle.max() < 10.0
    k_major = np.cos(v) / (R_MAJOR + R_MINOR * np.cos(v))

    def worst(arrays) -> float:
        return float(np.abs(arrays[object_field(0, "kmin")] - k_major).max())

    assert worst(out) < 0.03
    assert worst(raw) > 0.05  # unwelded, the seam reads as a boundary and the fit there is off
    # the two copies of a seam vertex carry the same values
    cv = 41
    first, last = np.arange(cv), 100 * cv + np.arange(cv)
    np.testing.assert_array_equal(out[object_field(0, "kmax")][first], out[object_field(0, "kmax")][last])


def test_sphere_falls_back_without_nan():
    mesh = sphere(1.0, 4)
    _, _, out = run_on([mesh])
    source = out[object_field(0, "source")]
    assert np.mean(source != DirectionSource.MEASURED) > 0.9
    assert np.mean(out[object_field(0, "confidence")] < 0.5) > 0.9
    for name in ("kmin", "kmax", "dmin", "dmax", "normal", "confidence"):
        assert np.isfinite(out[object_field(0, name)]).all()
    np.testing.assert_allclose(out[object_field(0, "kmin")], 1.0, rtol=0.06)


def test_same_mesh_twice_measured_once_and_arrays_shared(monkeypatch):
    from nodegraph_nodes.curvature import Curvature

    calls = []
    orig = Curvature.measure

    def counting(self, *a, **k):
        calls.append(1)
        return orig(self, *a, **k)

    monkeypatch.setattr(Curvature, "measure", counting)
    mesh, _, _ = torus_grid(40, 16)
    _, _, out = run_on([mesh, mesh], transforms=[np.eye(4), compose((5, 0, 0))])
    assert len(calls) == 1 and int(out["objects"]) == 2
    np.testing.assert_array_equal(out[object_field(0, "dmin")], out[object_field(1, "dmin")])
    assert str(out[object_field(0, "key")]) == str(out[object_field(1, "key")])


def test_key_covers_meshes_and_params_not_frame_camera_or_light():
    pipe = pl.loads(TEXT, "t.yaml")
    node = pipe.nodes["curv"]
    scene = pipe.scene
    moved = Scene(scene.name, scene.objects, frame_camera(*scene.bounds(), direction=(1, 2, 3)),
                  light_direction=(0, 1, 0), orbit=scene.orbit)
    k = node.key(HashContext((32, 32), 0, 1, scene), {})
    assert k == node.key(HashContext((640, 480), 9, 2, moved), {})
    other = Scene("s", (SceneObject(sphere(1.0, 2)),), scene.camera)
    assert k != node.key(HashContext((32, 32), 0, 1, other), {})
    assert k != pl.loads(TEXT, "t.yaml", overrides=["curv.radius=4"]).nodes["curv"].key(
        HashContext((32, 32), 0, 1, scene), {})


def test_persisted_once_and_reused_from_disk(tmp_path: Path):
    cache = Cache(tmp_path / "c")
    pipe = pl.loads(TEXT, "t.yaml")
    ex = Executor(pipe, cache, mode="loop")
    for frame in range(3):
        ex.run(frame)
    assert ex.compute_counts == {"curv": 1}
    cache.flush()
    ex2 = Executor(pl.loads(TEXT, "t.yaml"), cache, mode="loop")
    res = ex2.run(4)
    assert ex2.compute_counts == {} and res.stats["curv"].status == "disk"
    a, b = res.values[("curv", "out")], ex.run(0).values[("curv", "out")]
    assert set(a.data) == set(b.data)
    for name in a.data:
        np.testing.assert_array_equal(a[name], b[name])


def test_line_field_smoothing_is_sign_invariant_and_keeps_fixed():
    mesh, _, _ = torus_grid(40, 16)
    F = mesh.faces.astype(np.int64)
    n = mesh.n_vertices
    rng = np.random.default_rng(0)
    normal = np.tile([0.0, 0.0, 1.0], (n, 1))
    d = np.tile([1.0, 0.0, 0.0], (n, 1)) * rng.choice([-1.0, 1.0], size=(n, 1))  # one line, random signs
    out = smooth_line_field(F, d, normal, np.ones(n), 3)
    np.testing.assert_allclose(np.abs(out[:, 0]), 1.0, atol=1e-9)
    fixed = np.zeros(n, dtype=bool)
    fixed[:5] = True
    d2 = d.copy()
    d2[:5] = [0.0, 1.0, 0.0]
    out2 = smooth_line_field(F, d2, normal, np.ones(n), 3, fixed=fixed)
    np.testing.assert_array_equal(out2[:5], d2[:5])


def test_no_scene_is_a_clear_error():
    pipe = pl.loads(TEXT, "t.yaml", load_scene=False)
    with pytest.raises(NodeError, match=r"node '\w+' \(curvature\): needs a scene"):
        Executor(pipe, None).run()


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  c: {type: curvature}
"""
    ex, res = run_minimal(gl, nodes, {"out": "c.out"})
    assert assert_outputs_as_planned(ex, res, "c") == ["out"]


def test_smooth_field_follows_the_torus_major_circle_and_is_smoother():
    """field: smooth (global 2-RoSy solve): dmin within 10 degrees of the major circle, as spread, and the
    neighbour angle after transport no larger than spread's."""
    from nodegraph_nodes.curvature.field import smoothness_deg

    mesh, u, v = torus_grid()
    results = {}
    for field in ("spread", "smooth"):
        _, _, out = run_on([mesh], [f"curv.field={field}"])
        d = out[object_field(0, "dmin")].astype(np.float64)
        major = np.stack([-np.sin(u), np.cos(u), np.zeros_like(u)], 1)
        angle = np.degrees(np.arccos(np.clip(np.abs(np.sum(d * major, 1)), 0, 1)))
        assert angle.max() < 10.0, field
        results[field] = smoothness_deg(mesh.vertices, mesh.faces, out[object_field(0, "normal")].astype(np.float64), d)
    assert results["smooth"] <= results["spread"] + 0.05
