"""Posing prepared once, done for all parts at once (nodegraph/scene/posing.py, GltfAsset._posed_all): posed
vertices against a float64 NumPy reference of linear blend skinning and morph targets, the batched derived arrays
against each part's own, the compiled passes against the NumPy ones, GL buffers rewritten in place."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nodegraph.gpu.gl import MeshArrays
from nodegraph.scene import posing
from nodegraph.scene.gltf import load_asset
from nodegraph.scene.meshes import Mesh
from tests import gltf_files


@pytest.fixture
def asset(tmp_path):
    return load_asset(gltf_files.skinned_parts(tmp_path / "parts.gltf"))


def _reference(t: float) -> dict[str, np.ndarray]:
    """The file's posed vertices at t, by hand: joint 1 turned 90 t degrees about +Z at x = 1 (slerp about one
    axis is linear in the angle), the morph weight t; v' = sum_k w_k (J_k @ IBM_k) [v + t delta, 1]."""
    rings, segments = 9, 12
    xs = np.linspace(0.0, 2.0, rings)
    ang = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    v32 = np.array([[x, 0.2 * math.cos(a), 0.2 * math.sin(a)] for x in xs for a in ang], np.float32)
    v = v32.astype(np.float64)
    s = np.clip((v[:, 0].astype(np.float32) - np.float32(0.6)) / np.float32(0.8), 0.0, 1.0)
    w1f = (s * s * (3 - 2 * s)).astype(np.float32)
    w0, w1 = (np.float32(1) - w1f).astype(np.float64), w1f.astype(np.float64)  # as stored: float32
    th = math.radians(90.0 * t)
    rot = np.eye(4)
    rot[:2, :2] = [[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]]
    j1 = np.eye(4)
    j1[0, 3] = 1.0
    j1 = j1 @ rot
    ibm1 = np.eye(4)
    ibm1[0, 3] = -1.0
    m1 = j1 @ ibm1
    out = {}
    for name, offset, morph in (("morphing", 0.0, True), ("plain", 0.6, False)):
        p = (v32 + np.array([0.0, 0.0, offset], np.float32)).astype(np.float64)  # as stored: float32
        if morph:
            p = p + t * np.stack([np.zeros(len(v)), (v[:, 0].astype(np.float32) / 2).astype(np.float64),
                                  np.zeros(len(v))], 1)
        ph = np.c_[p, np.ones(len(p))]
        blended = w0[:, None, None] * np.eye(4) + w1[:, None, None] * m1
        out[name] = np.einsum("nij,nj->ni", blended, ph)[:, :3]
    return out


@pytest.mark.parametrize("t", [0.0, 0.35, 0.5, 1.0])
def test_posed_vertices_match_a_float64_reference(asset, t):
    anim = asset.animations[0]
    world, weights = asset.pose(t, anim)
    ref = _reference(t)
    for obj in asset.objects:
        mesh, skinned = asset.posed_mesh(obj, world, weights)
        assert skinned and mesh.rest is not None
        # float32 file data, float64 arithmetic: equal to float64 rounding
        np.testing.assert_allclose(mesh.vertices, ref[obj.name], rtol=0, atol=1e-12)
    # one batch for both parts, made once per pose
    a, _ = asset.posed_mesh(asset.objects[0], world, weights)
    b, _ = asset.posed_mesh(asset.objects[1], world, weights)
    assert posing.batched(a)[0] is posing.batched(b)[0]
    assert asset.posed_mesh(asset.objects[0], world, weights)[0] is a


def test_compiled_skinning_equals_the_numpy_reference(asset):
    world, weights = asset.pose(0.7, asset.animations[0])
    asset._posed_all(world, weights)
    ((skin, _, _), (prims, stacked)), = asset._skin_rows.items()
    joints, ibm = asset.skins[skin]
    v = np.concatenate([p.positions for p in prims])
    got, lin = posing.skin(stacked, world[joints] @ ibm, v)
    ref, ref_lin = posing.skin(stacked, world[joints] @ ibm, v, engine="numpy")
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-13)
    np.testing.assert_allclose(lin, ref_lin, rtol=0, atol=1e-13)


def test_posed_parts_share_their_rest_topology(asset):
    world, weights = asset.pose(0.5, asset.animations[0])
    mesh, _ = asset.posed_mesh(asset.objects[0], world, weights)
    rest = mesh.rest
    assert mesh.topology_mesh() is rest
    assert mesh.weld() is rest.weld() and mesh.face_components() is rest.face_components()
    assert mesh.render_arrays().indices is rest.render_arrays().indices
    assert mesh.hole_share() == rest.hole_share()


@pytest.mark.parametrize("t", [0.1, 0.2])
@pytest.mark.parametrize("engine", ["auto", "numpy"])
def test_batched_arrays_equal_each_part_alone(asset, t, engine):
    """Each part's render arrays and enlargement directions, made for the whole batch, against the same posed
    vertices as a plain mesh of its own (its smoothing groups, found on the posed surface, are the rest pose's:
    at these times no dihedral angle crosses the 40 degree crease angle)."""
    from nodes.rasterize import _enlarge_normals

    world, weights = asset.pose(t, asset.animations[0])
    posed = [m for m, _ in asset._posed_all(world, weights).values()]
    copies = [Mesh(m.name, m.vertices, m.faces, rest=m.rest) for m in posed]
    posing.PoseBatch(copies, engine=engine)
    for m in copies:
        alone = Mesh(m.name, m.vertices, m.faces)
        ra, ref = m.render_arrays(40.0), alone.render_arrays(40.0)
        np.testing.assert_array_equal(ra.indices, ref.indices)
        np.testing.assert_array_equal(ra.source_vertex, ref.source_vertex)
        np.testing.assert_array_equal(ra.positions, ref.positions)
        np.testing.assert_allclose(ra.normals, ref.normals, rtol=0, atol=2e-7)
        np.testing.assert_allclose(ra.smooth_normals, ref.smooth_normals, rtol=0, atol=2e-7)
        np.testing.assert_allclose(posing.enlarge_directions(m, 40.0), _enlarge_normals(alone, ref),
                                   rtol=0, atol=2e-7)
        lo, hi = m.bounds()
        np.testing.assert_array_equal(lo, m.vertices.min(axis=0))
        np.testing.assert_array_equal(hi, m.vertices.max(axis=0))


def test_mesh_buffers_rewrite_a_slot_in_place(gl):
    idx = np.array([[0, 1, 2]], np.uint32)

    def arrays(z: float) -> MeshArrays:
        return MeshArrays({"in_pos": (np.array([[0, 0, z], [1, 0, z], [0, 1, z]], np.float32), "3f")}, idx)

    first = gl.mesh_buffers(("test.posing", "a"), lambda: arrays(0.0), slot=("test.posing", "part"))
    second = gl.mesh_buffers(("test.posing", "b"), lambda: arrays(2.0), slot=("test.posing", "part"))
    assert second is first  # the same buffers, new vertices
    got = np.frombuffer(second.buffers["in_pos"][0].read(), np.float32).reshape(3, 3)
    np.testing.assert_array_equal(got[:, 2], [2.0, 2.0, 2.0])
    # other indices: new buffers
    other = MeshArrays({"in_pos": (np.zeros((3, 3), np.float32), "3f")}, np.array([[0, 2, 1]], np.uint32))
    third = gl.mesh_buffers(("test.posing", "c"), lambda: other, slot=("test.posing", "part"))
    assert third is not first
    # the rewritten key answers; the old one no longer does
    assert gl.mesh_buffers(("test.posing", "b"), lambda: arrays(5.0)) is first


def test_compiled_arrays_equal_the_numpy_reference(asset):
    """The compiled pass (one loop over faces, the third corner angle as pi less the other two) against the NumPy
    reference (three atan2 a face), the same posed vertices: equal to float32 rounding, bounds exactly."""
    if posing._jit() is None:
        pytest.skip("Numba not importable")
    world, weights = asset.pose(0.45, asset.animations[0])
    posed = [m for m, _ in asset._posed_all(world, weights).values()]
    made = {}
    for engine in ("auto", "numpy"):
        copies = [Mesh(m.name, m.vertices, m.faces, rest=m.rest) for m in posed]
        posing.PoseBatch(copies, engine=engine)
        made[engine] = [(m.render_arrays(40.0), posing.enlarge_directions(m, 40.0), m.vertex_normals(), m.bounds())
                        for m in copies]
    for (ra, en, vn, (lo, hi)), (ra0, en0, vn0, (lo0, hi0)) in zip(made["auto"], made["numpy"], strict=True):
        np.testing.assert_array_equal(ra.positions, ra0.positions)
        for got, want in ((ra.normals, ra0.normals), (ra.smooth_normals, ra0.smooth_normals), (en, en0),
                          (vn, vn0)):
            np.testing.assert_allclose(got, want, rtol=0, atol=1.2e-7)  # one float32 ulp at 1
        np.testing.assert_array_equal(lo, lo0)
        np.testing.assert_array_equal(hi, hi0)


def test_third_corner_angle_is_pi_less_the_others():
    """The identity the compiled pass uses, on slivers and near-flat triangles, in float64 against atan2."""
    rng = np.random.default_rng(3)
    p = rng.normal(size=(2000, 3, 3))
    p[:500, 2] = p[:500, 0] + 1e-6 * rng.normal(size=(500, 3))  # slivers
    p[500:1000, 2] = 0.5 * (p[500:1000, 0] + p[500:1000, 1]) + 1e-7 * rng.normal(size=(500, 3))  # near flat
    e = np.roll(p, -1, axis=1) - p
    area2 = np.linalg.norm(np.cross(e[:, 0], -e[:, 2]), axis=1)
    cos = -np.einsum("mij,mij->mi", e, np.roll(e, 1, axis=1))
    angles = np.arctan2(area2[:, None], cos)
    np.testing.assert_allclose(math.pi - angles[:, 0] - angles[:, 1], angles[:, 2], rtol=0, atol=2e-15)


def test_posed_vertices_are_shared_not_copied(asset):
    """The parts of one skin keep their rows of the skinning output (read-only), and the batch reads them in
    place: no copy per part, no concatenation."""
    world, weights = asset.pose(0.3, asset.animations[0])
    posed = [m for m, _ in asset._posed_all(world, weights).values()]
    base = posed[0].vertices.base
    assert base is not None and all(m.vertices.base is base for m in posed)
    v, _, _ = posing.batched(posed[0])[0]._vertices()
    assert np.shares_memory(v, base)
    np.testing.assert_array_equal(v, np.concatenate([m.vertices for m in posed]))
    # arrays that do not lie end to end are concatenated
    a, b = np.zeros((4, 3)), np.ones((2, 3))
    np.testing.assert_array_equal(posing._end_to_end([a, b]), np.concatenate([a, b]))
    whole = np.arange(30.0).reshape(10, 3)
    np.testing.assert_array_equal(posing._end_to_end([whole[4:], whole[:4]]), np.concatenate([whole[4:], whole[:4]]))
    assert np.shares_memory(posing._end_to_end([whole[:4], whole[4:7], whole[7:]]), whole)
