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
        N = ref.corner_normals(V, F, mesh.weld()[0])  # split at sharp edges, as mesh_lines' contours
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


def edge_samples(scene: str, size: int, view: str | None = None) -> tuple:
    """Every crease and boundary sample of mesh_lines (hidden kept) with its world position and the ray cast's
    verdict (reference.scene_occluded through every object): (strokes, edge mask, world points, seen)."""
    nodes = ("  gbuf:\n    type: rasterize\n  lines:\n    type: mesh_lines\n    in: {linear_depth: gbuf.linear_depth}\n"
             "    params: {hidden: true, intersections: false, min_length: 0}\n")
    ex, res = run_minimal(None, nodes, {"s": "lines.strokes"}, size=(size, size), scene=scene,
                          **({"view": view} if view else {}))
    s = res.values[("lines", "strokes")]
    sc = ex.pipeline.scene
    obj, pos = s["obj"], s["pos"].astype(np.float64)
    world = np.zeros_like(pos)
    for i, o in enumerate(sc.objects):
        m = np.asarray(o.transform, np.float64)
        world[obj == i] = pos[obj == i] @ m[:3, :3].T + m[:3, 3]
    edge = np.isin(s["kind"], (2, 3)) & (s.xy >= 0).all(1) & (s.xy < size).all(1)
    seen = np.zeros(len(pos), bool)
    lift = 1e-5 * float(np.linalg.norm(np.subtract(*sc.bounds())))
    seen[edge] = ~ref.scene_occluded(world[edge], np.asarray(sc.camera_at(0).eye, np.float64), sc, lift)
    return s, edge, world, seen


def test_edges_under_a_floor_are_hidden_at_a_distance(tmp_path):
    """Boxes sunk 0.1 into a floor, seen from 20 units at 600 px: each box's bottom edge lies 2-4 px below its
    junction with the floor on the screen but within 1 % of its depth of the floor in front of it, so a tolerance
    of a fraction of the depth alone drew it beside the junction. Crease samples against ray casting through every
    object (reference.scene_occluded): the bottom edges hidden, the rest as the ray cast says."""
    path = tmp_path / "sunk.yaml"
    boxes = "".join(f"  - primitive: {{type: box, size: 1.0}}\n    transform: {{translate: [{x}, 0.4, {z}], "
                    f"rotate: [0, {r}, 0]}}\n" for x, z, r in ((-3, 0, 20), (0, -2, 40), (3, 1, 65), (-1, 3, 5)))
    path.write_text("objects:\n  - primitive: {type: box, size: [40, 1, 40]}\n"
                    "    transform: {translate: [0, -0.5, 0]}\n"
                    f"{boxes}camera: {{eye: [0, 12, 16], target: [0, 0, 0], fov: 35}}\n")
    s, edge, world, seen = edge_samples(str(path), 600)
    crease = edge & (s["obj"] > 0)
    bottom = crease & (world[:, 1] < -0.05)
    assert bottom.sum() > 100
    assert not s["visible"][bottom].any(), int(s["visible"][bottom].sum())
    above = crease & (world[:, 1] > 0.02)
    assert seen[above].sum() > 500
    assert (s["visible"][above] == seen[above]).mean() > 0.98, (s["visible"][above] == seen[above]).mean()


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "view"), [("builtin:cloister", None), ("fandisk.obj", "back")])
def test_edge_visibility_against_ray_casting(scene, view):
    """Creases and boundaries at 800 x 800 against ray casting: a sample the ray cast hides but the node draws more
    than 1.5 px from every visible line is a stray (a hidden edge drawn beside the true ones). With a tolerance of
    1 % of the depth alone, the cloister's strays were 1.2 % of its edge samples (381); with the slope bound 0.04 %
    (14; docs/strokes.md, Accuracy). Hidden where the ray cast sees them: 0.3 %, lone samples at the cuts."""
    from scipy.spatial import cKDTree

    if not scene.startswith("builtin:"):
        scene = str(shared_mesh(scene))
    s, edge, _, seen = edge_samples(scene, 800, view)
    vis = s["visible"].astype(bool)
    drawn_hidden = edge & vis & ~seen
    d, _ = cKDTree(s.xy[(vis & seen) | (~edge & vis)]).query(s.xy[drawn_hidden])
    strays = int((d > 1.5).sum())
    missed = int((edge & ~vis & seen).sum())
    assert strays <= 0.002 * edge.sum(), (strays, int(edge.sum()))
    assert missed <= 0.005 * edge.sum(), (missed, int(edge.sum()))  # lone samples where visibility changes
