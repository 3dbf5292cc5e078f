"""Intersection lines: where two faces of one mesh, or of two objects, pass through each other (float64 NumPy).

A model built of parts that interpenetrate (a fish's fins pushed into its body, a character's eyes set into
their sockets, a table's legs into its top) has a visible line where one part enters the other that is none of
its edges: Blender's Line Art draws it as its "intersection" line type, and plotter users ask for it. Here:

* candidate pairs: the faces' bounding boxes binned in a uniform grid (cells the size of the median face's
  box), the pairs that share a cell, then an exact box-overlap test; a face spanning more than MAX_CELLS cells
  along an axis is placed in a grid MAX_CELLS times coarser (and so on) and paired there with every face
  placed so far; faces that share a corner (a welded vertex within one mesh, a
  position within 1e-6 of the scale across two) are left out: neighbours, and parts that meet at an edge,
  meet along an edge or at a corner, which is no intersection line;
* each pair: the segment where the two triangles cross (both triangles' crossings of the other's plane, on the
  line where the planes meet, overlapped). A face crosses the other's plane only with a corner more than
  PLANE_EPS of the scale on each side of it (a corner nearer counts as on the plane): coplanar pairs, a face
  resting on another (a box on a floor) and the float32 slivers round a dense UV sphere's pole give nothing, nor
  does an overlap shorter than TOUCH of the scale;
* on the screen (mesh_lines), an intersection sample within a pixel or so of a drawn line of another kind is
  dropped: a part sunk a hair into another draws its crease once, not twice;
* each segment end is where an edge of one face pierces the other face: its key (edge, pierced face) is shared
  by the segment of the next pair along the curve, so `extract.chain` follows the curve across faces. Where
  the curve passes exactly through an edge of each (parts that mirror each other), the two ends' keys differ;
  ends whose key no other end has join by position (within 1e-9 of the scale).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nodegraph.fsio import compiled

from . import extract

_JIT: Any = None  # intersect_jit, False where Numba is unavailable


def _jit() -> Any:
    """nodes/mesh_lines/intersect_jit.py, or None where Numba cannot be imported or finds no writable place for its
    cache (a warning, once; the NumPy code gives the same pairs, slower; `fsio.compiled`)."""
    global _JIT
    if _JIT is None:
        _JIT = compiled(__package__, "intersect_jit", "mesh_lines: the compiled intersection search is",
                        "the NumPy search, same lines, slower") or False
    return _JIT or None


PAIR_CHUNK = 2_000_000  # candidate pairs made at a time (`_grid_pairs`)
MAX_CELLS = 8  # a face's box spans at most this many grid cells per axis (larger faces: coarser cells for it)
PLANE_EPS = 1e-6  # of the scale: a corner this near the other face's plane is on it (a crossing needs one beyond)
TOUCH = 1e-9  # of the scale: an overlap shorter than this is a touch, not a line
MAX_PAIRS = 4_000_000  # candidate pairs are tested in batches of this many


def face_boxes(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    # corner by corner: the same values as tri.min(axis=1), several times faster over the short middle axis
    return (np.minimum(np.minimum(tri[:, 0], tri[:, 1]), tri[:, 2]),
            np.maximum(np.maximum(tri[:, 0], tri[:, 1]), tri[:, 2]))


def candidate_pairs(lo_a: np.ndarray, hi_a: np.ndarray, lo_b: np.ndarray | None = None,
                    hi_b: np.ndarray | None = None, engine: str = "auto", corners_a: np.ndarray | None = None,
                    corners_b: np.ndarray | None = None) -> np.ndarray:
    """Pairs (k, 2) of faces whose boxes overlap: within one set (i < j) when `lo_b` is None, else (a, b) across
    the two sets. Level 0 is a grid of cells the median box's largest side wide, holding the faces that span at
    most MAX_CELLS cells an axis; each further level is MAX_CELLS times coarser and pairs the faces it takes with
    every face placed so far (`_grid_pairs`). With `corners_a` (and `corners_b` across two sets): (faces, 3) ids
    of each face's corners, and the pairs of faces that share one are left out."""
    same = lo_b is None
    lo = lo_a if same else np.concatenate([lo_a, lo_b])
    hi = hi_a if same else np.concatenate([hi_a, hi_b])
    n_a = len(lo_a)
    if len(lo) < 2 or (not same and (n_a == 0 or len(lo_b) == 0)):
        return np.zeros((0, 2), np.int64)
    corners = None
    if corners_a is not None:
        corners = np.asarray(corners_a if same else np.concatenate([corners_a, corners_b]), np.int64)
    ext = hi - lo
    cell = float(np.median(np.maximum(np.maximum(ext[:, 0], ext[:, 1]), ext[:, 2])))
    scale = float(np.max(hi.max(axis=0) - lo.min(axis=0)))
    if not cell > 0.0:
        cell = scale * 1e-3 or 1.0
    origin = lo.min(axis=0)
    level = np.full(len(lo), -1)
    pairs = []
    k = 0
    while (level < 0).any() and k < 40:  # 8^40 cells hold any finite box
        size = cell * float(MAX_CELLS) ** k
        c0 = np.floor((lo - origin) / size).astype(np.int64)
        span = np.floor((hi - origin) / size).astype(np.int64) - c0 + 1
        fits = (level < 0) & (np.maximum(np.maximum(span[:, 0], span[:, 1]), span[:, 2]) <= MAX_CELLS)
        if k == 0:
            pairs.append(_grid_pairs(c0[fits], span[fits], np.flatnonzero(fits), None, lo, hi, engine, corners))
        else:  # the faces too large for the finer levels against every face placed so far and each other
            placed = (level >= 0) | fits
            pairs.append(_grid_pairs(c0[placed], span[placed], np.flatnonzero(placed), fits[placed], lo, hi,
                                     engine, corners))
        level[fits] = k
        k += 1
    p = np.concatenate(pairs)
    if not same:
        p = p[(p[:, 0] < n_a) & (p[:, 1] >= n_a)]
        p[:, 1] -= n_a
    return p


def _grid_pairs(c0: np.ndarray, span: np.ndarray, ids: np.ndarray, lead: np.ndarray | None = None,
                lo: np.ndarray | None = None, hi: np.ndarray | None = None, engine: str = "auto",
                corners: np.ndarray | None = None) -> np.ndarray:
    """Distinct pairs (i < j) of `ids` whose cell ranges [c0, c0 + span) share a cell, each given once: by the
    cell at the larger of the two ranges' first cells, axis by axis (the first cell they share). With `lead`,
    only the pairs with at least one `lead` face (a coarser level's large faces against the rest). With `lo` and
    `hi` (boxes by id), only the pairs whose boxes overlap. Made PAIR_CHUNK pairs at a time, so that memory
    holds the pairs kept rather than every pair that shares a cell. `engine` "auto": the pair loop compiled
    (intersect_jit.py) where Numba can be imported, the same pairs in the same order; "numpy": this code.
    `corners` (by id): the pairs of faces sharing a corner id are left out."""
    if len(ids) < 2:
        return np.zeros((0, 2), np.int64)
    count = span.prod(axis=1)
    rep = np.repeat(np.arange(len(ids)), count)
    k = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    sx, sy = span[rep, 0], span[rep, 1]
    cell = np.stack([c0[rep, 0] + k % sx, c0[rep, 1] + (k // sx) % sy, c0[rep, 2] + k // (sx * sy)], axis=1)
    del k, sx, sy
    dims = (c0 + span).max(axis=0) + 1
    key = (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2]
    order = np.argsort(key, kind="stable")
    key, rep, cell = key[order], rep[order], cell[order]
    starts = np.r_[0, np.flatnonzero(np.diff(key)) + 1]
    sizes = np.diff(np.r_[starts, len(key)])
    jit = _jit() if engine == "auto" else None
    if jit is not None:  # the same pairs in the same order, one compiled pass over the cells
        boxes = lo is not None and hi is not None
        no_box = np.zeros((0, 3), np.float64)
        return jit.cell_pairs(starts.astype(np.int64), sizes.astype(np.int64), rep.astype(np.int64),
                              cell.astype(np.int64), c0.astype(np.int64), ids.astype(np.int64),
                              lead if lead is not None else np.zeros(0, np.bool_), lead is not None,
                              np.asarray(lo, np.float64) if boxes else no_box,
                              np.asarray(hi, np.float64) if boxes else no_box, boxes,
                              corners if corners is not None else np.zeros((0, 3), np.int64), corners is not None)
    pos = np.arange(len(key))
    if lead is None:  # each entry pairs with the entries after it in its cell
        src = pos
        base = pos + 1
        n = np.repeat(starts + sizes, sizes) - pos - 1
        skip = None
    else:  # each lead entry pairs with every other entry of its cell
        src = np.flatnonzero(lead[rep])
        base = np.repeat(starts, sizes)[src]
        n = np.repeat(sizes, sizes)[src] - 1
        skip = src
    out = []
    total = np.cumsum(n)
    bounds = np.searchsorted(total, np.arange(PAIR_CHUNK, int(total[-1]) + PAIR_CHUNK, PAIR_CHUNK), side="right") \
        if len(total) and total[-1] > 0 else np.zeros(0, np.int64)
    for a0, a1 in zip(np.r_[0, bounds[:-1]], bounds, strict=True):
        if a1 <= a0:
            continue
        cnt = n[a0:a1]
        first = np.repeat(src[a0:a1], cnt)
        second = np.repeat(base[a0:a1], cnt) + (np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt))
        if skip is not None:
            second += second >= first
            both = lead[rep[second]]
            keep = ~both | (rep[first] < rep[second])
            first, second = first[keep], second[keep]
        a, b = rep[first], rep[second]
        own = np.all(cell[first] == np.maximum(c0[a], c0[b]), axis=1)
        a, b = ids[a[own]], ids[b[own]]
        if lo is not None and hi is not None:
            overlap = np.all((lo[a] <= hi[b]) & (lo[b] <= hi[a]), axis=1)
            a, b = a[overlap], b[overlap]
        if corners is not None:
            apart = ~(corners[a][:, :, None] == corners[b][:, None, :]).any(axis=(1, 2))
            a, b = a[apart], b[apart]
        out.append(np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1))
    return np.concatenate(out) if out else np.zeros((0, 2), np.int64)


def _plane_crossing(tri: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where triangles `tri` (k, 3, 3) cross planes whose signed distances at their corners are `d` (k, 3), for
    triangles with corners on both sides (`extract.zero_crossings`): (points (k, 2, 3), the corner each crossing
    edge starts from (k, 2), the corner it ends at (k, 2))."""
    lone, others, ts = extract.zero_crossings(d)
    rows = np.arange(len(tri))[:, None]
    start = np.repeat(lone[:, None], 2, axis=1)
    pa = tri[rows, start]
    return pa + ts[..., None] * (tri[rows, others] - pa), start, others


def tri_tri_segments(ta: np.ndarray, tb: np.ndarray, scale: float) -> dict[str, np.ndarray]:
    """The segments where triangles `ta` (k, 3, 3) and `tb` (k, 3, 3) cross, pair by pair. Returns `hit` (k,) and,
    for the pairs hit, `p` (h, 2, 3) the endpoints, `side` (h, 2) 0 where an edge of a pierces b, 1 where an edge
    of b pierces a, and `edge` (h, 2, 2) that edge's two corners (0-2) in its triangle."""
    na = np.cross(ta[:, 1] - ta[:, 0], ta[:, 2] - ta[:, 0])
    nb = np.cross(tb[:, 1] - tb[:, 0], tb[:, 2] - tb[:, 0])
    la, lb = np.linalg.norm(na, axis=1), np.linalg.norm(nb, axis=1)
    ok = (la > 0.0) & (lb > 0.0)
    na = na / np.where(ok, la, 1.0)[:, None]
    nb = nb / np.where(ok, lb, 1.0)[:, None]
    eps = PLANE_EPS * scale
    da = np.einsum("kij,kj->ki", ta - tb[:, :1], nb)  # a's corners against b's plane
    db = np.einsum("kij,kj->ki", tb - ta[:, :1], na)
    # a crossing has a corner beyond eps on each side: faces that only touch, or a fan of slivers whose float32
    # corners stray from the plane by a rounding error (a dense UV sphere's poles), cross nothing
    cross_a = (da > eps).any(axis=1) & (da < -eps).any(axis=1)
    cross_b = (db > eps).any(axis=1) & (db < -eps).any(axis=1)
    da = np.where(np.abs(da) <= eps, 0.0, da)
    db = np.where(np.abs(db) <= eps, 0.0, db)
    line = np.cross(na, nb)
    ok &= cross_a & cross_b & (np.linalg.norm(line, axis=1) > 1e-12)
    idx = np.flatnonzero(ok)
    out = {"hit": np.zeros(len(ta), bool)}
    if not len(idx):
        out.update(p=np.zeros((0, 2, 3)), side=np.zeros((0, 2), np.int64), edge=np.zeros((0, 2, 2), np.int64))
        return out
    pa, sa, ea = _plane_crossing(ta[idx], da[idx])
    pb, sb, eb = _plane_crossing(tb[idx], db[idx])
    u = line[idx]
    ta_ = np.einsum("kij,kj->ki", pa, u)
    tb_ = np.einsum("kij,kj->ki", pb, u)
    ia_lo, ib_lo = np.argmin(ta_, axis=1), np.argmin(tb_, axis=1)
    rows = np.arange(len(idx))
    a_lo, a_hi = ta_[rows, ia_lo], ta_[rows, 1 - ia_lo]
    b_lo, b_hi = tb_[rows, ib_lo], tb_[rows, 1 - ib_lo]
    lo_from_b = b_lo > a_lo
    hi_from_b = b_hi < a_hi
    lo_t = np.where(lo_from_b, b_lo, a_lo)
    hi_t = np.where(hi_from_b, b_hi, a_hi)
    keep = hi_t - lo_t > TOUCH * scale
    p0 = np.where(lo_from_b[:, None], pb[rows, ib_lo], pa[rows, ia_lo])
    p1 = np.where(hi_from_b[:, None], pb[rows, 1 - ib_lo], pa[rows, 1 - ia_lo])
    e0 = np.where(lo_from_b[:, None], np.stack([sb[rows, ib_lo], eb[rows, ib_lo]], axis=1),
                  np.stack([sa[rows, ia_lo], ea[rows, ia_lo]], axis=1))
    e1 = np.where(hi_from_b[:, None], np.stack([sb[rows, 1 - ib_lo], eb[rows, 1 - ib_lo]], axis=1),
                  np.stack([sa[rows, 1 - ia_lo], ea[rows, 1 - ia_lo]], axis=1))
    out["hit"][idx[keep]] = True
    out["p"] = np.stack([p0, p1], axis=1)[keep]
    out["side"] = np.stack([lo_from_b, hi_from_b], axis=1).astype(np.int64)[keep]
    out["edge"] = np.stack([e0, e1], axis=1)[keep]
    return out


def intersection_segs(va: np.ndarray, fa: np.ndarray, wa: np.ndarray, key_base: int,
                      vb: np.ndarray | None = None, fb: np.ndarray | None = None,
                      wb: np.ndarray | None = None) -> extract.Segs:
    """Intersection segments of mesh a with itself (`vb` None) or with mesh b (both in one space, a's: the
    segments are a's, on a's faces). `wa`, `wb`: welded vertex ids (faces sharing one are not tested, within one
    mesh). Keys start at `key_base`."""
    same = vb is None
    tri_a = va[fa]
    tri_b = tri_a if same else vb[fb]
    lo_a, hi_a = face_boxes(tri_a)
    lo_b, hi_b = (lo_a, hi_a) if same else face_boxes(tri_b)
    hi = np.maximum(hi_a.max(axis=0), hi_b.max(axis=0))
    lo = np.minimum(lo_a.min(axis=0), lo_b.min(axis=0))
    scale = float(np.linalg.norm(hi - lo)) or 1.0
    if same:
        pairs = candidate_pairs(lo_a, hi_a, corners_a=wa[fa])
    else:  # corners at one position (within 1e-6 of the scale) in both meshes: parts that meet at an edge
        q = np.rint(np.concatenate([va, vb]) / (1e-6 * scale)).astype(np.int64)
        _, pos_id = np.unique(q, axis=0, return_inverse=True)
        pos_id = pos_id.reshape(-1)
        pairs = candidate_pairs(lo_a, hi_a, lo_b, hi_b, corners_a=pos_id[:len(va)][fa],
                                corners_b=pos_id[len(va):][fb])
    if not len(pairs):
        return extract.Segs.empty()
    ps, faces, codes = [], [], []
    for s in range(0, len(pairs), MAX_PAIRS):
        pr = pairs[s:s + MAX_PAIRS]
        r = tri_tri_segments(tri_a[pr[:, 0]], tri_b[pr[:, 1]], scale)
        if not r["hit"].any():
            continue
        pr = pr[r["hit"]]
        # the key of each end: (which mesh's edge, its welded corners, the other face)
        f_edge = np.where(r["side"] == 0, pr[:, :1], pr[:, 1:])  # (h, 2) the face whose edge it is
        f_other = np.where(r["side"] == 0, pr[:, 1:], pr[:, :1])
        ea, eb = r["edge"][..., 0], r["edge"][..., 1]
        if same:
            c0, c1 = wa[fa[f_edge, ea]], wa[fa[f_edge, eb]]
        else:
            on_a = r["side"] == 0  # the edge is a's; else b's
            fa_i, fb_i = np.where(on_a, f_edge, 0), np.where(on_a, 0, f_edge)
            c0 = np.where(on_a, wa[fa[fa_i, ea]], wb[fb[fb_i, ea]])
            c1 = np.where(on_a, wa[fa[fa_i, eb]], wb[fb[fb_i, eb]])
        mesh_of_edge = r["side"] if not same else np.zeros_like(r["side"])
        codes.append(np.stack([mesh_of_edge, np.minimum(c0, c1), np.maximum(c0, c1), f_other], axis=-1))
        ps.append(r["p"])
        faces.append(pr[:, 0])
    if not ps:
        return extract.Segs.empty()
    p = np.concatenate(ps)
    face = np.concatenate(faces).astype(np.int64)
    code = np.concatenate(codes).reshape(-1, 4)
    _, inv, count = np.unique(code, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    # where the curve crosses an edge of the other mesh exactly at one of its own edges (mirror-image parts), the
    # two segments' ends carry different keys at one point: ends left alone by their key join by position
    lone = np.flatnonzero(count[inv] == 1)
    if len(lone) > 1:
        q = np.rint(p.reshape(-1, 3)[lone] / (1e-9 * scale)).astype(np.int64)
        _, at, group, n = np.unique(q, axis=0, return_index=True, return_inverse=True, return_counts=True)
        group = group.reshape(-1)
        joined = n[group] > 1
        inv[lone[joined]] = inv[lone[at[group[joined]]]]
    key = key_base + inv.reshape(-1, 2).astype(np.int64)
    tri = va[fa[face]]
    bary = np.stack([extract.barycentric(tri, p[:, k]) for k in range(2)], axis=1)
    return extract.Segs(p, bary, face, key, np.full(len(face), extract.KIND["intersection"], np.uint8),
                        np.ones(len(face), bool))
