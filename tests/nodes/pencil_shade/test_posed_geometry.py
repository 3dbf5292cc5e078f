"""pencil_shade's per-frame geometry of a posed part: the slotted vertex table (corner slots, copies, indices) is
topology, made once per rest pose and shared by every frame; curvature directions carried by the skin match a
float64 reference."""

from __future__ import annotations

import numpy as np
from nodegraph_nodes.pencil_shade import _slotted, corner_slots, skinned_directions

from nodegraph.scene.gltf import load_asset
from tests import gltf_files


def test_slotted_table_is_the_rest_poses_and_made_once(tmp_path):
    asset = load_asset(gltf_files.skinned_parts(tmp_path / "parts.gltf"))
    anim = asset.animations[0]
    tables = []
    for t in (0.2, 0.6):
        world, weights = asset.pose(t, anim)
        mesh, _ = asset.posed_mesh(asset.objects[0], world, weights)
        tables.append(_slotted(mesh.topology_mesh(), 40.0))
    assert tables[0] is tables[1]  # one table for both frames
    sv, rest = tables[0], mesh.rest
    ra = rest.render_arrays(40.0)
    # by hand: the copies are the distinct (render vertex, slot) pairs of the corners, sorted
    slots = corner_slots(ra.indices, ra.n_vertices)
    pairs = sorted({(int(v), int(s)) for v, s in zip(np.ravel(ra.indices), np.ravel(slots), strict=True)})
    np.testing.assert_array_equal(sv["vertex"], [v for v, _ in pairs])
    np.testing.assert_array_equal(sv["corner"], [s for _, s in pairs])
    where = {pair: i for i, pair in enumerate(pairs)}
    want = [[where[(int(v), int(s))] for v, s in zip(tri, sl, strict=True)] for tri, sl in zip(ra.indices, slots,
                                                                                                strict=True)]
    np.testing.assert_array_equal(sv["indices"], want)
    assert sv["indices"].dtype == np.uint32


def test_skinned_directions_match_a_float64_reference():
    rng = np.random.default_rng(5)

    class Posed:
        skin_linear = rng.normal(size=(50, 3, 3))

    d = rng.normal(size=(50, 3)).astype(np.float32)
    d[7] = 0.0  # no direction: stays zero
    src = rng.integers(0, 50, 80)
    got = skinned_directions(Posed(), d, src)
    want = np.array([Posed.skin_linear[s] @ d[s].astype(np.float64) for s in src])
    norm = np.linalg.norm(want, axis=1, keepdims=True)
    want = np.divide(want, norm, out=np.zeros_like(want), where=norm > 1e-12)
    np.testing.assert_allclose(got, want.astype(np.float32), rtol=0, atol=1.2e-7)
    assert got.dtype == np.float32
