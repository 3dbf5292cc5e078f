"""mesh_lines' visible contours against the float64 reference (reference.py): the exact zero set of n . v
with interpolated vertex normals, visibility by ray casting. Precision: visible contour samples within 1 px of
a visible reference point; recall: visible reference points within 1 px of a visible contour sample. With the
polygonal silhouette drawing the outline where the interpolated contours miss it (`outline`, the default), a
sample counts for precision within 1 px of a visible point of either reference: the zero set, or the mesh's
polygonal silhouette (reference.silhouette_points, visibility by the same ray casting)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from tests.helpers import run_minimal, shared_mesh
from tests.nodes.mesh_lines import reference as ref

NODES = ("  gbuf:\n    type: rasterize\n  lines:\n    type: mesh_lines\n"
         "    in: {{linear_depth: gbuf.linear_depth}}\n    params: {{creases: false, boundaries: false{extra}}}\n")


def measure(scene: str, size: int, k: int = 32, view: str | None = None, outline: bool = True) -> dict[str, float]:
    """outline: the node's default (the polygonal silhouette fills the outline; precision against either
    reference), else `outline: 0` (the interpolated contours alone; precision against the zero set)."""
    nodes = NODES.format(extra="" if outline else ", outline: 0")
    ex, res = run_minimal(None, nodes, {"s": "lines.strokes", "z": "gbuf.linear_depth"}, size=(size, size),
                          scene=scene, **({"view": view} if view else {}))
    strokes = res.values[("lines", "strokes")]
    zbuf = res.values[("gbuf", "linear_depth")].read()[:, :, 0].astype(np.float64)
    sc = ex.pipeline.scene
    cam = sc.camera_at(0)
    view, proj = cam.view_matrix(), cam.projection_matrix(1.0)
    eye = np.r_[cam.eye, 1.0] if not cam.orthographic else cam.toward_eye()
    vis_ref, vis_sil = [], []
    for obj in sc.objects:
        mesh = obj.mesh
        model = np.asarray(obj.transform, float)
        eye_obj = np.linalg.inv(model) @ eye
        V, F = mesh.vertices, mesh.faces
        N = mesh.vertex_normals().astype(np.float64)
        pts, faces = ref.contour_points(V, F, N, eye_obj, k)
        mvp = proj @ view @ model
        rings = ref.vertex_rings(F, mesh.weld()[0])
        hidden = ref.occluded_tiled(pts, faces, V, F, eye_obj, rings, mvp, (size, size))
        vis_ref.append(ref.project(pts[~hidden], mvp, (size, size)))
        if outline:
            pts, faces = ref.silhouette_points(V, F, mesh.weld()[0], eye_obj)
            hidden = ref.occluded_tiled(pts, faces, V, F, eye_obj, rings, mvp, (size, size))
            vis_sil.append(ref.project(pts[~hidden], mvp, (size, size)))
    R = np.concatenate(vis_ref)
    R = R[(R >= 0).all(1) & (size > R).all(1)]
    either = np.concatenate([R, *vis_sil])
    vis = strokes["visible"] & (strokes["kind"] == 1)
    S = strokes.xy[vis].astype(np.float64)
    assert len(S) > 50 and len(R) > 50
    d_s, _ = cKDTree(either).query(S)
    d_r, _ = cKDTree(S).query(R)
    # depth check: every visible sample has, within 2 px, a pixel that is background or no nearer than its depth
    # by more than the node's tolerance (1 %)
    far = np.where(zbuf > 0, zbuf, np.inf)
    from scipy.ndimage import maximum_filter

    fp = np.hypot(*np.meshgrid(np.arange(-2, 3), np.arange(-2, 3))) <= 2.0
    near2 = maximum_filter(far, footprint=fp, mode="constant", cval=np.inf)
    ix = np.clip(np.floor(S[:, 0]).astype(int), 0, size - 1)
    iy = np.clip(np.floor(S[:, 1]).astype(int), 0, size - 1)
    depth = strokes["depth"][vis].astype(np.float64)
    behind = near2[iy, ix] < depth * (1 - 0.01)
    return {"precision": float((d_s <= 1.0).mean()), "recall": float((d_r <= 1.0).mean()),
            "behind": int(behind.sum()), "samples": len(S), "reference": len(R)}


def check(m: dict[str, float]) -> None:
    assert m["precision"] >= 0.98, m
    assert m["recall"] >= 0.95, m
    assert m["behind"] == 0, m


def test_torus_small():
    check(measure("builtin:torus", 300))
    check(measure("builtin:torus", 300, outline=False))


@pytest.mark.slow
def test_torus_800():
    check(measure("builtin:torus", 800))


@pytest.mark.slow
@pytest.mark.parametrize(("name", "k", "view"), [
    ("spot.obj", 32, None), ("spot.obj", 32, "back"), ("stanford-bunny.obj", 16, None),
    ("stanford-bunny.obj", 16, "back"), ("stanford-bunny.obj", 16, "right"), ("stanford-bunny.obj", 16, "front")])
def test_shared_meshes_800(name, k, view):
    """k: the reference's barycentric grid per face (points well under a pixel apart on these meshes); view: the
    mesh's default framing (None) or a named view of it (from behind, the bunny's ears and back cross each other: a
    3 x 3 visibility window left stroke ends 1-3 px past where the ray cast hides them, precision 0.973)."""
    check(measure(str(shared_mesh(name)), 800, k, view))


@pytest.mark.slow
def test_spot_interpolated_alone():
    """The interpolated contours alone (`outline: 0`) against the zero set: spot's default view is the one where the
    polygonal silhouette fills the most (5 gaps of 8-14 px along its outline), 0.975 against the zero set alone."""
    check(measure(str(shared_mesh("spot.obj")), 800, 32, None, outline=False))
