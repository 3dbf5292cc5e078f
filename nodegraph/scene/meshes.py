"""Triangle meshes: loading (through libigl), welding, topology, normals and GPU-ready arrays.

All derived data is vectorised NumPy and cached on the (immutable) `Mesh` instance.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import sys
import tempfile
import threading
import warnings
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeshError
from ..fsio import check_input, clean, show_path
from .origin import FLOAT64_RATIO

SUPPORTED_EXTENSIONS = (".obj", ".ply", ".off", ".stl")
GLTF_EXTENSIONS = (".gltf", ".glb")  # read by nodegraph.scene.gltf

# Normal given to vertices that have no well-defined one (unreferenced, only degenerate faces).
FALLBACK_NORMAL = np.array([0.0, 0.0, 1.0])


class MeshWarning(UserWarning):
    """A mesh was usable but had to be repaired (degenerate or duplicate faces removed)."""


class MeshHealthWarning(MeshWarning):
    """What reading a mesh file found about its surface, one line each: faces turned to match their neighbours'
    winding, a noisy surface, holes in an otherwise closed one. Given when the file is parsed, not again when a
    later run reads the parsed mesh from the mesh store (nodegraph/scene/meshstore.py)."""


# --- surface health (thresholds of `Mesh.surface_noise` and `Mesh.holes`; see their docstrings) ---------------
NOISE_MIN_VERTICES = 1000
"""Fewer measured vertices than this: no noise verdict (a coarse mesh's triangles are large on screen, and its
interpolated normals do not change much from pixel to pixel)."""
NOISE_ROUGH_DEG = 5.0
"""`SurfaceNoise.rough_deg` (degrees) from which a surface can be noisy. Measured: clean icospheres 0.0-0.04,
fandisk 0.02, teapot 1.4, stanford-bunny 1.9, spot 2.3, ogre 2.6, cow 6.4 (coarse and curved: see NOISE_SHARE),
suzanne 15.4 (461 vertices measured); unit icospheres with every vertex moved 0.5% of the radius in a random
direction: 20k faces 2.9 (pencil's edges do not fire), 82k faces 6.3 (pencil's inner edges speckle the whole
sphere: 2% of its pixels, in every part of it); moved 1%: 20k faces 6.3."""
NOISE_SHARE = 0.55
"""...and `rough_deg` at least this share of `step_deg`: the change is not smooth curvature. Random
displacement: 0.72-0.92; the shared test meshes 0.0-0.37 (cow 0.37), suzanne 0.47."""
HOLE_WARN_SHARE = 0.05
"""Holes are reported on a mostly closed surface only: their loops can show at most this share of its area (the
`hole_share` bound: ogre.obj 0.0085, stanford-bunny 0.037; open meshes: teapot 0.24, a plane 1.3)..."""
HOLE_WARN_EDGES = 0.01
"""...and at most this share of the welded edges lie on them (ogre.obj 0.1%, stanford-bunny 0.2%; suzanne 2.9%:
its eye sockets, 0.052 of its area, are filled by the eyes, separate parts; teapot 1.7%)."""


@dataclass(frozen=True)
class MeshTopology:
    n_vertices: int
    n_faces: int
    n_components: int  # connected components of faces sharing welded vertices
    n_welded: int  # vertices merged into an earlier coincident one
    n_boundary_edges: int  # welded edges used by exactly one face
    n_nonmanifold_edges: int  # welded edges used by more than two faces
    n_unreferenced: int  # vertices used by no face
    n_degenerate: int  # faces with a repeated index or (numerically) zero area

    @property
    def closed(self) -> bool:
        return self.n_boundary_edges == 0 and self.n_nonmanifold_edges == 0


@dataclass(frozen=True)
class SurfaceNoise:
    """`Mesh.surface_noise`: how the drawn vertex normals vary between neighbouring vertices."""

    step_deg: float  # median angle between the normals of the two ends of a smooth edge
    rough_deg: float  # median angle between a vertex's normal and the mean of its neighbours' normals
    n_measured: int  # vertices away from boundaries, creases and non-manifold edges (where rough_deg is measured)

    @property
    def noisy(self) -> bool:
        """Enough vertices measured, and the normals change from vertex to vertex by more than NOISE_ROUGH_DEG
        beyond what smooth curvature explains, that change making at least NOISE_SHARE of the whole: in a
        drawing whose triangles are a few pixels wide, edge_detect's normal differences fire all over it."""
        return (self.n_measured >= NOISE_MIN_VERTICES and self.rough_deg >= NOISE_ROUGH_DEG
                and self.rough_deg >= NOISE_SHARE * self.step_deg)


@dataclass(frozen=True, eq=False)
class RenderArrays:
    """Vertex streams for drawing: vertices split where the surface has a crease."""

    positions: np.ndarray  # (k, 3) float32
    normals: np.ndarray  # (k, 3) float32, split at creases
    smooth_normals: np.ndarray  # (k, 3) float32, welded vertex normals (crack-free enlargement)
    indices: np.ndarray  # (m, 3) uint32
    component: np.ndarray  # (k,) float32, connected component id after welding
    source_vertex: np.ndarray  # (k,) int64, the original vertex each render vertex came from

    @property
    def n_vertices(self) -> int:
        return int(self.positions.shape[0])


# glTF sampler wrap modes (GL enums)
WRAP_REPEAT, WRAP_CLAMP, WRAP_MIRROR = 10497, 33071, 33648


@dataclass(frozen=True, eq=False)
class BaseTexture:
    """A material's base colour texture as drawn: the decoded image and how it is sampled."""

    pixels: np.ndarray  # (h, w, 4) uint8, RGB sRGB-encoded (as stored), alpha linear; row 0 is the image's top
    digest: str  # sha256 of the encoded image bytes: what identifies it in caches
    texcoord: int = 0  # TEXCOORD_n it is sampled through (KHR_texture_transform's texCoord wins)
    transform: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)  # uv' = M (u, v, 1): the first 2 rows of M
    wrap: tuple[int, int] = (WRAP_REPEAT, WRAP_REPEAT)  # wrapS, wrapT
    mag_filter: int = 9729  # LINEAR
    min_filter: int = 9987  # LINEAR_MIPMAP_LINEAR


@dataclass(frozen=True, eq=False)
class Material:
    """A glTF material as `rasterize` draws it: colour = baseColorFactor x vertex colour x base texture (linear),
    written as display values; alpha MASK discards fragments whose alpha is below `alpha_cutoff`."""

    factor: tuple[float, float, float, float]  # baseColorFactor, linear RGBA
    flat: tuple[float, float, float]  # the one display colour standing for it (the object's `color`)
    texture: BaseTexture | None = None
    alpha_mode: str = "OPAQUE"  # OPAQUE, MASK or BLEND (BLEND is drawn opaque)
    alpha_cutoff: float = 0.5


@dataclass(frozen=True, eq=False)
class Surface:
    """What a mesh's surface carries besides geometry (glTF primitives): texture coordinates, vertex colours and
    the material, vertex for vertex with `Mesh.vertices`."""

    material: Material
    uvs: tuple[np.ndarray, ...] = ()  # TEXCOORD_0, TEXCOORD_1, ...: (n, 2) float32 each
    colors: np.ndarray | None = None  # COLOR_0 as linear RGBA, (n, 4) float32

    def digest(self) -> str:
        m, t = self.material, self.material.texture
        h = hashlib.sha256(repr((m.factor, m.alpha_mode, m.alpha_cutoff)).encode())
        if t is not None:
            h.update(repr((t.digest, t.texcoord, t.transform, t.wrap, t.mag_filter, t.min_filter)).encode())
        for a in (*self.uvs, self.colors):
            if a is not None:
                h.update(f"{a.shape}".encode())
                h.update(np.ascontiguousarray(a, dtype=np.float32).tobytes())
        return h.hexdigest()


@dataclass(eq=False)
class Mesh:
    """An indexed triangle mesh. Arrays are made read-only: derived data is cached on the instance."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    source: str | None = None
    # a posed (skinned or morphed) mesh: the same mesh in its rest pose (same faces, vertex for vertex), what
    # object-space noise and curvature read so they stay on the deforming surface (docs/animation.md)
    rest: Mesh | None = field(default=None, repr=False, compare=False)
    # a skinned mesh: (n, 3, 3) the linear part of each vertex's blended skin matrix (rest -> posed), which
    # carries rest-pose tangent directions (curvature) with the skin
    skin_linear: np.ndarray | None = field(default=None, repr=False, compare=False)
    # a glTF primitive's texture coordinates, vertex colours and material (what `rasterize` colours it with)
    surface: Surface | None = field(default=None, repr=False, compare=False)
    _cache: dict[Any, Any] = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self.vertices = _readonly_copy(self.vertices, np.float64)
        self.faces = _readonly_copy(self.faces, np.int32)

    def __repr__(self) -> str:
        return f"Mesh({self.name!r}, {len(self.vertices)} vertices, {len(self.faces)} faces)"

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.faces.shape[0])

    def _cached(self, key: Any, make: Any) -> Any:
        """Compute once; arrays in the result are made read-only so callers cannot corrupt the cache."""
        try:
            return self._cache[key]
        except KeyError:
            value = make()
            for a in value if isinstance(value, tuple) else (value,):
                if isinstance(a, np.ndarray):
                    a.flags.writeable = False
            self._cache[key] = value
            return value

    # --- identity -------------------------------------------------------------------------------

    def content_hash(self) -> str:
        def make() -> str:
            h = hashlib.sha256()
            h.update(f"mesh:v{self.vertices.shape}:f{self.faces.shape}:".encode())
            h.update(self.vertices.tobytes())
            h.update(self.faces.tobytes())
            if self.surface is not None:  # meshes without one keep their hashes
                h.update(f"surface:{self.surface.digest()}".encode())
            return h.hexdigest()

        return self._cached("hash", make)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        def make() -> tuple[np.ndarray, np.ndarray]:
            if len(self.vertices) == 0:
                return np.zeros(3), np.zeros(3)
            return self.vertices.min(axis=0), self.vertices.max(axis=0)

        lo, hi = self._cached("bounds", make)
        return lo.copy(), hi.copy()

    def diagonal(self) -> float:
        lo, hi = self.bounds()
        return float(np.linalg.norm(hi - lo))

    # --- welding ----------------------------------------------------------------------------------

    def topology_mesh(self) -> Mesh:
        """The mesh whose topology this one has: a posed mesh's rest pose (the same faces, vertex for vertex), so
        welding, components, edges, holes and the smoothing groups of its render vertices are prepared once and
        do not change from frame to frame (nodegraph/scene/posing.py); any other mesh itself."""
        r = self.rest
        return r if r is not None and r.faces is self.faces else self

    def weld(self, tol_rel: float = 1e-6) -> tuple[np.ndarray, int]:
        """(welded_index (n,), n_unique): vertices in the same cell of size tol_rel * bbox diagonal merge.

        Welded ids are numbered in order of first appearance, so a mesh without duplicates maps to itself.
        """
        if (shape := self.topology_mesh()) is not self:
            return shape.weld(tol_rel)
        return self._cached(("weld", float(tol_rel)), lambda: _weld(self.vertices, tol_rel * self.diagonal()))

    def welded_faces(self) -> np.ndarray:
        if (shape := self.topology_mesh()) is not self:
            return shape.welded_faces()
        return self._cached("wfaces", lambda: self.weld()[0][self.faces])

    # --- per-face geometry ------------------------------------------------------------------------

    def _face_geometry(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(unit face normals (m,3) zero where degenerate, corner angles (m,3), degenerate mask (m,))."""

        def make() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            p = self.vertices[self.faces]  # (m, 3, 3)
            e = np.roll(p, -1, axis=1) - p  # e[:, i] = p[i+1] - p[i]
            cross = _cross(e[:, 0], -e[:, 2])  # (p1 - p0) x (p2 - p0)
            area2 = np.sqrt(np.einsum("ij,ij->i", cross, cross))
            diag = self.diagonal()
            wf = self.welded_faces()
            degenerate = (
                (area2 <= 1e-14 * diag * diag)
                | (wf[:, 0] == wf[:, 1]) | (wf[:, 1] == wf[:, 2]) | (wf[:, 0] == wf[:, 2])
            )
            with np.errstate(invalid="ignore", divide="ignore"):
                normals = np.where(degenerate[:, None], 0.0, cross / area2[:, None])
            # corner angle at i between (p[i+1] - p[i]) and (p[i-1] - p[i]); |sin| part is the same
            # for the three corners: twice the area
            cos = -np.einsum("mij,mij->mi", e, np.roll(e, 1, axis=1))
            angles = np.arctan2(np.broadcast_to(area2[:, None], cos.shape), cos)
            angles[degenerate] = 0.0
            return normals, angles, degenerate

        return self._cached("facegeo", make)

    def face_normals(self) -> np.ndarray:
        return self._face_geometry()[0]

    def face_centroids(self) -> np.ndarray:
        """(m, 3) the mean of each face's corners (cached: mesh_lines reads it every frame)."""
        return self._cached("centroids", lambda: self.vertices[self.faces].mean(axis=1))

    def signed_volume(self) -> float:
        """Volume enclosed by the (closed, consistently wound) surface; positive for outward CCW winding.
        Cached: pencil_shade asks every frame, and on ogre (124k faces) it took 16 ms a frame. Summed about the
        bounding-box centre (the same volume for a closed surface): about the origin, a mesh far from it sums
        terms of the order of its distance cubed, and a torus 0.26 across at 1e6 got a volume of the wrong sign
        (pencil_shade then culled its front faces)."""

        def make() -> float:
            lo, hi = self.bounds()
            p = self.vertices[self.faces] - (lo + hi) / 2.0
            return float(np.einsum("ij,ij->i", p[:, 0], _cross(p[:, 1], p[:, 2])).sum() / 6.0)

        return self._cached("volume", make)

    def area(self) -> float:
        def make() -> float:
            p = self.vertices[self.faces]
            return float(np.linalg.norm(_cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum() / 2.0)

        return self._cached("area", make)

    # --- normals ----------------------------------------------------------------------------------

    def vertex_normals(self) -> np.ndarray:
        """(n, 3) float32 angle-weighted normals, shared by all vertices at one welded position."""

        def make() -> np.ndarray:
            wid, nu = self.weld()
            normals, angles, _ = self._face_geometry()
            wf = self.welded_faces().ravel()
            contrib = (normals[:, None, :] * angles[:, :, None]).reshape(-1, 3)
            acc = np.stack([np.bincount(wf, contrib[:, k], minlength=nu) for k in range(3)], axis=1)
            out = _normalize_or(acc, FALLBACK_NORMAL)
            return out[wid].astype(np.float32)

        n = self._cached("vnormals", make)
        return n

    # --- topology ---------------------------------------------------------------------------------

    def face_components(self) -> np.ndarray:
        """(m,) component id per face, numbered in order of first face. Faces are adjacent when they
        share a welded edge used by exactly two faces (so parts that merely touch, like Suzanne's eyes,
        or meet at a non-manifold edge stay apart)."""
        if (shape := self.topology_mesh()) is not self:
            return shape.face_components()

        def make() -> np.ndarray:
            m = self.n_faces
            h1, h2 = self._manifold_pairs()
            root = connected_labels(m, h1 // 3, h2 // 3)
            is_root = root == np.arange(m)
            return ((np.cumsum(is_root) - 1)[root]).astype(np.int64)

        return self._cached("fcomp", make)

    def _edge_stats(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Half-edges of non-degenerate faces sorted by undirected welded edge.

        Returns (order of half-edge ids 3*f+i sorted by edge key, sorted keys, count of the key's edge per
        sorted half-edge)."""
        if (shape := self.topology_mesh()) is not self:
            return shape._edge_stats()

        def make() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            _, nu = self.weld()
            wf = self.welded_faces().astype(np.int64)
            _, _, degenerate = self._face_geometry()
            u = wf.ravel()
            v = np.roll(wf, -1, axis=1).ravel()
            key = np.minimum(u, v) * nu + np.maximum(u, v)
            valid = np.repeat(~degenerate, 3)
            ids = np.flatnonzero(valid)
            order = ids[np.argsort(key[ids], kind="stable")]
            skey = key[order]
            if len(skey) == 0:
                return order, skey, np.zeros(0, np.int64)
            starts = np.flatnonzero(np.r_[True, skey[1:] != skey[:-1]])
            counts = np.diff(np.r_[starts, len(skey)])
            return order, skey, np.repeat(counts, counts)

        return self._cached("edges", make)

    def _manifold_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """The two half-edge ids (3*f+i) of every welded edge used by exactly two faces."""
        if (shape := self.topology_mesh()) is not self:
            return shape._manifold_pairs()

        def make() -> tuple[np.ndarray, np.ndarray]:
            order, skey, count = self._edge_stats()
            if len(skey) < 2:
                return order[:0], order[:0]
            first = np.flatnonzero((count[:-1] == 2) & (skey[:-1] == skey[1:]))
            return order[first], order[first + 1]

        return self._cached("pairs", make)

    def hole_share(self) -> float:
        """An upper bound on the share of the surface area that holes can show: sum over boundary loops
        of L^2 / (4 pi) (the largest area a loop of length L encloses), over the surface area. 0 for a
        closed mesh. (Measured: ogre.obj 0.0085, stanford-bunny 0.037, teapot 0.24.)"""
        if (shape := self.topology_mesh()) is not self:
            return shape.hole_share()

        def make() -> float:
            order, skey, count = self._edge_stats()
            boundary = order[count == 1]
            area = self.area()
            if len(boundary) == 0 or area <= 0:
                return 0.0
            import scipy.sparse as sp
            from scipy.sparse.csgraph import connected_components

            wf = self.welded_faces().astype(np.int64)
            f, i = boundary // 3, boundary % 3
            a, b = wf[f, i], wf[f, (i + 1) % 3]
            _, nu = self.weld()
            rep = np.zeros((nu, 3))
            rep[self.weld()[0]] = self.vertices
            length = np.linalg.norm(rep[a] - rep[b], axis=1)
            graph = sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(nu, nu))
            _, label = connected_components(graph, directed=False)
            loops = np.bincount(label[a], weights=length)
            return float((loops**2).sum() / (4.0 * np.pi * area))

        from . import meshstore

        # kept on disk (nodegraph/scene/meshstore.py): importing scipy.sparse alone is 0.28 s
        return self._cached("hole_share", lambda: float(meshstore.memo(self, "holes", make, (__file__,), always=True)))

    def topology(self) -> MeshTopology:
        if (shape := self.topology_mesh()) is not self:
            return shape.topology()
        def make() -> MeshTopology:
            n, m = self.n_vertices, self.n_faces
            _, nu = self.weld()
            _, _, degenerate = self._face_geometry()
            _, skey, count = self._edge_stats()
            referenced = np.zeros(n, bool)
            referenced[self.faces.ravel()] = True
            comp = self.face_components()
            edge_first = np.r_[True, skey[1:] != skey[:-1]] if len(skey) else np.zeros(0, bool)
            edge_counts = count[edge_first]
            return MeshTopology(
                n_vertices=n,
                n_faces=m,
                n_components=int(comp.max() + 1) if len(comp) else 0,
                n_welded=n - nu,
                n_boundary_edges=int((edge_counts == 1).sum()),
                n_nonmanifold_edges=int((edge_counts > 2).sum()),
                n_unreferenced=int((~referenced).sum()),
                n_degenerate=int(degenerate.sum()),
            )

        return self._cached("topology", make)

    # --- surface health --------------------------------------------------------------------------

    def winding_conflicts(self) -> int:
        """Welded edges shared by exactly two faces that run along it the same way: the two faces are wound
        in opposite senses (a closed mesh draws one of them culled: a hole)."""
        if (shape := self.topology_mesh()) is not self:
            return shape.winding_conflicts()

        def make() -> int:
            h1, h2 = self._manifold_pairs()
            wf = self.welded_faces()
            f1, i1 = np.divmod(h1, 3)
            f2, i2 = np.divmod(h2, 3)
            return int((wf[f1, i1] == wf[f2, i2]).sum())  # the same start: the same direction

        return self._cached("conflicts", make)

    def surface_noise(self) -> SurfaceNoise:
        """How much the vertex normals change from vertex to vertex, and how much of that is not smooth
        curvature. Over welded edges shared by exactly two faces: `step_deg`, the median angle between the
        normals (`vertex_normals`) at the two ends; at every vertex away from boundary and non-manifold edges,
        the angle between its normal and the normalised sum of its neighbours' normals, `rough_deg` its median.
        Smooth curvature turns the normal evenly, so the neighbours' mean lies near the vertex's own normal (a
        clean sphere: below 0.2 degrees at any resolution; along a crease the two sides balance too: fandisk
        0.02); random displacement turns each normal its own way (about 0.7 of `step_deg`). Creases are not left
        out: displacement of a few per cent makes most edges creases. See `SurfaceNoise.noisy`."""

        def make() -> SurfaceNoise:
            wid, nu = self.weld()
            wf = self.welded_faces().astype(np.int64)
            h1, _ = self._manifold_pairs()
            f1, i1 = np.divmod(h1, 3)
            a, b = wf[f1, i1], wf[f1, (i1 + 1) % 3]
            order, _, count = self._edge_stats()
            rough_edges = order[count != 2]  # boundary and non-manifold: their vertices are not measured
            skip = np.zeros(nu, bool)
            skip[wf[rough_edges // 3, rough_edges % 3]] = True
            skip[wf[rough_edges // 3, (rough_edges % 3 + 1) % 3]] = True
            vn = np.zeros((nu, 3))
            vn[wid] = self.vertex_normals()
            step = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", vn[a], vn[b]), -1.0, 1.0)))
            ends = np.concatenate([a, b])
            others = vn[np.concatenate([b, a])]
            acc = np.stack([np.bincount(ends, others[:, k], minlength=nu) for k in range(3)], axis=1)
            measured = ~skip & (np.bincount(ends, minlength=nu) > 0)
            mean = _normalize_or(acc[measured], FALLBACK_NORMAL)
            rough = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", mean, vn[measured]), -1.0, 1.0)))
            return SurfaceNoise(step_deg=float(np.median(step)) if len(step) else 0.0,
                                rough_deg=float(np.median(rough)) if len(rough) else 0.0,
                                n_measured=int(measured.sum()))

        return self._cached("noise", make)

    def holes(self) -> tuple[int, int, float]:
        """(boundary loops, boundary edges, hole share): loops of welded edges used by one face, and the same
        bound on the share of the surface they can show as `hole_share` (sum of L^2 / (4 pi) over the loops,
        over the area), found without scipy (the loops are connected components of the boundary edges)."""
        if (shape := self.topology_mesh()) is not self:
            return shape.holes()

        def make() -> tuple[int, int, float]:
            order, _, count = self._edge_stats()
            boundary = order[count == 1]
            area = self.area()
            if len(boundary) == 0 or area <= 0:
                return 0, int(len(boundary)), 0.0
            wid, nu = self.weld()
            wf = self.welded_faces().astype(np.int64)
            f, i = boundary // 3, boundary % 3
            a, b = wf[f, i], wf[f, (i + 1) % 3]
            rep = np.zeros((nu, 3))
            rep[wid] = self.vertices
            length = np.linalg.norm(rep[a] - rep[b], axis=1)
            label = connected_labels(nu, a, b)[a]
            loops, loop_of = np.unique(label, return_inverse=True)
            per_loop = np.bincount(loop_of, weights=length)
            return int(len(loops)), int(len(boundary)), float((per_loop**2).sum() / (4.0 * np.pi * area))

        return self._cached("holes", make)

    def vertex_components(self) -> np.ndarray:
        """(n,) component id per original vertex: that of the first face using it (-1 if unreferenced)."""
        if (shape := self.topology_mesh()) is not self:
            return shape.vertex_components()

        def make() -> np.ndarray:
            comp = np.full(self.n_vertices, -1, np.int64)
            fc = np.repeat(self.face_components(), 3)[::-1]
            comp[self.faces.ravel()[::-1]] = fc  # reversed: the first face wins
            return comp

        return self._cached("vcomp", make)

    # --- render arrays ----------------------------------------------------------------------------

    def render_arrays(self, crease_angle_deg: float = 40.0) -> RenderArrays:
        """Vertex streams with normals split where faces meet at a dihedral angle > crease_angle_deg.

        Around each welded vertex, face corners joined across an edge shared by exactly two faces whose
        normals differ by at most the crease angle form one smoothing group, i.e. one render vertex.
        Boundary, non-manifold and sharp edges separate groups; a crease that ends inside a smooth
        region does not split the vertex where it ends.
        """
        from . import meshstore

        batch = self._cache.get("posing.batch")
        if batch is not None:  # a posed part: made with every part posed with it (nodegraph/scene/posing.py)
            batch[0].render_arrays(float(crease_angle_deg))
        names = tuple(f.name for f in fields(RenderArrays))

        def compute() -> dict[str, np.ndarray]:
            ra = self._render_arrays(crease_angle_deg)
            return {n: getattr(ra, n) for n in names}

        def make() -> RenderArrays:  # kept on disk for a large mesh (nodegraph/scene/meshstore.py)
            return RenderArrays(**meshstore.memo_arrays(self, f"render{float(crease_angle_deg)!r}", compute,
                                                        (__file__,), names))

        return self._cached(("render", float(crease_angle_deg)), make)

    def _render_arrays(self, crease_angle_deg: float) -> RenderArrays:
        m = self.n_faces
        normals, angles, _ = self._face_geometry()
        wf = self.welded_faces()
        h1, h2 = self._manifold_pairs()
        f1, i1 = np.divmod(h1, 3)
        f2, i2 = np.divmod(h2, 3)
        cos_crease = np.cos(np.radians(crease_angle_deg))
        smooth = np.einsum("ij,ij->i", normals[f1], normals[f2]) >= cos_crease - 1e-12
        f1, i1, f2, i2 = f1[smooth], i1[smooth], f2[smooth], i2[smooth]
        j1 = (i1 + 1) % 3
        j2 = (i2 + 1) % 3
        u = wf[f1, i1]
        # the corner of face 2 at the same welded vertex as corner (f1, i1), and the other one
        same = wf[f2, i2] == u
        c2_u = np.where(same, 3 * f2 + i2, 3 * f2 + j2)
        c2_v = np.where(same, 3 * f2 + j2, 3 * f2 + i2)
        a = np.concatenate([3 * f1 + i1, 3 * f1 + j1])
        b = np.concatenate([c2_u, c2_v])
        group = connected_labels(3 * m, a, b)
        is_root = group == np.arange(3 * m)
        gid = (np.cumsum(is_root) - 1)[group]
        k = int(is_root.sum())

        corner_vertex = self.faces.ravel().astype(np.int64)
        rep = corner_vertex[is_root]  # one original vertex per group (its lowest corner)
        contrib = (normals[:, None, :] * angles[:, :, None]).reshape(-1, 3)
        acc = np.stack([np.bincount(gid, contrib[:, c], minlength=k) for c in range(3)], axis=1)
        smooth_normals = self.vertex_normals()[rep]
        split = _normalize_or(acc, None)
        bad = ~np.isfinite(split).all(axis=1)
        split[bad] = smooth_normals[bad]
        comp = np.repeat(self.face_components(), 3)[is_root]

        arrays = {
            "positions": self.vertices[rep].astype(np.float32),
            "normals": split.astype(np.float32),
            "smooth_normals": np.array(smooth_normals, dtype=np.float32),
            "indices": gid.reshape(m, 3).astype(np.uint32),
            "component": comp.astype(np.float32),
            "source_vertex": rep,
        }
        for a in arrays.values():
            a.flags.writeable = False
        return RenderArrays(**arrays)

    # --- derived meshes ---------------------------------------------------------------------------

    def without_rest(self) -> Mesh:
        """The same posed mesh without its rest pose (same content hash)."""
        out = Mesh(self.name, self.vertices, self.faces, self.source)
        if "hash" in self._cache:
            out._cache["hash"] = self._cache["hash"]
        return out

    def transformed(self, matrix: np.ndarray, name: str | None = None) -> Mesh:
        """A copy with vertices mapped by a 4x4 affine matrix (winding flipped if it mirrors)."""
        mat = np.asarray(matrix, dtype=np.float64)
        v = self.vertices @ mat[:3, :3].T + mat[:3, 3]
        f = self.faces if np.linalg.det(mat[:3, :3]) > 0 else self.faces[:, ::-1]
        return Mesh(name or self.name, v, f, self.source)


def orient_consistently(mesh: Mesh) -> tuple[Mesh, int]:
    """(the mesh with every face wound like its neighbours, how many faces were turned). Within each patch of
    faces joined by manifold welded edges (libigl's `bfs_orient` on the welded faces), the winding that covers
    more of the patch's area is kept and the other faces are reversed; which way a whole patch faces is left to
    the file (and to `signed_volume`). The mesh itself (same object) when no edge is in conflict."""
    conflicts = mesh.winding_conflicts()
    if conflicts == 0:
        return mesh, 0
    import igl

    wf = np.ascontiguousarray(mesh.welded_faces(), dtype=np.int64)
    ff, patch = igl.bfs_orient(wf)
    ff, patch = np.asarray(ff, dtype=np.int64), np.asarray(patch, dtype=np.int64).ravel()
    kept = (ff == wf).all(axis=1) | (ff == np.roll(wf, 1, axis=1)).all(axis=1) | \
        (ff == np.roll(wf, -1, axis=1)).all(axis=1)  # the same cyclic order: not turned
    turned = ~kept
    p = mesh.vertices[mesh.faces]
    area = np.linalg.norm(_cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    k = int(patch.max()) + 1 if len(patch) else 0
    majority = np.bincount(patch, area * turned, k) > 0.5 * np.bincount(patch, area, k)
    turned ^= majority[patch]  # keep what most of the patch does
    if not turned.any():
        return mesh, 0
    faces = np.array(mesh.faces)
    faces[turned] = faces[turned][:, ::-1]
    out = Mesh(mesh.name, mesh.vertices, faces, mesh.source)
    if out.winding_conflicts() >= conflicts:  # a non-orientable patch (a Moebius strip): nothing gained
        return mesh, 0
    return out, int(turned.sum())


def health_notes(mesh: Mesh, turned: int = 0) -> list[str]:
    """One line for each thing wrong with the surface of a mesh read from a file (`MeshHealthWarning`): faces
    `turned` by `orient_consistently`, noise (`Mesh.surface_noise`), holes in a mostly closed surface
    (`Mesh.holes`)."""
    where = f"mesh '{mesh.name}' ({mesh.source})" if mesh.source else f"mesh '{mesh.name}'"
    notes: list[str] = []
    if turned:
        notes.append(f"{where}: {_plural(turned, 'face', 'faces')} flipped to match their neighbours (they "
                     "were wound the other way round, so culling would have drawn them as holes)")
    noise = mesh.surface_noise()
    if noise.noisy:
        notes.append(f"{where}: noisy surface: vertex normals turn {noise.rough_deg:.1f} degrees from their "
                     f"neighbours' mean (median; {noise.step_deg:.1f} between neighbours), more than smooth curvature "
                     f"does; edges will fire everywhere; smooth it first or raise edges.normal_threshold")
    loops, boundary, share = mesh.holes()
    if loops:
        _, _, count = mesh._edge_stats()
        n_edges = float((1.0 / count).sum()) if len(count) else 0.0
        if share <= HOLE_WARN_SHARE and boundary <= HOLE_WARN_EDGES * n_edges:
            notes.append(f"{where}: {_plural(loops, 'hole', 'holes')} in an otherwise closed surface ({boundary} "
                         f"boundary edges, at most {share:.1%} of its area): the background or the inside shows "
                         "through")
    return notes


def merge_meshes(meshes: list[Mesh], name: str) -> Mesh:
    """One mesh holding all of `meshes` (vertex ids offset; nothing welded)."""
    if not meshes:
        return Mesh(name, np.zeros((0, 3)), np.zeros((0, 3), np.int32))
    offsets = np.cumsum([0] + [m.n_vertices for m in meshes[:-1]])
    v = np.concatenate([m.vertices for m in meshes])
    f = np.concatenate([m.faces + o for m, o in zip(meshes, offsets, strict=True)])
    return Mesh(name, v, f)


# --- helpers ------------------------------------------------------------------------------------


def _readonly_copy(a: Any, dtype: Any) -> np.ndarray:
    """A read-only (n, 3) array; read-only input of the right type is shared, anything else copied."""
    if isinstance(a, np.ndarray) and a.dtype == dtype and not a.flags.writeable and a.flags.c_contiguous \
            and a.ndim == 2 and a.shape[1:] == (3,):
        return a
    out = np.array(a, dtype=dtype, copy=True).reshape(-1, 3)
    out.flags.writeable = False
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (k, 3) arrays (faster than np.cross for many short rows)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def _normalize_or(vectors: np.ndarray, fallback: np.ndarray | None) -> np.ndarray:
    """Rows scaled to unit length; zero or non-finite rows become `fallback` (NaN when None)."""
    length = np.linalg.norm(vectors, axis=1)
    ok = np.isfinite(length) & (length > 1e-300)
    out = np.empty_like(vectors, dtype=np.float64)
    out[ok] = vectors[ok] / length[ok, None]
    out[~ok] = np.nan if fallback is None else fallback
    return out


def _weld(vertices: np.ndarray, tol: float) -> tuple[np.ndarray, int]:
    n = len(vertices)
    if n == 0:
        return np.zeros(0, np.int64), 0
    if tol > 0:
        cells = np.round((vertices - vertices.min(axis=0)) / tol).astype(np.int64)
    else:  # exact: compare the bits (+ 0.0 turns -0.0 into 0.0)
        cells = np.ascontiguousarray(vertices + 0.0).view(np.int64)
    order = np.lexsort((cells[:, 2], cells[:, 1], cells[:, 0]))
    sc = cells[order]
    new = np.r_[True, (sc[1:] != sc[:-1]).any(axis=1)]
    run = np.cumsum(new) - 1  # run id per sorted vertex
    # representative of each run: its lowest vertex index; number runs by that representative
    run_min = np.full(run[-1] + 1, n, np.int64)
    np.minimum.at(run_min, run, order)
    rank = np.empty_like(run_min)
    rank[np.argsort(run_min)] = np.arange(len(run_min))
    welded = np.empty(n, np.int64)
    welded[order] = rank[run]
    return welded, int(len(run_min))


def connected_labels(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Connected components of n nodes joined by edges (a[i], b[i]): each node's label is the lowest
    node id of its component. Vectorised union-find: hook roots onto the smaller root, then jump."""
    parent = np.arange(n, dtype=np.int64)
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    while len(a):
        ra, rb = parent[a], parent[b]
        diff = ra != rb
        if not diff.any():
            break
        a, b, ra, rb = a[diff], b[diff], ra[diff], rb[diff]
        lo, hi = np.minimum(ra, rb), np.maximum(ra, rb)
        np.minimum.at(parent, hi, lo)
        while True:
            jumped = parent[parent]
            if np.array_equal(jumped, parent):
                break
            parent = jumped
    return parent


# --- loading ------------------------------------------------------------------------------------

_LOAD_CACHE: dict[tuple[str, int, int], Mesh] = {}
_LOAD_LOCK = threading.Lock()


def load_mesh(path: str | Path) -> Mesh:
    """Load a triangle mesh (OBJ, PLY, OFF, STL); polygons are triangulated, degenerate and duplicate
    faces removed with a `MeshWarning`, faces wound against their neighbours turned (`orient_consistently`);
    a `MeshHealthWarning` a line for what `health_notes` finds, when the file is parsed. Memoised by (absolute
    path, mtime, size)."""
    p = Path(path).expanduser().absolute()
    if p.suffix.lower() not in SUPPORTED_EXTENSIONS:
        raise MeshError(f"{show_path(p)}: unsupported mesh format '{show_path(p.suffix or '(no extension)', 20)}'; "
                        "supported: " + ", ".join(SUPPORTED_EXTENSIONS))
    try:
        os.stat(p)
    except FileNotFoundError:
        raise MeshError(f"{show_path(p)}: mesh file not found") from None
    except (OSError, ValueError):
        pass  # check_input says what is wrong
    st = check_input(p, "mesh file", error=MeshError)  # a FIFO or /dev/zero is refused, not read
    key = (str(p), st.st_mtime_ns, st.st_size)
    with _LOAD_LOCK:
        cached = _LOAD_CACHE.get(key)
    if cached is not None:
        return cached
    if st.st_size == 0:
        raise MeshError(f"{p}: empty file (no faces)")
    from . import meshstore

    health: list[str] = []

    def parse(path: Path) -> Mesh:
        mesh, turned = orient_consistently(_load_uncached(path))
        health.extend(health_notes(mesh, turned))
        return mesh

    # parsed in an earlier run: from the disk (nodegraph/scene/meshstore.py), the repairs' MeshWarnings given again;
    # what health_notes found is told here, once, when the file is parsed (not on a store hit: not every run)
    mesh = meshstore.load(p, parse, lambda v, f: Mesh(p.stem, v, f, str(p)), MeshWarning, (__file__,))
    for text in health:
        warnings.warn(text, MeshHealthWarning, stacklevel=2)
    with _LOAD_LOCK:
        for old in [k for k in _LOAD_CACHE if k[0] == key[0]]:
            del _LOAD_CACHE[old]
        _LOAD_CACHE[key] = mesh
    return mesh


def clear_mesh_cache() -> None:
    with _LOAD_LOCK:
        _LOAD_CACHE.clear()


def _load_uncached(p: Path) -> Mesh:
    ext = p.suffix.lower()
    note = ""
    if ext == ".ply":
        try:
            v, f = _read_ply(p)
        except _PlyError as exc:
            raise MeshError(f"{p}: cannot read PLY: {exc}") from None
        except OSError as exc:
            raise MeshError(f"{p}: cannot read: {exc.strerror}") from None
    else:
        if ext == ".stl":
            _check_stl(p)
        v, f, note = _igl_read(p)
    if v.size == 0 or v.ndim != 2 or v.shape[1] != 3:
        raise MeshError(f"{p}: no vertices could be read (not a valid {ext[1:].upper()} file?)")
    if not (isinstance(f, np.ndarray) and f.ndim == 2 and f.shape[1] == 3):
        f = _triangulate(f)
    f = np.asarray(f, dtype=np.int64).reshape(-1, 3)
    if len(f) == 0:
        raise MeshError(f"{p}: no faces (empty mesh; {_plural(len(v), 'vertex', 'vertices')} read)")
    base, counting = (1, "counted from 1, as OBJ does") if ext == ".obj" else (0, "counted from 0")
    bad = ~np.isfinite(v).all(axis=1)
    if bad.any():
        raise MeshError(f"{p}: {int(bad.sum())} of {_plural(len(v), 'vertex', 'vertices')} with NaN/Inf "
                        f"coordinates (first: vertex {int(np.argmax(bad)) + base}, {counting})")
    _check_precision(p, v)
    out = (f < 0) | (f >= len(v))
    if out.any():
        # the vertex in the file's own numbering (libigl gives OBJ's 1-based indices back from 0); no face number,
        # since the reader splits polygons into triangles and would count those
        raise MeshError(f"{p}: a face uses vertex {int(f[out][0]) + base} ({counting}), out of range: the file has "
                        f"{_plural(len(v), 'vertex', 'vertices')}")
    if note:
        warnings.warn(f"{show_path(p)}: {note}", MeshWarning, stacklevel=3)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = _repair(Mesh(p.stem, v, f.astype(np.int32), str(p)))
    mesh, n_unused = _drop_unused(mesh)
    notes = [str(w.message) for w in caught if issubclass(w.category, MeshWarning)]
    for w in caught:
        if not issubclass(w.category, MeshWarning):
            warnings.warn(w.message, w.category, stacklevel=3)
    if n_unused:  # one line for the repair and the drop
        dropped = f"dropped {_plural(n_unused, 'vertex', 'vertices')} no face uses; {mesh.n_vertices} remain"
        notes = [f"{notes[0]}; {dropped}"] if notes else [f"mesh '{mesh.name}' ({mesh.source}): {dropped}"]
    for text in notes:
        warnings.warn(text, MeshWarning, stacklevel=3)
    return mesh


def _drop_unused(mesh: Mesh) -> tuple[Mesh, int]:
    """The mesh without the vertices no face uses (never drawn; one far away would frame the picture), and how
    many went."""
    used = np.zeros(mesh.n_vertices, bool)
    used[mesh.faces.ravel()] = True
    n_unused = int((~used).sum())
    if n_unused == 0:
        return mesh, 0
    remap = np.cumsum(used) - 1
    return Mesh(mesh.name, mesh.vertices[used], remap[mesh.faces].astype(np.int32), mesh.source), n_unused


def _triangulate(polygons: Any) -> np.ndarray:
    """Fan-triangulate polygons (a 2D index array, or a list of index sequences of any lengths)."""
    if isinstance(polygons, np.ndarray) and polygons.ndim == 2:
        polys = polygons.astype(np.int64)
        k = polys.shape[1]
        if k < 3:
            return np.zeros((0, 3), np.int64)
        fans = [np.stack([polys[:, 0], polys[:, j], polys[:, j + 1]], axis=1) for j in range(1, k - 1)]
        return np.stack(fans, axis=1).reshape(-1, 3)
    seqs = [np.asarray(poly, dtype=np.int64).ravel() for poly in polygons]
    if not seqs:
        return np.zeros((0, 3), np.int64)
    lengths = np.array([len(q) for q in seqs])
    flat = np.concatenate(seqs)
    starts = np.cumsum(lengths) - lengths
    n_tri = np.maximum(lengths - 2, 0)
    first = np.repeat(starts, n_tri)
    j = np.arange(n_tri.sum()) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri)
    return np.stack([flat[first], flat[first + 1 + j], flat[first + 2 + j]], axis=1)


def _igl_read(p: Path) -> tuple[np.ndarray, np.ndarray, str]:
    """libigl's reader with file descriptors 1 and 2 captured: libigl explains failures there only.

    Its warnings quote the file's lines, so they are never echoed: the third value is a short note
    (the first problem in libigl's own words) for a warning once the mesh is known good."""
    import igl

    saved: dict[int, int] = {}
    for fd in (1, 2):  # some libigl readers (OFF) print to stdout
        with contextlib.suppress(OSError):  # nothing to capture
            saved[fd] = os.dup(fd)
    result: tuple[np.ndarray, np.ndarray] | None = None
    text = ""
    with tempfile.TemporaryFile() as tmp:
        sys.stdout.flush()
        sys.stderr.flush()
        for fd in saved:
            os.dup2(tmp.fileno(), fd)
        try:
            v, f = igl.read_triangle_mesh(str(p))
            result = (np.asarray(v), np.asarray(f))
        except Exception:
            result = None
        finally:
            for fd, copy in saved.items():
                os.dup2(copy, fd)
                os.close(copy)
        tmp.seek(0)
        text = tmp.read(1 << 16).decode("utf-8", "replace")
    if result is not None:
        notes = _igl_notes(text)
        first = _reader_note(notes[0]) if notes else ""
        note = ("the mesh reader reported problems" + (f" (first: {first})" if first else "")) if notes else ""
        return (*result, note)
    nonfinite = _count_nonfinite_text(p)
    if nonfinite:
        raise MeshError(f"{p}: {_plural(nonfinite, 'vertex', 'vertices')} with NaN/Inf coordinates") from None
    lines = [ln for ln in text.splitlines() if ln[:1].strip()]  # indented lines quote the file
    reason = _reader_note(lines[0]) if lines else ""
    raise MeshError(f"{p}: unreadable mesh file" + (f" ({reason})" if reason else "")) from None


# OBJ statements that carry no surface (object names, free-form curve and surface data, display and render
# attributes): libigl's OBJ reader skips them with a warning each, which is no problem of the file's
_OBJ_QUIET = frozenset({"o", "vp", "cstype", "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim", "hole",
                        "scrv", "sp", "end", "con", "mg", "lod", "usemap", "maplib", "shadow_obj", "trace_obj",
                        "ctech", "stech", "bevel", "c_interp", "d_interp"})


def _igl_notes(text: str) -> list[str]:
    """libigl's own lines of what it printed while reading (the indented lines quote the file), less its
    warnings about OBJ statements that carry no surface (`_OBJ_QUIET`: Blender writes an `o NAME` line into every
    OBJ). Lines (`l`) and points (`p`) are kept: they are geometry the drawing leaves out."""
    lines = text.splitlines()
    notes = []
    for k, ln in enumerate(lines):
        if not ln[:1].strip():
            continue
        quoted = lines[k + 1].split() if k + 1 < len(lines) and not lines[k + 1][:1].strip() else []
        if "ignored non-comment line" in ln and quoted:
            if quoted[0] in _OBJ_QUIET:
                continue
            ln = f"{ln.rstrip(':')} (an {clean(quoted[0], 12)!r} statement)"  # what the line was, not its content
        notes.append(ln)
    return notes


def _reader_note(line: str) -> str:
    """A line of libigl's stderr fit for a message: its own words only, up to the first ':' (what follows
    quotes the file), printable and short."""
    head = line.replace("Warning:", "").replace("Error:", "").strip()
    head = head.split(":")[0] if ":" in head else head
    return clean(head, 80)


FLOAT32_MAX = float(np.finfo(np.float32).max)
FLOAT64_SPAN = FLOAT64_RATIO
"""A mesh whose coordinates reach this many times its extent (1e12) keeps fewer than ~12 bits of its shape even in
float64 (53 bits): refused. Closer in, nothing is lost on the way to the GPU: coordinates are read as float64,
and the nodes that draw upload them relative to the mesh's own centre (nodegraph/scene/origin.py), rounding to
float32 only then. (origin.FLOAT64_RATIO: where a scene's objects are checked.)"""


def _check_precision(p: Path, v: np.ndarray) -> None:
    """Coordinates the drawing can hold: the mesh's extent within float32 range about its centre (what the GPU
    receives), and its position not so far out, for its size, that float64 has lost its shape. A mesh far from
    the origin is otherwise fine at any offset: at 1e6 its coordinates still hold 15 significant digits."""
    lo, hi = v.min(axis=0), v.max(axis=0)
    half = hi * 0.5 - lo * 0.5  # halved first: no overflow
    if float(half.max()) > FLOAT32_MAX:
        centre = lo * 0.5 + hi * 0.5
        big = np.abs(v - centre).max(axis=1) > FLOAT32_MAX
        raise MeshError(f"{show_path(p)}: {int(big.sum())} of {_plural(len(v), 'vertex', 'vertices')} with "
                        f"coordinates beyond float32 range from the mesh's centre (expected the mesh to span at "
                        f"most {FLOAT32_MAX:.3g} each way; vertex {int(np.argmax(big))} lies "
                        f"{float(np.abs(v[int(np.argmax(big))] - centre).max()):.3g} from it)")
    extent = 2.0 * float(half.max())
    reach = float(np.abs(v).max())
    if reach > 0 and reach > extent * FLOAT64_SPAN:
        raise MeshError(f"{show_path(p)}: coordinates reach {reach:.3g} but the mesh spans only {extent:.3g}: "
                        f"even float64 keeps too few digits of its shape there; expected coordinates at most "
                        f"{FLOAT64_SPAN:.0e} times the mesh's extent (move it nearer the origin)")


_TEXT_BYTES = bytes(range(32, 127)) + b"\t\n\r\f\v"


def _check_stl(p: Path) -> None:
    """Decide binary or ASCII STL before libigl reads it (libigl loops forever on a 'solid' header followed
    by binary data, and allocates whatever triangle count a binary header declares)."""
    size = p.stat().st_size
    with p.open("rb") as fh:
        head = fh.read(84)
    n = int.from_bytes(head[80:84], "little") if len(head) == 84 else 0
    if size >= 84 and size == 84 + 50 * n:
        return  # binary, and libigl reads it as binary (it checks this size too)
    if head.lstrip()[:5].lower() == b"solid":
        with p.open("rb") as fh:
            while chunk := fh.read(1 << 20):
                if chunk.translate(None, _TEXT_BYTES):  # a byte that is not printable ASCII text
                    raise MeshError(f"{show_path(p)}: starts like ASCII STL ('solid') but holds binary data; "
                                    "expected ASCII STL text, or a binary STL of 84 + 50 x N bytes for the N "
                                    f"triangles its header declares (N = {n}: {84 + 50 * n} bytes; found "
                                    f"{size} bytes)")
        return
    if size < 84:
        raise MeshError(f"{show_path(p)}: not an STL file: expected ASCII text starting with 'solid' or a binary "
                        f"STL of at least 84 bytes, found {size} bytes")
    raise MeshError(f"{show_path(p)}: binary STL header declares {n} triangles, so expected 84 + 50 x {n} = "
                    f"{84 + 50 * n} bytes, found {size} bytes (truncated or not an STL file)")


def _plural(k: int, one: str, many: str) -> str:
    return f"{k} {one if k == 1 else many}"


def _count_nonfinite_text(p: Path) -> int:
    """Vertices written with nan/inf (or overflowing) coordinates in an OBJ or ASCII STL file."""
    prefix = {".obj": "v", ".stl": "vertex"}.get(p.suffix.lower())
    if prefix is None:
        return 0
    count = 0
    try:
        with p.open("r", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                parts = line.split()
                if len(parts) >= 4 and parts[0] == prefix:
                    try:
                        xyz = [float(t) for t in parts[1:4]]
                    except ValueError:
                        continue
                    if not all(np.isfinite(xyz)):
                        count += 1
    except OSError:
        return 0
    return count


def _repair(mesh: Mesh) -> Mesh:
    """Remove degenerate faces (repeated index, zero area) and exact duplicates (same cyclic order)."""
    f = mesh.faces.astype(np.int64)
    _, _, degenerate = mesh._face_geometry()
    repeated = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
    # zero area in the original indexing (welding-induced degeneracy is counted as zero area too)
    drop = degenerate | repeated
    # canonical rotation: smallest index first, orientation kept
    shift = np.argmin(f, axis=1)
    rows = np.arange(len(f))[:, None]
    canon = f[rows, (shift[:, None] + np.arange(3)) % 3]
    canon_keep = canon[~drop]
    idx_keep = np.flatnonzero(~drop)
    n = max(mesh.n_vertices, 1)
    if n < 2**21:
        _, first = np.unique((canon_keep[:, 0] * n + canon_keep[:, 1]) * n + canon_keep[:, 2],
                             return_index=True)
    else:
        _, first = np.unique(canon_keep, axis=0, return_index=True)
    unique_mask = np.zeros(len(idx_keep), bool)
    unique_mask[first] = True
    n_dup = int((~unique_mask).sum())
    n_deg = int(drop.sum())
    if n_dup == 0 and n_deg == 0:
        return mesh
    keep = np.sort(idx_keep[unique_mask])
    if len(keep) == 0:  # an error, not a warning and then an error
        raise MeshError(f"{mesh.source}: no faces left after removing "
                        f"{_plural(n_deg, 'degenerate face', 'degenerate faces')} (repeated vertex or zero area)")
    warnings.warn(
        f"mesh '{mesh.name}' ({mesh.source}): removed {_plural(n_deg, 'degenerate face', 'degenerate faces')} "
        f"(repeated vertex or zero area) and {_plural(n_dup, 'duplicate face', 'duplicate faces')}; {len(keep)} of "
        f"{len(f)} faces remain",
        MeshWarning,
        stacklevel=4,
    )
    return Mesh(mesh.name, mesh.vertices, mesh.faces[keep], mesh.source)


# --- PLY ----------------------------------------------------------------------------------------
# libigl's PLY reader aborts the process on faces of mixed sizes and returns uninitialised data for
# ASCII 'nan', so PLY files are read here: ASCII and binary, vertex x/y/z and face vertex lists.


class _PlyError(ValueError):
    pass


_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


@dataclass
class _PlyElement:
    name: str
    count: int
    props: list[tuple[str, str, str | None]]  # (name, value type, list count type or None)


def _ply_header(data: bytes) -> tuple[str, list[_PlyElement], int]:
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise _PlyError("missing 'ply' magic or 'end_header'")
    body = data.index(b"\n", end) + 1 if b"\n" in data[end:] else len(data)
    fmt = ""
    elements: list[_PlyElement] = []
    for raw in data[:end].decode("ascii", "replace").splitlines()[1:]:
        parts = raw.split()
        if not parts or parts[0] in ("comment", "obj_info"):
            continue
        if parts[0] == "format" and len(parts) >= 2:
            fmt = parts[1]
        elif parts[0] == "element" and len(parts) == 3:
            if not parts[2].isdigit() or len(parts[2]) > 12:
                raise _PlyError(f"element '{clean(parts[1], 40)}': expected a count of 0 to 10^12 rows, found "
                                f"'{clean(parts[2], 20)}'")
            elements.append(_PlyElement(parts[1], int(parts[2]), []))
        elif parts[0] == "property" and elements:
            try:
                if parts[1] == "list" and len(parts) == 5:
                    elements[-1].props.append((parts[4], _PLY_TYPES[parts[3]], _PLY_TYPES[parts[2]]))
                elif len(parts) == 3:
                    elements[-1].props.append((parts[2], _PLY_TYPES[parts[1]], None))
                else:
                    raise _PlyError(f"bad header line '{clean(raw, 60)}'")
            except KeyError as exc:
                raise _PlyError(f"unknown property type '{clean(exc.args[0], 20)}'") from None
        else:
            raise _PlyError(f"bad header line '{clean(raw, 60)}'")
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise _PlyError(f"unknown format '{clean(fmt, 30)}'; expected ascii, binary_little_endian or "
                        "binary_big_endian")
    return fmt, elements, body


def _read_ply(p: Path) -> tuple[np.ndarray, Any]:
    data = p.read_bytes()
    fmt, elements, pos = _ply_header(data)
    _check_ply_counts(fmt, elements, len(data) - pos)
    reader = _ply_ascii_elements if fmt == "ascii" else _ply_binary_elements
    columns = reader(data[pos:], elements, "<" if fmt == "binary_little_endian" else ">")
    vert = columns.get("vertex", {})
    if not all(k in vert for k in "xyz"):
        raise _PlyError("no 'vertex' element with x, y, z properties")
    v = np.stack([np.asarray(vert[k], dtype=np.float64) for k in "xyz"], axis=1)
    face = columns.get("face", {})
    lists = face.get("vertex_indices", face.get("vertex_index"))
    if lists is not None:
        return v, lists
    strips = columns.get("tristrips", {})
    strip_lists = strips.get("vertex_indices", strips.get("vertex_index"))
    if strip_lists is not None:
        return v, _strips_to_triangles(strip_lists)
    others = ", ".join(f"'{clean(el.name, 30)}' ({el.count})" for el in elements if el.name != "vertex") or "none"
    raise _PlyError(f"no faces: {_plural(len(v), 'vertex', 'vertices')} and no 'face' or 'tristrips' element with "
                    f"'vertex_indices' (other elements: {others}); a point cloud cannot be drawn")


def _strips_to_triangles(strips: Any) -> np.ndarray:
    """Triangles of PLY triangle strips (each a list of vertex indices; -1 restarts a strip): triangle k of a run
    is (k, k+1, k+2), every other one reversed so all keep the first one's winding; triangles with a repeated
    index (the joins strips use) are left out."""
    flat = [np.asarray(s, dtype=np.int64).ravel() for s in (strips if not isinstance(strips, np.ndarray)
                                                           or strips.ndim == 1 else list(strips))]
    out: list[np.ndarray] = []
    for strip in flat:
        cuts = np.flatnonzero(strip < 0)
        for run in np.split(strip, cuts):
            run = run[run >= 0]
            if len(run) < 3:
                continue
            k = np.arange(len(run) - 2)
            tri = np.stack([run[k], run[k + 1], run[k + 2]], axis=1)
            odd = (k % 2) == 1
            tri[odd] = tri[odd][:, [1, 0, 2]]
            out.append(tri)
    if not out:
        return np.zeros((0, 3), np.int64)
    tri = np.concatenate(out)
    repeated = (tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2]) | (tri[:, 0] == tri[:, 2])
    return tri[~repeated]


def _check_ply_counts(fmt: str, elements: list[_PlyElement], available: int) -> None:
    """Refuse element counts the file cannot hold before anything is allocated for them: each row takes
    at least its fixed-size values (binary) or two characters per value (ASCII)."""
    need = 0
    for el in elements:
        if fmt == "ascii":
            row = 2 * max(len(el.props), 1)
        else:
            row = max(sum(np.dtype(cnt or t).itemsize for _, t, cnt in el.props), 1)
        need += el.count * row
        if need > available + 1:
            raise _PlyError(f"header declares {el.count} '{clean(el.name, 40)}' rows, at least {el.count * row} "
                            f"bytes, but only {available} bytes follow the header (a wrong count or a truncated file)")


def _ply_binary_elements(buf: bytes, elements: list[_PlyElement], endian: str) -> dict[str, dict[str, Any]]:
    import struct

    out: dict[str, dict[str, Any]] = {}
    pos = 0
    for el in elements:
        cols: dict[str, Any] = {}
        if all(cnt is None for _, _, cnt in el.props):
            dt = np.dtype([(name, endian + t) for name, t, _ in el.props])
            size = dt.itemsize * el.count
            if pos + size > len(buf):
                raise _PlyError(f"file ends inside element '{el.name}'")
            arr = np.frombuffer(buf, dt, el.count, pos)
            cols = {name: arr[name] for name, _, _ in el.props}
            pos += size
            out[el.name] = cols
            continue
        # fast path: every list as long as the first row's
        fields: list[tuple[str, str, int]] = []
        lengths: list[tuple[str, int]] = []
        probe = pos
        for name, t, cnt in el.props:
            if cnt is None:
                fields.append((name, endian + t, 0))
                probe += np.dtype(t).itemsize
                continue
            if probe + np.dtype(cnt).itemsize > len(buf):
                break
            k = int(np.frombuffer(buf, endian + cnt, 1, probe)[0])
            fields.append((name + "#n", endian + cnt, 0))
            fields.append((name, endian + t, k))
            lengths.append((name + "#n", k))
            probe += np.dtype(cnt).itemsize + k * np.dtype(t).itemsize
        else:
            dt = np.dtype([(n, t, (k,)) if k else (n, t) for n, t, k in fields])
            if el.count and pos + dt.itemsize * el.count <= len(buf):
                arr = np.frombuffer(buf, dt, el.count, pos)
                if all((arr[n] == k).all() for n, k in lengths):
                    out[el.name] = {n: arr[n] for n, _, _ in fields if not n.endswith("#n")}
                    pos += dt.itemsize * el.count
                    continue
        # slow path: row by row
        rows: dict[str, list[Any]] = {name: [] for name, _, _ in el.props}
        try:
            for _ in range(el.count):
                for name, t, cnt in el.props:
                    if cnt is None:
                        rows[name].append(struct.unpack_from(endian + np.dtype(t).char, buf, pos)[0])
                        pos += np.dtype(t).itemsize
                    else:
                        (k,) = struct.unpack_from(endian + np.dtype(cnt).char, buf, pos)
                        pos += np.dtype(cnt).itemsize
                        rows[name].append(np.frombuffer(buf, endian + t, int(k), pos))
                        pos += int(k) * np.dtype(t).itemsize
        except (struct.error, ValueError):
            raise _PlyError(f"file ends inside element '{el.name}'") from None
        out[el.name] = rows
    return out


def _ply_ascii_elements(buf: bytes, elements: list[_PlyElement], endian: str) -> dict[str, dict[str, Any]]:
    lines = [ln for ln in buf.decode("ascii", "replace").splitlines() if ln.strip()]
    out: dict[str, dict[str, Any]] = {}
    pos = 0
    for el in elements:
        chunk = lines[pos:pos + el.count]
        if len(chunk) < el.count:
            raise _PlyError(f"file ends inside element '{el.name}' ({len(chunk)} of {el.count} rows)")
        pos += el.count
        tokens = [ln.split() for ln in chunk]
        try:
            if all(cnt is None for _, _, cnt in el.props) or (
                tokens and len({len(t) for t in tokens}) == 1 and el.props[0][2] is not None
                and len(el.props) == 1
            ):
                table = np.array(tokens, dtype=np.float64) if tokens else np.zeros((0, len(el.props)))
                if all(cnt is None for _, _, cnt in el.props):
                    if table.shape[1] != len(el.props):
                        raise _PlyError(f"element '{el.name}': expected {len(el.props)} values per row")
                    out[el.name] = {name: table[:, i] for i, (name, _, _) in enumerate(el.props)}
                else:  # one list property, all rows the same length
                    if (table[:, 0] != table.shape[1] - 1).any():
                        raise _PlyError(f"element '{el.name}': list length does not match its row")
                    out[el.name] = {el.props[0][0]: table[:, 1:].astype(np.int64)}
                continue
            rows: dict[str, list[Any]] = {name: [] for name, _, _ in el.props}
            for row in tokens:
                i = 0
                for name, _, cnt in el.props:
                    if cnt is None:
                        rows[name].append(float(row[i]))
                        i += 1
                    else:
                        k = int(row[i])
                        rows[name].append([int(float(x)) for x in row[i + 1:i + 1 + k]])
                        i += 1 + k
            out[el.name] = rows
        except (ValueError, IndexError):
            raise _PlyError(f"element '{el.name}': malformed row") from None
    return out
