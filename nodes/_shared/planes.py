"""The planes of a mesh: connected flat faces large enough to be drawn as facets of their own, each with a
direction in its plane along which an illustrator would hatch it (stroke_hatching's straight hatching,
pencil_shade's hatching direction on flat faces).

A flat face has no curvature direction of its own: the curvature node measures one at its corners, across the
creases that bound it, so a field interpolated or smoothed from the corners bends and whirls across it. An
illustrator hatches a flat face with straight parallel lines, usually along one of its edges. A plane's
direction here is its outline's dominant direction (our choice): the principal direction of the
length-weighted structure tensor of its outline edges, which is the longer side of a rectangle; an outline with
no dominant side (a square, a regular polygon) is hatched level, along the plane's horizontal (across the
object's y axis; along x on a horizontal plane). Planes facing the same way (parallel, the same side out) share
one direction, taken from all their outlines together, as technical illustration hatches faces by orientation: a
staircase's risers are hatched alike whatever part of each is hidden. `across` is the direction in the plane
perpendicular to it.

A plane is a connected set of faces in planar regions (`feature_lines.planar_faces`) joined across manifold
edges of the welded mesh where their normals agree within PLANAR_DEG; regions in one plane (the same normal
within PLANAR_DEG and offsets within PLANE_TOL of the mesh's diagonal) are merged, so two cushions side by
side share their top. Planes under MIN_AREA of the mesh's area are left to the curvature directions: on a
dense smooth mesh a nearly flat spot of a few faces is not a facet."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .feature_lines import PLANAR_DEG, manifold_pairs, planar_faces

MIN_AREA = 0.005  # a plane smaller than this share of its mesh's area is left to the curvature directions
PLANE_TOL = 2e-3  # coplanar within this fraction of the mesh's diagonal
PIECE = 0.02  # a flat region under this share of MIN_AREA does not count toward a plane
TIE = 0.9  # an outline whose two principal directions weigh within this ratio has no dominant side


@dataclass(frozen=True)
class Planes:
    """The planes of one mesh, object space: unit normals (k, 3), offsets (k,) with n . p = d on the plane,
    hatching directions (k, 3) and cross directions (k, 3), both unit and in the plane, which vertices touch
    only faces of these planes (those whose curvature directions are measured across creases), and the plane of
    each face (-1 off the planes); `centre`, the mesh's bounding-box centre, so that what is fixed on a plane does
    not depend on where the mesh lies."""

    normal: np.ndarray
    offset: np.ndarray
    along: np.ndarray
    across: np.ndarray
    flat_vertices: np.ndarray
    diagonal: float
    face_plane: np.ndarray
    centre: np.ndarray  # (3,) the mesh's bounding-box centre: where lines fixed on its planes are counted from

    def __len__(self) -> int:
        return len(self.offset)


def _components(n: int, pairs: np.ndarray) -> np.ndarray:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(g, directed=False)[1]


_PLANAR: dict[str, np.ndarray] = {}  # mesh content hash -> its faces in planar regions


def planar(mesh: Any, weld: np.ndarray) -> np.ndarray:
    """The faces of a (posed) mesh in planar regions (`feature_lines.planar_faces` with its face normals, welded by
    `weld`), kept for a few meshes: mesh_lines and the planes ask for the same mesh's."""
    key = mesh.content_hash()
    got = _PLANAR.get(key)
    if got is None:
        if len(_PLANAR) >= 8:
            _PLANAR.pop(next(iter(_PLANAR)))
        got = _PLANAR[key] = planar_faces(mesh.faces, mesh.face_normals(), weld)
    return got


def mesh_planes(V: np.ndarray, F: np.ndarray, weld: np.ndarray, min_area: float = MIN_AREA,
                flat: np.ndarray | None = None) -> Planes:
    """The planes of a mesh (module docstring). `weld`: vertex ids with the copies at seams sharing one; `flat`:
    its faces in planar regions where already known (`planar`)."""
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    diag = float(np.linalg.norm(V.max(0) - V.min(0))) if len(V) else 1.0
    centre = 0.5 * (V.min(0) + V.max(0)) if len(V) else np.zeros(3)
    empty = Planes(np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(len(V), bool), diag,
                   np.full(len(F), -1, np.int64), centre)
    if len(F) == 0:
        return empty
    p = V[F]
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area2 = np.linalg.norm(cross, axis=1)
    ok = area2 > 1e-12 * max(diag, 1e-300) ** 2
    nf = cross / np.where(ok, area2, 1.0)[:, None]
    wid = np.asarray(weld, np.int64)[F]
    flat = (planar_faces(F, nf, weld) if flat is None else np.asarray(flat, bool)) & ok
    if area2[flat].sum() < min_area * area2[ok].sum():  # not even all flat faces together would make a plane
        return empty
    # manifold edges of the welded mesh between two flat faces whose normals agree
    pairs = manifold_pairs(F, weld)
    same = flat[pairs[:, 0]] & flat[pairs[:, 1]] & \
        (np.sum(nf[pairs[:, 0]] * nf[pairs[:, 1]], axis=1) >= np.cos(np.radians(PLANAR_DEG)))
    label = _components(len(F), pairs[same])
    label = np.where(flat, label, -1)
    total = float(area2[ok].sum())
    # each region's area and plane (area-weighted normal, offset through its area-weighted centroid); regions
    # under PIECE x min_area of the mesh's area are dropped before merging (dense meshes' nearly flat spots)
    regions, inverse = np.unique(label[flat], return_inverse=True)
    a = area2[flat]
    ra = np.bincount(inverse, a, len(regions))
    nsum = np.stack([np.bincount(inverse, a * nf[flat][:, k], len(regions)) for k in range(3)], 1)
    csum = np.stack([np.bincount(inverse, a * p[flat].mean(axis=1)[:, k], len(regions)) for k in range(3)], 1)
    big = ra >= PIECE * min_area * total
    regions, ra, nsum, csum = regions[big], ra[big], nsum[big], csum[big]
    rn_a = nsum / np.maximum(np.linalg.norm(nsum, axis=1, keepdims=True), 1e-300)
    rd_a = np.sum(rn_a * csum / ra[:, None], axis=1)
    # merge regions lying in one plane
    group = np.arange(len(regions))
    cos_tol, d_tol = np.cos(np.radians(PLANAR_DEG)), PLANE_TOL * diag
    for i in range(len(regions)):
        if group[i] != i:
            continue
        match = (rn_a @ rn_a[i] >= cos_tol) & (np.abs(rd_a - rd_a[i]) <= d_tol) & (group == np.arange(len(group)))
        group[match] = i
    normals, offsets, kept = [], [], []
    in_plane = np.zeros(len(F), bool)
    face_plane = np.full(len(F), -1, np.int64)
    for g in np.unique(group):
        members = regions[group == g]
        if ra[group == g].sum() < min_area * total:
            continue
        faces = np.isin(label, members)
        in_plane |= faces
        face_plane[faces] = len(normals)
        normals.append(rn_a[g])
        offsets.append(rd_a[g])
        kept.append(faces)
    if not normals:
        return empty
    # planes facing one way (parallel, the same side out) share one direction, from all their outlines together:
    # a staircase's risers are hatched alike, however much of each shows
    along: list[np.ndarray] = [np.zeros(3)] * len(normals)
    done = np.zeros(len(normals), bool)
    for i in range(len(normals)):
        if done[i]:
            continue
        same = [j for j in range(len(normals)) if not done[j] and normals[j] @ normals[i] >= cos_tol]
        faces = np.logical_or.reduce([kept[j] for j in same])
        direction = _outline_direction(V, F[faces], wid[faces], normals[i])
        for j in same:
            d = direction - normals[j] * (direction @ normals[j])
            along[j] = d / max(np.linalg.norm(d), 1e-300)
            done[j] = True
    across = [np.cross(n, a) for n, a in zip(normals, along, strict=True)]
    touched = np.zeros(len(V), bool)
    touched[F[~in_plane].ravel()] = True
    flat_v = np.zeros(len(V), bool)
    flat_v[F[in_plane].ravel()] = True
    return Planes(np.array(normals), np.array(offsets), np.array(along), np.array(across), flat_v & ~touched, diag,
                  face_plane, centre)


def _outline_direction(V: np.ndarray, F: np.ndarray, wid: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The unit principal direction, in the plane of normal `n`, of the outline edges (welded edges used by one
    face of F) weighted by length; a plane with no outline (closed) takes its edges' all."""
    e = np.concatenate([wid[:, [0, 1]], wid[:, [1, 2]], wid[:, [2, 0]]])
    ev = np.concatenate([V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 1]], V[F[:, 0]] - V[F[:, 2]]])
    k = np.sort(e, axis=1)
    _, inv, cnt = np.unique(k[:, 0] * (int(k.max()) + 1) + k[:, 1], return_inverse=True, return_counts=True)
    outline = cnt[inv] == 1
    if outline.any():
        ev = ev[outline]
    ev = ev - np.outer(ev @ n, n)
    length = np.linalg.norm(ev, axis=1)
    use = length > 0
    u = ev[use] / length[use, None]
    tensor = (u * length[use, None]).T @ u
    vals, vecs = np.linalg.eigh(tensor)
    a = vecs[:, -1] - n * (vecs[:, -1] @ n)
    if vals[-1] <= 0 or vals[-2] > TIE * vals[-1] or np.linalg.norm(a) < 1e-9:
        # no dominant side (a square, a regular polygon): level lines, along the plane's horizontal (normal x
        # the object's y axis); on a horizontal plane, along x
        a = np.cross(n, [0.0, 1.0, 0.0])
        if np.linalg.norm(a) < 0.1:
            a = np.array([1.0, 0.0, 0.0]) - n * n[0]
    a /= np.linalg.norm(a)
    # a fixed sign, so that the same plane gives the same direction whatever the face order
    big = int(np.argmax(np.abs(a)))
    return a if a[big] > 0 else -a


_STORE: dict[str, Planes] = {}  # mesh content hash -> its planes


def cached_planes(mesh: Any) -> Planes:
    """mesh_planes of a mesh (welded by Mesh.weld), kept for a few meshes (by content hash)."""
    key = mesh.content_hash()
    got = _STORE.get(key)
    if got is None:
        if len(_STORE) >= 8:
            _STORE.pop(next(iter(_STORE)))
        weld = mesh.weld()[0]
        got = _STORE[key] = mesh_planes(mesh.vertices, mesh.faces, weld, flat=planar(mesh, weld))
    return got
