"""Straight hatching on flat faces: the planes of a mesh large enough to hatch on their own, each with a hatching
direction in its plane, and the pixels of the G-buffer that lie on each.

A flat face has no curvature direction of its own. The curvature node measures one at its corners, across the
creases that bound it, and the smoothed field blends those corner directions over the face, so streamlines
curve across a box's side. An illustrator hatches a flat face with straight parallel lines instead, usually
along one of its edges. Here a plane's hatching runs along its outline's dominant direction (our choice): the
principal direction of the length-weighted structure tensor of its outline edges, which is the longer side of
a rectangle; an outline with no dominant side (a square, a regular polygon) is hatched level, along the plane's
horizontal (across the object's y axis; along x on a horizontal plane). The cross-hatching runs across it, in
the plane. The lines are fixed on the plane: {p : p . across = m G}, nested grids of gaps G x 2^i with G on a
ladder of powers of two of the mesh's diagonal. The plane's grid is the one spaced nearest the tone's spacing at
its median pixel; where a plane recedes so far that its lines crowd under half the spacing every other line
stops, and where they spread over twice the spacing lines come in between (`plane_lines`). A camera that moves
keeps every line where it was on the plane; lines of a grid come and go where the spacing crosses a bound, or
all over the plane where its median spacing moves the plane's grid a step.

A plane is a connected set of faces in planar regions (`feature_lines.planar_faces`) joined across manifold
edges of the welded mesh where their normals agree within PLANAR_DEG; regions in one plane (the same normal
within PLANAR_DEG and offsets within PLANE_TOL of the mesh's diagonal) are merged, so two cushions side by
side are hatched as one top. Planes under MIN_AREA of the mesh's area are left to the curvature field: on a
dense smooth mesh a nearly flat spot of a few faces is not a facet."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._shared.feature_lines import PLANAR_DEG, planar_faces

MIN_AREA = 0.005  # a plane smaller than this share of its mesh's area is hatched by the curvature field
PLANE_TOL = 2e-3  # a pixel lies on a plane within this fraction of the mesh's diagonal
PIECE = 0.02  # a flat region under this share of MIN_AREA does not count toward a plane
MAX_LEVEL = 40  # line 0 belongs to every grid
TIE = 0.9  # an outline whose two principal directions weigh within this ratio has no dominant side
NORMAL_COS = 0.999  # and its view-space normal within about 2.6 degrees of the plane's (16-bit normals)


@dataclass(frozen=True)
class Planes:
    """The planes of one mesh, object space: unit normals (k, 3), offsets (k,) with n . p = d on the plane,
    hatching directions (k, 3) and cross directions (k, 3), both unit and in the plane, and which vertices
    touch only faces of these planes (those whose curvature directions are measured across creases)."""

    normal: np.ndarray
    offset: np.ndarray
    along: np.ndarray
    across: np.ndarray
    flat_vertices: np.ndarray
    diagonal: float

    def __len__(self) -> int:
        return len(self.offset)


def _components(n: int, pairs: np.ndarray) -> np.ndarray:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(g, directed=False)[1]


def mesh_planes(V: np.ndarray, F: np.ndarray, weld: np.ndarray, min_area: float = MIN_AREA) -> Planes:
    """The planes of a mesh (module docstring). `weld`: vertex ids with the copies at seams sharing one."""
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    diag = float(np.linalg.norm(V.max(0) - V.min(0))) if len(V) else 1.0
    empty = Planes(np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(len(V), bool), diag)
    if len(F) == 0:
        return empty
    p = V[F]
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area2 = np.linalg.norm(cross, axis=1)
    ok = area2 > 1e-12 * max(diag, 1e-300) ** 2
    nf = cross / np.where(ok, area2, 1.0)[:, None]
    wid = np.asarray(weld, np.int64)[F]
    flat = planar_faces(F, nf, weld) & ok
    if not flat.any():
        return empty
    # manifold edges of the welded mesh between two flat faces whose normals agree
    e = np.sort(np.concatenate([wid[:, [0, 1]], wid[:, [1, 2]], wid[:, [2, 0]]]), axis=1)
    key = e[:, 0] * (int(wid.max()) + 1) + e[:, 1]
    order = np.argsort(key, kind="stable")
    skey, face = key[order], np.tile(np.arange(len(F)), 3)[order]
    start = np.flatnonzero(np.r_[True, skey[1:] != skey[:-1]])
    count = np.diff(np.r_[start, len(skey)])
    first = start[count == 2]
    pairs = np.stack([face[first], face[first + 1]], axis=1)
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
    normals, offsets, along, across = [], [], [], []
    in_plane = np.zeros(len(F), bool)
    for g in np.unique(group):
        members = regions[group == g]
        if ra[group == g].sum() < min_area * total:
            continue
        faces = np.isin(label, members)
        in_plane |= faces
        n = rn_a[g]
        direction = _outline_direction(V, F[faces], wid[faces], n)
        normals.append(n)
        offsets.append(rd_a[g])
        along.append(direction)
        across.append(np.cross(n, direction))
    if not normals:
        return empty
    touched = np.zeros(len(V), bool)
    touched[F[~in_plane].ravel()] = True
    flat_v = np.zeros(len(V), bool)
    flat_v[F[in_plane].ravel()] = True
    return Planes(np.array(normals), np.array(offsets), np.array(along), np.array(across), flat_v & ~touched, diag)


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


def pixel_planes(planes: Planes, pos: np.ndarray, nview: np.ndarray, on_object: np.ndarray,
                 normal_matrix: np.ndarray) -> np.ndarray:
    """(h, w) int: the index of the plane each pixel of an object lies on, -1 elsewhere. `pos` (h, w, 3) the
    object-space position of the G-buffer, `nview` (h, w, 3) its view-space normal, `on_object` (h, w) the
    object's pixels, `normal_matrix` (3, 3) object to view space for normals. A pixel lies on a plane where its
    position is within PLANE_TOL x diagonal of it and its normal within NORMAL_COS of the plane's."""
    out = np.full(on_object.shape, -1, np.int64)
    if not len(planes) or not on_object.any():
        return out
    r, c = np.nonzero(on_object)
    p = pos[r, c].astype(np.float64)
    nv = nview[r, c].astype(np.float64)
    nv /= np.maximum(np.linalg.norm(nv, axis=1, keepdims=True), 1e-12)
    pn = planes.normal @ normal_matrix.T
    pn /= np.maximum(np.linalg.norm(pn, axis=1, keepdims=True), 1e-300)
    best = np.full(len(r), np.inf)
    got = np.full(len(r), -1, np.int64)
    tol = PLANE_TOL * planes.diagonal
    for k in range(len(planes)):
        dist = np.abs(p @ planes.normal[k] - planes.offset[k])
        hit = (dist <= tol) & (nv @ pn[k] >= NORMAL_COS) & (dist < best)
        got[hit], best[hit] = k, dist[hit]
    out[r, c] = got
    return out


def window(points: np.ndarray, mvp: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Object-space points (n, 3) to window positions (n, 2) (x right, y up) and whether they lie in front."""
    clip = np.c_[points, np.ones(len(points))] @ mvp.T
    ok = clip[:, 3] > 1e-9
    wc = np.where(ok, clip[:, 3], 1.0)
    return np.stack([(clip[:, 0] / wc + 1) * 0.5 * size[0], (clip[:, 1] / wc + 1) * 0.5 * size[1]], 1), ok


def valuation(m: np.ndarray) -> np.ndarray:
    """The 2-adic valuation of integers (how many times 2 divides each); MAX_LEVEL for 0."""
    m = np.abs(np.asarray(m, np.int64))
    out = np.zeros(m.shape, np.int64)
    rest = m.copy()
    for _ in range(MAX_LEVEL):
        even = (rest % 2 == 0) & (rest > 0)
        if not even.any():
            break
        out[even] += 1
        rest[even] //= 2
    out[m == 0] = MAX_LEVEL
    return out


def plane_lines(points: np.ndarray, normal: np.ndarray, offset: float, line: np.ndarray, step_dir: np.ndarray,
                on_plane: np.ndarray, mvp: np.ndarray, size: tuple[int, int], spacing_px: float, diagonal: float,
                step: float, min_length: float) -> list[np.ndarray]:
    """Straight hatching of one plane, fixed on it: the lines {p on the plane : p . step_dir = m G} (direction
    `line`), G = diagonal x 2^j the finest gap any visible pixel may need. Line m belongs to the grids of gap
    G x 2^i for i <= v(m) (`valuation`). The plane's grid is the one spaced nearest `spacing_px` on the screen
    at its median pixel; its lines and coarser grids' are drawn where their grid's lines lie at least
    spacing_px / 2 apart on the screen, finer grids' where theirs lie at least spacing_px apart. So a plane seen
    with mild perspective keeps one grid all over (0.5-2 x spacing_px), and where a plane recedes far, every
    other line stops where the lines crowd, or lines come in between where they spread. `on_plane` (h, w) bool,
    rows bottom-up; `points` the object-space positions of those pixels, in np.nonzero order. Each line is
    sampled every `step` px along its projection and cut where it leaves the plane's pixels or its grid; pieces
    shorter than `min_length` px are dropped. Window coordinates."""
    w, h = size
    eps = 1e-3 * diagonal
    here, ok = window(points, mvp, size)
    across, ok2 = window(points + eps * step_dir, mvp, size)
    ahead, ok3 = window(points + eps * line, mvp, size)
    along = ahead - here
    along /= np.maximum(np.linalg.norm(along, axis=1, keepdims=True), 1e-12)
    d = across - here
    ppu = np.where(ok & ok2 & ok3, np.abs(along[:, 0] * d[:, 1] - along[:, 1] * d[:, 0]) / eps, 0.0)
    if not (ppu > 1e-9).any():
        return []
    gap = float(diagonal * 2.0 ** np.floor(np.log2(spacing_px / (ppu.max() * diagonal))))
    # the plane's own grid: spaced nearest spacing_px at its median pixel
    base_level = max(int(np.round(np.log2(spacing_px / (gap * float(np.median(ppu[ppu > 1e-9])))))), 0)
    grid = np.zeros(on_plane.shape)
    grid[on_plane] = ppu * gap  # px between neighbouring lines of the finest grid, at each pixel of the plane
    u = points @ step_dir
    ms = np.arange(np.ceil(u.min() / gap), np.floor(u.max() / gap) + 1).astype(np.int64)
    if not len(ms):
        return []
    centre = points.mean(axis=0)
    centre = centre - normal * (centre @ normal - offset)
    base = centre + np.outer(ms * gap - centre @ step_dir, step_dir)
    p0, ok0 = window(base, mvp, size)
    p1, ok1 = window(base + eps * line, mvp, size)
    keep = ok0 & ok1
    p0, ms = p0[keep], ms[keep]
    dirs = p1[keep] - p0
    dirs /= np.maximum(np.linalg.norm(dirs, axis=1, keepdims=True), 1e-12)
    v = valuation(ms)
    levels = 2.0 ** v.astype(np.float64)
    # the plane's grid and coarser ones stay down to half the spacing; finer ones come in from the full spacing
    least = np.where(v >= base_level, 0.5 * spacing_px, spacing_px)
    reach = float(np.hypot(w, h))
    t = np.arange(-reach, reach + step, step)
    out: list[np.ndarray] = []
    for origin, dv, level, floor in zip(p0, dirs, levels, least, strict=True):
        # the part of the line inside the window, then its samples on the plane's pixels where its grid is kept
        lo_t, hi_t = -reach, reach
        for o, dd, extent in ((origin[0], dv[0], w), (origin[1], dv[1], h)):
            if abs(dd) < 1e-12:
                if not 0 <= o < extent:
                    lo_t, hi_t = 1.0, 0.0
                continue
            ta, tb = sorted(((0 - o) / dd, (extent - o) / dd))
            lo_t, hi_t = max(lo_t, ta), min(hi_t, tb)
        if hi_t <= lo_t:
            continue
        tt = t[(t >= lo_t) & (t < hi_t)]
        xy = origin + np.outer(tt, dv)
        r = np.clip(xy[:, 1].astype(int), 0, h - 1)
        c = np.clip(xy[:, 0].astype(int), 0, w - 1)
        drawn = on_plane[r, c] & (grid[r, c] * level >= floor)
        if not drawn.any():
            continue
        edges = np.flatnonzero(np.diff(np.r_[0, drawn.astype(np.int8), 0]))
        for s0, s1 in zip(edges[::2], edges[1::2], strict=True):
            if (s1 - s0 - 1) * step >= max(min_length, step):
                out.append(xy[s0:s1])
    return out


class ScenePlanes:
    """The planes seen in a frame: `plane` (h, w) int, an index per plane seen (-1 off the planes), and for each
    index its object's planes, its own index among them and the object's model-view-projection; `points` the
    object-space positions of the frame's pixels; `flat_vertices` per object index (Planes.flat_vertices)."""

    def __init__(self, plane: np.ndarray, entries: list[tuple[Planes, int, np.ndarray]], points: np.ndarray,
                 flat_vertices: dict[int, np.ndarray], size: tuple[int, int], step: float) -> None:
        self.plane, self.entries, self.points = plane, entries, points
        self.flat_vertices, self.size, self.step = flat_vertices, size, step

    def hatching(self, family: int, bright: np.ndarray, limit: float, lo: float, hi: float,
                 min_length: float) -> list[np.ndarray]:
        """Family 0 (along each plane's outline) or 1 (across it) on every plane whose median brightness is
        under `limit`, spaced lo + (hi - lo) x brightness px as the streamlines are."""
        out: list[np.ndarray] = []
        for g, (pl, k, mvp) in enumerate(self.entries):
            on = self.plane == g
            b = float(np.median(bright[on]))
            if b >= limit:
                continue
            line, across = (pl.along[k], pl.across[k]) if family == 0 else (pl.across[k], pl.along[k])
            out += plane_lines(self.points[on], pl.normal[k], float(pl.offset[k]), line, across, on, mvp, self.size,
                               lo + (hi - lo) * min(max(b, 0.0), 1.0), pl.diagonal, self.step, min_length)
        return out


def scene_planes(scene: Any, view: np.ndarray, proj: np.ndarray, pos: np.ndarray, nview: np.ndarray,
                 ids: np.ndarray, size: tuple[int, int], step: float = 1.0) -> ScenePlanes | None:
    """The pixels on each rigid mesh's planes, or None where no pixel lies on one. Posed (skinned, morphed)
    meshes are left to the curvature field: `position` holds their rest pose."""
    from nodegraph.scene import origin

    plane = np.full(ids.shape, -1, np.int64)
    points = np.zeros(ids.shape + (3,))
    entries: list[tuple[Planes, int, np.ndarray]] = []
    flat_vertices: dict[int, np.ndarray] = {}
    for index, obj in enumerate(scene.objects):
        mesh = obj.mesh
        if mesh.rest is not None or not (ids == index + 1).any():
            continue
        planes = cached_planes(mesh)
        if not len(planes):
            continue
        flat_vertices[index] = planes.flat_vertices
        mv = view @ np.asarray(obj.transform, np.float64)
        if abs(np.linalg.det(mv[:3, :3])) < 1e-300:
            continue
        on_obj = ids == index + 1
        p = pos[..., :3].astype(np.float64) + origin.mesh_origin(mesh)
        points[on_obj] = p[on_obj]
        which = pixel_planes(planes, p, nview, on_obj, np.linalg.inv(mv[:3, :3]).T)
        mvp = proj @ mv
        for k in np.unique(which[which >= 0]):
            plane[which == k] = len(entries)
            entries.append((planes, int(k), mvp))
    if not entries:
        return None
    return ScenePlanes(plane, entries, points, flat_vertices, size, step)


_STORE: dict[str, Planes] = {}  # mesh content hash -> its planes


def cached_planes(mesh: Any) -> Planes:
    """mesh_planes of a mesh (welded by Mesh.weld), kept for a few meshes (by content hash)."""
    key = mesh.content_hash()
    got = _STORE.get(key)
    if got is None:
        if len(_STORE) >= 8:
            _STORE.pop(next(iter(_STORE)))
        got = _STORE[key] = mesh_planes(mesh.vertices, mesh.faces, mesh.weld()[0])
    return got
