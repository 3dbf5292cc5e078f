"""An independent float64 reference for occluding contours (tests only): the exact zero set of
G(b) = (sum_i b_i n_i) . (e - e_w sum_i b_i p_i) inside each face (interpolated corner normals, the true view
vector at each point: a quadratic in the barycentric coordinates b), found on a fine barycentric grid, and its
visibility by ray casting against the mesh (Moller-Trumbore, vectorised)."""

from __future__ import annotations

import numpy as np


def corner_normals(V: np.ndarray, F: np.ndarray, weld: np.ndarray, crease_angle: float = 60.0) -> np.ndarray:
    """(m, 3, 3) the normal at each face corner that mesh_lines' contours interpolate, found here by a flood fill
    in plain Python (independent of Mesh.render_arrays' union-find): around each welded vertex, the faces joined
    through edges of exactly two faces whose unit normals differ by at most `crease_angle` degrees form one group,
    and a corner's normal is its group's sum of face normals weighted by the corner angles, normalised."""
    p = np.asarray(V, np.float64)[F]
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    fn = cross / np.maximum(np.linalg.norm(cross, axis=1), 1e-300)[:, None]
    ang = np.zeros(F.shape)
    for c in range(3):
        a, b = p[:, (c + 1) % 3] - p[:, c], p[:, (c + 2) % 3] - p[:, c]
        ang[:, c] = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), (a * b).sum(1))
    wf = np.asarray(weld)[F]
    edge_faces: dict[tuple[int, int], list[int]] = {}
    star: dict[int, list[tuple[int, int]]] = {}
    for f, row in enumerate(wf.tolist()):
        for c in range(3):
            u, v = row[c], row[(c + 1) % 3]
            edge_faces.setdefault((min(u, v), max(u, v)), []).append(f)
            star.setdefault(u, []).append((f, c))
    cos_max = np.cos(np.radians(crease_angle))
    out = np.zeros((len(F), 3, 3))
    for u, corners in star.items():
        at = {f: c for f, c in corners}
        group = {f: -1 for f in at}
        for f0 in at:
            if group[f0] >= 0:
                continue
            group[f0], todo, members = f0, [f0], []
            while todo:
                f = todo.pop()
                members.append(f)
                for v in wf[f].tolist():
                    if v == u:
                        continue
                    faces = edge_faces[(min(u, v), max(u, v))]
                    if len(faces) != 2:
                        continue
                    g = faces[1] if faces[0] == f else faces[0]
                    if g in group and group[g] < 0 and float(fn[f] @ fn[g]) >= cos_max:
                        group[g] = f0
                        todo.append(g)
            n = sum(fn[f] * ang[f, at[f]] for f in members)
            n = n / max(float(np.linalg.norm(n)), 1e-300)
            for f in members:
                out[f, at[f]] = n
    return out


def contour_points(V: np.ndarray, F: np.ndarray, N: np.ndarray, eye: np.ndarray, k: int = 32
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Points (q, 3) on the zero set of G and the face (q,) of each: on a k x k barycentric grid in each face
    whose grid values change sign, the crossings of every grid edge by the root of G along it (G is quadratic
    along a straight line in b: solved exactly). `N`: (n, 3) vertex normals, or (m, 3, 3) normals per face
    corner (`corner_normals`)."""
    NF = N if N.ndim == 3 else N[F]  # the normals at each face's corners
    i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
    keep = i + j <= k
    grid = np.stack([k - i[keep] - j[keep], i[keep], j[keep]], 1) / k  # (g, 3) barycentric
    index = -np.ones((k + 1, k + 1), np.int64)
    index[i[keep], j[keep]] = np.arange(keep.sum())
    edges = []
    for a, b in (((0, 0), (1, 0)), ((0, 0), (0, 1)), ((1, 0), (0, 1))):
        ii, jj = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        ok = (ii + a[0] + jj + a[1] <= k) & (ii + b[0] + jj + b[1] <= k)
        edges.append(np.stack([index[ii[ok] + a[0], jj[ok] + a[1]], index[ii[ok] + b[0], jj[ok] + b[1]]], 1))
    E = np.concatenate(edges)

    def G(bary: np.ndarray, faces: np.ndarray) -> np.ndarray:  # (f, g) values
        n = np.einsum("gc,fcd->fgd", bary, NF[faces])
        p = np.einsum("gc,fcd->fgd", bary, V[F[faces]])
        return np.einsum("fgd,fgd->fg", n, eye[:3] - eye[3] * p)

    pts, fids = [], []
    for chunk in np.array_split(np.arange(len(F)), max(1, len(F) // 2000)):
        g = G(grid, chunk)
        mixed = (g.min(1) < 0) & (g.max(1) >= 0)
        if not mixed.any():
            continue
        fc, gm = chunk[mixed], g[mixed]
        ga, gb = gm[:, E[:, 0]], gm[:, E[:, 1]]
        fi, ei = np.nonzero((ga < 0) != (gb < 0))
        b0, b1 = grid[E[ei, 0]], grid[E[ei, 1]]
        faces = fc[fi]
        # G(b0 + t (b1 - b0)) = (n0 + t dn) . (w0 - t dp): quadratic c2 t^2 + c1 t + c0
        n0 = np.einsum("qc,qcd->qd", b0, NF[faces])
        dn = np.einsum("qc,qcd->qd", b1 - b0, NF[faces])
        p0 = np.einsum("qc,qcd->qd", b0, V[F[faces]])
        dp = np.einsum("qc,qcd->qd", b1 - b0, V[F[faces]])
        w0 = eye[:3] - eye[3] * p0
        dw = -eye[3] * dp
        c0, c1, c2 = (n0 * w0).sum(1), (n0 * dw + dn * w0).sum(1), (dn * dw).sum(1)
        disc = np.sqrt(np.maximum(c1 * c1 - 4 * c2 * c0, 0.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            r1 = (-c1 - disc) / (2 * c2)
            r2 = (-c1 + disc) / (2 * c2)
            lin = -c0 / c1
        t = np.where(np.abs(c2) < 1e-14, lin, np.where((r1 >= 0) & (r1 <= 1), r1, r2))
        t = np.clip(np.nan_to_num(t, nan=0.5), 0.0, 1.0)
        pts.append(p0 + t[:, None] * dp)
        fids.append(faces)
    if not pts:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    return np.concatenate(pts), np.concatenate(fids)


def occluded_tiled(points: np.ndarray, point_face: np.ndarray, V: np.ndarray, F: np.ndarray, eye: np.ndarray,
                   ring: list[set[int]], mvp: np.ndarray, size: tuple[int, int], tile: int = 16) -> np.ndarray:
    """`occluded`, each point tested only against the triangles whose projected bounding box touches its screen
    tile (a triangle that crosses the ray to the eye covers the point's projection): the same answer, faster."""
    xy = project(V, mvp, size)
    txy = xy[F]  # (m, 3, 2)
    lo = np.floor(txy.min(1) / tile).astype(np.int64)
    hi = np.floor(txy.max(1) / tile).astype(np.int64)
    pt = np.floor(project(points, mvp, size) / tile).astype(np.int64)
    ntx = int(max(pt[:, 0].max(initial=0), hi[:, 0].max(initial=0))) + 2
    out = np.zeros(len(points), bool)
    pkey = pt[:, 1] * ntx + pt[:, 0]
    for key in np.unique(pkey):
        tx, ty = key % ntx, key // ntx
        tris = np.flatnonzero((lo[:, 0] <= tx) & (hi[:, 0] >= tx) & (lo[:, 1] <= ty) & (hi[:, 1] >= ty))
        sel = np.flatnonzero(pkey == key)
        if len(tris):
            out[sel] = occluded(points[sel], point_face[sel], V, F, eye, ring, tris)
    return out


def occluded(points: np.ndarray, point_face: np.ndarray, V: np.ndarray, F: np.ndarray, eye: np.ndarray,
             ring: list[set[int]], tris: np.ndarray | None = None) -> np.ndarray:
    """Whether a triangle (of `tris`, default all) other than the point's face and its neighbours (`ring`: faces
    sharing a vertex with each face) crosses the ray from the point towards the eye (strictly between them)."""
    tris = np.arange(len(F)) if tris is None else tris
    A, B, C = V[F[tris, 0]], V[F[tris, 1]], V[F[tris, 2]]
    e1, e2 = B - A, C - A
    out = np.zeros(len(points), bool)
    for chunk in np.array_split(np.arange(len(points)), max(1, len(points) * len(tris) // 1_000_000)):
        o = points[chunk]
        # towards the eye; far enough along the direction to the viewer for an orthographic camera
        d = np.broadcast_to(eye[:3], o.shape) * 1e3 if eye[3] == 0.0 else eye[:3] - o
        pv = np.cross(d[:, None, :], e2[None])  # (c, m, 3)
        det = np.einsum("md,cmd->cm", e1, pv)
        inv = 1.0 / np.where(np.abs(det) > 1e-300, det, np.inf)
        tv = o[:, None, :] - A[None]
        u = np.einsum("cmd,cmd->cm", tv, pv) * inv
        qv = np.cross(tv, e1[None])
        v = np.einsum("cd,cmd->cm", d, qv) * inv
        t = np.einsum("md,cmd->cm", e2, qv) * inv
        hit = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-9) & (t < 1.0 - 1e-9) & (np.abs(det) > 1e-300)
        for row, c in enumerate(chunk):
            faces = tris[hit[row]]
            out[c] = any(f not in ring[point_face[c]] for f in faces.tolist())
    return out


def vertex_rings(F: np.ndarray, weld: np.ndarray) -> list[set[int]]:
    """Per face, the faces sharing a (welded) vertex with it."""
    wF = weld[F]
    by_vertex: dict[int, list[int]] = {}
    for f, tri in enumerate(wF.tolist()):
        for v in tri:
            by_vertex.setdefault(v, []).append(f)
    return [set(by_vertex[a]) | set(by_vertex[b]) | set(by_vertex[c]) for a, b, c in wF.tolist()]


def project(points: np.ndarray, mvp: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    h = np.c_[points, np.ones(len(points))] @ mvp.T
    return (h[:, :2] / h[:, 3:4] * 0.5 + 0.5) * np.asarray(size, float)


def silhouette_points(V: np.ndarray, F: np.ndarray, weld: np.ndarray, eye: np.ndarray, k: int = 8
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Points (q, 3) on the mesh's polygonal silhouette and the face (q,) of each: k + 1 points along every edge
    (by welded vertex ids) that two faces share, one turned toward the eye and one away (the sign of the face's
    plane normal . (e - e_w centroid), float64), with the face turned toward it."""
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    n = np.cross(B - A, C - A)
    centroid = (A + B + C) / 3.0
    toward = eye[:3] - eye[3] * centroid
    front = np.einsum("ij,ij->i", n, toward) > 0.0
    faces_of: dict[tuple[int, int], list[tuple[int, int, int]]] = {}
    wF = weld[F]
    for f, (tri, vs) in enumerate(zip(wF.tolist(), F.tolist(), strict=True)):
        for c in range(3):
            key = (min(tri[c], tri[(c + 1) % 3]), max(tri[c], tri[(c + 1) % 3]))
            faces_of.setdefault(key, []).append((f, vs[c], vs[(c + 1) % 3]))
    t = np.linspace(0.0, 1.0, k + 1)[:, None]
    pts, fids = [], []
    for pair in faces_of.values():
        if len(pair) != 2 or front[pair[0][0]] == front[pair[1][0]]:
            continue
        f, a, b = pair[0] if front[pair[0][0]] else pair[1]
        pts.append(V[a] + t * (V[b] - V[a]))
        fids.append(np.full(k + 1, f))
    if not pts:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    return np.concatenate(pts), np.concatenate(fids)


def scene_occluded(points: np.ndarray, eye: np.ndarray, scene, lift: float = 1e-3) -> np.ndarray:
    """Points (world space) on the scene's surfaces hidden from a perspective `eye` (3,): a triangle of any
    object crosses the ray from the point, moved `lift` toward the eye (off the faces it lies on), to the eye."""
    world = [o.mesh.vertices.astype(np.float64) @ np.asarray(o.transform)[:3, :3].T + np.asarray(o.transform)[:3, 3]
             for o in scene.objects]
    V = np.concatenate(world)
    F = np.concatenate([o.mesh.faces + sum(len(w) for w in world[:i]) for i, o in enumerate(scene.objects)])
    d = eye - points
    start = points + lift * d / np.linalg.norm(d, axis=1)[:, None]
    none = [set() for _ in range(len(F))]
    return occluded(start, np.zeros(len(points), np.int64), V, F, np.r_[eye, 1.0], none)
