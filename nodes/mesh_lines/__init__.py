"""mesh_lines: the lines of the posed meshes as vector strokes (contours, creases, boundaries, borders and, with
curvature, suggestive contours, ridges and valleys), chained across faces, visible parts apart from hidden."""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field

from nodegraph.errors import NodeError
from nodegraph.node import HashContext, Input, Node, NodeParams, Output, RunContext
from nodegraph.scene import meshes, meshstore, origin
from nodegraph.types import ARRAYS, SCENE, STROKES, Texture

from .._shared import planes
from . import extract, intersect, solids

_FEATURES = ("suggestive", "ridges", "valleys")


class _Kept:
    """Values kept by key, least recently used dropped first once their meshes' faces pass `budget` (a scene of
    two hundred small objects keeps all of them; a few million-face meshes, a few)."""

    def __init__(self, budget: int) -> None:
        self.budget = budget
        self.items: OrderedDict[str, tuple[Any, int]] = OrderedDict()
        self.faces = 0

    def get(self, key: str, make: Any, faces: int) -> Any:
        got = self.items.get(key)
        if got is not None:
            self.items.move_to_end(key)
            return got[0]
        value = make()
        self.items[key] = (value, faces)
        self.faces += faces
        while self.faces > self.budget and len(self.items) > 1:
            _, (_, n) = self.items.popitem(last=False)
            self.faces -= n
        return value


_TOPOLOGY = _Kept(4_000_000)  # mesh topology hash -> (weld ids, welded count, welded edges and their faces)
_FEATURE_OPS: dict[tuple[Any, ...], dict[Any, Any]] = {}
_SELF_CROSSINGS = _Kept(4_000_000)  # posed mesh hash -> its intersection segments with itself
_PART_TOPOLOGY = _Kept(4_000_000)  # mesh topology hash -> its parts' faces (solids.PartTopology)
_PARTS = _Kept(4_000_000)  # posed mesh hash -> its parts' boxes and trees (solids.Parts)
_SHARP = _Kept(4_000_000)  # posed mesh hash and crease angle -> its sharp edges (extract.sharp_edges)
_CORNERS = _Kept(4_000_000)  # posed mesh hash and crease angle -> its contours' corner normals (corner_normals)
JUNCTION_REACH = 8.0  # px at the reference size: lines this near a junction are tested for lying inside a part


class _FeatureDefaults:
    """feature_lines' default thresholds (nodes/feature_lines: its Params), used for mesh_lines' feature kinds."""

    derivative_threshold = 2.0
    angle_threshold = 25.0
    ridge_threshold = 20.0
    curvature_smoothing = 0.01
    min_length = 0.03
    chain_strength = 0.5


FEATURE_DEFAULTS = _FeatureDefaults()
# the kinds on the rendered surface, whose visibility tolerance is bounded by the depth buffer's slope
# (extract.depth_visibility; measured against ray casting for these: docs/strokes.md, Accuracy, "Edges")
ON_SURFACE = np.array([extract.KIND[k] for k in ("crease", "boundary", "border", "intersection")], np.uint8)


class MeshLines(Node):
    """Lines found on every object's posed mesh in object space, each frame, as `Strokes` (nodegraph/values.py;
    docs/strokes.md): occluding contours (interpolated zero crossings of n . v inside faces, n the smooth vertex
    normal, parted where an edge sharper than `crease_angle` meets the vertex (`extract.corner_normals`), v towards
    the eye, or the constant view direction of an orthographic camera; in planar regions, where
    those normals lean over the creases around them, the edges between faces turned toward and away; on a coarse
    mesh, where the interpolated contours stray from the polygonal silhouette by more than `outline` pixels, that
    silhouette, on the image's outline: `extract.reconcile_outline`), creases (welded
    edges whose faces' normals differ by more than `crease_angle`), boundaries (edges of one face), borders
    (boundaries another object shares: object and material borders), intersections (where faces of one object or
    of two pass through each other: `intersect.py`; the other lines stop where they enter a closed part:
    `solids.py`) and, where a curvature node is connected,
    feature_lines' suggestive contours, ridges and valleys (its CPU code, its default thresholds). Segments are
    chained across faces (through points two segments of one kind share; where three or more meet, along the
    straightest pair turning by less than `junction_turn`, as Freestyle chooses at a junction), sampled every
    `spacing` pixels, and each sample is tested against the linear depth buffer: visible where a pixel within one
    pixel of it (the 2 x 2 pixels whose centres surround it) is background or no nearer than its depth x
    (1 - `depth_tolerance`), for lines on the surface (not contours) also within twice the buffer's slope there
    (extract.depth_visibility). Strokes are split where visibility
    changes and at screen turns sharper than `split_angle`; strokes shorter than `min_length` pixels are
    dropped; hidden strokes are kept (their own SVG layers) only with `hidden`."""

    version = "20"
    context_keys = frozenset({"size", "frame", "scene", "camera", "px_scale"})
    inputs = {
        "linear_depth": Input(Texture("R32F"), "Linear view depth (rasterize.linear_depth): the occluders, and the "
                              "canvas size."),
        "curvature": Input(ARRAYS, "Per-object curvature (curvature.out, smoothing: 0) for suggestive contours, "
                           "ridges and valleys.", optional=True),
        "scene": Input(SCENE, "Scene to draw; the pipeline's scene when not connected.", optional=True),
    }
    outputs = {"strokes": Output(STROKES, "The lines as strokes, in pixels, y up, with their surface points.")}

    class Params(NodeParams):
        contours: bool = Field(True, description="Occluding contours.")
        creases: bool = Field(True, description="Creases (edges sharper than crease_angle).")
        boundaries: bool = Field(True, description="Boundaries (edges of one face) and borders between objects.")
        suggestive: bool = Field(False, description="Suggestive contours (needs the curvature input).")
        ridges: bool = Field(False, description="Ridges (needs the curvature input).")
        valleys: bool = Field(False, description="Valleys (needs the curvature input).")
        crease_angle: float = Field(60.0, gt=0, lt=180, description="Dihedral angle in degrees (between the two "
                                    "faces' normals) above which an edge is a crease, and parts the normals "
                                    "the contours interpolate.")
        split_angle: float = Field(100.0, gt=0, le=180, description="A stroke is split where it turns by more "
                                   "than this many degrees on the screen (180: never).")
        junction_turn: float = Field(extract.JUNCTION_TURN, ge=0, le=90, description="Where three or more "
                                     "segments of one kind meet, a chain goes on along the straightest pair of "
                                     "them that turns by less than this many degrees (object space; 0: chains "
                                     "end at every junction).")
        min_length: float = Field(3.0, ge=0, le=1e4, description="Strokes shorter than this many pixels (at the "
                                  "reference size, times px_scale) are dropped.")
        spacing: float = Field(1.0, gt=0.05, le=64, description="Stroke samples are at most this many pixels "
                               "apart (visibility is tested at each).")
        depth_tolerance: float = Field(0.01, ge=0, le=0.5, description="A sample is hidden where every pixel "
                                       "of the 2 x 2 whose centres surround it is nearer by more than this "
                                       "fraction of its depth; for creases, boundaries, borders and intersection "
                                       "lines by more than the smaller of that and twice the depth buffer's slope "
                                       "there (extract.depth_visibility).")
        outline: float = Field(1.0, ge=0, le=64, description="Where the interpolated contours stray more than "
                               "this many pixels (at the reference size, times px_scale, and at least one pixel of "
                               "the image: a smaller difference does not show) from the mesh's polygonal silhouette "
                               "(a coarse mesh), the silhouette draws the outline and the strays are dropped "
                               "(extract.reconcile_outline); 0: interpolated contours only.")
        intersections: bool = Field(True, description="Intersection lines: where faces of one object, or of two, "
                                    "pass through each other (parts pushed into each other; nodes/mesh_lines/"
                                    "intersect.py).")
        hidden: bool = Field(False, description="Keep hidden strokes (visible = False: their own layers).")
        width: float = Field(1.0, gt=0, le=64, description="Stroke width in pixels at the reference size (times "
                             "px_scale).")
        color: tuple[float, float, float] = Field((0.1, 0.1, 0.1), description="Stroke colour (RGB, 0..1).")

    def hash_extra(self, ctx: HashContext) -> Any:
        return origin.hash_extra(ctx.scene, ctx.frame)

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        scene = ctx.input_scene(inputs)
        zb = inputs["linear_depth"]
        w, h = zb.size
        zbuf = zb.read()[:, :, 0]
        features = {k for k in _FEATURES if getattr(p, k)}
        curv = inputs.get("curvature")
        if features and curv is None:
            raise NodeError(f"{', '.join(sorted(features))} need the curvature input: connect a curvature node "
                            "(smoothing: 0)", self.id, self.type_name)
        cam = scene.camera_at(ctx.frame)
        view = cam.view_matrix()
        proj = cam.projection_matrix(w / h)
        eye = np.r_[np.linalg.inv(view)[:3, 3], 1.0] if not cam.orthographic else cam.toward_eye()
        objs, segs, transforms = [], [], []
        for index, obj in enumerate(scene.objects):
            if obj.mesh.n_faces == 0:
                continue
            model = np.asarray(obj.transform, dtype=np.float64)
            eye_obj = np.linalg.inv(model) @ eye
            s, outline = object_lines(obj.mesh, eye_obj, p.contours, p.creases, p.boundaries, p.crease_angle,
                                      p.outline > 0, p.intersections)
            if features:
                s = extract.Segs.concat([s, self.feature_segments(curv, index, obj.mesh, eye_obj, features)])
            objs.append((index, model, outline))
            segs.append(s)
            transforms.append(model)
        if p.intersections and len(segs) > 1:
            segs = crossings_between(scene, objs, segs)
        if p.boundaries and len(segs) > 1:
            lo, hi = scene.bounds()
            segs = extract.mark_borders(segs, transforms, 1e-6 * max(float(np.linalg.norm(hi - lo)), 1e-12))
        parts, crossings = [], []
        far = extract.outline_far(zbuf)
        radius = max(p.outline * ctx.px_scale, 1.0)
        cut = (p.spacing * ctx.px_scale, p.depth_tolerance, p.split_angle, p.min_length * ctx.px_scale, p.hidden,
               p.junction_turn)
        views = [extract.View(proj @ view @ model, view @ model, (w, h)) for _, model, _ in objs]
        junctions = solid_tests(scene, objs, segs, views, JUNCTION_REACH * ctx.px_scale) if p.intersections \
            else [None] * len(objs)
        for (index, _, outline), s, v, solid in zip(objs, segs, views, junctions, strict=True):
            inter = s.kind == extract.KIND["intersection"]
            parts.append(strokes_of(index, s.select(~inter), v, zbuf, *cut, outline, radius, far, solid))
            crossings.append((index, s.select(inter), v))
        parts += crossing_parts(crossings, parts, zbuf, *cut, radius, far)
        return {"strokes": extract.to_strokes(parts, (w, h), p.width * ctx.px_scale, p.color)}

    def feature_segments(self, curv: Any, index: int, mesh: Any, eye_obj: np.ndarray, kinds: set[str]) -> Any:
        """feature_lines' segments (its CPU code in nodes/_shared/feature_lines.py, FEATURE_DEFAULTS: its
        parameters' defaults) as `extract.Segs`."""
        from .._shared import feature_lines as fl
        from .._shared.curvature import object_field

        name = object_field(index, "kmin")
        if name not in curv.data or curv.data[name].shape != (mesh.n_vertices,):
            raise NodeError(f"the curvature input has no arrays for object {index} of this mesh; connect the "
                            "curvature node of the same scene", self.id, self.type_name)
        d = FEATURE_DEFAULTS
        ckey = str(curv.data.get(object_field(index, "key"), ""))
        base = (mesh.content_hash(), ckey)
        entry = _FEATURE_OPS.get(base)
        weld, nw = mesh.weld()
        if entry is None:
            if len(_FEATURE_OPS) >= 4:
                _FEATURE_OPS.pop(next(iter(_FEATURE_OPS)))
            arr = {k: curv.data[object_field(index, k)] for k in ("kmin", "kmax", "dmin", "dmax", "normal",
                                                                  "confidence")}
            ops = fl.mesh_ops(mesh.vertices, mesh.faces, **arr, weld=weld)
            ops = fl.smooth_curvature(ops, d.curvature_smoothing * ops.diag, weld)
            entry = _FEATURE_OPS[base] = {"ops": ops, "ext": fl.extrema_data(ops, weld)}
        ops = entry["ops"]
        min_len = d.min_length * ops.diag
        eye_fl = eye_obj[:3] if eye_obj[3] != 0.0 else eye_obj
        parts = []
        for kind, label in (("suggestive", "suggestive"), ("ridges", "ridge"), ("valleys", "valley")):
            if kind not in kinds:
                continue
            if kind == "suggestive":
                seg = fl.suggestive_contours(ops, eye_fl, d.derivative_threshold, d.angle_threshold)
                seg = fl.filter_chains(seg, min_len, weld, d.chain_strength)
            else:
                if kind not in entry:
                    entry[kind] = fl.filter_chains(fl.ridges(ops, entry["ext"], d.ridge_threshold, label), min_len,
                                                   weld, d.chain_strength)
                seg = entry[kind]
                seg = seg.select(fl.front_facing(ops, seg.face, eye_fl))
            if not len(seg):
                continue
            face = ops.face_index[seg.face].astype(np.int64)
            tri = mesh.vertices[mesh.faces[face]]  # (s, 3, 3)
            bary = np.stack([extract.barycentric(tri, seg.points[:, k]) for k in range(2)], axis=1)
            e = seg.edge
            key = extract.edge_key(weld[e[..., 0]], weld[e[..., 1]], nw)
            parts.append(extract.Segs(seg.points, bary, face, key, np.full(len(seg), extract.KIND[label], np.uint8),
                                      np.ones(len(seg), bool)))
        return extract.Segs.concat(parts)


def topology(mesh: Any) -> tuple[np.ndarray, int, extract.EdgeFaces]:
    """(weld ids, welded count, welded edges and their faces) of a mesh's topology, kept (`_Kept`): a posed mesh
    shares its rest pose's."""
    shape = mesh.topology_mesh()

    def make() -> tuple[np.ndarray, int, extract.EdgeFaces]:
        weld, nw = shape.weld()
        return weld, nw, extract.edge_faces(weld[shape.faces], nw)

    return _TOPOLOGY.get(shape.content_hash(), make, len(shape.faces))


def object_segments(mesh: Any, eye_obj: np.ndarray, contours: bool = True, creases: bool = True,
                    boundaries: bool = True, crease_angle: float = 60.0) -> extract.Segs:
    """Contour, crease and boundary segments of one mesh seen from `eye_obj` (homogeneous, object space)."""
    return object_lines(mesh, eye_obj, contours, creases, boundaries, crease_angle)[0]


def object_lines(mesh: Any, eye_obj: np.ndarray, contours: bool = True, creases: bool = True,
                 boundaries: bool = True, crease_angle: float = 60.0, outline: bool = False,
                 intersections: bool = False) -> tuple[extract.Segs, tuple[extract.Segs, np.ndarray] | None]:
    """`object_segments` (with `intersections`, the mesh's intersections with itself: `self_crossings`), and with
    `outline` (and `contours`) the mesh's polygonal silhouette outside planar regions (`extract.outline_edges`;
    edges sharper than `crease_angle` left to the creases where they are drawn) with its faces in planar regions,
    for `strokes_of`."""
    weld, nw, ef = topology(mesh)
    V, F = mesh.vertices, mesh.faces
    parts = []
    fn = mesh.face_normals()
    face_g = extract.face_facing(V, F, fn, eye_obj, mesh.face_centroids())
    edges = None
    sharp = None
    if contours or creases:
        sharp = _SHARP.get(f"{mesh.content_hash()}:{crease_angle!r}", lambda: extract.sharp_edges(fn, ef, crease_angle),
                           len(F))
    if contours:
        flat = planes.planar(mesh, weld)
        crease = crease_angle if creases else None
        corners = None
        if sharp is not None and len(sharp[0]):  # normals parted at sharp edges (extract.corner_normals)
            corners = _CORNERS.get(f"{mesh.content_hash()}:{crease_angle!r}",
                                   lambda: extract.corner_normals(mesh, crease_angle), len(F))
        parts.append(extract.contours(V, F, mesh.vertex_normals().astype(np.float64), weld, nw, eye_obj, flat,
                                      corners))
        silhouette = extract.silhouette_edges(fn, ef, face_g, crease)
        parts.append(extract.facet_contours(V, F, weld, flat, silhouette))
        if outline:
            edges = (extract.outline_edges(V, F, weld, flat, silhouette), flat)
    if creases or boundaries:
        parts.append(extract.creases_and_boundaries(V, F, fn, weld, ef, face_g, crease_angle, creases, boundaries,
                                                    sharp))
    if intersections:
        parts.append(self_crossings(mesh, weld, nw))
    return extract.Segs.concat(parts), edges


SEG_FIELDS = ("p", "bary", "face", "key", "kind", "front")


def self_crossings(mesh: Any, weld: np.ndarray, nw: int) -> extract.Segs:
    """The posed mesh's intersection lines with itself (`intersect.intersection_segs`), kept (`_Kept`): a rigid
    object's are found once, not each frame; and, for a mesh file's mesh of 2,000 faces and more, in the disk
    cache's mesh store where there is one (nodegraph/scene/meshstore.py: a later process reads them, as it reads
    the parsed file; ogre's search takes 0.4 s). Their keys lie beyond every edge key."""

    def find() -> dict[str, np.ndarray]:
        segs = intersect.intersection_segs(np.asarray(mesh.vertices, np.float64), mesh.faces, weld, nw * nw + nw)
        return {name: getattr(segs, name) for name in SEG_FIELDS}

    def make() -> extract.Segs:
        sources = (intersect.__file__, str(Path(intersect.__file__).with_name("intersect_jit.py")), extract.__file__,
                   meshes.__file__)
        got = meshstore.memo_arrays(mesh, "self_crossings", find, sources, SEG_FIELDS)
        if not stored_segs_fit(got, mesh.n_faces):  # a store entry that is not what `find` writes: found again
            got = find()
        return extract.Segs(*(np.asarray(got[name]) for name in SEG_FIELDS))

    return _SELF_CROSSINGS.get(mesh.content_hash(), make, len(mesh.faces))


def stored_segs_fit(got: dict[str, np.ndarray], n_faces: int) -> bool:
    """Whether arrays read back for `self_crossings` are segments of a mesh of `n_faces` faces: shapes that agree,
    faces in range, finite points."""
    n = len(got["face"])
    return (got["p"].shape == (n, 2, 3) and got["bary"].shape == (n, 2, 3) and got["key"].shape == (n, 2)
            and got["kind"].shape == (n,) and got["front"].shape == (n,) and got["face"].dtype.kind in "iu"
            and (n == 0 or (int(got["face"].min()) >= 0 and int(got["face"].max()) < n_faces))
            and bool(np.isfinite(got["p"]).all()))


def object_boxes(scene: Any, objs: list[tuple[Any, ...]]) -> tuple[np.ndarray, np.ndarray]:
    """Boxes (k, 3 corners each) round the objects in the world: each mesh's own box (its cached bounds) turned by
    its transform, and the box round that (at least as large as the box of its turned vertices)."""
    corners = [box_corners(*scene.objects[index].mesh.bounds()) @ model[:3, :3].T + model[:3, 3]
               for index, model, _ in objs]
    return np.array([c.min(axis=0) for c in corners]), np.array([c.max(axis=0) for c in corners])


def boxes_meet(lo: np.ndarray, hi: np.ndarray, i: int, others: np.ndarray) -> np.ndarray:
    """Which of the objects `others` (indices) have world boxes (`object_boxes`) that meet object `i`'s."""
    return ~(np.any(hi[i] < lo[others], axis=1) | np.any(hi[others] < lo[i], axis=1))


def box_corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The eight corners (8, 3) of the box from `lo` to `hi`."""
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def crossings_between(scene: Any, objs: list[tuple[Any, ...]], segs: list[extract.Segs]) -> list[extract.Segs]:
    """Each object's segments with its intersection lines with the objects after it whose world boxes overlap
    its own (on its faces, in its space; keys beyond its other keys): those objects merged into one mesh and
    searched at once (one broad phase for a floor under two hundred boxes, not two hundred)."""
    out = list(segs)
    lo, hi = object_boxes(scene, objs)
    for i, (ia, ma, _) in enumerate(objs):
        later = np.arange(i + 1, len(objs))
        later = later[boxes_meet(lo, hi, i, later)]
        if not len(later):
            continue
        a = scene.objects[ia].mesh
        to_a = np.linalg.inv(ma)
        vb, fb, wb, nv, nw = [], [], [], 0, 0
        for j in later:
            b = scene.objects[objs[j][0]].mesh
            w, n, _ = topology(b)
            to_b = to_a @ objs[j][1]
            vb.append(np.asarray(b.vertices, np.float64) @ to_b[:3, :3].T + to_b[:3, 3])
            fb.append(b.faces + nv)
            wb.append(w + nw)
            nv += len(b.vertices)
            nw += n
        wa, _, _ = topology(a)
        base = int(out[i].key.max()) + 1 if len(out[i]) else 0
        cross = intersect.intersection_segs(np.asarray(a.vertices, np.float64), a.faces, wa, base,
                                            np.concatenate(vb), np.concatenate(fb), np.concatenate(wb))
        out[i] = extract.Segs.concat([out[i], cross])
    return out


def mesh_parts(mesh: Any) -> solids.Parts:
    """`solids.parts` of a posed mesh, kept (`_Kept`): which faces make which part and which parts are closed are
    kept per topology (a skinned mesh's every pose shares them), the boxes and trees per pose."""
    weld, nw, _ = topology(mesh)
    shape = mesh.topology_mesh()
    topo = _PART_TOPOLOGY.get(shape.content_hash(), lambda: solids.part_topology(shape.faces, weld, nw),
                              len(shape.faces))
    return _PARTS.get(mesh.content_hash(), lambda: solids.parts(mesh.vertices, mesh.faces, topo), len(mesh.faces))


def solid_tests(scene: Any, objs: list[tuple[Any, ...]], segs: list[extract.Segs], views: list[extract.View],
                reach: float) -> list[solids.Junctions | None]:
    """Per object (`objs`, `segs` as `compute` makes them), where any intersection lines were found: its samples
    within `reach` px of one on the screen are tested for lying inside a closed part of its own mesh other than
    the sample's, or of another object whose world box overlaps its own (`solids`). None for an object with
    neither."""
    inter = [s.select(s.kind == extract.KIND["intersection"]) for s in segs]
    if not any(len(x) for x in inter):
        return [None] * len(objs)
    near = extract.distance_tree(np.concatenate([extract.edge_points(x, v, 1.0) for x, v in
                                                 zip(inter, views, strict=True)]))
    lo, hi = object_boxes(scene, objs)
    out: list[solids.Junctions | None] = []
    for i in range(len(objs)):
        mesh = scene.objects[objs[i][0]].mesh
        every = np.arange(len(objs))
        others = [int(j) for j in every[boxes_meet(lo, hi, i, every) & (every != i)]]
        if not others and not mesh_parts(mesh).closed.any():
            out.append(None)
            continue

        def test(points: np.ndarray, face: np.ndarray, i: int = i, others: list[int] = others) -> np.ndarray:
            mesh = scene.objects[objs[i][0]].mesh
            own = mesh_parts(mesh)
            hit = solids.inside(points, own.label[face], mesh.vertices, mesh.faces, own)
            for j in others:
                rest = np.flatnonzero(~hit)
                if not len(rest):
                    break
                other = scene.objects[objs[j][0]].mesh
                to_j = np.linalg.inv(objs[j][1]) @ objs[i][1]
                q = points[rest] @ to_j[:3, :3].T + to_j[:3, 3]
                hit[rest] = solids.inside(q, np.full(len(rest), -1), other.vertices, other.faces, mesh_parts(other))
            return hit

        out.append(solids.Junctions(near, test, reach))
    return out


def sampled(segs: extract.Segs, view: extract.View, zbuf: np.ndarray, spacing: float, tolerance: float,
            junction_turn: float, far: np.ndarray | None = None,
            solid: solids.Junctions | None = None) -> tuple[extract.Samples, np.ndarray]:
    """Segments chained, sampled along the screen and tested against the depth buffer (`far`: its
    `extract.outline_far`, where made already). `solid` (`solids.Junctions`): for an object whose parts pass
    through others, the visible samples near its junctions that lie inside another closed part are hidden."""
    half, offsets = extract.chain(segs.key, segs.kind, segs.p, junction_turn)
    return tested(segs, half, offsets, view, zbuf, spacing, tolerance, far, solid)


def tested(segs: extract.Segs, half: np.ndarray, offsets: np.ndarray, view: extract.View, zbuf: np.ndarray,
           spacing: float, tolerance: float, far: np.ndarray | None = None,
           solid: solids.Junctions | None = None) -> tuple[extract.Samples, np.ndarray]:
    """`sampled` after its chaining (`half`, `offsets`: `extract.chain`)."""
    sm = extract.sample(segs, half, offsets, view, spacing)
    far = extract.outline_far(zbuf) if far is None else far
    state = extract.depth_visibility(sm.xy, sm.depth, zbuf, tolerance, far, np.isin(sm.kind, ON_SURFACE))
    state = np.where(~sm.front & (state > 0), 0, state).astype(np.int8)  # creases between back faces
    state = extract.close_flicker(state, sm.offsets, (sm.kind == extract.KIND["contour"]) & (state == 0))
    if solid is not None:
        state = solid.hide(sm.p, sm.face, sm.xy, sm.depth, state, sm.kind, extract.KIND["intersection"], far)
    return sm, state


def strokes_of(index: int, segs: extract.Segs, view: extract.View, zbuf: np.ndarray, spacing: float,
               tolerance: float, split_angle: float, min_length: float, hidden: bool,
               junction_turn: float = extract.JUNCTION_TURN,
               outline: tuple[extract.Segs, np.ndarray] | None = None, radius: float = 1.0,
               far: np.ndarray | None = None, solid: solids.Junctions | None = None) -> tuple[Any, ...]:
    """One object's segments chained, sampled, tested and split: a part for `extract.to_strokes`. With `outline`
    (`object_lines`) the polygonal silhouette draws the outline where the interpolated contours stray from it
    by more than `radius` px (`extract.reconcile_outline`; `far`: `extract.outline_far` of `zbuf`), cut, cleaned
    and joined to them as `split_lines` says. `solid`: as `sampled` takes it."""
    far = extract.outline_far(zbuf) if far is None else far
    sm, state = sampled(segs, view, zbuf, spacing, tolerance, junction_turn, far, solid)
    filled = None
    if outline is not None:
        edges, flat = outline
        so, st_o = sampled(extract.outline_candidates(edges, view, far), view, zbuf, spacing, tolerance,
                           junction_turn, far, solid)
        state, filled = reconciled(sm, state, so, st_o, flat, radius, far,
                                   extract.edge_points(edges, view, 0.5 * radius), spacing, tolerance)
    return (index, *split_lines(sm, state, split_angle, min_length, hidden, filled, radius, spacing))


def crossing_parts(crossings: list[tuple[int, extract.Segs, extract.View]], parts: list[tuple[Any, ...]],
                   zbuf: np.ndarray, spacing: float, tolerance: float, split_angle: float, min_length: float,
                   hidden: bool, junction_turn: float, radius: float, far: np.ndarray) -> list[tuple[Any, ...]]:
    """The intersection lines of each object (index, segments, view) as parts for `extract.to_strokes`, sampled,
    tested and split as `strokes_of` does, less the samples within `radius` + 0.5 px of a line of another kind
    drawn in `parts` (of any object) with the same visibility: a part sunk a hair into another, or whose junction
    runs along its own outline, draws that line once. What is left under max(2 `min_length`, 4 `radius`) px is
    dropped as a speck (the ends of such a cut, and the hook a junction makes where it turns round a corner onto
    the hidden side)."""
    crossings = [c for c in crossings if len(c[1])]
    if not crossings:
        return []
    trees = {}
    for seen in (0, 1):
        xy = [sm.xy[idx[state[idx] == seen]] for _, sm, state, idx, _ in parts]
        pts = np.concatenate(xy) if xy else np.zeros((0, 2))
        trees[seen] = extract.distance_tree(pts) if len(pts) else None
    speck = max(2.0 * min_length, 4.0 * radius)
    out = []
    for index, segs, view in crossings:
        sm, state = sampled(segs, view, zbuf, spacing, tolerance, junction_turn, far)
        for seen, tree in trees.items():
            at = np.flatnonzero(state == seen)
            if tree is not None and len(at):
                d, _ = tree.query(sm.xy[at], distance_upper_bound=radius + 0.5)
                state[at[np.isfinite(d)]] = -1
        out.append((index, sm, state, *extract.split(sm, state, split_angle, speck, hidden)))
    return out


def reconciled(sm: extract.Samples, state: np.ndarray, so: extract.Samples, st_o: np.ndarray, flat: np.ndarray,
               radius: float, far: np.ndarray, silhouette: np.ndarray, spacing: float,
               tolerance: float) -> tuple[np.ndarray, tuple[Any, ...]]:
    """`extract.reconcile_outline` for one object's sampled lines (`sm`, `state`) and silhouette (`so`, `st_o`):
    its interpolated contours are the contour samples outside planar regions (`flat`), `spacing` and `tolerance`
    the sampling's and the visibility's; then
    `extract.bridge_outline` over gaps up to four times the suppression reach (2 `radius` + 1 px): the reach at
    either end, where the silhouette is suppressed, and as much again between, where what is left of it is a
    speck and dropped. Returns the lines' states and the `filled` argument of `split_lines`."""
    interpolated = (sm.kind == extract.KIND["contour"]) & ~flat[sm.face]
    state, st_o = extract.reconcile_outline(sm, state, interpolated, so, st_o, sm.kind == extract.KIND["crease"],
                                            radius, far, silhouette)
    reach = 2.0 * radius + 1.0
    state = extract.bridge_outline(sm, state, interpolated, so, st_o, reach, int(np.ceil(4.0 * reach / spacing)),
                                   far, tolerance)
    return state, (so, st_o, interpolated)


def split_lines(sm: extract.Samples, state: np.ndarray, split_angle: float, min_length: float, hidden: bool,
                filled: tuple[Any, ...] | None = None, radius: float = 1.0, spacing: float = 1.0) -> tuple[Any, ...]:
    """(samples, state, vertex indices, stroke offsets): the lines cut into strokes (`extract.split`), and with
    `filled` (from `reconciled`: the silhouette's samples and states, and which line samples are interpolated
    contours) the silhouette where it fills the outline: its samples within 2 `radius` + 1 px of the interpolated
    contours' drawn strokes are dropped (`extract.suppress_filled`), the rest cut into strokes and joined to the
    interpolated contours whose ends lie within 2 `radius` + 1 + 3 `spacing` px of their ends (`extract.join_ends`:
    the gap the suppression leaves, and a sample's spacing either side), so that an outline runs on as one stroke
    where the fill takes over (one pen stroke, one overshoot); a group of
    filled pieces spanning under max(2 `min_length`, 4 `radius`) px (a cusp's folds) is dropped, and so is an
    interpolated contour stroke that short left between strays `reconcile_outline` dropped
    (`extract.drop_fragments`)."""
    idx, off = extract.split(sm, state, split_angle, min_length, hidden)
    if filled is None:
        return sm, state, idx, off
    so, st_o, interpolated = filled
    speck = max(2.0 * min_length, 4.0 * radius)
    idx, off = extract.drop_fragments(sm, state, idx, off, interpolated, speck)
    first = idx[off[:-1]]
    drawn_stroke = interpolated[first] & (state[first] > 0)
    drawn = sm.xy[idx[np.repeat(drawn_stroke, np.diff(off))]]
    st_o = extract.suppress_filled(drawn, so, st_o, 2.0 * radius + 1.0)
    idx_o, off_o = extract.split(so, st_o, split_angle, min_length, hidden)
    n = len(sm.xy)
    sm, state = extract.concat_samples(sm, so), np.r_[state, st_o].astype(np.int8)
    idx, off = np.r_[idx, idx_o + n], np.r_[off, off_o[1:] + off[-1]]
    first = idx[off[:-1]]
    role = np.where(first >= n, 2, np.where(sm.kind[first] == extract.KIND["contour"], 1, 0))
    idx, off = extract.join_ends(sm.xy, idx, off, role, state[first], 2.0 * radius + 1.0 + 3.0 * spacing, speck,
                                 1.5 * spacing)
    return sm, state, idx, off


NODE = MeshLines
