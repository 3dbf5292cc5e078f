"""Vector lines of a triangle mesh (float64 NumPy, no GL): segments on the surface, chained into strokes,
sampled on the screen, tested for visibility against a linear depth buffer and split into `Strokes`.

Segments (`Segs`) lie inside one face each; each endpoint carries a key shared by the segments of other faces
that end at the same surface point (a welded vertex id, or a welded mesh edge for a point inside an edge), so
chaining follows the surface across faces:

* occluding contours: the zero set of g = n . (e - e_w p), n the (welded, angle-weighted) vertex normal, or
  where an edge sharper than the crease angle meets the vertex the normal of the corner's smoothing group
  (`corner_normals`), and e the eye in homogeneous object coordinates (a direction for an orthographic camera),
  linearly interpolated inside each face: one segment between the zero crossings on the two edges whose ends
  differ in sign. Not inside a planar region (`feature_lines.planar_faces`: the faces of a box, a CAD part's
  flat sides), where the averaged normals of its corners, which lean over the creases around it, put zero
  crossings across flat faces (boxes touching, as a sofa's back on its seat, drew lines along their sides'
  diagonals); there the contour is the welded edges between a face turned toward the viewer and one turned away
  (`facet_contours`), as the render draws the region flat;
* creases: welded edges between two faces whose normals differ by more than the crease angle;
* boundaries: welded edges of one face only; `mark_borders` turns those that another object shares (the same
  world position) into borders (object and material borders: glTF primitives are separate objects);
* intersections (intersect.py): where faces of one mesh, or of two objects, pass through each other;
* any other segments with surface keys (feature_lines' suggestive contours, ridges and valleys).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from nodegraph.values import LINE_KINDS, Strokes

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

KIND = {name: i for i, name in enumerate(LINE_KINDS)}
JUNCTION_TURN = 60.0  # degrees: at a junction, `chain` continues along a pair of segments turning by less than this


@dataclass(frozen=True, eq=False)
class Segs:
    """Segments in object space: endpoints p (s, 2, 3), their barycentric coordinates in `face` (s, 2, 3), the
    face (s,), the endpoint keys (s, 2) int64 and the line kind (s,) (index into LINE_KINDS); `front` (s,) is
    False for segments known to lie on faces turned away (creases between two back faces)."""

    p: np.ndarray
    bary: np.ndarray
    face: np.ndarray
    key: np.ndarray
    kind: np.ndarray
    front: np.ndarray

    def __len__(self) -> int:
        return len(self.face)

    @staticmethod
    def empty() -> Segs:
        return Segs(np.zeros((0, 2, 3)), np.zeros((0, 2, 3)), np.zeros(0, np.int64), np.zeros((0, 2), np.int64),
                    np.zeros(0, np.uint8), np.zeros(0, bool))

    def select(self, keep: np.ndarray) -> Segs:
        return Segs(self.p[keep], self.bary[keep], self.face[keep], self.key[keep], self.kind[keep],
                    self.front[keep])

    @staticmethod
    def concat(parts: list[Segs]) -> Segs:
        parts = [s for s in parts if len(s)]
        if not parts:
            return Segs.empty()
        return Segs(*(np.concatenate([getattr(s, f) for s in parts]) for f in ("p", "bary", "face", "key", "kind",
                                                                                "front")))


def barycentric(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (k, 3) of points p (k, 3) in triangles tri (k, 3, 3) (projected onto the plane)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, p - a
    d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
    d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
    den = np.where(np.abs(d00 * d11 - d01 * d01) > 1e-300, d00 * d11 - d01 * d01, 1e-300)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.stack([1.0 - v - w, v, w], axis=1)


def edge_key(wa: np.ndarray, wb: np.ndarray, nw: int) -> np.ndarray:
    """Key of a point inside the welded edge (wa, wb): beyond every vertex key, the same for (wb, wa)."""
    lo, hi = np.minimum(wa, wb).astype(np.int64), np.maximum(wa, wb).astype(np.int64)
    return nw + lo * nw + hi


def facing(V: np.ndarray, N: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """g = N . (e[:3] - e[3] V) per row: > 0 where the surface faces the viewer."""
    return np.einsum("ij,ij->i", N, eye[None, :3] - eye[3] * V)


def zero_crossings(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Of triangles whose corner values `d` (k, 3) differ in sign (>= 0 counts as positive): the corner alone on
    its side (k,), and on its two edges the corner each ends at (k, 2) and the parameter t of the zero along it
    from the lone corner (k, 2), linearly interpolated."""
    pos = d >= 0.0
    cnt = pos.sum(axis=1)
    lone = np.where(cnt == 1, np.argmax(pos, axis=1), np.argmin(pos, axis=1))
    rows = np.arange(len(d))
    others = np.stack([(lone + 1) % 3, (lone + 2) % 3], axis=1)
    dl = d[rows, lone][:, None]
    ts = dl / (dl - d[rows[:, None], others])
    return lone, others, ts


def corner_normals(mesh: Any, crease_angle: float) -> tuple[np.ndarray, np.ndarray]:
    """The face corners whose normal for the contours is not the welded vertex normal (`Mesh.vertex_normals`):
    those at a vertex whose faces a sharp edge (dihedral angle above `crease_angle` degrees) parts into smoothing
    groups, each with the normal of its group (`Mesh.render_arrays`: the faces joined across edges of two faces no
    sharper than the angle, angle-weighted as the vertex normal). Returns (flat corner indices face * 3 + corner
    (k,), their unit normals (k, 3) float64)."""
    ra = mesh.render_arrays(crease_angle)
    group = ra.indices.astype(np.int64).ravel()
    wf = mesh.welded_faces().ravel()
    parted = np.flatnonzero(np.bincount(group)[group] != np.bincount(wf)[wf])  # the group is not every corner
    return parted, np.asarray(ra.normals, np.float64)[group[parted]]


def contours(V: np.ndarray, F: np.ndarray, N: np.ndarray, wid: np.ndarray, nw: int, eye: np.ndarray,
             flat: np.ndarray | None = None, corners: tuple[np.ndarray, np.ndarray] | None = None) -> Segs:
    """Occluding contours: interpolated zero crossings of g = n . v inside faces (module docstring), none inside
    the faces `flat` marks (planar regions: `facet_contours` draws theirs). With `corners` (`corner_normals`) n
    is, at the corners it names, the corner's normal, not the vertex's `N`: beside a sharp edge the surface's own
    normal, not one leaning over the edge (which put a second contour along creases: the cloister's arches, a
    capped tube's rim). The two faces of a sharp edge then find their zero crossings on it at different points;
    both keep the edge's key, so a contour chains from one to the other along the edge, which between them is a
    silhouette edge (one face turned toward the viewer, the other away)."""
    g = facing(V, N, eye)[F]
    if corners is not None and len(corners[0]):
        at, normal = corners
        g[at // 3, at % 3] = facing(V[F[at // 3, at % 3]], normal, eye)
    cnt = (g >= 0.0).sum(axis=1)
    crossed = (cnt == 1) | (cnt == 2)
    fi = np.flatnonzero(crossed if flat is None else crossed & ~flat)
    if not len(fi):
        return Segs.empty()
    lone, others, ts = zero_crossings(g[fi])
    pts, bary, keys = [], [], []
    rows = np.arange(len(fi))
    va = F[fi, lone]
    for other, t in zip(others.T, ts.T, strict=True):
        vx = F[fi, other]
        pts.append(V[va] + t[:, None] * (V[vx] - V[va]))
        b = np.zeros((len(fi), 3))
        b[rows, lone] = 1.0 - t
        b[rows, other] = t
        bary.append(b)
        keys.append(edge_key(wid[va], wid[vx], nw))
    return Segs(np.stack(pts, axis=1), np.stack(bary, axis=1), fi.astype(np.int64), np.stack(keys, axis=1),
                np.full(len(fi), KIND["contour"], np.uint8), np.ones(len(fi), bool))


@dataclass(frozen=True, eq=False)
class EdgeFaces:
    """The welded edges of a mesh (topology only: the same for every pose): for each edge its first
    occurrence (face * 3 + corner, the edge running from that corner to the next) and, for an edge of two
    faces, the second (-1 otherwise); edges of three or more faces are left out (non-manifold)."""

    first: np.ndarray
    second: np.ndarray


def edge_faces(wF: np.ndarray, nw: int) -> EdgeFaces:
    a = wF.astype(np.int64)
    b = np.roll(a, -1, axis=1)
    key = (np.minimum(a, b) * nw + np.maximum(a, b)).ravel()
    order = np.argsort(key, kind="stable")
    k = key[order]
    new = np.r_[True, k[1:] != k[:-1]]
    starts = np.flatnonzero(new)
    counts = np.diff(np.r_[starts, len(k)])
    one = counts <= 2
    first = order[starts[one]]
    second = np.where(counts[one] == 2, order[np.minimum(starts[one] + 1, len(k) - 1)], -1)
    return EdgeFaces(first, second)


def _edge_segs(V: np.ndarray, F: np.ndarray, wid: np.ndarray, occ: np.ndarray, kind: int,
               front: np.ndarray) -> Segs:
    f, c = occ // 3, occ % 3
    c2 = (c + 1) % 3
    va, vb = F[f, c], F[f, c2]
    bary = np.zeros((len(occ), 2, 3))
    rows = np.arange(len(occ))
    bary[rows, 0, c] = 1.0
    bary[rows, 1, c2] = 1.0
    return Segs(np.stack([V[va], V[vb]], axis=1), bary, f.astype(np.int64),
                np.stack([wid[va], wid[vb]], axis=1).astype(np.int64), np.full(len(occ), kind, np.uint8), front)


def face_facing(V: np.ndarray, F: np.ndarray, face_normals: np.ndarray, eye: np.ndarray,
                centroids: np.ndarray | None = None) -> np.ndarray:
    """g per face, at its centroid (one sign over the face's plane; `centroids`: V[F].mean(axis=1) where known):
    > 0 where it faces the viewer."""
    return facing(V[F].mean(axis=1) if centroids is None else centroids, face_normals, eye)


def silhouette_edges(face_normals: np.ndarray, ef: EdgeFaces, face_g: np.ndarray,
                     crease_angle: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The welded edges between a face turned toward the viewer and one turned away (`face_g`, `face_facing`), as
    occurrences on the face turned toward the viewer, the other face of each, and whether each is sharper than
    `crease_angle` degrees (all False for None)."""
    two = ef.second >= 0
    o1, o2 = ef.first[two], ef.second[two]
    front1 = face_g[o1 // 3] > 0.0
    keep = front1 != (face_g[o2 // 3] > 0.0)
    o1, o2, front1 = o1[keep], o2[keep], front1[keep]
    occ, back = np.where(front1, o1, o2), np.where(front1, o2, o1) // 3
    sharp = np.zeros(len(occ), bool)
    if crease_angle is not None:
        sharp = np.einsum("ij,ij->i", face_normals[occ // 3], face_normals[back]) < np.cos(np.radians(crease_angle))
    return occ, back, sharp


def facet_contours(V: np.ndarray, F: np.ndarray, wid: np.ndarray, flat: np.ndarray,
                   silhouette: tuple[np.ndarray, np.ndarray, np.ndarray]) -> Segs:
    """Occluding contours of planar regions: the silhouette edges (`silhouette`: `silhouette_edges`) whose two
    faces are both in planar regions (`flat`; next to a curved face, that face's interpolated contour runs along
    the edge), on the face turned toward the viewer; those sharper than the crease angle are left to the creases."""
    occ, back, sharp = silhouette
    keep = flat[occ // 3] & flat[back] & ~sharp
    return _edge_segs(V, F, wid, occ[keep], KIND["contour"], np.ones(int(keep.sum()), bool))


def outline_edges(V: np.ndarray, F: np.ndarray, wid: np.ndarray, flat: np.ndarray,
                  silhouette: tuple[np.ndarray, np.ndarray, np.ndarray]) -> Segs:
    """The polygonal silhouette outside planar regions: the silhouette edges (`silhouette_edges`) not both of whose
    faces are planar (`facet_contours` draws those) and not sharper than the crease angle, on the face turned toward
    the viewer. `reconcile_outline` draws them where the interpolated contours miss the mesh's outline."""
    occ, back, sharp = silhouette
    keep = ~(flat[occ // 3] & flat[back]) & ~sharp
    return _edge_segs(V, F, wid, occ[keep], KIND["contour"], np.ones(int(keep.sum()), bool))


def sharp_edges(face_normals: np.ndarray, ef: EdgeFaces, crease_angle: float) -> tuple[np.ndarray, np.ndarray]:
    """The welded edges of two faces whose normals differ by more than `crease_angle` degrees: both occurrences
    of each (the same for every view of a posed mesh)."""
    two = ef.second >= 0
    o1, o2 = ef.first[two], ef.second[two]
    cos = np.einsum("ij,ij->i", face_normals[o1 // 3], face_normals[o2 // 3])
    sharp = cos < np.cos(np.radians(crease_angle))
    return o1[sharp], o2[sharp]


def creases_and_boundaries(V: np.ndarray, F: np.ndarray, face_normals: np.ndarray, wid: np.ndarray,
                           ef: EdgeFaces, face_g: np.ndarray, crease_angle: float, creases: bool = True,
                           boundaries: bool = True,
                           sharp: tuple[np.ndarray, np.ndarray] | None = None) -> Segs:
    """Creases (dihedral angle above `crease_angle` degrees, on the face of the pair nearer facing the viewer;
    `front` False where both faces turn away: `face_g`, `face_facing`) and boundaries (edges of one face).
    `sharp`: `sharp_edges` where known."""
    parts = []
    if creases:
        o1, o2 = sharp_edges(face_normals, ef, crease_angle) if sharp is None else sharp
        g1, g2 = face_g[o1 // 3], face_g[o2 // 3]
        occ = np.where(g1 >= g2, o1, o2)
        parts.append(_edge_segs(V, F, wid, occ, KIND["crease"], np.maximum(g1, g2) > 0.0))
    if boundaries:
        occ = ef.first[ef.second < 0]
        parts.append(_edge_segs(V, F, wid, occ, KIND["boundary"], np.ones(len(occ), bool)))
    return Segs.concat(parts)


def mark_borders(per_object: list[Segs], transforms: list[np.ndarray], quantum: float) -> list[Segs]:
    """Boundary segments that another object also has at the same world position (within `quantum`) become
    borders, kept on the first object that has them only."""
    rows, owner, index = [], [], []
    for i, (s, t) in enumerate(zip(per_object, transforms, strict=True)):
        b = np.flatnonzero(s.kind == KIND["boundary"])
        if not len(b):
            continue
        w = s.p[b] @ t[:3, :3].T + t[:3, 3]
        q = np.rint(w / quantum).astype(np.int64)  # (k, 2, 3)
        a, c = q[:, 0], q[:, 1]
        first_a = (a[:, 0] < c[:, 0]) | ((a[:, 0] == c[:, 0]) & ((a[:, 1] < c[:, 1]) | ((a[:, 1] == c[:, 1])
                                                                                       & (a[:, 2] <= c[:, 2]))))
        lo = np.where(first_a[:, None], a, c)
        hi = np.where(first_a[:, None], c, a)
        rows.append(np.concatenate([lo, hi], axis=1))
        owner.append(np.full(len(b), i))
        index.append(b)
    if len(rows) < 2:
        return per_object
    allrows, allown, allidx = np.concatenate(rows), np.concatenate(owner), np.concatenate(index)
    _, inv, counts = np.unique(allrows, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    first_owner = np.full(len(counts), np.iinfo(np.int64).max)
    np.minimum.at(first_owner, inv, allown)
    shared = counts[inv] > 1
    out = []
    for i, s in enumerate(per_object):
        mine = allown == i
        if not mine.any():
            out.append(s)
            continue
        kind = s.kind.copy()
        keep = np.ones(len(s), bool)
        sh = shared[mine]
        idx = allidx[mine]
        kind[idx[sh]] = KIND["border"]
        keep[idx[sh & (first_owner[inv[mine]] != i)]] = False
        out.append(Segs(s.p, s.bary, s.face, s.key, kind, s.front).select(keep))
    return out


def chain(key: np.ndarray, kind: np.ndarray, p: np.ndarray | None = None,
          max_turn: float = JUNCTION_TURN) -> tuple[np.ndarray, np.ndarray]:
    """Chains of segments of one kind that share endpoints, continued through endpoints two segments meet
    at (valence 2). Where three or more meet (a junction) and the segments' endpoints `p` (s, 2, 3) are given,
    the chain goes on along the straightest continuation, as Freestyle's chaining chooses at a junction: the
    pairs of segments leaving the junction are taken most nearly opposite first, each segment at most once, while
    they turn by less than `max_turn` degrees (object space); the other segments end there. Returns (half-edges
    (k,), chain offsets (c + 1,)): half-edge h = 2 * segment + end walks the segment from that end to the other;
    a closed loop ends where it began."""
    s = len(key)
    if s == 0:
        return np.zeros(0, np.int64), np.zeros(1, np.int64)
    node_key = key.astype(np.int64) * len(LINE_KINDS) + kind.astype(np.int64)[:, None]
    _, inv = np.unique(node_key.ravel(), return_inverse=True)
    inv = inv.reshape(-1)
    order = np.argsort(inv, kind="stable")
    deg = np.bincount(inv)
    partner = np.full(2 * s, -1, np.int64)
    two = deg[inv[order]] == 2
    ho = order[two].reshape(-1, 2)  # both half-edges of each valence-2 node, next to each other
    partner[ho[:, 0]] = ho[:, 1]
    partner[ho[:, 1]] = ho[:, 0]
    if p is not None and max_turn > 0:
        _pair_junctions(partner, inv, order, deg, np.asarray(p, np.float64), max_turn)
    partner_l = partner.tolist()
    visited = bytearray(s)
    out: list[int] = []
    offsets = [0]
    for s0 in range(s):
        if visited[s0]:
            continue
        visited[s0] = 1
        back: list[int] = []
        cur = 2 * s0
        while True:  # backwards from end 0
            p = partner_l[cur]
            if p < 0 or visited[p >> 1]:
                break
            visited[p >> 1] = 1
            back.append(p ^ 1)
            cur = p ^ 1
        back.reverse()
        out.extend(back)
        out.append(2 * s0)
        cur = 2 * s0 + 1
        while True:  # forwards from end 1
            p = partner_l[cur]
            if p < 0 or visited[p >> 1]:
                break
            visited[p >> 1] = 1
            out.append(p)
            cur = p ^ 1
        offsets.append(len(out))
    return np.asarray(out, np.int64), np.asarray(offsets, np.int64)


def _pair_junctions(partner: np.ndarray, inv: np.ndarray, order: np.ndarray, deg: np.ndarray, p: np.ndarray,
                    max_turn: float) -> None:
    """`chain`'s choice at junctions, written into `partner` (half-edge -> the half-edge it continues into)."""
    sorted_deg = deg[inv[order]]
    at = order[sorted_deg >= 3]  # half-edges at junctions, grouped by node
    if not len(at):
        return
    seg, end = at >> 1, at & 1
    out = p[seg, 1 - end] - p[seg, end]  # each half-edge's direction out of its junction
    out /= np.maximum(np.linalg.norm(out, axis=1), 1e-300)[:, None]
    nodes = inv[at]
    bounds = np.r_[0, np.flatnonzero(np.diff(nodes)) + 1, len(at)]
    limit = -np.cos(np.radians(max_turn))  # u_i . u_j below this: the pair turns by less than max_turn
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        u = out[a:b]
        cos = u @ u.T
        i, j = np.triu_indices(b - a, 1)
        c = cos[i, j]
        ok = c < limit
        taken = np.zeros(b - a, bool)
        for k in np.argsort(c[ok], kind="stable"):
            x, y = i[ok][k], j[ok][k]
            if taken[x] or taken[y]:
                continue
            taken[x] = taken[y] = True
            partner[at[a + x]], partner[at[a + y]] = at[a + y], at[a + x]


@dataclass(frozen=True)
class View:
    """How object points reach the screen: `mvp` (object -> clip), `mv` (object -> view), canvas size."""

    mvp: np.ndarray
    mv: np.ndarray
    size: tuple[int, int]

    def screen(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(xy in pixels (k, 2), y up; linear view depth (k,))."""
        h = np.c_[p, np.ones(len(p))]
        clip = h @ self.mvp.T
        w = clip[:, 3:4]
        ndc = clip[:, :2] / np.where(np.abs(w) > 1e-300, w, 1e-300)
        xy = (ndc * 0.5 + 0.5) * np.array(self.size, np.float64)
        depth = -(h @ self.mv[2])
        return xy, depth


FLICKER = 2  # samples: a contour's hidden run this short between visible samples of its chain is drawn


def close_flicker(state: np.ndarray, offsets: np.ndarray, among: np.ndarray, most: int = FLICKER) -> np.ndarray:
    """`state` with each run of at most `most` samples `among` (those a gap may be made of: the contours' hidden
    samples) not visible, of one chain (`offsets`), whose neighbours on both sides in the chain are visible (1),
    made visible. A contour on a coarse mesh's outline lies within a pixel of it, on the face turned away; where no
    pixel of its 2 x 2 is background the depth buffer holds the face turned toward the viewer, and a sample or two
    at a time tests hidden: the line was drawn in dashes, a break at each (a capped cone's side, the cow)."""
    out = state.copy()
    n = len(state)
    if n < 3 or most < 1:
        return out
    chain = np.zeros(n, np.int64)
    starts = offsets[:-1][offsets[1:] > offsets[:-1]]
    chain[starts[1:]] = 1
    chain = np.cumsum(chain)
    hid = among & (state != 1)
    edge = np.diff(np.r_[0, hid.astype(np.int8), 0])
    a, b = np.flatnonzero(edge == 1), np.flatnonzero(edge == -1)  # runs [a, b)
    ok = (b - a <= most) & (a > 0) & (b < n)
    a, b = a[ok], b[ok]
    ok = (state[a - 1] == 1) & (state[b] == 1) & (chain[a - 1] == chain[a]) & (chain[b] == chain[b - 1])
    a, b = a[ok], b[ok]
    run = np.repeat(np.arange(len(a)), b - a)
    out[a[run] + np.arange(len(run)) - np.repeat(np.cumsum(b - a) - (b - a), b - a)] = 1
    return out


def depth_visibility(xy: np.ndarray, depth: np.ndarray, zbuf: np.ndarray, tolerance: float,
                     far: np.ndarray | None = None, on_surface: np.ndarray | None = None) -> np.ndarray:
    """Per sample: 1 visible, 0 hidden, -1 off the canvas. `zbuf` (H, W): linear view depth, row 0 at the
    bottom, 0 = background. A sample is visible where one of the 2 x 2 pixels whose centres surround it is
    background or no nearer than its depth less a tolerance: `tolerance` x its depth, and for the samples
    `on_surface` (lines on the rendered surface: creases, boundaries, intersections; not the interpolated
    contours, which lie off the polygons near a silhouette) at most SLOPE_PX times the depth buffer's slope there
    (`depth_slope`) plus DEPTH_EPS of the depth. A line on a silhouette sees the background or its own surface
    beside it, a line behind a nearer surface sees only that surface. (A 3 x 3 block around the sample's pixel
    reaches up to 1.5 px: a contour passing behind the surface stayed visible up to 3 px past the point where a
    ray cast hides it, and the bunny's precision against the ray-cast reference was 0.973-0.976 from two of four
    views; with 2 x 2 it is 0.987-0.998.) The slope bound matters at a distance, where a fraction of the depth is
    many pixels' worth of a surface: a box's bottom edge sunk 0.05 under a floor seen from 20 units lay within 1 %
    and was drawn 2-3 px beside the junction; against ray casting: docs/strokes.md, Accuracy, "Edges"."""
    h, w = zbuf.shape
    far = outline_far(zbuf) if far is None else far  # padded by 2
    ix = np.floor(xy[:, 0]).astype(np.int64)
    iy = np.floor(xy[:, 1]).astype(np.int64)
    on = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h) & (depth > 0.0)
    state = np.full(len(xy), -1, np.int8)
    x0, y0, near_max = farthest_around(xy[on], far)
    d = depth[on]
    allow = d * tolerance
    if on_surface is not None and np.any(on_surface[on]):
        surf = np.flatnonzero(on_surface[on])
        xs, ys = x0[surf], y0[surf]
        slope = np.maximum(np.maximum(depth_slope(far, ys, xs), depth_slope(far, ys, xs + 1)),
                           np.maximum(depth_slope(far, ys + 1, xs), depth_slope(far, ys + 1, xs + 1)))
        allow[surf] = np.minimum(allow[surf], SLOPE_PX * slope + DEPTH_EPS * d[surf])
    state[on] = (near_max >= d - allow).astype(np.int8)
    return state


def farthest_around(xy: np.ndarray, far: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Of points on the canvas (pixels, y up): the corner (x0, y0) in `far` (`outline_far`, padded by 2) of the
    2 x 2 pixels whose centres surround each, and the farthest depth among them."""
    x0 = np.floor(xy[:, 0] - 0.5).astype(np.int64) + 2
    y0 = np.floor(xy[:, 1] - 0.5).astype(np.int64) + 2
    most = np.maximum(np.maximum(far[y0, x0], far[y0, x0 + 1]), np.maximum(far[y0 + 1, x0], far[y0 + 1, x0 + 1]))
    return x0, y0, most


SLOPE_PX = 2.0  # pixels of the depth buffer's slope a sample on the surface may lie behind it (depth_visibility)
DEPTH_EPS = 1e-4  # and this fraction of its depth (float32 depth, rasterisation)


def depth_slope(far: np.ndarray, y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The depth buffer's change over one pixel at pixels (y, x) of `far` (`outline_far`; at least one pixel
    inside its padding): per axis the smaller of the two one-sided differences (the side on the same surface at a
    depth edge), their length. inf where a pixel is background or both sides of an axis are (a sliver one pixel
    wide: no slope to read)."""
    c = far[y, x].astype(np.float64)
    with np.errstate(invalid="ignore"):
        gx = np.fmin(np.abs(far[y, x + 1] - c), np.abs(c - far[y, x - 1]))
        gy = np.fmin(np.abs(far[y + 1, x] - c), np.abs(c - far[y - 1, x]))
    g = np.hypot(gx, gy)
    return np.where(np.isnan(g) | ~np.isfinite(c), np.inf, g)


@dataclass(frozen=True, eq=False)
class Samples:
    """Chains sampled along the screen: per sample object point, face, barycentric, kind, xy, depth, and the
    chain offsets (c + 1,)."""

    p: np.ndarray
    face: np.ndarray
    bary: np.ndarray
    kind: np.ndarray
    front: np.ndarray
    xy: np.ndarray
    depth: np.ndarray
    offsets: np.ndarray


def sample(segs: Segs, half: np.ndarray, offsets: np.ndarray, view: View, spacing: float) -> Samples:
    """Each chained segment cut into pieces at most `spacing` pixels long on the screen, the chain's last end
    added: points interpolated in object space, barycentric coordinates inside the segment's face."""
    seg, end = half >> 1, half & 1
    p0, p1 = segs.p[seg, end], segs.p[seg, 1 - end]
    b0, b1 = segs.bary[seg, end], segs.bary[seg, 1 - end]
    xy0, _ = view.screen(p0)
    xy1, _ = view.screen(p1)
    n = np.maximum(1, np.ceil(np.hypot(*(xy1 - xy0).T) / spacing)).astype(np.int64)
    n = np.minimum(n, 4096)
    rep = np.repeat(np.arange(len(half)), n)
    first = np.r_[0, np.cumsum(n)[:-1]]
    t = (np.arange(int(n.sum())) - first[rep]) / n[rep]
    pts = p0[rep] + t[:, None] * (p1 - p0)[rep]
    bar = b0[rep] + t[:, None] * (b1 - b0)[rep]
    face = segs.face[seg][rep]
    kind = segs.kind[seg][rep]
    front = segs.front[seg][rep]
    # the chain ends: insert each chain's last endpoint after its last piece
    c_last = offsets[1:] - 1
    nonempty = offsets[1:] > offsets[:-1]
    c_last = c_last[nonempty]
    ins_at = np.cumsum(n)[c_last]  # position after the chain's last piece
    pts = np.insert(pts, ins_at, p1[c_last], axis=0)
    bar = np.insert(bar, ins_at, b1[c_last], axis=0)
    face = np.insert(face, ins_at, segs.face[seg[c_last]])
    kind = np.insert(kind, ins_at, segs.kind[seg[c_last]])
    front = np.insert(front, ins_at, segs.front[seg[c_last]])
    per_chain = np.add.reduceat(n, offsets[:-1][nonempty]) + 1 if len(n) else np.zeros(0, np.int64)
    s_off = np.r_[0, np.cumsum(per_chain)].astype(np.int64)
    xy, depth = view.screen(pts)
    return Samples(pts, face, bar, kind, front, xy, depth, s_off)


def split(sm: Samples, state: np.ndarray, split_angle: float, min_length: float,
          hidden: bool) -> tuple[np.ndarray, np.ndarray]:
    """Strokes from sampled chains: cut where visibility `state` changes (the next stroke starts at the next
    sample), at turns sharper than `split_angle` degrees on the screen (both strokes share the vertex), dropped
    off the canvas, when hidden (unless `hidden`) and when shorter than `min_length` pixels. Returns (vertex
    indices into the samples (k,), stroke offsets (m + 1,))."""
    n = len(sm.xy)
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(1, np.int64)
    chain_start = sm.offsets[:-1][sm.offsets[1:] > sm.offsets[:-1]]
    chain_end = sm.offsets[1:][sm.offsets[1:] > sm.offsets[:-1]] - 1
    interior = np.ones(n, bool)
    interior[chain_start] = False
    interior[chain_end] = False
    d = np.diff(sm.xy, axis=0)
    ln = np.hypot(d[:, 0], d[:, 1])
    turn = np.zeros(n, bool)
    if n > 2:
        a, b = d[:-1], d[1:]
        la, lb = ln[:-1], ln[1:]
        cos = np.einsum("ij,ij->i", a, b) / np.maximum(la * lb, 1e-300)
        turn[1:-1] = (cos < np.cos(np.radians(split_angle))) & (la > 1e-9) & (lb > 1e-9)
    turn &= interior
    change = np.zeros(n, bool)  # a stroke ends at i, the next starts at i + 1
    change[:-1] = state[:-1] != state[1:]
    change &= interior  # no cut at a chain's last sample (the chain ends there anyway)
    change[chain_end] = False
    tv = np.flatnonzero(turn & ~change)
    cv = np.flatnonzero(change)
    starts = np.sort(np.r_[chain_start, tv, cv + 1])
    ends = np.sort(np.r_[chain_end, tv, cv])
    cum = np.r_[0.0, np.cumsum(ln)]
    length = cum[ends] - cum[starts]
    # a closed chain cut inside: its last stroke runs on into its first where the two have one state and the
    # closing point is no sharp turn (the chain's start is arbitrary, not a place to cut)
    lead = np.full(len(starts), -1, np.int64)  # stroke k is preceded by stroke lead[k]'s samples
    closed = (chain_end > chain_start + 1) & (np.hypot(*(sm.xy[chain_end] - sm.xy[chain_start]).T) < 1e-6)
    for cs, ce in zip(chain_start[closed].tolist(), chain_end[closed].tolist(), strict=True):
        first, last = int(np.searchsorted(starts, cs)), int(np.searchsorted(ends, ce))
        if first == last or state[cs] != state[ce] or turn_at(sm.xy, ce - 1, cs + 1, ce, split_angle):
            continue
        lead[first] = last
    merged = lead >= 0
    dropped = np.zeros(len(starts), bool)
    dropped[lead[merged]] = True
    length = length + np.where(merged, length[np.maximum(lead, 0)], 0.0)
    keep = (ends - starts + 1 >= 2) & ~dropped
    keep &= state[starts] >= (0 if hidden else 1)
    keep &= length >= min_length
    parts = []
    for k in np.flatnonzero(keep).tolist():
        if merged[k]:
            j = int(lead[k])
            parts.append(np.r_[np.arange(starts[j], ends[j] + 1), np.arange(starts[k] + 1, ends[k] + 1)])
        else:
            parts.append(np.arange(starts[k], ends[k] + 1))
    if not parts:
        return np.zeros(0, np.int64), np.zeros(1, np.int64)
    counts = np.array([len(x) for x in parts], np.int64)
    return np.concatenate(parts).astype(np.int64), np.r_[0, np.cumsum(counts)].astype(np.int64)


def turn_at(xy: np.ndarray, before: int, after: int, at: int, split_angle: float) -> bool:
    """Whether the path before -> at -> after turns by more than `split_angle` degrees on the screen."""
    a, b = xy[at] - xy[before], xy[after] - xy[at]
    la, lb = float(np.hypot(*a)), float(np.hypot(*b))
    return la > 1e-9 and lb > 1e-9 and float(a @ b) / (la * lb) < np.cos(np.radians(split_angle))


OUTLINE_JUMP = 0.02
"""`reconcile_outline`: a silhouette sample is on the image's outline where a pixel of the 3 x 3 around it is
background or farther than its depth by more than this fraction of it."""


def outline_far(zbuf: np.ndarray) -> np.ndarray:
    """The linear depth buffer with the background at inf, padded by two pixels of background all round (float32, as
    rendered): made once a frame, read by `depth_visibility` and `at_outline`."""
    far = np.full((zbuf.shape[0] + 4, zbuf.shape[1] + 4), np.inf, np.float32)  # the buffer's own precision
    np.copyto(far[2:-2, 2:-2], zbuf, where=zbuf > 0.0, casting="same_kind")
    return far


def at_outline(xy: np.ndarray, depth: np.ndarray, far: np.ndarray) -> np.ndarray:
    """Per point (pixels, y up; linear depth): on the image's outline, where a pixel of the 3 x 3 around its pixel
    is background or farther than its depth by OUTLINE_JUMP of it (`far`: `outline_far`; off the canvas: True)."""
    return farthest_within(xy, far, 2) > depth * (1.0 + OUTLINE_JUMP)


def farthest_within(xy: np.ndarray, far: np.ndarray, r2: int) -> np.ndarray:
    """Per point (pixels, y up): the farthest depth in `far` (`outline_far`, padded by 2) among the pixels whose
    offset (dx, dy) from its pixel has dx^2 + dy^2 <= `r2` (at most 4: 2 for the 3 x 3 block, 4 for the disc of
    radius 2); a point off the canvas reads the padding (inf)."""
    h, w = far.shape
    ix = np.clip(np.floor(xy[:, 0]).astype(np.int64) + 2, 2, w - 3)
    iy = np.clip(np.floor(xy[:, 1]).astype(np.int64) + 2, 2, h - 3)
    most = np.full(len(ix), -np.inf)
    for dy in range(-2, 3):
        for dx in range(-2, 3):
            if dx * dx + dy * dy <= r2:
                most = np.maximum(most, far[iy + dy, ix + dx])
    return most


def beside_outline(xy: np.ndarray, depth: np.ndarray, far: np.ndarray, tolerance: float) -> np.ndarray:
    """Per point (pixels, y up; linear depth): a pixel whose centre is within 2 px of its pixel's is background or no
    nearer than its depth less `tolerance` of it (`far`: `outline_far`): a line drawn there is at most 2 px from
    where the surface in front of it ends (the accuracy tests' bound for a visible contour sample)."""
    return farthest_within(xy, far, 4) >= depth * (1.0 - tolerance)


def outline_candidates(edges: Segs, view: View, far: np.ndarray) -> Segs:
    """The silhouette edges (`outline_edges`) with an end or their middle on the image's outline
    (`at_outline`): the others cannot draw any of it (`reconcile_outline` drops their samples), so they are not
    chained."""
    if not len(edges):
        return edges
    keep = np.zeros(len(edges), bool)
    for point in (edges.p[:, 0], edges.p[:, 1], 0.5 * (edges.p[:, 0] + edges.p[:, 1])):
        xy, depth = view.screen(point)
        keep |= at_outline(xy, depth, far)
    return edges.select(keep)


def edge_points(segs: Segs, view: View, step: float) -> np.ndarray:
    """Points along every segment on the screen (pixels, y up), at most `step` pixels apart, ends included,
    without chaining (for distances)."""
    if not len(segs):
        return np.zeros((0, 2))
    a, _ = view.screen(segs.p[:, 0])
    b, _ = view.screen(segs.p[:, 1])
    n = np.minimum(np.maximum(1, np.ceil(np.hypot(*(b - a).T) / step)), 4096).astype(np.int64) + 1
    rep = np.repeat(np.arange(len(segs)), n)
    t = (np.arange(int(n.sum())) - np.repeat(np.r_[0, np.cumsum(n)[:-1]], n)) / (n[rep] - 1)
    return a[rep] + t[:, None] * (b - a)[rep]


def distance_tree(points: np.ndarray) -> cKDTree:
    """A k-d tree for distance queries alone, built the faster way (unbalanced, no node shrinking: the same
    distances; 25 % less time to build and query the few thousand points of a frame's lines)."""
    from scipy.spatial import cKDTree

    return cKDTree(points, balanced_tree=False, compact_nodes=False)


def reconcile_outline(sm: Samples, state: np.ndarray, interpolated: np.ndarray, outline: Samples,
                      outline_state: np.ndarray, sharp: np.ndarray, radius: float, far: np.ndarray,
                      silhouette: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One outline from a mesh's interpolated contours and its polygonal silhouette (`outline_edges`), which
    agree within a pixel on a finely tessellated smooth mesh and part on a coarse one (a low-poly
    rock: the interpolated zero set cuts across faces turned toward the viewer, inside the outline the render
    draws, or lies hidden behind them). `sm`, `state`: the other lines' samples and visibility, `interpolated`
    marking the interpolated contour samples and `sharp` the crease samples; `outline`, `outline_state` the
    silhouette's. Returns the two states with dropped samples at -1 (as off the canvas: never kept):

    * a visible interpolated contour sample farther than `radius` px from every point of the silhouette
      (`silhouette`: `edge_points` of every outline segment, visible or not) and every visible crease
      sample (a stray: nothing of the mesh turns away there) is dropped where it is off the image's outline
      (a line across faces turned toward the viewer) or where a visible silhouette sample on the outline lies
      within 2 `radius` + 1 px (the silhouette takes over there). A stray on the outline with no silhouette to
      take over (where a tube's contour meets the crease round its cap) is kept: dropping it left a gap;
    * a silhouette sample is dropped where it is hidden (the hidden layer keeps the interpolated contours) or off
      the image's outline (`far`, `outline_far`: no pixel of the 3 x 3 around it is background or farther than
      its depth by OUTLINE_JUMP; the small folds of a scanned mesh's bumps turn faces away inside the outline).

    `suppress_filled` then drops the silhouette samples near the interpolated contours that are drawn, so the
    silhouette draws the outline only where no interpolated contour does."""
    state, outline_state = state.copy(), outline_state.copy()
    outline_state[outline_state == 0] = -1
    vis = outline_state > 0
    outline_state[np.flatnonzero(vis)[~at_outline(outline.xy[vis], outline.depth[vis], far)]] = -1
    ref = np.concatenate([silhouette, sm.xy[sharp & (state > 0)]])
    cand = np.flatnonzero(interpolated & (state > 0))
    if len(cand):
        stray = np.ones(len(cand), bool)
        if len(ref):
            stray = distance_tree(ref).query(sm.xy[cand], distance_upper_bound=radius)[0] > radius
        cand = cand[stray]
        drop = ~at_outline(sm.xy[cand], sm.depth[cand], far)
        fill = outline_state > 0
        if fill.any():
            reach = 2.0 * radius + 1.0
            drop |= distance_tree(outline.xy[fill]).query(sm.xy[cand], distance_upper_bound=reach)[0] <= reach
        state[cand[drop]] = -1
    return state, outline_state


def bridge_outline(sm: Samples, state: np.ndarray, interpolated: np.ndarray, outline: Samples,
                   outline_state: np.ndarray, reach: float, most: int, far: np.ndarray,
                   tolerance: float) -> np.ndarray:
    """`state` with each run of at most `most` interpolated contour samples hidden (0) or dropped (-1) between
    visible samples of its chain made visible where every sample of the run is within 2 px of where the surface in
    front of it ends (`beside_outline` with the visibility `tolerance`; not a contour passing behind a fold inside
    the outline) and within `reach` px of a visible silhouette sample on the outline (`outline_state` > 0 after
    `reconcile_outline`): the outline is there, and the contour, within a pixel or two of it, tested hidden behind
    the faces turned toward the viewer for a few pixels, or strayed from the silhouette by more than r there and
    was dropped for it. The silhouette does not fill
    such a gap: `suppress_filled` drops its samples within 2 r + 1 px of the contour's drawn ends and what is left
    is a speck, which left gaps of up to 9 px (the cow's back and ears)."""
    vis = outline_state > 0
    cand = np.flatnonzero((state != 1) & interpolated)
    cand = cand[beside_outline(sm.xy[cand], sm.depth[cand], far, tolerance)]
    near = np.zeros(len(state), bool)
    if vis.any() and len(cand):
        near[cand] = distance_tree(outline.xy[vis]).query(sm.xy[cand], distance_upper_bound=reach)[0] <= reach
    return close_flicker(state, sm.offsets, near, most)


def suppress_filled(drawn: np.ndarray, outline: Samples, outline_state: np.ndarray, radius: float) -> np.ndarray:
    """The silhouette's states with its visible samples within `radius` px of a drawn interpolated contour sample
    (`drawn`, (k, 2) pixels: samples of the visible strokes cut from them, so not the odd visible sample of a
    contour that runs just behind the outline, flickering between visible and hidden, and drawn nowhere) dropped
    (-1): that contour draws the outline there (`split_lines` passes 2 x its tolerance + 1 px: a contour kept
    within the tolerance of a fold of the silhouette can run that far from the fold's outer edge, which drew a
    second line beside it)."""
    out = outline_state.copy()
    vis = out > 0
    if len(drawn) and vis.any():
        near = distance_tree(drawn).query(outline.xy[vis], distance_upper_bound=radius)[0] <= radius
        out[np.flatnonzero(vis)[near]] = -1
    return out


def drop_fragments(sm: Samples, state: np.ndarray, idx: np.ndarray, off: np.ndarray, interpolated: np.ndarray,
                   short: float) -> tuple[np.ndarray, np.ndarray]:
    """Strokes (`idx`, `off` from `split`) without the interpolated contour strokes under `short` px whose chain
    goes on, before or after them, in a dropped sample (state -1: by `reconcile_outline`, or off the canvas): what
    is left of a stray between the samples dropped around it."""
    m = len(off) - 1
    if m == 0:
        return idx, off
    first, last = idx[off[:-1]], idx[off[1:] - 1]
    d = np.diff(sm.xy[idx], axis=0)
    step = np.r_[0.0, np.hypot(d[:, 0], d[:, 1])]
    step[off[:-1]] = 0.0
    length = np.add.reduceat(step, off[:-1])
    chain = np.searchsorted(sm.offsets, np.arange(len(sm.xy)), side="right") - 1
    n = len(sm.xy)

    def dropped(j: np.ndarray, i: np.ndarray) -> np.ndarray:
        ok = (j >= 0) & (j < n)
        jj = np.clip(j, 0, n - 1)
        return ok & (chain[jj] == chain[i]) & (state[jj] < 0)

    frag = interpolated[first] & (length < short) & (dropped(first - 1, first) | dropped(last + 1, last))
    if not frag.any():
        return idx, off
    keep = np.repeat(~frag, np.diff(off))
    return idx[keep], np.r_[0, np.cumsum(np.diff(off)[~frag])].astype(np.int64)


def _group_span(xy: np.ndarray, idx: np.ndarray, off: np.ndarray, member: np.ndarray, ends: np.ndarray,
               which: np.ndarray, touch: float) -> tuple[np.ndarray, np.ndarray]:
    """Per stroke: the diagonal of the bounding box of its group, the `member` strokes whose ends lie within
    `touch` px of each other, transitively (one polyline cut where it turned or its visibility changed); inf for
    the others; and the group label of every stroke."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    m = len(off) - 1
    out = np.full(m, np.inf)
    e = np.flatnonzero(member[which])
    if not len(e):
        return out, np.arange(m)
    pairs = cKDTree(ends[e]).query_pairs(touch, output_type="ndarray")
    pairs = pairs.reshape(-1, 2)
    a, b = which[e[pairs[:, 0]]], which[e[pairs[:, 1]]]
    _, label = connected_components(coo_matrix((np.ones(len(a)), (a, b)), shape=(m, m)), directed=False)
    pts_stroke = np.repeat(np.arange(m), np.diff(off))
    lab = label[pts_stroke]
    keep = member[pts_stroke]
    p = xy[idx][keep]
    lab = lab[keep]
    n = int(label.max()) + 1
    lo = np.full((n, 2), np.inf)
    hi = np.full((n, 2), -np.inf)
    np.minimum.at(lo, lab, p)
    np.maximum.at(hi, lab, p)
    span = np.hypot(*(hi - lo).T)
    out[member] = span[label[member]]
    return out, label


def join_ends(xy: np.ndarray, idx: np.ndarray, off: np.ndarray, role: np.ndarray, group: np.ndarray,
              dist: float, speck: float = 0.0, touch: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Strokes (vertex indices `idx` into `xy`, offsets `off`) with each stroke of role 2 (a filled piece of
    outline) joined end to end with strokes of role 1 (interpolated contours) of the same `group` (visibility)
    whose ends lie within `dist` px of its ends, nearest pairs first, each end once; role 0 strokes are left as
    they are. Joined strokes run through both in turn (one reversed where needed); a chain that closes on itself
    stays one stroke. Role 2 strokes whose ends touch (within `touch` px, transitively: one polyline cut where it
    turned or its visibility changed) form a group; a group whose bounding box spans under `speck` px is dropped
    unless its ends come within `dist` of two different role 1 ends (a short gap bridged): the polygonal
    silhouette folds back and forth in a few pixels by a cusp, where an interpolated contour ends. Returns the new
    (idx, off)."""
    from scipy.spatial import cKDTree

    m = len(off) - 1
    if m == 0 or not (role == 2).any():
        return idx, off
    first, last = idx[off[:-1]], idx[off[1:] - 1]
    ends = np.r_[xy[first], xy[last]]  # end e of stroke i: e = i (start) or i + m (end)
    which = np.r_[np.arange(m), np.arange(m)]
    fill_e = np.flatnonzero(role[which] == 2)
    line_e = np.flatnonzero(role[which] == 1)
    pairs = cKDTree(ends[line_e]).query_ball_point(ends[fill_e], dist) if len(line_e) else [[]] * len(fill_e)
    cand = [(float(np.hypot(*(ends[f] - ends[line_e[j]]))), int(f), int(line_e[j]))
            for f, js in zip(fill_e, pairs, strict=True) for j in js if group[which[f]] == group[which[line_e[j]]]]
    drop = np.zeros(m, bool)
    if speck > 0.0:
        span, label = _group_span(xy, idx, off, role == 2, ends, which, touch)
        # a group whose ends come near two different contour ends bridges a gap between them: kept, however short
        near = {(int(label[which[f]]), int(b)) for _, f, b in cand}
        ends_per_group = np.bincount(np.array([g for g, _ in near], np.int64), minlength=m) if near else np.zeros(m)
        drop = (role == 2) & (span < speck) & (ends_per_group[label] < 2)
    link = np.full(2 * m, -1, np.int64)
    for _, a, b in sorted(cand):
        other = link[(a + m) % (2 * m)]  # the fill's other end: not to the same stroke at both (there and back)
        if link[a] < 0 and link[b] < 0 and not drop[which[a]] and not (other >= 0 and which[other] == which[b]):
            link[a], link[b] = b, a
    seen = drop.copy()
    out_idx, counts = [], []

    def walk(start: int, enter: int) -> None:
        """Append the chain that starts at stroke `start`, entered at its end `enter` (0 start, 1 end)."""
        parts, i, e = [], start, enter
        while True:
            seen[i] = True
            verts = idx[off[i]:off[i + 1]]
            parts.append(verts if e == 0 else verts[::-1])
            nxt = link[i + m * (1 - e)]  # across the end we leave by
            if nxt < 0 or seen[which[nxt]]:
                break
            i, e = int(which[nxt]), int(nxt >= m)
        out_idx.append(np.concatenate(parts))
        counts.append(len(out_idx[-1]))

    for i in range(m):  # chains with a free end first, from that end
        if not seen[i] and (link[i] < 0 or link[i + m] < 0):
            walk(i, 0 if link[i] < 0 else 1)
    for i in range(m):  # what is left are closed chains
        if not seen[i]:
            walk(i, 0)
    if not out_idx:
        return np.zeros(0, np.int64), np.zeros(1, np.int64)
    return np.concatenate(out_idx).astype(np.int64), np.r_[0, np.cumsum(counts)].astype(np.int64)


def concat_samples(a: Samples, b: Samples) -> Samples:
    """Two sets of sampled chains as one (b's chains after a's)."""
    fields = ("p", "face", "bary", "kind", "front", "xy", "depth")
    return Samples(*(np.concatenate([getattr(a, f), getattr(b, f)]) for f in fields),
                   np.r_[a.offsets, b.offsets[1:] + a.offsets[-1]].astype(np.int64))


def to_strokes(parts: list[tuple[int, Samples, np.ndarray, np.ndarray, np.ndarray]], size: tuple[int, int],
               width: float, color: tuple[float, float, float]) -> Strokes:
    """`parts`: (object index, samples, state, vertex indices, stroke offsets) of each object."""
    xy, starts, attrs = [], [0], {k: [] for k in ("depth", "obj", "face", "bary", "pos", "kind", "visible")}
    base = 0
    for obj, sm, state, idx, off in parts:
        xy.append(sm.xy[idx])
        attrs["depth"].append(sm.depth[idx])
        attrs["obj"].append(np.full(len(idx), obj, np.int32))
        attrs["face"].append(sm.face[idx])
        attrs["bary"].append(sm.bary[idx])
        attrs["pos"].append(sm.p[idx])
        attrs["kind"].append(sm.kind[idx])
        attrs["visible"].append(state[idx] > 0)
        starts.extend((off[1:] + base).tolist())
        base += len(idx)
    if not xy:
        return Strokes.from_arrays(np.zeros((0, 2)), np.zeros(1, np.int64), size, width, color)
    return Strokes.from_arrays(np.concatenate(xy), np.asarray(starts, np.int64), size, width, color,
                               {k: np.concatenate(v) for k, v in attrs.items()})
