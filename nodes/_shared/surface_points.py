"""Points fixed on the surfaces of a scene, seen from a frame's camera: starts that follow their objects from
frame to frame (stroke_hatching's and particle_sketch's `surface` anchors)."""

from __future__ import annotations

from typing import Any

import numpy as np

R2 = (0.7548776662466927, 0.5698402909980532)  # the R2 sequence's steps: 1 / g, 1 / g^2, g the plastic number


def project(v: np.ndarray, proj: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """View-space points (n, 3) to window positions (n, 2) in pixels (x right, y up), and where they lie in front
    of the camera (clip w > 0)."""
    clip = np.c_[v, np.ones(len(v))] @ proj.T
    ok = clip[:, 3] > 1e-9
    wcl = np.where(ok, clip[:, 3], 1.0)
    return np.stack([(clip[:, 0] / wcl + 1) * 0.5 * size[0], (clip[:, 1] / wcl + 1) * 0.5 * size[1]], 1), ok


def surface_points(scene: Any, view: np.ndarray, proj: np.ndarray, depth: np.ndarray, ids: np.ndarray,
                   size: tuple[int, int], cell: float, tol: float, most: int = 64, keep: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The visible points fixed on the surfaces, in a fixed order: (rows (n, 3) of window x, y and object id + 1;
    keys (n,) uint64), sorted by key. Face f of an object carries the points k = 0 .. n_f - 1 of the R2
    low-discrepancy sequence folded into the triangle (n_f = its screen area / cell^2, 1 to `most`; a face
    that grows on screen keeps its points and gains more), keyed by a 32-bit hash of (object, f, k); a point is
    visible where the object id at its pixel is its object's and the linear `depth` there is within `tol` of
    its own depth, and, where `keep` ((h, w) bool, row 0 at the bottom) is given, its pixel is kept there (the
    others' order among themselves is the same). Posing moves the points with their faces (same faces, same
    barycentric coordinates), so a point keeps its key from frame to frame."""
    w, h = size
    out, keys = [], []
    table = None
    if keep is not None:  # summed-area table: faces whose screen box holds no kept pixel carry no points
        table = np.zeros((h + 1, w + 1), np.int64)
        table[1:, 1:] = np.cumsum(np.cumsum(keep, axis=0), axis=1)
    for index, obj in enumerate(scene.objects):
        v = np.asarray(obj.mesh.vertices, np.float64)
        f = np.asarray(obj.mesh.faces, np.int64)
        mv = view @ np.asarray(obj.transform, np.float64)
        vv = v @ mv[:3, :3].T + mv[:3, 3]
        xy, ok = project(vv, proj, size)
        t = xy[f]
        area = 0.5 * np.abs((t[:, 1, 0] - t[:, 0, 0]) * (t[:, 2, 1] - t[:, 0, 1])
                            - (t[:, 2, 0] - t[:, 0, 0]) * (t[:, 1, 1] - t[:, 0, 1]))
        n = np.clip(np.ceil(np.nan_to_num(area) / cell ** 2), 1, most).astype(np.int64)
        n[~ok[f].all(axis=1)] = 0
        if table is not None:  # a point's pixel lies in its face's box (the face projects to a triangle)
            x0 = np.clip(np.floor(np.nan_to_num(t[..., 0].min(axis=1))), 0, w - 1).astype(np.int64)
            x1 = np.clip(np.floor(np.nan_to_num(t[..., 0].max(axis=1))), 0, w - 1).astype(np.int64) + 1
            y0 = np.clip(np.floor(np.nan_to_num(t[..., 1].min(axis=1))), 0, h - 1).astype(np.int64)
            y1 = np.clip(np.floor(np.nan_to_num(t[..., 1].max(axis=1))), 0, h - 1).astype(np.int64) + 1
            n[table[y1, x1] - table[y0, x1] - table[y1, x0] + table[y0, x0] == 0] = 0
        face = np.repeat(np.arange(len(f)), n)
        k = np.arange(len(face)) - np.repeat(np.cumsum(n) - n, n)
        u, q = (0.5 + k * R2[0]) % 1.0, (0.5 + k * R2[1]) % 1.0
        fold = u + q > 1.0
        u, q = np.where(fold, 1.0 - u, u), np.where(fold, 1.0 - q, q)
        bary = np.stack([1.0 - u - q, u, q], 1)
        pts = np.einsum("nk,nkd->nd", bary, vv[f[face]])
        sxy, sok = project(pts, proj, size)
        inside = sok & (sxy[:, 0] >= 0) & (sxy[:, 0] < w) & (sxy[:, 1] >= 0) & (sxy[:, 1] < h)
        ix = np.clip(sxy[:, 0].astype(np.int64), 0, w - 1)
        iy = np.clip(sxy[:, 1].astype(np.int64), 0, h - 1)
        vis = inside & (ids[iy, ix] == index + 1) & \
            (np.abs(depth[iy, ix] + pts[:, 2]) <= tol * np.maximum(-pts[:, 2], 1e-9))
        if keep is not None:
            vis &= keep[iy, ix]
        key = ((face.astype(np.uint64) * np.uint64(2654435761) + k.astype(np.uint64) * np.uint64(40503)
                + np.uint64(index) * np.uint64(97531)) * np.uint64(0x9E3779B1)) % np.uint64(1 << 32)
        out.append(np.c_[sxy[vis], np.full(int(vis.sum()), index + 1)])
        keys.append(key[vis])
    rows = np.concatenate(out) if out else np.zeros((0, 3))
    key_all = np.concatenate(keys) if keys else np.zeros(0, np.uint64)
    order = np.argsort(key_all.astype(np.float64), kind="stable")
    return rows[order], key_all[order]
