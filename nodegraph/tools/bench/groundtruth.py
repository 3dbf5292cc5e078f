"""Line-drawing ground truth computed from the mesh itself, for measuring image-space edge detectors.

Independent of `edge_detect`: the lines come from the triangles, not from any image filter.

* **Feature edges, in object space.** Vertices are welded (the mesh's own welding, 1e-6 of the
  bounding-box diagonal) so split normals and seams do not count as boundaries. Degenerate faces
  (zero area, repeated vertex) are ignored. Each welded edge is classified by the faces that use it:
  - *silhouette*: an edge between a front-facing and a back-facing triangle, front meaning the eye
    lies on the side of the face's normal (perspective: the eye position, not a view direction);
  - *crease*: two faces whose normals differ by more than `crease_angle` degrees (default 40: the
    angle above which `rasterize` splits normals, so only there does the normal buffer jump);
  - *boundary*: an edge used by one face; *nonmanifold*: an edge used by more than two faces.
  Faces wound inconsistently across an edge (the two half-edges run the same way) are compared
  with one normal flipped, so a winding error is neither a crease nor a silhouette.
* **Visibility against the depth buffer.** Every edge is clipped to the near plane and sampled in
  3D every `step` pixels of its projection (perspective-correct positions and depths). A sample is
  visible when the depth buffer at the pixel holding it is no nearer than what the edge's own surface
  would show there, less a tolerance (`depth_tolerance` of the depth plus `slope_pixels` pixel
  footprints): that surface is the nearest of the sample itself and the planes of the one or two faces
  beside the edge, cut by the ray through the pixel centre. So a silhouette sample whose pixel centre
  falls on its own, steeply receding face, or a crease in a valley, counts as visible, and a sample
  behind anything else does not.
* **Rasterised as 1-px lines**: each visible sample marks the pixel that contains it.

Images are (H, W) arrays with row 0 the bottom row (the GL texture convention, as `Tex.read()`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

KINDS = ("silhouette", "crease", "boundary", "nonmanifold")


@dataclass
class FeatureEdges:
    """Feature edges of one mesh for one eye position: vertex index pairs (k, 2) per kind."""

    edges: dict[str, np.ndarray]
    faces: dict[str, np.ndarray]  # kind -> (k, 2) the faces beside each edge (-1: none), into mesh.faces
    n_edges: int  # welded edges of non-degenerate faces
    n_inconsistent: int  # manifold edges whose two faces are wound inconsistently

    def all(self) -> np.ndarray:
        return np.concatenate([self.edges[k] for k in KINDS]) if self.n_features else np.zeros((0, 2), np.int64)

    @property
    def n_features(self) -> int:
        return sum(len(v) for v in self.edges.values())


@dataclass
class GroundTruth:
    """A line drawing: `lines` is the union of the per-kind images; `counts` says how it was made."""

    lines: np.ndarray  # (H, W) bool
    by_kind: dict[str, np.ndarray]  # kind -> (H, W) bool
    counts: dict[str, Any] = field(default_factory=dict)


def _face_normals(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (zero where degenerate) and the non-degenerate mask."""
    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    cross = np.cross(p1 - p0, p2 - p0)
    area2 = np.linalg.norm(cross, axis=1)
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) if len(v) else 0.0
    ok = area2 > 1e-14 * max(diag, 1e-300) ** 2
    ok &= (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    n = np.zeros_like(cross)
    n[ok] = cross[ok] / area2[ok, None]
    return n, ok


def feature_edges(mesh: Any, eye_object: np.ndarray | None, crease_angle: float = 40.0) -> FeatureEdges:
    """Silhouette (needs `eye_object`, the eye in the mesh's own coordinates), crease, boundary and
    non-manifold edges of `mesh`, as pairs of original vertex indices."""
    v = np.asarray(mesh.vertices, np.float64)
    welded, nu = mesh.weld()
    wf = welded[np.asarray(mesh.faces, np.int64)]
    normals, ok = _face_normals(v, np.asarray(mesh.faces, np.int64))
    # a welded-degenerate face (two corners welded together) is degenerate too
    ok &= (wf[:, 0] != wf[:, 1]) & (wf[:, 1] != wf[:, 2]) & (wf[:, 0] != wf[:, 2])
    faces_ok = np.flatnonzero(ok)
    empty = np.zeros((0, 2), np.int64)
    if faces_ok.size == 0:
        return FeatureEdges({k: empty for k in KINDS}, {k: empty for k in KINDS}, 0, 0)
    of = np.asarray(mesh.faces, np.int64)[faces_ok]
    w = wf[faces_ok]
    # half-edges: (face, a -> b) with a, b welded ids; original ids kept for drawing
    a = w.ravel()
    b = np.roll(w, -1, axis=1).ravel()
    oa = of.ravel()
    ob = np.roll(of, -1, axis=1).ravel()
    face = np.repeat(np.arange(len(faces_ok)), 3)
    key = np.minimum(a, b) * max(nu, 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    skey = key[order]
    starts = np.flatnonzero(np.r_[True, skey[1:] != skey[:-1]])
    counts = np.diff(np.r_[starts, len(skey)])
    first = order[starts]
    pair = np.stack([oa[first], ob[first]], axis=1)

    # the faces beside each edge: the first two half-edges' faces (the second -1 on a boundary)
    second = np.where(counts > 1, order[np.minimum(starts + 1, len(order) - 1)], -1)
    beside = np.stack([faces_ok[face[first]], np.where(second >= 0, faces_ok[face[np.maximum(second, 0)]], -1)],
                      axis=1)
    kinds: dict[str, np.ndarray] = {}
    sides: dict[str, np.ndarray] = {}
    kinds["boundary"], sides["boundary"] = pair[counts == 1], beside[counts == 1]
    kinds["nonmanifold"], sides["nonmanifold"] = pair[counts > 2], beside[counts > 2]
    m2 = counts == 2
    h1, h2 = order[starts[m2]], order[starts[m2] + 1]
    f1, f2 = face[h1], face[h2]
    consistent = a[h1] != a[h2]  # opposite directions along the shared edge
    sign = np.where(consistent, 1.0, -1.0)
    n1, n2 = normals[faces_ok][f1], normals[faces_ok][f2]
    cosang = np.einsum("ij,ij->i", n1, n2) * sign
    crease = cosang < np.cos(np.radians(crease_angle))
    if eye_object is not None:
        eye = np.asarray(eye_object, np.float64).reshape(3)
        cen = v[of].mean(axis=1)
        front = np.einsum("ij,ij->i", normals[faces_ok], eye - cen) > 0.0
        sil = np.where(consistent, front[f1] != front[f2], front[f1] == front[f2])
    else:
        sil = np.zeros(len(f1), bool)
    pairs2, beside2 = pair[m2], beside[m2]
    kinds["silhouette"], sides["silhouette"] = pairs2[sil], beside2[sil]
    kinds["crease"], sides["crease"] = pairs2[crease & ~sil], beside2[crease & ~sil]
    return FeatureEdges({k: kinds[k] for k in KINDS}, {k: sides[k] for k in KINDS}, int(len(starts)),
                        int((~consistent).sum()))


def _sample_edges(p0: np.ndarray, p1: np.ndarray, view: np.ndarray, proj: np.ndarray, size: tuple[int, int],
                  near: float, step: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """World segments -> samples: (x_px, y_px, view depth, edge index), near-clipped."""
    w, h = size
    q0 = np.c_[p0, np.ones(len(p0))] @ view.T
    q1 = np.c_[p1, np.ones(len(p1))] @ view.T
    z0, z1 = -q0[:, 2], -q1[:, 2]
    zn = near * (1.0 + 1e-6)
    keep = (z0 > zn) | (z1 > zn)
    q0, q1, z0, z1 = q0[keep], q1[keep], z0[keep], z1[keep]
    idx = np.flatnonzero(keep)
    # clip the part behind the near plane: both ends move to where the segment crosses it
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(z1 != z0, (zn - z0) / (z1 - z0), 0.0)
    cross = q0 + t[:, None] * (q1 - q0)
    q0 = np.where((z0 < zn)[:, None], cross, q0)
    q1 = np.where((z1 < zn)[:, None], cross, q1)
    if len(q0) == 0:
        e = np.zeros(0)
        return e, e, e, np.zeros(0, np.int64)

    def to_px(q: np.ndarray) -> np.ndarray:
        c = q @ proj.T
        ndc = c[:, :2] / c[:, 3:4]
        return np.c_[(ndc[:, 0] * 0.5 + 0.5) * w, (ndc[:, 1] * 0.5 + 0.5) * h]

    s0, s1 = to_px(q0), to_px(q1)
    length = np.linalg.norm(s1 - s0, axis=1)
    # samples beyond a few screen sizes are off screen anyway; cap the count per edge
    n = np.clip(np.ceil(length / step).astype(np.int64), 1, 8 * (w + h)) + 1
    seg = np.repeat(np.arange(len(q0)), n)
    within = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
    # screen-space uniform parameter s -> 3D parameter t (perspective-correct)
    s = within / (n[seg] - 1)
    za, zb = -q0[seg, 2], -q1[seg, 2]
    tt = s * za / (s * za + (1.0 - s) * zb)
    q = q0[seg] + tt[:, None] * (q1[seg] - q0[seg])
    px = to_px(q)
    return px[:, 0], px[:, 1], -q[:, 2], idx[seg]


def window_max(img: np.ndarray, r: int = 1) -> np.ndarray:
    """Maximum over the (2r+1)^2 block around each pixel (edges clamped)."""
    out = img.copy()
    h, w = img.shape
    p = np.pad(img, r, mode="edge")
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            if dx or dy:
                np.maximum(out, p[r + dy:r + dy + h, r + dx:r + dx + w], out=out)
    return out


def line_drawing(scene: Any, size: tuple[int, int], linear_depth: np.ndarray, frame: int = 0, *,
                 crease_angle: float = 40.0, depth_tolerance: float = 0.005, slope_pixels: float = 1.0,
                 step: float = 0.25, objects: list[Any] | None = None) -> GroundTruth:
    """The visible feature lines of `scene` seen by its camera at `frame`, as 1-px lines.

    `linear_depth` is the scene's view depth per pixel (H, W) with 0 = background, e.g.
    `rasterize.linear_depth` read back (row 0 = bottom)."""
    w, h = size
    depth = np.asarray(linear_depth, np.float64)
    if depth.ndim == 3:
        depth = depth[..., 0]
    if depth.shape != (h, w):
        raise ValueError(f"line_drawing: depth buffer is {depth.shape[::-1]} (W, H), expected {size}")
    cam = scene.camera_at(frame)
    view = cam.view_matrix()
    proj = cam.projection_matrix(w / h)
    seen = np.where(depth > 0.0, depth, np.inf)
    tan_x, tan_y = cam.tan_half(w / h)
    footprint = 2.0 * tan_y / h  # world size of a pixel per unit depth
    by_kind = {k: np.zeros((h, w), bool) for k in KINDS}
    counts: dict[str, Any] = {f"{k}_edges": 0 for k in KINDS}
    counts.update(samples=0, visible_samples=0, inconsistent_edges=0)
    for obj in objects if objects is not None else scene.objects:
        m = np.asarray(obj.transform, np.float64)
        eye_obj = np.linalg.solve(m, np.r_[cam.eye, 1.0])[:3]
        fe = feature_edges(obj.mesh, eye_obj, crease_angle)
        counts["inconsistent_edges"] += fe.n_inconsistent
        verts = np.asarray(obj.mesh.vertices, np.float64) @ m[:3, :3].T + m[:3, 3]
        vview = verts @ view[:3, :3].T + view[:3, 3]
        faces = np.asarray(obj.mesh.faces, np.int64)
        for kind in KINDS:
            e = fe.edges[kind]
            counts[f"{kind}_edges"] += int(len(e))
            if len(e) == 0:
                continue
            x, y, z, which = _sample_edges(verts[e[:, 0]], verts[e[:, 1]], view, proj, size, cam.near, step)
            col = np.floor(x).astype(np.int64)
            row = np.floor(y).astype(np.int64)
            inside = (col >= 0) & (col < w) & (row >= 0) & (row < h) & np.isfinite(z)
            col, row, z, which = col[inside], row[inside], z[inside], which[inside]
            # the ray through each pixel centre (view space, unit view depth)
            ray = np.stack([((col + 0.5) / w * 2.0 - 1.0) * tan_x, ((row + 0.5) / h * 2.0 - 1.0) * tan_y,
                            -np.ones(len(col))], axis=1)
            own = z.copy()
            for side in range(2):
                f = fe.faces[kind][which, side]
                has = f >= 0
                tri = vview[faces[np.maximum(f, 0)]]
                n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
                with np.errstate(divide="ignore", invalid="ignore"):
                    t = np.einsum("ij,ij->i", n, tri[:, 0]) / np.einsum("ij,ij->i", n, ray)
                hit = has & np.isfinite(t) & (t > 0.0)
                own = np.where(hit, np.minimum(own, t), own)
            tol = depth_tolerance * z + slope_pixels * footprint * z
            vis = seen[row, col] >= own - tol
            counts["samples"] += int(inside.sum())
            counts["visible_samples"] += int(vis.sum())
            by_kind[kind][row[vis], col[vis]] = True
    lines = np.zeros((h, w), bool)
    for img in by_kind.values():
        lines |= img
    counts["line_pixels"] = int(lines.sum())
    return GroundTruth(lines, by_kind, counts)


def dilate(mask: np.ndarray, r: int = 1) -> np.ndarray:
    """Binary dilation by a (2r+1)^2 square (Chebyshev distance <= r)."""
    return window_max(np.asarray(mask, np.uint8), r).astype(bool)


def precision_recall(detected: np.ndarray, truth: np.ndarray, tolerance: int = 1) -> dict[str, float]:
    """Precision (detected pixels with a true pixel within `tolerance` px, Chebyshev), recall (true
    pixels with a detected pixel within `tolerance`), F1. Empty sets count as perfect on their side."""
    d = np.asarray(detected, bool)
    t = np.asarray(truth, bool)
    if d.shape != t.shape:
        raise ValueError(f"detected {d.shape} and truth {t.shape} differ in shape")
    nd, nt = int(d.sum()), int(t.sum())
    precision = float((d & dilate(t, tolerance)).sum() / nd) if nd else 1.0
    recall = float((t & dilate(d, tolerance)).sum() / nt) if nt else 1.0
    f1 = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0
    return {"precision": precision, "recall": recall, "f1": f1, "detected_pixels": nd, "truth_pixels": nt}
