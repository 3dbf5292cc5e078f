"""Straight hatching on flat faces (nodes/_shared/planes.py finds the planes and their directions): the pixels
of the G-buffer that lie on each plane, and lines fixed on the plane drawn through them.

The lines are {p : (p - c) . across = m G}, c the mesh's bounding-box centre, nested grids of gaps G x 2^i with G
on a ladder of powers of two of the mesh's diagonal. The plane's grid is the one spaced nearest the tone's spacing
at its median pixel; where a plane recedes so far that its lines crowd under half the spacing every other line
stops, and where they spread over twice the spacing lines come in between (`plane_lines`). A camera that moves
keeps every line where it was on the plane; lines of a grid come and go where the spacing crosses a bound, or all
over the plane where its median spacing moves the plane's grid a step."""

from __future__ import annotations

from typing import Any

import numpy as np

from .._shared.planes import PLANE_TOL, Planes, cached_planes
from .._shared.surface_points import project

MAX_LEVEL = 40  # line 0 belongs to every grid
EDGE_MARGIN = 0.4  # a plane line running along its plane's edge closer than this share of the spacing is left out
NORMAL_COS = 0.999  # a pixel's view-space normal within about 2.6 degrees of its plane's (16-bit normals)


def pixel_planes(planes: Planes, points: np.ndarray, nview: np.ndarray, normal_matrix: np.ndarray) -> np.ndarray:
    """(n,) int: the index of the plane each of an object's pixels lies on, -1 for none. `points` (n, 3) their
    object-space positions (the G-buffer's), `nview` (n, 3) their view-space normals, `normal_matrix` (3, 3)
    object to view space for normals. A pixel lies on a plane where its position is within PLANE_TOL x diagonal
    of it and its normal within NORMAL_COS of the plane's (the nearest plane where several pass)."""
    got = np.full(len(points), -1, np.int64)
    if not len(planes) or not len(points):
        return got
    nv = nview / np.maximum(np.linalg.norm(nview, axis=1, keepdims=True), 1e-12)
    pn = planes.normal @ normal_matrix.T
    pn /= np.maximum(np.linalg.norm(pn, axis=1, keepdims=True), 1e-300)
    best = np.full(len(points), np.inf)
    tol = PLANE_TOL * planes.diagonal
    for k in range(len(planes)):
        dist = np.abs(points @ planes.normal[k] - planes.offset[k])
        hit = (dist <= tol) & (nv @ pn[k] >= NORMAL_COS) & (dist < best)
        got[hit], best[hit] = k, dist[hit]
    return got


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
                labels: np.ndarray, label: int, pixels: np.ndarray, mvp: np.ndarray, size: tuple[int, int],
                spacing_px: float, diagonal: float, step: float, min_length: float,
                scratch: np.ndarray | None = None, local: np.ndarray | None = None,
                edge: np.ndarray | None = None) -> list[np.ndarray]:
    """Straight hatching of one plane, fixed on it: the lines {p on the plane : p . step_dir = m G} (direction
    `line`), G = diagonal x 2^j the finest gap any visible pixel may need. Line m belongs to the grids of gap
    G x 2^i for i <= v(m) (`valuation`). The plane's grid is the one spaced nearest `spacing_px` on the screen
    at its median pixel; its lines and coarser grids' are drawn where their grid's lines lie at least
    spacing_px / 2 apart on the screen, finer grids' where theirs lie at least spacing_px apart. So a plane seen
    with mild perspective keeps one grid all over (0.5-2 x spacing_px), and where a plane recedes far, every
    other line stops where the lines crowd, or lines come in between where they spread. The plane's pixels are
    those where `labels` (h, w; rows bottom-up) is `label`; `pixels` their flat indices and `points` (n, 3) their
    object-space positions, in the same order. `scratch`: an (h, w) float array to write the spacing into (its
    other pixels are not read). `local` (h, w): the spacing wanted at each pixel (the tone's; inf: no hatching
    there), which then takes spacing_px's place in the two bounds pixel by pixel, so a plane whose tone varies
    (a point light) is hatched denser where it is darker; spacing_px still chooses the plane's grid. Each line is
    sampled every `step` px along its projection and cut where it leaves the plane's pixels or its grid; pieces
    shorter than `min_length` px are dropped, and, where `edge` (h, w: each pixel's distance in px to the nearest
    pixel off its plane) is given, pieces that run along the plane's edge closer than EDGE_MARGIN x the wanted
    spacing (their median distance): a hatch line a pixel beside an outline drew a doubled, heavy edge on thin
    faces. A piece that crosses the plane keeps its ends at the edges. Window coordinates."""
    w, h = size
    eps = 1e-3 * diagonal
    here, ok = project(points, mvp, size)
    across, ok2 = project(points + eps * step_dir, mvp, size)
    ahead, ok3 = project(points + eps * line, mvp, size)
    along = ahead - here
    along /= np.maximum(np.linalg.norm(along, axis=1, keepdims=True), 1e-12)
    d = across - here
    ppu = np.where(ok & ok2 & ok3, np.abs(along[:, 0] * d[:, 1] - along[:, 1] * d[:, 0]) / eps, 0.0)
    if not (ppu > 1e-9).any():
        return []
    finest = spacing_px
    if local is not None:
        wanted = local.ravel()[pixels]
        finest = min(spacing_px, float(wanted[np.isfinite(wanted)].min())) if np.isfinite(wanted).any() else finest
    gap = float(diagonal * 2.0 ** np.floor(np.log2(finest / (ppu.max() * diagonal))))
    # the plane's own grid: spaced nearest spacing_px at its median pixel
    base_level = max(int(np.round(np.log2(spacing_px / (gap * float(np.median(ppu[ppu > 1e-9])))))), 0)
    grid = np.empty(labels.shape) if scratch is None else scratch
    grid.ravel()[pixels] = ppu * gap  # px between neighbouring lines of the finest grid, at the plane's pixels
    u = points @ step_dir
    ms = np.arange(np.ceil(u.min() / gap), np.floor(u.max() / gap) + 1).astype(np.int64)
    if not len(ms):
        return []
    centre = points.mean(axis=0)
    centre = centre - normal * (centre @ normal - offset)
    base = centre + np.outer(ms * gap - centre @ step_dir, step_dir)
    p0, ok0 = project(base, mvp, size)
    p1, ok1 = project(base + eps * line, mvp, size)
    keep = ok0 & ok1
    p0, ms = p0[keep], ms[keep]
    dirs = p1[keep] - p0
    dirs /= np.maximum(np.linalg.norm(dirs, axis=1, keepdims=True), 1e-12)
    v = valuation(ms)
    levels = 2.0 ** v.astype(np.float64)
    # the plane's grid and coarser ones stay down to half the spacing; finer ones come in from the full spacing
    share = np.where(v >= base_level, 0.5, 1.0)  # of the wanted spacing
    reach = float(np.hypot(w, h))
    t = np.arange(-reach, reach + step, step)
    out: list[np.ndarray] = []
    for origin, dv, level, part in zip(p0, dirs, levels, share, strict=True):
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
        want = spacing_px if local is None else local[r, c]
        drawn = (labels[r, c] == label) & (grid[r, c] * level >= part * want)
        if not drawn.any():
            continue
        edges = np.flatnonzero(np.diff(np.r_[0, drawn.astype(np.int8), 0]))
        for s0, s1 in zip(edges[::2], edges[1::2], strict=True):
            if (s1 - s0 - 1) * step < max(min_length, step):
                continue
            if edge is not None:  # a piece running along its plane's edge, closer than the margin, is left out
                near = edge[r[s0:s1], c[s0:s1]]
                wanted = want if np.isscalar(want) else want[s0:s1]
                if np.median(near - EDGE_MARGIN * wanted) < 0.0:
                    continue
            out.append(xy[s0:s1])
    return out


class ScenePlanes:
    """The planes seen in a frame: `plane` (h, w) int, an index per plane seen (-1 off the planes); for each index
    its object's planes, its own index among them, the object's model-view-projection, its pixels' flat indices
    and their object-space positions; `flat_vertices` per object index (Planes.flat_vertices)."""

    def __init__(self, plane: np.ndarray, entries: list[tuple[Planes, int, np.ndarray, np.ndarray, np.ndarray]],
                 flat_vertices: dict[int, np.ndarray], size: tuple[int, int], step: float) -> None:
        self.plane, self.entries = plane, entries
        self.flat_vertices, self.size, self.step = flat_vertices, size, step
        self._edge: np.ndarray | None = None

    def edge(self) -> np.ndarray:
        """(h, w) each pixel's distance in px to the nearest pixel off its plane (another plane, the background or
        off the image), made once a frame for both families."""
        if self._edge is None:
            from scipy.ndimage import distance_transform_edt

            lab = self.plane
            rim = np.zeros(lab.shape, bool)  # pixels beside a pixel of another label, or on the image's border
            rim[:-1] |= lab[:-1] != lab[1:]
            rim[1:] |= lab[1:] != lab[:-1]
            rim[:, :-1] |= lab[:, :-1] != lab[:, 1:]
            rim[:, 1:] |= lab[:, 1:] != lab[:, :-1]
            rim[[0, -1]] = True
            rim[:, [0, -1]] = True
            self._edge = distance_transform_edt(~rim) + 0.5
        return self._edge

    def hatching(self, family: int, bright: np.ndarray, limit: float, lo: float, hi: float,
                 min_length: float) -> list[np.ndarray]:
        """Family 0 (along each plane's outline) or 1 (across it) where the brightness is under `limit`, spaced
        lo + (hi - lo) x brightness px pixel by pixel as the streamlines are (the plane's grid from the median
        of its hatched pixels)."""
        out: list[np.ndarray] = []
        scratch = np.empty(self.plane.shape)
        edge = self.edge()
        tone = np.clip(bright, 0.0, 1.0)
        local = np.where(bright < limit, lo + (hi - lo) * tone, np.inf)
        flat_bright = tone.ravel()
        for g, (pl, k, mvp, pixels, points) in enumerate(self.entries):
            hatched = flat_bright[pixels][bright.ravel()[pixels] < limit]
            if not len(hatched):
                continue
            b = float(np.median(hatched))
            line, across = (pl.along[k], pl.across[k]) if family == 0 else (pl.across[k], pl.along[k])
            # counted from the mesh's centre, so the lines lie on the plane alike wherever the mesh is
            shift = np.eye(4)
            shift[:3, 3] = pl.centre
            out += plane_lines(points - pl.centre, pl.normal[k], float(pl.offset[k] - pl.normal[k] @ pl.centre), line,
                               across, self.plane, g, pixels, mvp @ shift, self.size,
                               lo + (hi - lo) * b, pl.diagonal, self.step, min_length, scratch, local, edge)
        return out


def scene_planes(scene: Any, view: np.ndarray, proj: np.ndarray, pos: np.ndarray, nview: np.ndarray,
                 ids: np.ndarray, size: tuple[int, int], step: float = 1.0) -> ScenePlanes | None:
    """The pixels on each rigid mesh's planes, or None where no pixel lies on one. Posed (skinned, morphed)
    meshes are left to the curvature field: `position` holds their rest pose."""
    from nodegraph.scene import origin

    plane = np.full(ids.shape, -1, np.int64)
    entries: list[tuple[Planes, int, np.ndarray, np.ndarray, np.ndarray]] = []
    flat_vertices: dict[int, np.ndarray] = {}
    flat_ids = ids.ravel()
    order = np.argsort(flat_ids, kind="stable")  # every object's pixels, grouped
    bounds = np.searchsorted(flat_ids[order], np.arange(len(scene.objects) + 2))
    pos_flat = pos[..., :3].reshape(-1, 3)
    n_flat = nview.reshape(-1, 3)
    for index, obj in enumerate(scene.objects):
        mesh = obj.mesh
        pixels = order[bounds[index + 1]:bounds[index + 2]]
        if mesh.rest is not None or not len(pixels):
            continue
        planes = cached_planes(mesh)
        if not len(planes):
            continue
        flat_vertices[index] = planes.flat_vertices
        mv = view @ np.asarray(obj.transform, np.float64)
        if abs(np.linalg.det(mv[:3, :3])) < 1e-300:
            continue
        points = pos_flat[pixels].astype(np.float64) + origin.mesh_origin(mesh)
        which = pixel_planes(planes, points, n_flat[pixels].astype(np.float64), np.linalg.inv(mv[:3, :3]).T)
        mvp = proj @ mv
        by = np.argsort(which, kind="stable")
        cuts = np.searchsorted(which[by], np.arange(len(planes) + 1))
        for k in range(len(planes)):
            sel = by[cuts[k]:cuts[k + 1]]
            if not len(sel):
                continue
            plane.ravel()[pixels[sel]] = len(entries)
            entries.append((planes, k, mvp, pixels[sel], points[sel]))
    if not entries:
        return None
    return ScenePlanes(plane, entries, flat_vertices, size, step)
