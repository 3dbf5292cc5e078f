"""Procedural meshes, centred at the origin with +Y up, wound counter-clockwise seen from outside.

Closed primitives share vertices (no seams): `Mesh.render_arrays` splits normals at creases.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .meshes import Mesh

_PHI = (1.0 + math.sqrt(5.0)) / 2.0


def _quads(q: np.ndarray) -> np.ndarray:
    """(k, 4) counter-clockwise quads -> (2k, 3) triangles."""
    q = np.asarray(q, dtype=np.int64).reshape(-1, 4)
    return np.stack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], axis=1).reshape(-1, 3)


def _drop_repeated(faces: np.ndarray) -> np.ndarray:
    ok = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    return faces[ok]


def _compact(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop unreferenced vertices (keeping order) and renumber faces."""
    used = np.zeros(len(vertices), bool)
    used[faces.ravel()] = True
    new_id = np.cumsum(used) - 1
    return vertices[used], new_id[faces]


def plane(size: float = 1.0, subdiv: int = 1) -> Mesh:
    """A square in the XZ plane (y = 0) facing +Y, split into subdiv x subdiv cells."""
    n = max(int(subdiv), 1)
    t = np.linspace(-size / 2.0, size / 2.0, n + 1)
    x, z = np.meshgrid(t, t, indexing="ij")  # vertex (i, j) at x[i], z[j]
    v = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    v00 = (i * (n + 1) + j).ravel()
    v10, v01 = v00 + (n + 1), v00 + 1
    v11 = v10 + 1
    return Mesh("plane", v, _quads(np.stack([v00, v01, v11, v10], axis=1)))


def box(size: tuple[float, float, float] | float = (1.0, 1.0, 1.0)) -> Mesh:
    """An axis-aligned box: 8 shared corners, 12 triangles."""
    s = np.broadcast_to(np.asarray(size, dtype=np.float64), (3,))
    bits = np.arange(8)
    v = (np.stack([bits & 1, (bits >> 1) & 1, (bits >> 2) & 1], axis=1) - 0.5) * s
    q = [(0, 4, 6, 2), (1, 3, 7, 5), (0, 1, 5, 4), (2, 6, 7, 3), (0, 2, 3, 1), (4, 5, 7, 6)]
    return Mesh("box", v, _quads(np.array(q)))


def _icosahedron() -> tuple[np.ndarray, np.ndarray]:
    p = _PHI
    v = np.array([(-1, p, 0), (1, p, 0), (-1, -p, 0), (1, -p, 0), (0, -1, p), (0, 1, p), (0, -1, -p),
                  (0, 1, -p), (p, 0, -1), (p, 0, 1), (-p, 0, -1), (-p, 0, 1)], dtype=np.float64)
    f = np.array([(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
                  (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
                  (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)], dtype=np.int64)
    return v / np.linalg.norm(v, axis=1, keepdims=True), f


def _subdivide(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split every triangle into four at its edge midpoints (shared between neighbours)."""
    n = len(v)
    edges = np.stack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]], axis=1).reshape(-1, 2)
    key = np.minimum(edges[:, 0], edges[:, 1]) * n + np.maximum(edges[:, 0], edges[:, 1])
    uniq, first, inv = np.unique(key, return_index=True, return_inverse=True)
    mids = (v[edges[first, 0]] + v[edges[first, 1]]) / 2.0
    m = (n + inv).reshape(-1, 3)  # midpoint ids of edges (01, 12, 20) per face
    a, b, c = f[:, 0], f[:, 1], f[:, 2]
    ab, bc, ca = m[:, 0], m[:, 1], m[:, 2]
    nf = np.stack([np.stack([a, ab, ca], 1), np.stack([b, bc, ab], 1), np.stack([c, ca, bc], 1),
                   np.stack([ab, bc, ca], 1)], axis=1).reshape(-1, 3)
    return np.concatenate([v, mids]), nf


def sphere(radius: float = 1.0, subdiv: int = 3) -> Mesh:
    """An icosphere: 20 * 4**subdiv triangles of nearly equal size."""
    v, f = _icosahedron()
    for _ in range(max(int(subdiv), 0)):
        v, f = _subdivide(v, f)
        v /= np.linalg.norm(v, axis=1, keepdims=True)
    return Mesh("sphere", v * radius, f)


def ellipsoid(a: float = 1.0, b: float = 0.75, c: float = 0.5, subdiv: int = 3) -> Mesh:
    """An icosphere scaled to semi-axes a (X), b (Y), c (Z)."""
    s = sphere(1.0, subdiv)
    return Mesh("ellipsoid", s.vertices * np.array([a, b, c], dtype=np.float64), s.faces)


def _revolve(profile: np.ndarray, segments: int,
             closed_profile: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Surface of revolution about +Y of (r, y) profile points.

    The outside lies to the left of the profile's direction of travel in the (r, y) plane (a sphere's
    profile runs from the north pole down). Points with r == 0 become single pole vertices.
    """
    profile = np.asarray(profile, dtype=np.float64)
    k, n = len(profile), int(segments)
    phi = 2.0 * np.pi * np.arange(n) / n
    r, y = profile[:, 0:1], profile[:, 1:2]
    v = np.stack([r * np.cos(phi), np.broadcast_to(y, (k, n)), r * np.sin(phi)], axis=2).reshape(-1, 3)
    idx = np.arange(k * n).reshape(k, n)
    pole = profile[:, 0] == 0.0
    idx[pole] = idx[pole][:, :1]  # collapse pole rings to their first vertex
    rows = np.arange(k if closed_profile else k - 1)
    nxt = (rows + 1) % k
    i0 = np.arange(n)
    i1 = (i0 + 1) % n
    q = np.stack([idx[rows][:, i0], idx[rows][:, i1], idx[nxt][:, i1], idx[nxt][:, i0]], axis=2)
    f = _drop_repeated(_quads(q.reshape(-1, 4)))
    return _compact(v, f)


def revolve(profile: Any, segments: int = 32, name: str = "revolved") -> Mesh:
    """A body of revolution about +Y: (r, y) profile points, the outside to the left of the profile's direction
    of travel; points with r == 0 are poles."""
    return Mesh(name, *_revolve(np.asarray(profile, dtype=np.float64), segments))


def uv_sphere(radius: float = 1.0, n_u: int = 32, n_v: int = 16) -> Mesh:
    """A latitude/longitude sphere: n_u segments around +Y, n_v rings from pole to pole."""
    theta = np.pi * np.arange(int(n_v) + 1) / int(n_v)
    profile = np.stack([np.sin(theta), np.cos(theta)], axis=1) * radius
    profile[[0, -1], 0] = 0.0
    v, f = _revolve(profile, n_u)
    return Mesh("uv_sphere", v, f)


def cylinder(radius: float = 0.5, height: float = 1.0, segments: int = 32, caps: bool = True) -> Mesh:
    """A cylinder about +Y from y = -height/2 to +height/2; open at both ends without caps."""
    h = height / 2.0
    profile = [(0.0, h), (radius, h), (radius, -h), (0.0, -h)] if caps else [(radius, h), (radius, -h)]
    v, f = _revolve(np.array(profile), segments)
    return Mesh("cylinder", v, f)


def cone(radius: float = 0.5, height: float = 1.0, segments: int = 32) -> Mesh:
    """A closed cone about +Y, base at y = -height/2, apex at +height/2."""
    h = height / 2.0
    v, f = _revolve(np.array([(0.0, h), (radius, -h), (0.0, -h)]), segments)
    return Mesh("cone", v, f)


def torus(R: float = 1.0, r: float = 0.25, n_major: int = 48, n_minor: int = 24) -> Mesh:  # noqa: N803
    """A ring torus about +Y: major radius R in the XZ plane, tube radius r; a wrapping grid."""
    t = 2.0 * np.pi * np.arange(int(n_minor)) / int(n_minor)
    profile = np.stack([R + r * np.cos(t), -r * np.sin(t)], axis=1)  # clockwise: outside on the left
    v, f = _revolve(profile, n_major, closed_profile=True)
    return Mesh("torus", v, f)


def arch(span: float = 1.0, thickness: float = 0.15, depth: float = 0.3, segments: int = 16,
         spandrels: bool = False) -> Mesh:
    """A round (semicircular) arch of rectangular cross-section, for arcades.

    The intrados is a half circle of diameter `span` about the origin in the XY plane, springing at
    y = 0; the ring is `thickness` thick radially and `depth` deep along Z. With `spandrels` the outside
    is a rectangle (width span + 2*thickness, height span/2 + thickness) instead of a half circle, so
    arches of neighbouring bays tile into a wall. `segments` is rounded up to a multiple of 4.
    """
    n = max(4, int(math.ceil(segments / 4.0)) * 4)
    ri = span / 2.0
    ro = ri + thickness
    theta = np.pi * np.arange(n + 1) / n
    c, s = np.cos(theta), np.sin(theta)
    c[n // 2] = 0.0
    inner = np.stack([ri * c, ri * s], axis=1)
    if spandrels:
        outer = ro * np.stack([c, s], axis=1) / np.maximum(np.abs(c), s)[:, None]
    else:
        outer = np.stack([ro * c, ro * s], axis=1)
    inner[[0, -1], 1] = 0.0
    outer[[0, -1], 1] = 0.0
    d = depth / 2.0
    v = np.empty((n + 1, 4, 3))
    v[:, 0, :2], v[:, 0, 2] = inner, d  # inner front
    v[:, 1, :2], v[:, 1, 2] = inner, -d  # inner back
    v[:, 2, :2], v[:, 2, 2] = outer, d  # outer front
    v[:, 3, :2], v[:, 3, 2] = outer, -d  # outer back
    i = np.arange(n)
    IF, IB, OF, OB = 4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 3  # noqa: N806
    q = [
        np.stack([IF, OF, OF + 4, IF + 4], 1),  # front, +Z
        np.stack([IB, IB + 4, OB + 4, OB], 1),  # back, -Z
        np.stack([IF, IF + 4, IB + 4, IB], 1),  # intrados, facing the opening
        np.stack([OF, OB, OB + 4, OF + 4], 1),  # extrados
        np.array([[0, 1, 3, 2], [4 * n, 4 * n + 2, 4 * n + 3, 4 * n + 1]]),  # springer ends, -Y
    ]
    return Mesh("arch", v.reshape(-1, 3), _quads(np.concatenate(q)))


PRIMITIVES = {
    "plane": plane,
    "box": box,
    "sphere": sphere,
    "uv_sphere": uv_sphere,
    "cylinder": cylinder,
    "cone": cone,
    "torus": torus,
    "ellipsoid": ellipsoid,
    "arch": arch,
}
