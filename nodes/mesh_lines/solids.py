"""Line samples inside another closed part: where parts are pushed into each other (a snowman's spheres, a fin in a
body, an eye in its socket), a contour or crease of one part runs on inside the other. Near the junction the two
surfaces are at nearly one depth, and on the outline one of the pixels around a sample is background, so the depth
test (`extract.depth_visibility`) keeps such a line visible for a few pixels past the junction. A point inside a
closed surface is hidden from every eye outside it, so a visible sample within a few pixels of an intersection line
on the screen that lies inside a closed part other than its own is hidden (`Junctions`).

A part is a set of faces joined through welded corners; it is closed where every welded edge of it has exactly
two faces. A point is inside a closed part where a ray from it crosses the part's surface an odd number of times
(libigl's AABB tree, built once per part of a posed mesh). Open parts (a floor, a mesh with holes) hide nothing
this way: the depth test alone decides there."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Parts:
    """Per face its part (`label`); per part whether it is closed, and its box (`lo`, `hi`); `trees`: the closed
    parts' libigl AABB trees and faces, made when first asked for (`tree`)."""

    label: np.ndarray
    closed: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    trees: dict[int, Any] = field(default_factory=dict)

    def tree(self, c: int, V: np.ndarray, F: np.ndarray) -> tuple[Any, np.ndarray, np.ndarray]:
        """(AABB tree, vertices, faces) of closed part `c` of the mesh (V, F): its own vertices alone."""
        got = self.trees.get(c)
        if got is None:
            import igl

            used, local = np.unique(F[self.label == c], return_inverse=True)
            verts = np.ascontiguousarray(V[used], np.float64)
            faces = np.ascontiguousarray(local.reshape(-1, 3), np.int64)
            tree = igl.AABB()
            tree.init(verts, faces)
            got = self.trees[c] = (tree, verts, faces)
        return got


@dataclass(frozen=True)
class PartTopology:
    """Per face its part (`label`); per part whether it is closed; the vertices of the faces in part order
    (`order`: a vertex is in one part, through its welded corner) and where each part starts in it (`starts`).
    The same for every pose of a mesh."""

    label: np.ndarray
    closed: np.ndarray
    order: np.ndarray
    starts: np.ndarray


def part_topology(F: np.ndarray, weld: np.ndarray, nw: int) -> PartTopology:
    """The parts of a mesh's faces (`weld`: welded vertex ids, `nw` of them)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = len(F)
    wF = weld[F].astype(np.int64)
    rows = np.repeat(np.arange(m), 3)
    graph = coo_matrix((np.ones(3 * m, np.int8), (rows, m + wF.ravel())), shape=(m + nw, m + nw))
    _, lab = connected_components(graph, directed=False)
    _, label = np.unique(lab[:m], return_inverse=True)
    label = label.reshape(-1)
    n = int(label.max()) + 1 if m else 0
    a, b = wF, np.roll(wF, -1, axis=1)
    key = (np.minimum(a, b) * nw + np.maximum(a, b)).ravel()
    _, inv, count = np.unique(key, return_inverse=True, return_counts=True)
    open_edge = count[inv.reshape(-1)] != 2
    closed = np.ones(n, bool)
    closed[np.unique(np.repeat(label, 3)[open_edge])] = False
    vlabel = np.full(int(F.max()) + 1 if m else 0, -1, np.int64)
    vlabel[F.ravel()] = np.repeat(label, 3)
    used = np.flatnonzero(vlabel >= 0)
    order = used[np.argsort(vlabel[used], kind="stable")]
    starts = np.searchsorted(vlabel[order], np.arange(n))
    return PartTopology(label, closed, order, starts)


def parts(V: np.ndarray, F: np.ndarray, weld: np.ndarray | PartTopology, nw: int = 0) -> Parts:
    """The parts of a posed mesh, from its `PartTopology` (or its welded vertex ids `weld`, `nw` of them)."""
    topo = weld if isinstance(weld, PartTopology) else part_topology(F, weld, nw)
    if not len(F):
        return Parts(topo.label, topo.closed, np.zeros((0, 3)), np.zeros((0, 3)))
    v = np.asarray(V, np.float64)[topo.order]  # the faces' vertices in part order
    return Parts(topo.label, topo.closed, np.minimum.reduceat(v, topo.starts), np.maximum.reduceat(v, topo.starts))


def inside(points: np.ndarray, own: np.ndarray, V: np.ndarray, F: np.ndarray, p: Parts) -> np.ndarray:
    """Whether each point (mesh space) lies inside a closed part of the mesh other than its `own` (-1: none of
    this mesh's parts)."""
    out = np.zeros(len(points), bool)
    if not len(points):
        return out
    for c in np.flatnonzero(p.closed):
        near = np.flatnonzero(~out & (own != c) & np.all((points >= p.lo[c]) & (points <= p.hi[c]), axis=1))
        if not len(near):
            continue
        tree, verts, faces = p.tree(int(c), V, F)
        q = np.ascontiguousarray(points[near], np.float64)
        hits = tree.intersect_ray(verts, faces, q, np.broadcast_to(RAY, q.shape).copy())
        at = 1e-9 * float(np.linalg.norm(p.hi[c] - p.lo[c])) / float(np.linalg.norm(RAY))  # a hit at the start
        out[near] = np.array([sum(1 for h in hit if h[1] > at) % 2 == 1 for hit in hits], bool)
    return out


RAY = np.array([0.5377, 0.8411, 0.0579]) * 1e6  # a direction along no axis and no simple diagonal, long enough to
# leave any part (intersect_ray's hits are along the whole segment origin -> origin + RAY)


@dataclass(frozen=True)
class Junctions:
    """The junction test of one object: `near` a k-d tree of the points of every intersection line in the frame
    on the screen (two objects' junction lies on the earlier one's faces: `crossings_between`), `test` the inside
    test of points on this object (object space, with their faces), `reach` pixels."""

    near: Any
    test: Callable[[np.ndarray, np.ndarray], np.ndarray]
    reach: float

    def hide(self, p: np.ndarray, face: np.ndarray, xy: np.ndarray, depth: np.ndarray, state: np.ndarray,
             kind: np.ndarray, skip: int, far: np.ndarray) -> np.ndarray:
        """`state` with the visible samples (object points `p` on faces `face`, at `xy` on the screen, `depth`)
        within `reach` of a junction and inside another closed part hidden (0). Only the samples the depth test
        keeps for its tolerance or for a background pixel beside them are tested (`far`: `extract.outline_far`):
        one with a pixel of its 2 x 2 no nearer than itself and not background sees a surface at or behind it,
        within a pixel of the junction at most if it is inside. Samples of kind `skip` (the intersection lines,
        on both surfaces) are left as they are."""
        from .extract import farthest_around

        cand = np.flatnonzero((state > 0) & (kind != skip))
        if len(cand):
            most = farthest_around(xy[cand], far)[2]
            cand = cand[(most < depth[cand]) | np.isinf(most)]
        if not len(cand):
            return state
        cand = cand[self.near.query(xy[cand], distance_upper_bound=self.reach)[0] <= self.reach]
        out = state.copy()
        out[cand[self.test(p[cand], face[cand])]] = 0
        return out
