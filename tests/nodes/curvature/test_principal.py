"""Principal curvature (curvature node core): analytic torus, umbilic sphere, flat grid, broken meshes."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.curvature.principal import (
    DEFAULT_RADIUS,
    CurvatureResult,
    DirectionSource,
    Reason,
    compute_curvature,
    mesh_content_key,
)

from nodegraph.errors import MeshError

R_MAJOR, R_MINOR = 2.0, 0.5


def torus(nu: int = 200, nv: int = 50, jitter: float = 0.0, seed: int = 0):
    """Torus on a wrapped (u, v) grid: u around the z axis (major circle), v around the tube.

    Returns V, F, u, v.  Outward normals (counter-clockwise faces seen from outside).
    """
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    u = (i + jitter * rng.uniform(-1, 1, i.shape)) * 2 * np.pi / nu
    v = (j + jitter * rng.uniform(-1, 1, j.shape)) * 2 * np.pi / nv
    ring = R_MAJOR + R_MINOR * np.cos(v)
    V = np.stack([ring * np.cos(u), ring * np.sin(u), R_MINOR * np.sin(v)], -1).reshape(-1, 3)
    a = i * nv + j
    b = (i + 1) % nu * nv + j
    c = (i + 1) % nu * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    if jitter:  # random diagonals too
        flip = rng.random(i.shape) < 0.5
        t1 = np.where(flip[..., None], np.stack([a, b, d], -1), np.stack([a, b, c], -1))
        t2 = np.where(flip[..., None], np.stack([b, c, d], -1), np.stack([a, c, d], -1))
    else:
        t1, t2 = np.stack([a, b, c], -1), np.stack([a, c, d], -1)
    F = np.concatenate([t1.reshape(-1, 3), t2.reshape(-1, 3)])
    return V, F, u.ravel(), v.ravel()


def icosphere(level: int):
    t = (1 + 5**0.5) / 2
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                  [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)  # fmt: skip
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])  # fmt: skip
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    for _ in range(level):
        edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = V[unique[:, 0]] + V[unique[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        ab, bc, ca = inverse.reshape(3, -1) + len(V)
        a, b, c = F.T
        F = np.concatenate([np.stack(t, 1) for t in ([a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca])])
        V = np.concatenate([V, mid])
    return V, F


def uv_sphere(nu: int = 64, nv: int = 32):
    theta = np.linspace(0, np.pi, nv + 1)[1:-1]
    phi = np.arange(nu) * 2 * np.pi / nu
    T, P = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    V = np.concatenate([[[0.0, 0.0, 1.0]], ring, [[0.0, 0.0, -1.0]]])
    south = len(V) - 1
    F = []
    for i in range(nv - 1):
        for j in range(nu):
            a, b = 1 + i * nu + j, 1 + i * nu + (j + 1) % nu
            if i == 0:
                F.append([0, a, b])
            if i < nv - 2:
                c, d = 1 + (i + 1) * nu + j, 1 + (i + 1) * nu + (j + 1) % nu
                F += [[a, c, d], [a, d, b]]
            else:
                F.append([south, b, a])
    return V, np.array(F)


def grid(n: int = 20, z=None):
    x, y = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="ij")
    V = np.stack([x.ravel(), y.ravel(), np.zeros(n * n) if z is None else z(x, y).ravel()], 1)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a, b, c, d = i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1
    F = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return V, F


def channel(n_arc: int = 24, n_wall: int = 16, n_len: int = 40):
    """U-shaped channel extruded along y: a half-cylinder (radius 1) between two flat vertical walls."""
    arc = np.linspace(np.pi, 2 * np.pi, n_arc + 1)
    h = np.pi / n_arc  # wall spacing ~ arc spacing
    wall = np.arange(1, n_wall + 1) * h
    xs = np.concatenate([np.full(n_wall, -1.0), np.cos(arc), np.full(n_wall, 1.0)])
    zs = np.concatenate([wall[::-1], np.sin(arc), wall])
    ys = np.arange(n_len) * h
    m = xs.size
    V = np.stack([np.tile(xs, n_len), np.repeat(ys, m), np.tile(zs, n_len)], 1)
    i, j = np.meshgrid(np.arange(m - 1), np.arange(n_len - 1), indexing="ij")
    a, b, c, d = j * m + i, j * m + i + 1, (j + 1) * m + i + 1, (j + 1) * m + i
    F = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return V, F, np.tile(zs, n_len)


def assert_valid(res: CurvatureResult, n: int) -> None:
    for name in ("kmin", "kmax", "confidence"):
        arr = getattr(res, name)
        assert arr.shape == (n,) and arr.dtype == np.float64 and np.isfinite(arr).all(), name
    for name in ("dmin", "dmax", "normal"):
        arr = getattr(res, name)
        assert arr.shape == (n, 3) and arr.dtype == np.float64 and np.isfinite(arr).all(), name
        np.testing.assert_allclose(np.linalg.norm(arr, axis=1), 1.0, atol=1e-9)
    assert np.all(np.abs(res.kmin) <= np.abs(res.kmax))
    assert res.confidence.min() >= 0.0 and res.confidence.max() <= 1.0
    np.testing.assert_allclose(np.sum(res.dmin * res.normal, axis=1), 0.0, atol=1e-9)
    np.testing.assert_allclose(res.dmax, np.cross(res.normal, res.dmin), atol=1e-12)


@pytest.fixture(scope="module")
def torus_case():
    V, F, u, v = torus()
    return V, F, u, v, compute_curvature(V, F)


def test_default_radius_is_the_measured_one() -> None:
    assert DEFAULT_RADIUS == 3


def test_torus_values_match_analytic(torus_case) -> None:
    # Outward normals, convex positive, ordered by magnitude: the tube circle has kmax = 1/r = 2 (the larger
    # magnitude everywhere), the major circle kmin = cos v / (R + r cos v) in [-1/(R - r), 1/(R + r)] =
    # [-0.667, 0.4]: never umbilic.
    V, F, u, v, res = torus_case
    assert len(V) == 10_000
    assert_valid(res, len(V))
    k_tube = 1.0 / R_MINOR
    k_major = np.cos(v) / (R_MAJOR + R_MINOR * np.cos(v))
    assert np.all(np.abs(res.kmax - k_tube) <= 0.05 * k_tube)
    err = np.abs(res.kmin - k_major)
    big = np.abs(k_major) >= 0.05  # relative error is meaningless where k passes through 0 (v = +-pi/2)
    assert np.all(err[big] <= 0.05 * np.abs(k_major[big]))
    assert np.all(err <= 0.05 * np.abs(k_major).max())
    assert res.confidence.min() > 0.99
    assert all(count == 0 for count in res.counts.values())


def test_torus_directions_match_analytic(torus_case) -> None:
    # kmin is the major-circle curvature, so dmin runs along the major circle (d/du) and dmax around the tube.
    V, F, u, v, res = torus_case
    along_major = np.stack([-np.sin(u), np.cos(u), np.zeros_like(u)], 1)
    around_tube = np.stack([-np.sin(v) * np.cos(u), -np.sin(v) * np.sin(u), np.cos(v)], 1)
    angle_min = np.degrees(np.arccos(np.clip(np.abs(np.sum(res.dmin * along_major, 1)), 0, 1)))
    angle_max = np.degrees(np.arccos(np.clip(np.abs(np.sum(res.dmax * around_tube, 1)), 0, 1)))
    assert angle_min.max() < 10.0 and angle_max.max() < 10.0
    assert np.all(res.source == DirectionSource.MEASURED)


def test_jittered_torus_stays_close() -> None:
    V, F, u, v = torus(jitter=0.25, seed=1)
    res = compute_curvature(V, F)
    assert_valid(res, len(V))
    along_major = np.stack([-np.sin(u), np.cos(u), np.zeros_like(u)], 1)
    angle = np.degrees(np.arccos(np.clip(np.abs(np.sum(res.dmin * along_major, 1)), 0, 1)))
    assert angle.max() < 10.0
    assert np.percentile(np.abs(res.kmax - 2.0) / 2.0, 95) < 0.05


@pytest.mark.parametrize("mesh", ["icosphere", "uv_sphere"])
def test_sphere_is_umbilic_and_falls_back(mesh: str) -> None:
    V, F = icosphere(4) if mesh == "icosphere" else uv_sphere()
    res = compute_curvature(V, F)
    assert_valid(res, len(V))
    assert np.mean(res.confidence < 0.5) > 0.9
    assert res.counts["umbilic"] >= 0.9 * len(V)
    np.testing.assert_allclose(res.kmin, 1.0, rtol=0.06)  # unit sphere, outward normals: k = +1
    np.testing.assert_allclose(res.kmax, 1.0, rtol=0.06)
    assert np.all(res.source != DirectionSource.MEASURED)


def test_flat_grid_uses_fixed_frame() -> None:
    V, F = grid()
    res = compute_curvature(V, F)
    assert_valid(res, len(V))
    np.testing.assert_allclose(res.kmin, 0.0, atol=1e-9)
    np.testing.assert_allclose(res.kmax, 0.0, atol=1e-9)
    assert np.all(res.confidence == 0.0)
    assert np.all(res.source == DirectionSource.FIXED_FRAME)
    np.testing.assert_allclose(np.abs(res.normal[:, 2]), 1.0)
    np.testing.assert_allclose(res.dmin, np.tile([1.0, 0.0, 0.0], (len(V), 1)), atol=1e-12)  # world x


def test_unreliable_directions_smoothed_from_neighbours() -> None:
    # Every principal direction of an extrusion is along or across the extrusion axis y, and kmin = 0
    # along y.  The flat walls are umbilic: their directions come from the curved part, ring by ring.
    V, F, z = channel()
    res = compute_curvature(V, F)
    assert_valid(res, len(V))
    smoothed = res.source == DirectionSource.SMOOTHED
    assert res.counts["smoothed"] == int(smoothed.sum()) > 0
    assert np.all(res.confidence[smoothed] < 0.5)
    assert np.all(z[smoothed] > 0.0)  # only on the walls
    # libigl itself is ~3.4 degrees off on the wall row next to the arc (the fit straddles the jump in
    # curvature) and up to ~9 degrees at the open ends; the smoothed walls inherit that, no more.
    assert np.all(np.abs(res.dmin[smoothed, 1]) > np.cos(np.radians(10.0)))
    measured = res.source == DirectionSource.MEASURED
    assert np.all(np.abs(res.dmin[measured, 1]) > np.cos(np.radians(10.0)))
    fixed = res.source == DirectionSource.FIXED_FRAME  # wall normal ~ +-x, so the fixed frame uses world y
    assert fixed.any() and np.all(np.abs(res.dmin[fixed, 1]) > 0.999)


def test_unreferenced_vertex_and_degenerate_triangles() -> None:
    V, F, _, _ = torus()
    n = len(V)
    collinear = 0.5 * (V[F[0, 0]] + V[F[0, 1]])  # a vertex on the edge F[0,0]-F[0,1]
    V2 = np.concatenate([V, [[10.0, 10.0, 10.0]], [collinear]])
    F2 = np.concatenate([F, [[F[0, 0], F[0, 1], n + 1]], [[5, 7, 7]]])  # zero area; repeated index
    res = compute_curvature(V2, F2)
    assert_valid(res, len(V2))
    assert res.confidence[n] == 0.0 and res.confidence[n + 1] == 0.0
    assert res.reason[n] == Reason.UNREFERENCED and res.reason[n + 1] == Reason.UNREFERENCED
    assert res.kmin[n] == res.kmax[n] == 0.0
    np.testing.assert_allclose(res.dmin[n], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(res.dmax[n], [0.0, 1.0, 0.0])
    assert res.counts["unreferenced"] == 2
    # The rest of the mesh is untouched by the broken triangles.
    plain = compute_curvature(V, F)
    np.testing.assert_array_equal(res.kmax[:n], plain.kmax)
    np.testing.assert_array_equal(res.dmin[:n], plain.dmin)


def test_tiny_mesh_is_all_fallback() -> None:
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    res = compute_curvature(V, np.array([[0, 1, 2]]))
    assert_valid(res, 3)
    assert np.all(res.confidence == 0.0)
    assert np.all(res.source == DirectionSource.FIXED_FRAME)


def test_result_arrays_are_read_only(torus_case) -> None:
    res = torus_case[-1]
    with pytest.raises(ValueError):
        res.kmin[0] = 1.0


def test_mesh_content_key() -> None:
    V, F = icosphere(1)
    key = mesh_content_key(V, F, 3)
    assert len(key) == 64 and int(key, 16) >= 0
    assert key == mesh_content_key(V.copy(), F.astype(np.int32), 3)  # same content, other int width
    assert key != mesh_content_key(V, F, 4)
    moved = V.copy()
    moved[0, 0] += 1e-9
    assert key != mesh_content_key(moved, F, 3)
    assert key != mesh_content_key(V, F[:, [0, 2, 1]], 3)


@pytest.mark.parametrize(
    ("V", "F", "error", "match"),
    [
        (np.zeros((3, 2)), np.array([[0, 1, 2]]), MeshError, "shape"),
        (np.zeros((3, 3)), np.array([[0, 1, 3]]), MeshError, "face indices"),
        (np.array([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]), MeshError, "NaN"),
    ],
)
def test_bad_meshes_raise(V, F, error, match) -> None:
    with pytest.raises(error, match=match):
        compute_curvature(V, F)


def test_bad_radius_raises() -> None:
    V, F = icosphere(1)
    with pytest.raises(ValueError, match="radius"):
        compute_curvature(V, F, radius=1)
