"""mesh_lines on coarse meshes: where the interpolated contours miss the outline the render draws, the polygonal
silhouette draws it (`outline`, extract.reconcile_outline), against the float64 reference of reference.py: the
mesh's polygonal silhouette, visibility by ray casting. Rocks made in code (a displaced icosphere). The rule was
shaped looking at rocks of seeds 3, 5, 11, 21-25 and 31-36, spot, and ten low-poly meshes of a blind check; the
rocks of seeds 41-46 (other sizes, mirrored and turned) were measured once, after it was settled."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from tests.helpers import run_minimal, shared_mesh
from tests.nodes.mesh_lines import reference as ref

NODES = ("  gbuf:\n    type: rasterize\n  lines:\n    type: mesh_lines\n"
         "    in: {{linear_depth: gbuf.linear_depth}}\n    params: {{boundaries: false, outline: {outline}}}\n")


def icosphere(sub: int) -> tuple[np.ndarray, np.ndarray]:
    t = (1 + 5 ** 0.5) / 2
    v = [np.array(p, float) / np.linalg.norm(p) for p in (
        (-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t), (t, 0, -1),
        (t, 0, 1), (-t, 0, -1), (-t, 0, 1))]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    mid: dict[tuple[int, int], int] = {}  # no edge of a finer level joins two vertices of a coarser one

    def m(a: int, b: int) -> int:
        key = (min(a, b), max(a, b))
        if key not in mid:
            p = v[a] + v[b]
            v.append(p / np.linalg.norm(p))
            mid[key] = len(v) - 1
        return mid[key]

    for _ in range(sub):
        f = [g for a, b, c in f for g in ((a, m(a, b), m(c, a)), (b, m(b, c), m(a, b)), (c, m(c, a), m(b, c)),
                                          (m(a, b), m(b, c), m(c, a)))]
    return np.array(v), np.array(f)


def rock(path: Path, seed: int, sub: int, amp: float, mirror: bool = False, turn: float = 0.0) -> str:
    """A low-poly rock as an OBJ: an icosphere with each vertex moved along its radius by amp x N(0, 1), stretched,
    optionally mirrored (x) and turned about y."""
    rng = np.random.default_rng(seed)
    v, f = icosphere(sub)
    v = v * (1 + amp * rng.standard_normal(len(v)))[:, None] * np.array([1.3, 0.8, 1.0])
    if mirror:
        v[:, 0] *= -1
        f = f[:, ::-1]
    c, s = np.cos(np.radians(turn)), np.sin(np.radians(turn))
    v = v @ np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
    with path.open("w") as fh:
        fh.writelines(f"v {a:.6f} {b:.6f} {d:.6f}\n" for a, b, d in v)
        fh.writelines(f"f {a + 1} {b + 1} {d + 1}\n" for a, b, d in f)
    return str(path)


def measure(scene: str, outline: float, size: int = 400) -> dict[str, float]:
    """Recall: visible polygonal-silhouette reference points on the image's outline (within 1.5 px of the
    rasterizer's coverage boundary or a depth jump over 2 %) within 1 px of a visible contour or crease sample;
    precision: those samples within 1 px of a visible silhouette point or visible zero-set point of n . v."""
    ex, res = run_minimal(None, NODES.format(outline=outline), {"s": "lines.strokes", "z": "gbuf.linear_depth"},
                          size=(size, size), scene=scene, up="y")
    strokes = res.values[("lines", "strokes")]
    zbuf = res.values[("gbuf", "linear_depth")].read()[:, :, 0].astype(np.float64)
    sc = ex.pipeline.scene
    cam = sc.camera_at(0)
    view, proj = cam.view_matrix(), cam.projection_matrix(1.0)
    eye = np.r_[cam.eye, 1.0]
    (obj,) = sc.objects
    mesh, model = obj.mesh, np.asarray(obj.transform, float)
    eye_obj = np.linalg.inv(model) @ eye
    V, F = mesh.vertices, mesh.faces
    weld = mesh.weld()[0]
    rings = ref.vertex_rings(F, weld)
    mvp = proj @ view @ model
    pts, faces = ref.silhouette_points(V, F, weld, eye_obj, 256)
    sil = ref.project(pts[~ref.occluded_tiled(pts, faces, V, F, eye_obj, rings, mvp, (size, size))], mvp,
                      (size, size))
    # 64 x 64 grid points a face: on the coarsest rock a face spans 50 px, and 16 left the zero set's points 3 px
    # apart (a sample on the curve could be 1.5 px from the nearest)
    pts, faces = ref.contour_points(V, F, ref.corner_normals(V, F, weld), eye_obj, 64)
    zero = ref.project(pts[~ref.occluded_tiled(pts, faces, V, F, eye_obj, rings, mvp, (size, size))], mvp,
                       (size, size))
    # the reference points on the image's outline: a pixel within 1.5 px is background or 2 % farther
    far = np.pad(np.where(zbuf > 0, zbuf, np.inf), 2, constant_values=np.inf)
    ix = np.clip(np.floor(sil[:, 0]).astype(int) + 2, 1, size + 2)
    iy = np.clip(np.floor(sil[:, 1]).astype(int) + 2, 1, size + 2)
    near = np.min([far[iy + dy, ix + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
    most = np.max([far[iy + dy, ix + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
    rim = sil[most > near * 1.02]
    kinds = strokes["kind"]
    vis = strokes["visible"] & ((kinds == 1) | (kinds == 2))
    S = strokes.xy[vis].astype(np.float64)
    d_r = cKDTree(S).query(rim)[0] if len(S) else np.full(len(rim), np.inf)
    d_s = cKDTree(np.concatenate([sil, zero])).query(strokes.xy[strokes["visible"] & (kinds == 1)])[0]
    return {"recall": float((d_r <= 1.0).mean()), "precision": float((d_s <= 1.0).mean()), "rim": len(rim),
            "samples": len(S)}


# (seed, subdivisions, displacement, mirrored, turn in degrees): recall with the rule on / off, precision on
HELD_OUT = [(41, 0, 0.15, False, 110),  # 0.99 / 0.54, 1.00
            (42, 1, 0.15, True, 10),  # 0.97 / 0.42, 1.00
            (43, 1, 0.25, False, 200),  # 0.89 / 0.53, 1.00
            (44, 2, 0.1, True, 70),  # 0.93 / 0.50, 1.00
            (45, 2, 0.15, False, 330),  # 0.97 / 0.71, 1.00
            (46, 3, 0.08, True, 150)]  # 0.90 / 0.68, 1.00


@pytest.mark.slow
@pytest.mark.parametrize(("seed", "sub", "amp", "mirror", "turn"), HELD_OUT)
def test_rock_outline_drawn(tmp_path, seed, sub, amp, mirror, turn):
    """The outline of a low-poly rock is drawn (recall >= 0.8 of the visible silhouette on the image's outline,
    0.89-0.99 measured, against 0.42-0.71 with the interpolated contours alone) and every contour sample lies on the
    mesh's silhouette or its zero set of n . v (precision >= 0.98)."""
    path = rock(tmp_path / f"rock{seed}.obj", seed, sub, amp, mirror, turn)
    on, off = measure(path, 1.0), measure(path, 0.0)
    assert on["recall"] >= 0.8 and on["precision"] >= 0.98, on
    assert off["recall"] <= on["recall"] - 0.2, (on, off)


def test_rock_outline_small(tmp_path):
    """The same on the 20-face rock at 160 px (fast tier)."""
    path = rock(tmp_path / "rock.obj", 31, 0, 0.25, True, 20)
    on, off = measure(path, 1.0, 160), measure(path, 0.0, 160)
    assert on["recall"] >= 0.9 and on["precision"] >= 0.98, on
    assert off["recall"] <= on["recall"] - 0.2, (on, off)


def test_small_render_of_a_smooth_mesh_unchanged():
    """At 256 px for an 800 px reference (px_scale 0.32) the tolerance stays one pixel of the image: the built-in
    torus, whose interpolated contours stray from its polygonal silhouette by under a pixel there, draws the same
    strokes with the rule as without it."""
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor

    got = []
    for outline in (1.0, 0.0):
        text = ("pipeline: t\nsize: [256, 256]\nreference_size: 800\nscene: builtin:torus\nnodes:\n"
                + NODES.format(outline=outline) + "outputs:\n  s: lines.strokes\n")
        ex = Executor(pl.loads(text, "t.yaml"), None)
        try:
            got.append(ex.run().values[("lines", "strokes")])
        finally:
            ex.close()
    a, b = got
    assert len(a.xy) > 100
    np.testing.assert_array_equal(a.xy, b.xy)
    np.testing.assert_array_equal(a.starts, b.starts)


def outline_gaps(scene: str, size: int = 800) -> tuple[float, int]:
    """(share of the depth buffer's rim pixels, on the background, with a visible line sample within 1.5 px; the
    longest run of rim pixels without one, in pixels: the largest group of missed rim pixels joined within 2 px)."""
    from scipy import ndimage

    nodes = "  gbuf:\n    type: rasterize\n  lines:\n    type: mesh_lines\n    in: {linear_depth: gbuf.linear_depth}\n"
    _, res = run_minimal(None, nodes, {"s": "lines.strokes", "z": "gbuf.linear_depth"}, size=(size, size),
                         scene=scene)
    st = res.values[("lines", "strokes")]
    covered = res.values[("gbuf", "linear_depth")].read()[:, :, 0] > 0
    rows, cols = np.nonzero(covered & ~ndimage.binary_erosion(covered))
    rim = np.c_[cols + 0.5, rows + 0.5]
    missed = rim[cKDTree(st.xy[st["visible"]]).query(rim)[0] > 1.5]
    if not len(missed):
        return 1.0, 0
    grid = np.zeros((size, size), bool)
    grid[np.floor(missed[:, 1]).astype(int), np.floor(missed[:, 0]).astype(int)] = True
    labels, n = ndimage.label(ndimage.binary_dilation(grid, iterations=1), structure=np.ones((3, 3)))
    longest = max(int((labels[grid] == k).sum()) for k in range(1, n + 1))
    return 1.0 - len(missed) / len(rim), longest


@pytest.mark.slow
def test_the_cows_outline_has_no_gaps():
    """The cow at 800 px (the case the rule was shaped on: `extract.bridge_outline`): where its contour tested
    hidden for a few pixels just inside the outline, or strayed from the silhouette there and was dropped for it,
    and the silhouette was suppressed beside the contour's drawn ends, the outline had gaps of 5-7 px (coverage
    0.976); now 0.99 or more, no gap over 3 px."""
    coverage, longest = outline_gaps(str(shared_mesh("cow.obj")))
    assert coverage >= 0.99 and longest <= 3, (coverage, longest)
