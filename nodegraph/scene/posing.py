"""Posed meshes drawn frame after frame: what does not change between frames is prepared once.

A posed (skinned or morphed) mesh has its rest pose's faces, vertex for vertex, so it shares the rest pose's
topology: welding, connected components, edges and the smoothing groups of its render vertices (creases are where
the rest pose has them, so a crease does not come and go as a joint bends). `Mesh` asks its rest pose for these
(`Mesh.topology_mesh`). What does change, the float data drawn (render positions, split and smooth normals,
enlargement directions, bounds), is computed here for every posed part of a file at once: a `PoseBatch` lays the
parts end to end, vertex and index arrays offset, and runs one pass over all of them (compiled by Numba in
posing_jit.py; the NumPy code here where Numba cannot be imported), then hands each part its slices. The maths is
that of `Mesh` (`_face_geometry`, `vertex_normals`, `_render_arrays`) and of rasterize's enlargement directions, row
for row, so a part's arrays are the ones it would get alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..fsio import compiled
from .meshes import FALLBACK_NORMAL, Mesh, RenderArrays, _cross, _normalize_or

BATCH_KEY = "posing.batch"  # a posed mesh's `_cache` entry: (its PoseBatch, its index there)
_TOPOLOGIES: dict[Any, tuple[list[Mesh], _Topology]] = {}  # (rest meshes, crease) -> their laid-out topology
_JIT: Any = None  # the compiled passes (posing_jit), False where Numba is unavailable


def _jit() -> Any:
    """nodegraph/scene/posing_jit.py, or None where Numba cannot be imported or finds no writable place for its
    cache (a warning, once; the NumPy code here gives the same arrays, slower; `fsio.compiled`)."""
    global _JIT
    if _JIT is None:
        _JIT = compiled(__package__, "posing_jit", "posing: the compiled skinning is",
                        "the NumPy skinning, same poses, slower") or False
    return _JIT or None


def skin(weights: Any, joint_matrices: np.ndarray, vertices: np.ndarray,
         engine: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """Linear blend skinning of all the vertices of the parts of one skin at once: (posed (n, 3), each vertex's
    blended linear part (n, 3, 3)). `weights`: the (n, J) CSR skin weights (`animation.skin_weights`, the parts'
    rows stacked); `joint_matrices` (J, 4, 4): world @ inverse bind. `engine`: "numpy" for the reference
    (`animation.skin_matrices`, one sparse product and an einsum), "auto" compiled where Numba is there."""
    from .animation import skin_matrices

    jit = _jit() if engine == "auto" else None
    if jit is None:
        blended = skin_matrices(None, weights, joint_matrices)
        v = np.einsum("nij,nj->ni", blended[:, :, :3], vertices) + blended[:, :, 3]
        return v, blended[:, :, :3]
    mats = np.ascontiguousarray(np.asarray(joint_matrices, dtype=np.float64)[:, :3, :]).reshape(-1, 12)
    out = np.empty((len(vertices), 3))
    linear = np.empty((len(vertices), 3, 3))
    jit.skin(weights.indptr, weights.indices, np.asarray(weights.data, np.float64), mats,
             np.ascontiguousarray(vertices, dtype=np.float64), out, linear)
    out.flags.writeable = linear.flags.writeable = False  # a posed Mesh then shares its rows (no copy)
    return out, linear


@dataclass
class _Topology:
    """The rest-pose arrays of all parts laid end to end (global vertex, welded, render-vertex and key ids)."""

    faces: np.ndarray  # (M, 3) int64, vertex ids
    wf: np.ndarray  # (M * 3,) int64, welded ids of the corners
    wid: np.ndarray  # (N,) int64, welded id of each vertex
    n_welded: int
    welded_bad: np.ndarray  # (M,) faces with a repeated welded vertex (degenerate whatever the pose)
    gid: np.ndarray  # (M * 3,) int64, render vertex of each corner
    rep: np.ndarray  # (K,) int64, the vertex each render vertex came from
    key_of_corner: np.ndarray  # (M * 3,) int64, enlargement key (welded vertex, component) of each corner
    n_keys: int
    key_of_vertex: np.ndarray  # (K,) int64, the key slot each render vertex reads
    key_found: np.ndarray  # (K,) bool, whether that slot is its key
    # per part: vertex, face and render-vertex ranges
    v_at: np.ndarray
    f_at: np.ndarray
    k_at: np.ndarray
    parts: list[RenderArrays]  # the rest poses' render arrays (indices, components, source vertices)


def _part_topology(rest: Mesh, crease: float) -> dict[str, Any]:
    """One rest mesh's share of `_Topology` (local ids), cached on the rest mesh."""

    def make() -> dict[str, Any]:
        ra = rest.render_arrays(crease)
        wid, nu = rest.weld()
        faces = rest.faces.astype(np.int64)
        wf = wid[faces]
        comp = rest.face_components().astype(np.int64)
        n_comp = int(comp.max()) + 1 if len(comp) else 1
        corner_key = (wf * n_comp + comp[:, None]).ravel()
        keys, inverse = np.unique(corner_key, return_inverse=True)
        vertex_key = wid[ra.source_vertex] * n_comp + ra.component.astype(np.int64)
        slot = np.clip(np.searchsorted(keys, vertex_key), 0, max(len(keys) - 1, 0))
        found = keys[slot] == vertex_key if len(keys) else np.zeros(len(vertex_key), bool)
        return {"ra": ra, "wid": wid, "nu": int(nu), "wf": wf.ravel(),
                "welded_bad": (wf[:, 0] == wf[:, 1]) | (wf[:, 1] == wf[:, 2]) | (wf[:, 0] == wf[:, 2]),
                "inverse": inverse.astype(np.int64).ravel(), "n_keys": len(keys), "slot": slot.astype(np.int64),
                "found": found}

    return rest._cached(("posing.topology", float(crease)), make)


def _topology(rests: list[Mesh], crease: float) -> _Topology:
    key = (tuple(id(r) for r in rests), crease)
    hit = _TOPOLOGIES.get(key)
    if hit is not None:
        return hit[1]
    if len(_TOPOLOGIES) >= 8:
        _TOPOLOGIES.clear()
    topo = _lay_out(rests, crease)
    _TOPOLOGIES[key] = (rests, topo)  # the rests kept alive: their ids stay theirs
    return topo


def _lay_out(rests: list[Mesh], crease: float) -> _Topology:
    parts = [_part_topology(r, crease) for r in rests]
    n_v = np.array([r.n_vertices for r in rests], np.int64)
    n_f = np.array([r.n_faces for r in rests], np.int64)
    n_k = np.array([p["ra"].n_vertices for p in parts], np.int64)
    n_w = np.array([p["nu"] for p in parts], np.int64)
    n_keys = np.array([p["n_keys"] for p in parts], np.int64)
    v_at, f_at, k_at = (np.concatenate([[0], np.cumsum(n)]) for n in (n_v, n_f, n_k))
    w_at, key_at = (np.concatenate([[0], np.cumsum(n)]) for n in (n_w, n_keys))
    cat = np.concatenate
    return _Topology(
        faces=cat([r.faces.astype(np.int64) + v_at[i] for i, r in enumerate(rests)]).reshape(-1, 3),
        wf=cat([p["wf"] + w_at[i] for i, p in enumerate(parts)]),
        wid=cat([p["wid"] + w_at[i] for i, p in enumerate(parts)]),
        n_welded=int(w_at[-1]),
        welded_bad=cat([p["welded_bad"] for p in parts]),
        gid=cat([np.asarray(p["ra"].indices, np.int64).ravel() + k_at[i] for i, p in enumerate(parts)]),
        rep=cat([p["ra"].source_vertex + v_at[i] for i, p in enumerate(parts)]),
        key_of_corner=cat([p["inverse"] + key_at[i] for i, p in enumerate(parts)]),
        n_keys=int(key_at[-1]),
        key_of_vertex=cat([p["slot"] + key_at[i] for i, p in enumerate(parts)]),
        key_found=cat([p["found"] for p in parts]),
        v_at=v_at, f_at=f_at, k_at=k_at, parts=[p["ra"] for p in parts])


def _end_to_end(arrays: list[np.ndarray]) -> np.ndarray:
    """The (n, 3) float64 arrays one after the other: a view where they already lie so in memory (the parts of
    one skin, rows of one skinning output), else a concatenation."""
    first = arrays[0] if arrays else None
    if first is not None and all(a.dtype == np.float64 and a.flags.c_contiguous for a in arrays):
        at = first.__array_interface__["data"][0]
        base = first.base
        contiguous = True
        for a in arrays:
            if a.__array_interface__["data"][0] != at or (a.size and a.base is not base):
                contiguous = False
                break
            at += a.nbytes
        if contiguous and isinstance(base, np.ndarray) and base.flags.c_contiguous:
            start = first.__array_interface__["data"][0] - base.__array_interface__["data"][0]
            stop = start + sum(a.nbytes for a in arrays)
            if start >= 0 and stop <= base.nbytes:
                return base.reshape(-1).view(np.uint8)[start:stop].view(np.float64).reshape(-1, 3)
    return np.concatenate(arrays)


def _bincount3(ids: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    return np.stack([np.bincount(ids, values[:, k], minlength=n) for k in range(3)], axis=1)


class PoseBatch:
    """The posed parts of one file at one moment (`meshes`, each with its rest pose and the same faces); their
    derived arrays are made for all of them together on first use, per crease angle."""

    def __init__(self, meshes: list[Mesh], engine: str = "auto"):
        self.meshes = meshes
        self.engine = engine  # "auto": compiled where Numba is there; "numpy": the reference
        self._done: set[Any] = set()
        for i, m in enumerate(meshes):
            m._cache[BATCH_KEY] = (self, i)

    def _vertices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(all posed vertices, per-part bounding-box diagonal, its lows and highs), parts end to end."""
        if "v" not in self._done:
            v = _end_to_end([m.vertices for m in self.meshes])
            jit = _jit() if self.engine == "auto" else None
            if jit is not None:
                at = np.concatenate([[0], np.cumsum([m.n_vertices for m in self.meshes])]).astype(np.int64)
                lo, hi = np.empty((len(self.meshes), 3)), np.empty((len(self.meshes), 3))
                jit.bounds(v, at, lo, hi)
                empty = np.diff(at) == 0
                lo[empty] = hi[empty] = 0.0
            else:
                lo = np.stack([m.vertices.min(axis=0) if m.n_vertices else np.zeros(3) for m in self.meshes])
                hi = np.stack([m.vertices.max(axis=0) if m.n_vertices else np.zeros(3) for m in self.meshes])
            for m, a, b in zip(self.meshes, lo, hi, strict=True):
                m._cache.setdefault("bounds", (a, b))
                a.flags.writeable = b.flags.writeable = False
            self._v = (v, np.linalg.norm(hi - lo, axis=1), lo)
            self._done.add("v")
        return self._v

    def render_arrays(self, crease: float) -> None:
        """Fill every part's `render_arrays(crease)` and its enlargement directions (`enlarge_directions`)."""
        if ("render", crease) in self._done:
            return
        rests = [m.rest for m in self.meshes]
        assert all(r is not None for r in rests)
        topo = _topology(rests, crease)  # type: ignore[arg-type]
        v, diag, _ = self._vertices()
        n_faces = np.diff(topo.f_at)
        diag_f = np.repeat(diag, n_faces)

        jit = _jit() if self.engine == "auto" else None
        if jit is not None:
            k = int(topo.k_at[-1])
            positions, split32, smooth, enlarge = (np.empty((k, 3), np.float32) for _ in range(4))
            vn = np.empty((len(v), 3), np.float32)
            jit.arrays(v, topo.faces, diag_f, topo.welded_bad, topo.wf, topo.wid, topo.n_welded, topo.gid,
                       topo.rep, topo.key_of_corner, topo.n_keys, topo.key_of_vertex, topo.key_found,
                       FALLBACK_NORMAL, positions, split32, smooth, enlarge, vn)
        else:
            positions, split32, smooth, enlarge, vn = self._numpy_arrays(v, diag_f, topo)
        self._hand_out(topo, crease, positions, split32, smooth, enlarge, vn)

    def _numpy_arrays(self, v: np.ndarray, diag_f: np.ndarray, topo: _Topology) -> tuple[np.ndarray, ...]:
        """(positions, split normals, smooth normals, enlargement directions, vertex normals): the reference."""
        # Mesh._face_geometry, all parts at once
        p = v[topo.faces]
        e = np.roll(p, -1, axis=1) - p
        cross = _cross(e[:, 0], -e[:, 2])
        area2 = np.sqrt(np.einsum("ij,ij->i", cross, cross))
        degenerate = (area2 <= 1e-14 * diag_f * diag_f) | topo.welded_bad
        with np.errstate(invalid="ignore", divide="ignore"):
            normals = np.where(degenerate[:, None], 0.0, cross / area2[:, None])
        cos = -np.einsum("mij,mij->mi", e, np.roll(e, 1, axis=1))
        angles = np.arctan2(np.broadcast_to(area2[:, None], cos.shape), cos)
        angles[degenerate] = 0.0
        contrib = (normals[:, None, :] * angles[:, :, None]).reshape(-1, 3)
        # Mesh.vertex_normals
        vn = _normalize_or(_bincount3(topo.wf, contrib, topo.n_welded), FALLBACK_NORMAL)[topo.wid].astype(np.float32)
        # Mesh._render_arrays: split normals over the rest pose's smoothing groups
        k = int(topo.k_at[-1])
        smooth = vn[topo.rep]
        split = _normalize_or(_bincount3(topo.gid, contrib, k), None)
        bad = ~np.isfinite(split).all(axis=1)
        split[bad] = smooth[bad]
        split32 = split.astype(np.float32)
        positions = v[topo.rep].astype(np.float32)
        enlarge = self._enlarge(e, topo, smooth)
        return positions, split32, smooth, enlarge, vn

    def _hand_out(self, topo: _Topology, crease: float, positions: np.ndarray, split32: np.ndarray,
                  smooth: np.ndarray, enlarge: np.ndarray, vn: np.ndarray) -> None:
        for i, m in enumerate(self.meshes):
            lo, hi = topo.v_at[i], topo.v_at[i + 1]
            a, b = topo.k_at[i], topo.k_at[i + 1]
            rest_ra = topo.parts[i]
            arrays = {"positions": positions[a:b], "normals": split32[a:b], "smooth_normals": smooth[a:b],
                      "indices": rest_ra.indices, "component": rest_ra.component,
                      "source_vertex": rest_ra.source_vertex}
            for arr in arrays.values():
                arr.flags.writeable = False
            m._cache.setdefault("vnormals", vn[lo:hi])
            m._cache.setdefault(("render", float(crease)), RenderArrays(**arrays))
            m._cache.setdefault(("posing.enlarge", float(crease)), enlarge[a:b])
        vn.flags.writeable = False
        enlarge.flags.writeable = False
        self._done.add(("render", crease))

    @staticmethod
    def _enlarge(e: np.ndarray, topo: _Topology, smooth: np.ndarray) -> np.ndarray:
        """rasterize's enlargement directions (nodes/rasterize, `_enlarge_normals`), all parts at once."""
        cross = np.cross(e[:, 0], -e[:, 2])
        area2 = np.linalg.norm(cross, axis=1)
        face_n = np.divide(cross, area2[:, None], out=np.zeros_like(cross), where=area2[:, None] > 0)
        cos = -np.einsum("mij,mij->mi", e, np.roll(e, 1, axis=1))
        angles = np.arctan2(np.broadcast_to(area2[:, None], cos.shape), cos)
        contrib = (face_n[:, None, :] * angles[:, :, None]).reshape(-1, 3)
        acc = _bincount3(topo.key_of_corner, contrib, topo.n_keys)
        length = np.linalg.norm(acc, axis=1)
        ok = length > 1e-12
        acc[ok] /= length[ok, None]
        slot = topo.key_of_vertex
        found = topo.key_found & ok[slot] if len(ok) else topo.key_found
        return np.where(found[:, None], acc[slot] if len(acc) else smooth, smooth).astype(np.float32)


def batched(mesh: Mesh) -> tuple[PoseBatch, int] | None:
    """(the batch a posed mesh was made in, its index there), or None."""
    return mesh._cache.get(BATCH_KEY)


def render_arrays(mesh: Mesh, crease: float) -> RenderArrays | None:
    """A posed mesh's render arrays made with its whole batch (None: the mesh is not in one)."""
    hit = batched(mesh)
    if hit is None:
        return None
    hit[0].render_arrays(float(crease))
    return mesh._cache[("render", float(crease))]


def enlarge_directions(mesh: Mesh, crease: float) -> np.ndarray | None:
    """rasterize's enlargement directions of a posed mesh, made with its whole batch (None: not in one)."""
    hit = batched(mesh)
    if hit is None:
        return None
    hit[0].render_arrays(float(crease))
    return mesh._cache[("posing.enlarge", float(crease))]
