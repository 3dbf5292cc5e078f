"""The flicker figure of `sketchgraph bench flicker` and its still-pixel mask on hand-made arrays, and the bench's
torso: its bent frame crosses rasterize's crease angle on several edges while the posed mesh keeps its rest pose's
normal splits (so crease lines do not come and go)."""

from __future__ import annotations

import math

import numpy as np

from nodegraph.tools.bench.flicker import pair_flicker


def test_pair_flicker_by_hand():
    a = np.zeros((4, 4))
    b = np.zeros((4, 4))
    a[1, :] = 1.0          # a line of 4 pixels
    b[1, :3] = 1.0         # the same line, one pixel off
    b[2, 0] = 0.25         # and a faint new pixel
    keep = np.ones((4, 4), bool)
    flicker, switching = pair_flicker(a, b, keep)
    assert math.isclose(flicker, (1.0 + 0.25) / (4 + 0.25))
    assert math.isclose(switching, 1 / 4)  # binarised at 0.5: 4 on in either, 1 switched
    keep[1, 3] = False     # a pixel left out (its surface moved)
    flicker, switching = pair_flicker(a, b, keep)
    assert math.isclose(flicker, 0.25 / 3.25) and switching == 0.0
    assert pair_flicker(np.zeros((2, 2)), np.zeros((2, 2)), np.ones((2, 2), bool)) == (0.0, 0.0)


def _crease_edges(v: np.ndarray, f: np.ndarray, degrees: float) -> set[tuple[int, int]]:
    """Edges (welded vertex pairs) where two faces meet at a dihedral angle over `degrees`, in float64."""
    v = v.astype(np.float64)
    _, wid = np.unique(np.round(v, 9), axis=0, return_inverse=True)
    wf = wid.reshape(-1)[f]
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    faces_of: dict[tuple[int, int], list[int]] = {}
    for i, tri in enumerate(wf):
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            faces_of.setdefault((min(a, b), max(a, b)), []).append(i)
    cos = math.cos(math.radians(degrees))
    return {e for e, fs in faces_of.items() if len(fs) == 2 and n[fs[0]] @ n[fs[1]] < cos}


def test_flicker_shot_bends_creases_across_the_crease_angle_and_rasterize_keeps_the_rest_pose(tmp_path):
    """The bench's torso: a bent frame has faces whose dihedral angle crossed rasterize's 40 degrees (creases that
    would come and go), while a posed mesh's render vertices (its smoothing groups) stay the rest pose's."""
    from nodegraph.scene.meshes import Mesh
    from nodegraph.scene.scene import load_scene
    from nodegraph.tools.bench.flicker import RINGS, SEGMENTS, figure

    scene = load_scene(str(figure(tmp_path / "torso.glb")))
    rest = scene.animation.pose(scene, 0).objects[0].mesh
    bent = scene.animation.pose(scene, 24).objects[0].mesh  # 1 s: the lean at its widest
    assert len(rest.faces) == 2 * (RINGS - 1) * SEGMENTS + 2 * SEGMENTS
    faces = np.asarray(rest.faces)
    rest_creases = _crease_edges(np.asarray(rest.vertices), faces, 40.0)
    bent_creases = _crease_edges(np.asarray(bent.vertices), faces, 40.0)
    assert len(rest_creases ^ bent_creases) >= 5
    assert bent.rest is not None
    np.testing.assert_array_equal(bent.render_arrays(40.0).indices, bent.rest.render_arrays(40.0).indices)
    # a plain mesh of the bent vertices splits its own way: the smoothing groups differ
    alone = Mesh("alone", np.array(bent.vertices), faces)
    assert len(alone.render_arrays(40.0).positions) != len(bent.render_arrays(40.0).positions)


def test_still_mask_by_hand():
    from nodegraph.tools.bench.flicker import still_mask

    pos0 = np.zeros((1, 4, 4))
    pos1 = np.zeros((1, 4, 4))
    pos1[0, :, 0] = [0.0, 0.01, 0.02, 0.0]       # world units moved
    d0 = np.array([[1.0, 1.0, 1.0, 0.0]])        # the last pixel is background in frame a
    d1 = np.ones((1, 4))
    keep = still_mask(pos0, pos1, d0, d1, np.full((1, 4), 30.0), 0.5)  # 30 px a unit: 0, 0.3, 0.6 px
    assert keep.tolist() == [[True, True, False, False]]
