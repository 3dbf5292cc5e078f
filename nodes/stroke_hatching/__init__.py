"""stroke_hatching: hatching as vector strokes: evenly spaced streamlines of the smoothed curvature directions
over the visible surfaces, spaced by tone, cross-hatched in the darkest tones."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from nodegraph import fsio
from nodegraph.errors import NodeError
from nodegraph.node import HashContext, Input, Node, NodeParams, Output, RunContext
from nodegraph.scene import origin
from nodegraph.types import ARRAYS, SCENE, STROKES, Texture
from nodegraph.values import LINE_KINDS, Strokes

from .._shared.curvature import object_field
from .._shared.pencil import view_light
from .._shared.surface_points import project, surface_points
from . import planes, streamlines

HATCHING = LINE_KINDS.index("hatching")


class StrokeHatching(Node):
    """Hatching as strokes (a vector form of pencil_shade's hatching). Each object's per-vertex minimum- and
    maximum-curvature directions (curvature node) are projected to the screen at its visible vertices (its depth
    within `depth_tolerance` of the depth buffer and its object id at its pixel), weighted by how little they are
    foreshortened, and summed as structure tensors on a grid of `cell` pixels smoothed by a Gaussian of
    `smoothing` pixels: the smoothed line field. Brightness b = max(N.L, 0) from the G-buffer's view-space normal
    and the scene light (or the luminance of `shading` where connected), blurred by `cell`. Streamlines of the
    minimum-curvature field (Jobard and Lefer 1997: integrated both ways from a seed in steps of `step` pixels,
    stopped closer than stop_ratio x d_sep to another streamline, seeds d_sep to either side of each one) where
    b < `white`, d_sep = spacing[0] + (spacing[1] - spacing[0]) x b (darker: denser); where b < `cross_below` a
    second family along the maximum-curvature field. Streamlines stay on the object they start on and are dropped
    shorter than `min_length`. Output strokes of kind "hatching", visible, with depth, object, and `pos` (the
    object-space surface point) where `position` is connected; spacing, step and lengths are in pixels at the
    reference size (times px_scale). `anchor: surface` seeds from points fixed on the surfaces in a fixed order
    instead (surface_seeds), so a film's hatching holds to its objects. `planes` (with `position` connected):
    the flat faces of a rigid mesh are hatched with straight lines fixed on the plane instead, along its outline's
    dominant direction and spaced by its tone, converging in perspective (module planes)."""

    version = "3"
    context_keys = frozenset({"size", "frame", "scene", "camera", "px_scale"})
    inputs = {
        "curvature": Input(ARRAYS, "Per-object curvature arrays (curvature.out) of the same scene."),
        "linear_depth": Input(Texture("R32F"), "Linear view depth (rasterize.linear_depth)."),
        "normal": Input(Texture("RGBA16F"), "View-space normal (rasterize.normal): brightness N.L."),
        "object_id": Input(Texture("R32F"), "Object index + 1 (rasterize.object_id)."),
        "shading": Input(Texture("RGBA8"), "Lit colour (rasterize.color with lit): brightness from its luminance "
                         "instead of N.L.", optional=True),
        "position": Input(Texture("RGBA32F"), "Object-space position (rasterize.position): the strokes' `pos`.",
                          optional=True),
        "lines": Input(STROKES, "Other strokes (mesh_lines.strokes) to hand on with the hatching in `combined`.",
                       optional=True),
        "scene": Input(SCENE, "Scene; the pipeline's scene when not connected.", optional=True),
    }
    outputs = {
        "strokes": Output(STROKES, "The hatching strokes."),
        "combined": Output(STROKES, "`lines` followed by the hatching strokes (one SVG layer each kind)."),
    }

    class Params(NodeParams):
        spacing: tuple[float, float] = Field((4.0, 14.0), description="Separation d_sep in pixels in the darkest "
                                             "and the lightest hatched tone.")
        white: float = Field(0.85, ge=0, le=1, description="No hatching where the brightness is above this.")
        cross_below: float = Field(0.3, ge=0, le=1, description="Cross-hatching (max-curvature family) where the "
                                   "brightness is below this.")
        stop_ratio: float = Field(0.5, gt=0, le=1, description="A streamline stops closer than stop_ratio x d_sep "
                                  "to another (Jobard and Lefer's d_test).")
        step: float = Field(1.5, gt=0, le=8, description="Integration step in pixels.")
        cell: float = Field(4.0, ge=1, le=64, description="Grid cell of the direction field in pixels.")
        smoothing: float = Field(10.0, ge=0, le=200, description="Gaussian smoothing of the direction field "
                                 "(pixels).")
        min_length: float = Field(8.0, ge=0, le=1000, description="Streamlines shorter than this (pixels) are "
                                  "dropped.")
        depth_tolerance: float = Field(0.02, gt=0, le=1, description="A vertex is visible within this fraction "
                                       "of its depth of the depth buffer.")
        width: float = Field(0.8, gt=0, le=64, description="Stroke width in pixels at the reference size.")
        tone: float = Field(1.0, ge=0, le=1, description="Darkness of the strokes.")
        anchor: Literal["screen", "surface"] = Field("screen", description="Where streamlines start: `screen`, "
                                                     "a pixel grid, darkest first, and Jobard and Lefer's seeds beside "
                                                     "each streamline (the most even spacing); `surface`, points "
                                                     "fixed on each object's surface (faces and barycentric "
                                                     "coordinates) in a fixed order, so films keep their hatching "
                                                     "from frame to frame.")

        planes: bool = Field(True, description="Flat faces (planes over 0.5 % of their mesh's area) hatched "
                             "with straight parallel lines fixed on the plane, along its outline; needs `position`. "
                             "Off: streamlines of the curvature field, blended from the faces' corners, everywhere.")

    def hash_extra(self, ctx: HashContext) -> Any:
        return origin.hash_extra(ctx.scene, ctx.frame)

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        scene = ctx.input_scene(inputs)
        depth_tex = inputs["linear_depth"]
        w, h = depth_tex.size
        depth = depth_tex.read()[..., 0].astype(np.float64)
        ids = np.rint(inputs["object_id"].read()[..., 0]).astype(np.int64)
        cam = scene.camera_at(ctx.frame)
        view, proj = cam.view_matrix(), cam.projection_matrix(w / h)
        pos = inputs["position"].read() if inputs.get("position") is not None else None
        use_planes = p.planes and pos is not None
        nview = inputs["normal"].read()[..., :3].astype(np.float64) \
            if use_planes or inputs.get("shading") is None else None
        if inputs.get("shading") is not None:
            rgb = inputs["shading"].read()[..., :3].astype(np.float64)
            bright = rgb @ np.array([0.2126, 0.7152, 0.0722])
        else:
            bright = np.maximum(nview @ view_light(scene, cam), 0.0)
        bright = np.where(ids > 0, bright, 1.0)
        from scipy.ndimage import gaussian_filter

        raw = bright  # the planes' tone: their own pixels', not blurred across their edges
        bright = gaussian_filter(bright, p.cell * ctx.px_scale * 0.5, mode="nearest")
        s = ctx.px_scale
        lo, hi = p.spacing[0] * s, p.spacing[1] * s
        lines: list[np.ndarray] = []
        flat = planes.scene_planes(scene, view, proj, pos, nview, ids, (w, h), p.step * s) if use_planes else None
        curved = ids  # the pixels the streamlines cover: all but the planes'
        if flat is not None:
            for family, limit in ((0, p.white), (1, p.cross_below)):
                lines += flat.hatching(family, raw, limit, lo, hi, p.min_length * s)
            curved = np.where(flat.plane >= 0, 0, ids)
        fields = [self._field(inputs["curvature"], scene, view, proj, depth, curved, name, (w, h), s,
                              flat.flat_vertices if flat is not None else None) for name in ("dmin", "dmax")]
        anchored = surface_seeds(scene, view, proj, depth, curved, (w, h), lo, p.depth_tolerance) \
            if p.anchor == "surface" else None
        for family, limit in ((0, p.white), (1, p.cross_below)):
            lines += hatch(fields[family], bright, curved, (w, h), lo, hi, limit, p.stop_ratio, p.step * s,
                           p.min_length * s, p.cell * s, anchored)
        strokes = to_strokes(lines, (w, h), depth, ids, pos, p.width * s, p.tone)
        out: dict[str, Any] = {"strokes": strokes}
        if "combined" in needed:
            out["combined"] = concat(inputs.get("lines"), strokes)
        return out

    def _field(self, curv: Any, scene: Any, view: np.ndarray, proj: np.ndarray, depth: np.ndarray, ids: np.ndarray,
               name: str, size: tuple[int, int], px_scale: float,
               flat_vertices: dict[int, np.ndarray] | None = None) -> np.ndarray:
        """The smoothed tensor field of one curvature direction over every object's visible vertices, less those
        on planes only (`flat_vertices` per object index: their directions are measured across creases)."""
        w, h = size
        pts, dirs, wts = [], [], []
        for index, obj in enumerate(scene.objects):
            key = object_field(index, name)
            if key not in curv.data:
                raise NodeError(f"the curvature input has no arrays for object {index}; connect the curvature node "
                                "of the same scene", self.node.id, self.node.type_name)
            d = np.asarray(curv.data[key], np.float64)
            v = np.asarray(obj.mesh.vertices, np.float64)
            if d.shape != v.shape:
                raise NodeError(f"curvature of object {index} has {d.shape[0]} vertices, its mesh {v.shape[0]}; "
                                "connect the curvature node of the same scene", self.node.id, self.node.type_name)
            mv = view @ np.asarray(obj.transform, np.float64)
            vv = v @ mv[:3, :3].T + mv[:3, 3]
            dv = d @ mv[:3, :3].T
            xy, ok = project(vv, proj, size)
            xy2, ok2 = project(vv + 1e-3 * dv * np.maximum(np.abs(vv[:, 2:3]), 1e-6), proj, size)
            sd = xy2 - xy
            ln = np.hypot(*sd.T)
            ix = np.clip(xy[:, 0].astype(int), 0, w - 1)
            iy = np.clip(xy[:, 1].astype(int), 0, h - 1)
            inside = ok & ok2 & (xy[:, 0] >= 0) & (xy[:, 0] < w) & (xy[:, 1] >= 0) & (xy[:, 1] < h)
            vis = inside & (ids[iy, ix] == index + 1) & \
                (np.abs(depth[iy, ix] + vv[:, 2]) <= p_tol(self) * np.maximum(-vv[:, 2], 1e-9)) & (ln > 0)
            if flat_vertices is not None and index in flat_vertices:
                vis &= ~flat_vertices[index]
            fore = np.linalg.norm(dv[:, :2], axis=1) / np.maximum(np.linalg.norm(dv, axis=1), 1e-12)
            pts.append(xy[vis])
            dirs.append(sd[vis] / ln[vis, None])
            wts.append(fore[vis] ** 2)
        allp = np.concatenate(pts) if pts else np.zeros((0, 2))
        return streamlines.tensor_field(allp, np.concatenate(dirs) if dirs else np.zeros((0, 2)),
                                        np.concatenate(wts) if wts else np.zeros(0), size,
                                        self.params.cell * px_scale, self.params.smoothing * px_scale,
                                        fill=covered(ids, self.params.cell * px_scale))


def covered(ids: np.ndarray, cell: float) -> np.ndarray:
    """(rows, cols) whether an object covers any pixel of each cell of `cell` pixels (tensor_field's grid)."""
    h, w = ids.shape
    cols, rows = int(np.ceil(w / cell)), int(np.ceil(h / cell))
    ys, xs = np.nonzero(ids > 0)
    out = np.zeros((rows, cols), dtype=bool)
    out[np.minimum((ys / cell).astype(int), rows - 1), np.minimum((xs / cell).astype(int), cols - 1)] = True
    return out


def p_tol(node: StrokeHatching) -> float:
    return node.params.depth_tolerance


def surface_seeds(scene: Any, view: np.ndarray, proj: np.ndarray, depth: np.ndarray, ids: np.ndarray,
                  size: tuple[int, int], spacing: float, tol: float) -> np.ndarray:
    """Seeds fixed on the surfaces: (x, y, object id) rows in a fixed order: the visible points of
    `surface_points` at a cell of spacing / 2 pixels, the first in their order in each cell of spacing / 2
    pixels."""
    w = size[0]
    cell = max(spacing * 0.5, 1.0)
    rows, _ = surface_points(scene, view, proj, depth, ids, size, cell, tol)
    gx = (rows[:, 0] / cell).astype(np.int64)
    gy = (rows[:, 1] / cell).astype(np.int64)
    _, first = np.unique(gy * (int(w / cell) + 2) + gx, return_index=True)
    return rows[np.sort(first)]


def hatch(tensor: np.ndarray, bright: np.ndarray, ids: np.ndarray, size: tuple[int, int], lo: float, hi: float,
          limit: float, stop_ratio: float, step: float, min_length: float, cell: float,
          anchored: np.ndarray | None = None, engine: Literal["auto", "jit", "python"] = "auto") -> list[np.ndarray]:
    """One family of evenly spaced streamlines of `tensor` (streamlines.tensor_field) where brightness < limit,
    each on the object it starts on; from `anchored` seeds (surface_seeds) in their order where given.
    `engine`: "python" runs streamlines.Hatcher (the reference), "jit" the same loop compiled (module `jit`: the
    same streamlines bit for bit), "auto" compiled where Numba is there."""
    w, h = size
    dirs = streamlines.principal(tensor)
    strength = tensor[..., 0] + tensor[..., 2]
    rows, cols = dirs.shape[:2]
    if engine not in ("auto", "jit", "python"):
        raise ValueError(f"engine: expected 'auto', 'jit' or 'python', got {engine!r}")
    jit = _jit() if engine != "python" else None
    if jit is None and engine == "jit":
        raise RuntimeError("engine 'jit' needs numba, which could not be imported")
    if jit is not None:
        return _hatch_jit(jit, dirs, strength, bright, ids, size, lo, hi, limit, stop_ratio, step, min_length, cell,
                          anchored)
    state = {"obj": 0}

    def at(x: float, y: float) -> tuple[int, int]:
        return min(max(int(y), 0), h - 1), min(max(int(x), 0), w - 1)

    def field(x: float, y: float) -> tuple[float, float] | None:
        r, c = at(x, y)
        if ids[r, c] == 0 or ids[r, c] != state["obj"] or bright[r, c] >= limit:
            return None
        gr, gc = min(int(y / cell), rows - 1), min(int(x / cell), cols - 1)
        if strength[gr, gc] <= streamlines.EMPTY:
            return None
        d = dirs[gr, gc]
        return float(d[0]), float(d[1])

    def dsep(x: float, y: float) -> float:
        r, c = at(x, y)
        return lo + (hi - lo) * min(max(float(bright[r, c]), 0.0), 1.0)

    hatcher = streamlines.Hatcher(size, field, dsep, hi, stop_ratio, step, min_length)
    if anchored is not None:
        r = np.clip(anchored[:, 1].astype(int), 0, h - 1)
        c = np.clip(anchored[:, 0].astype(int), 0, w - 1)
        use = anchored[bright[r, c] < limit]
        for obj in np.unique(use[:, 2]):
            state["obj"] = int(obj)
            hatcher.run_fixed(use[use[:, 2] == obj, :2])
        return hatcher.lines
    seeds, objs = grid_seeds(bright, ids, (w, h), lo, limit)
    for obj in np.unique(objs):
        state["obj"] = int(obj)
        hatcher.run(seeds[objs == obj])
    return hatcher.lines


def grid_seeds(bright: np.ndarray, ids: np.ndarray, size: tuple[int, int], lo: float,
               limit: float) -> tuple[np.ndarray, np.ndarray]:
    """The screen-anchored seeds: a grid of max(lo, 2) px kept on objects darker than `limit`, darkest first
    (the dense regions are laid out before the light ones reach into them), and each seed's object id."""
    w, h = size
    g = max(lo, 2.0)
    ys, xs = np.mgrid[0.5 * g:h:g, 0.5 * g:w:g]
    seeds = np.c_[xs.ravel(), ys.ravel()]
    r = np.clip(seeds[:, 1].astype(int), 0, h - 1)
    c = np.clip(seeds[:, 0].astype(int), 0, w - 1)
    keep = (ids[r, c] > 0) & (bright[r, c] < limit)
    order = np.argsort(bright[r[keep], c[keep]], kind="stable")
    return seeds[keep][order], ids[r[keep], c[keep]][order]


_JIT: Any = None  # the module `jit`, False where Numba cannot be imported or cache its code


def _jit() -> Any:
    """The compiled streamline loop (module `jit`), or None where Numba cannot be imported or finds no writable
    place for its cache (a warning, once: the Python loop gives the same streamlines, slower; `fsio.compiled`)."""
    global _JIT
    if _JIT is None:
        _JIT = fsio.compiled(__package__, "jit", "stroke_hatching: the compiled streamlines are",
                             "the Python loop, same strokes, much slower") or False
    return _JIT or None


def _hatch_jit(jit: Any, dirs: np.ndarray, strength: np.ndarray, bright: np.ndarray, ids: np.ndarray,
               size: tuple[int, int], lo: float, hi: float, limit: float, stop_ratio: float, step: float,
               min_length: float, cell: float, anchored: np.ndarray | None) -> list[np.ndarray]:
    """hatch's seeds as the Python path makes them, grouped by object in the order it runs the groups, and the
    streamlines grown by `jit.hatch_lines`."""
    w, h = size
    bright = np.ascontiguousarray(bright, np.float64)
    ids = np.ascontiguousarray(ids, np.int64)
    if bright.shape != (h, w) or ids.shape != (h, w):
        raise ValueError(f"bright {bright.shape} and ids {ids.shape} must be (h, w) = {(h, w)}")
    if anchored is not None:
        r = np.clip(anchored[:, 1].astype(int), 0, h - 1)
        c = np.clip(anchored[:, 0].astype(int), 0, w - 1)
        use = anchored[bright[r, c] < limit]
        seeds, objs = use[:, :2], use[:, 2].astype(np.int64)
    else:
        seeds, objs = grid_seeds(bright, ids, (w, h), lo, limit)
    group = np.argsort(objs, kind="stable")  # the Python path: np.unique's order, each object's seeds in order
    xy, starts = jit.hatch_lines(np.ascontiguousarray(dirs, np.float64), np.ascontiguousarray(strength, np.float64),
                                 ids, bright, np.ascontiguousarray(seeds[group], np.float64),
                                 np.ascontiguousarray(objs[group]), float(limit), float(lo), float(hi), float(cell),
                                 float(stop_ratio), float(step), float(min_length), 4000, anchored is None)
    return [xy[a:b] for a, b in zip(starts[:-1], starts[1:], strict=True)]


def to_strokes(lines: list[np.ndarray], size: tuple[int, int], depth: np.ndarray, ids: np.ndarray,
               pos: np.ndarray | None, width: float, tone: float) -> Strokes:
    w, h = size
    xy = np.concatenate(lines) if lines else np.zeros((0, 2))
    starts = np.r_[0, np.cumsum([len(q) for q in lines])].astype(np.int64)
    r = np.clip(xy[:, 1].astype(int), 0, h - 1)
    c = np.clip(xy[:, 0].astype(int), 0, w - 1)
    n = len(xy)
    attrs = {"depth": depth[r, c].astype(np.float32), "obj": (ids[r, c] - 1).astype(np.int32),
             "kind": np.full(n, HATCHING, np.uint8), "tone": np.full(n, tone, np.float32),
             "width": np.full(n, width, np.float32)}
    if pos is not None:
        attrs["pos"] = pos[r, c, :3].astype(np.float32)
    return Strokes.from_arrays(xy.astype(np.float32), starts, size, width, attrs=attrs)


def concat(first: Strokes | None, second: Strokes) -> Strokes:
    """The strokes of `first` then those of `second` (the first one's size, width and colour)."""
    if first is None or len(first) == 0:
        return second
    starts = np.r_[first.starts, first.n_vertices + second.starts[1:]].astype(np.int64)
    xy = np.concatenate([first.xy, second.xy])
    attrs = {}
    for k in first.attrs:
        b = second.attrs[k]
        if k == "width":
            b = np.where(np.isnan(b), second.width, b).astype(b.dtype)
        attrs[k] = np.concatenate([first.attrs[k], b])
    return Strokes.from_arrays(xy, starts, first.size, first.width, first.color, attrs)


NODE = StrokeHatching
