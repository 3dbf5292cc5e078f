"""curvature: per-vertex principal curvatures and directions of every mesh in a scene (libigl), cached.

The measurement and its fallbacks are in ``principal``; this node runs it once per mesh content on the
welded mesh (duplicated seam vertices of OBJ files would otherwise read as boundaries), smooths the
minimum-curvature line field the way a hatching direction field wants it (by default one global solve for
the smoothest field aligned to the reliable directions, ``field``; or the tensor-field smoothing Lee et al.
2006 borrow from Alliez et al. 2003), and hands out per-object arrays indexed like the mesh's own
vertices.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from nodegraph.node import HashContext, Input, Node, NodeParams, Output, RunContext, digest
from nodegraph.types import ARRAYS, SCENE
from nodegraph.values import Arrays

from .._shared.curvature import DirectionSource, object_field
from .principal import DEFAULT_RADIUS, compute_curvature, mesh_content_key


class Curvature(Node):
    """Principal curvature per vertex of every scene object (libigl quadric fitting on `radius` rings),
    ordered by magnitude: dmin is the direction of least bending, the one hatching follows. Where the
    direction is undefined or unreliable (flat, umbilic, too few neighbours, unreferenced, non-finite)
    the vertex gets a defined fallback: the direction smoothed from reliable neighbours, else the world x
    axis in its tangent plane, and a confidence of 0 (see `principal`). dmin is then replaced by the
    smoothest line field (2-RoSy) that follows the measured directions where the surface bends much more
    one way than the other, weighted by the anisotropy, over a length of `smoothing` x the bounding-box
    diagonal: one global sparse solve after Knoppel et al. 2013 (`field`: smooth, see field.py), so
    hatching follows the form, not scanner noise, without the whorls and rings of spreading directions from
    neighbours (`field`: spread, the line-field tensor diffused as Lee et al. after Alliez et al. 2003). Output:
    Arrays with, per object i, o{i}_kmin, o{i}_kmax (n,), o{i}_dmin, o{i}_dmax, o{i}_normal (n, 3),
    o{i}_confidence (n,), o{i}_reason, o{i}_source (n,) uint8 codes, o{i}_key (a digest of the mesh and
    the params); n is the object's mesh vertex count, arrays are in object space. The key covers the mesh
    contents and the params only, never the frame, size, camera or light. A skinned or morphing mesh is
    measured in its rest pose (`Mesh.rest`): the arrays are the rest pose's, the same for every frame, so
    they are computed once for the whole animation."""

    version = "2"
    persist = "always"
    context_keys = frozenset()
    inputs = {"scene": Input(SCENE, "Scene whose meshes to measure; the pipeline's scene when not connected.",
                             optional=True)}
    outputs = {"out": Output(ARRAYS, "Per-object arrays o{i}_kmin, o{i}_kmax, o{i}_dmin, o{i}_dmax, "
                             "o{i}_normal, o{i}_confidence, o{i}_reason, o{i}_source, o{i}_key.")}

    class Params(NodeParams):
        radius: int = Field(DEFAULT_RADIUS, ge=2, le=12, description="libigl's neighbourhood in rings of "
                            "vertices (3 keeps an analytic torus within 5%; larger is smoother but biased).")
        smoothing: float = Field(0.02, ge=0, le=0.5, description="Smoothing length of the hatching field "
                                 "dmin, as a fraction of the bounding-box diagonal (0: libigl's directions as "
                                 "measured); the same on coarse and dense meshes. smooth: l in the energy; "
                                 "spread: the diffusion length (its old default was 0.05).")
        min_confidence: float = Field(0.5, gt=0, le=1, description="Below this a vertex's own direction is "
                                      "replaced by one smoothed from its neighbours.")
        weld: bool = Field(True, description="Measure on the mesh with coincident vertices merged.")
        field: Literal["spread", "smooth"] = Field("smooth", description="How dmin is smoothed: smooth: one "
                                                   "global solve for the smoothest line field aligned to the "
                                                   "measured directions, each weighted by its anisotropy "
                                                   "(Knoppel et al. 2013; see field.py), `smoothing` x "
                                                   "diagonal its length; spread: rounds of 1-ring tensor "
                                                   "averaging (the earlier default, with smoothing 0.05).")

    def key(self, ctx: HashContext, input_keys: dict[str, str]) -> str:
        base = super().key(ctx, input_keys)
        if "scene" in input_keys or ctx.scene is None:
            return base
        return digest([base, [measured(o.mesh).content_hash() for o in ctx.scene.objects]])

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        scene = ctx.input_scene(inputs)
        data: dict[str, np.ndarray] = {}
        done: dict[str, dict[str, np.ndarray]] = {}
        for index, obj in enumerate(scene.objects):
            mesh = measured(obj.mesh)
            h = mesh.content_hash()
            if h not in done:
                done[h] = self.measure(mesh.vertices, mesh.faces, weld=mesh.weld() if self.params.weld else None)
            for name, value in done[h].items():
                data[object_field(index, name)] = value
        data["objects"] = np.array(len(scene.objects), dtype=np.int64)
        return {"out": Arrays(data)}

    def measure(self, V: np.ndarray, F: np.ndarray, weld: tuple[np.ndarray, int] | None = None) -> dict[str, Any]:
        """The per-vertex arrays of one mesh (float32 values, uint8 codes), indexed like V."""
        p = self.params
        V = np.asarray(V, dtype=np.float64)
        F = np.asarray(F, dtype=np.int64)
        if weld is not None:
            wid, nu = weld
            rep = np.full(nu, len(V), dtype=np.int64)
            np.minimum.at(rep, wid, np.arange(len(V)))
            Vm, Fm = V[rep], wid[F]
        else:
            wid, Vm, Fm = np.arange(len(V)), V, F
        key = digest({"mesh": mesh_content_key(V, F, p.radius), "params": p})
        if len(V) == 0:
            res = {"kmin": np.zeros(0, np.float32), "kmax": np.zeros(0, np.float32),
                   "dmin": np.zeros((0, 3), np.float32), "dmax": np.zeros((0, 3), np.float32),
                   "normal": np.zeros((0, 3), np.float32), "confidence": np.zeros(0, np.float32),
                   "reason": np.zeros(0, np.uint8), "source": np.zeros(0, np.uint8)}
            return {**res, "key": np.array(key)}
        c = compute_curvature(Vm, Fm, p.radius, min_confidence=p.min_confidence)
        dmin = np.array(c.dmin)
        source = np.array(c.source)
        rounds = smoothing_rounds(Vm, Fm, p.smoothing)
        if p.field == "smooth" and p.smoothing > 0 and len(Fm):
            from .field import alignment_weight, smooth_field
            from .principal import Reason

            measured = (c.reason == Reason.OK) | (c.reason == Reason.UMBILIC)
            weight = alignment_weight(c.kmin, c.kmax, measured)
            diag = float(np.linalg.norm(Vm.max(axis=0) - Vm.min(axis=0)))
            field, strength = smooth_field(Vm, Fm, c.normal, c.dmin, weight, p.smoothing * diag)
            ok = strength > 1e-3 * max(float(strength.max()), 1e-300)
            dmin[ok] = field[ok]
            source[ok & (source == DirectionSource.FIXED_FRAME)] = DirectionSource.SMOOTHED
        elif rounds:
            dmin = smooth_line_field(Fm, dmin, c.normal, np.maximum(c.confidence, 0.05), rounds,
                                     fixed=c.source == DirectionSource.FIXED_FRAME)
        dmax = np.cross(c.normal, dmin)
        out = {"kmin": c.kmin, "kmax": c.kmax, "dmin": dmin, "dmax": dmax, "normal": c.normal,
               "confidence": c.confidence}
        res = {k: np.ascontiguousarray(v[wid], dtype=np.float32) for k, v in out.items()}
        res["reason"] = np.ascontiguousarray(c.reason[wid], dtype=np.uint8)
        res["source"] = np.ascontiguousarray(source[wid], dtype=np.uint8)
        res["key"] = np.array(key)
        return res


def measured(mesh: Any) -> Any:
    """The mesh whose curvature is measured: a posed (skinned, morphed) mesh's rest pose, so the arrays (in
    rest-pose object space) are the same at every frame and computed once; consumers carry the directions
    with the skin (`Mesh.skin_linear`, pencil_shade)."""
    return mesh.rest if getattr(mesh, "rest", None) is not None else mesh


def smoothing_rounds(V: np.ndarray, F: np.ndarray, length: float, cap: int = 400) -> int:
    """Rounds of 1-ring averaging whose diffusion reaches about `length` x the bounding-box diagonal:
    (length / mean edge)^2, at most `cap`."""
    if length <= 0.0 or len(F) == 0:
        return 0
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    edge = float(np.linalg.norm(V[F[:, [1, 2, 0]]] - V[F], axis=2).mean())
    if edge <= 0.0:
        return 0
    return int(min(cap, max(1, round((length * diag / edge) ** 2))))


def smooth_line_field(F: np.ndarray, d: np.ndarray, normal: np.ndarray, weight: np.ndarray, rounds: int,
                      fixed: np.ndarray | None = None) -> np.ndarray:
    """Diffuses the line-field tensor w d d^T over the mesh (`rounds` of averaging over each vertex and
    its 1-ring), then takes at each vertex the dominant eigenvector projected onto its tangent plane:
    sign-invariant, and vertices of high weight (confidence) dominate their surroundings. Vertices in
    `fixed` (no measured direction anywhere near) keep theirs and give no weight."""
    import scipy.sparse as sp

    n = len(d)
    d = np.asarray(d, dtype=np.float64).copy()
    if rounds <= 0 or n == 0:
        return d
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    ij = (np.r_[e[:, 0], e[:, 1], np.arange(n)], np.r_[e[:, 1], e[:, 0], np.arange(n)])
    adj = sp.csr_matrix((np.ones(2 * len(e) + n), ij), shape=(n, n))
    adj.data[:] = 1.0
    avg = sp.diags(1.0 / np.asarray(adj.sum(axis=1)).ravel()) @ adj
    w = np.asarray(weight, dtype=np.float64).copy()
    free = np.ones(n, dtype=bool) if fixed is None else ~np.asarray(fixed, dtype=bool)
    w[~free] = 0.0
    x, y, z = d.T
    s = np.stack([x * x, y * y, z * z, x * y, x * z, y * z], axis=1) * w[:, None]
    for _ in range(rounds):
        s = avg @ s
    t = np.empty((n, 3, 3))
    t[:, 0, 0], t[:, 1, 1], t[:, 2, 2] = s[:, 0], s[:, 1], s[:, 2]
    t[:, 0, 1] = t[:, 1, 0] = s[:, 3]
    t[:, 0, 2] = t[:, 2, 0] = s[:, 4]
    t[:, 1, 2] = t[:, 2, 1] = s[:, 5]
    proj = np.eye(3)[None] - normal[:, :, None] * normal[:, None, :]
    _, vecs = np.linalg.eigh(proj @ t @ proj)
    new = vecs[:, :, 2]
    new -= np.sum(new * normal, axis=1, keepdims=True) * normal
    length = np.linalg.norm(new, axis=1)
    ok = free & (length > 1e-9) & (np.trace(t, axis1=1, axis2=2) > 1e-12)
    d[ok] = new[ok] / length[ok, None]
    return d


NODE = Curvature
