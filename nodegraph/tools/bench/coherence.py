"""`sketchgraph bench coherence`: how much each shipped pipeline flickers or swims in a film, as the warping
error between consecutive frames along the exact screen-space motion (`rasterize.motion`).

For each pair of consecutive frames (t - 1, t) of a shot,

    E_t = mean over the reliable pixels of |L_t - warp(L_{t-1}, motion_t)|

where L is the luminance (Rec. 709 weights, the image composited over white where it has alpha, values 0..1),
`warp` reads the previous frame bilinearly where the pixel's surface point was then, and the reliable pixels
(`motion.reliable`) are those visible in both frames (`visible_both`: the point was not hidden and stayed in the
picture, or the background stayed background) and off motion boundaries (`motion_boundaries`: the pixels on
either side of an occluding contour of the frame, where coverage or view depth jumps between neighbours). That is
the non-occlusion mask of Lai et al. 2018 (Ruder et al. 2016's disocclusion and motion-boundary tests; after
Bonneel et al. 2015), with the exact motion and geometry instead of optical flow (nodegraph/output/motion.py).
A shot's E is the mean of E_t over its pairs. Three figures are measured the same way:

- `e_pipeline`: the pipeline's `image` as configured;
- `e_plain`: the plain lit render (`rasterize` with lit: true): the floor, shading change and aliasing only;
- `e_reseed`: the pipeline with every stochastic node re-seeded each frame (the pipeline seed changes every
  frame, so every seeded node draws new noise): boiling at its worst.

Beside them, not part of the index, `e_no_uncertainty`: the pipeline with its SWEEP params (how far marks stray)
at 0: what is left is the drawing's own change (lines sliding over the surface at silhouettes, edge aliasing,
hatching), the most a film setting that keeps the look can expect to remove.

    coherence_index = 1 - (e_pipeline - e_plain) / (e_reseed - e_plain), clipped to [0, 1]

1 = as coherent as the plain render (or more: an error at or under the floor), 0 = as incoherent as re-seeding
every frame (None where re-seeding changes nothing, or where the pipeline's error is above the floor and
re-seeding's is not). Paper grain is measured off (`grain` and `paper_tint` 0 on the nodes reading
a `paper` input): it stays fixed on the sheet by design and would count as error wherever a surface moves.

`sketchiness_px`: the mean distance in pixels (at the bench size) from each drawn pixel (a thin dark mark: at
least 0.1 darker in luminance than the image's 5x5 grey closing there, whatever the fill around it) of the first
frame of the `turn` shot to the nearest true feature line of the mesh (silhouettes, creases and boundaries,
visible by depth: nodegraph/tools/bench/groundtruth.py, as the accuracy charts use); hatching counts as drawn
marks too.

`with_boundaries`: beside each index, the same figures over every pixel visible in both frames, motion boundaries
included. A pixel on an outline straddles two surfaces and its one motion vector follows one of them, so there the
error counts the outline's own antialiasing (the plain render at 2x2 supersampling scores worse than without) and
any line drawn along it, which moves with the outline rather than with either surface.

`extended`: beside each index, the same figures with the motion extended beyond the outlines (`extend_motion`):
background pixels within BAND_PX (6 px at 256) of an object move as the nearest covered pixel does, so a mark drawn
just beyond an outline (an offset line, spilled shade) that moves with its object is not counted as change; the
sheet the band has just left is left out as uncovered sheet is (`extended_pixels`). The exact motion gives such
pixels no motion (the sheet stays put), which the plain render, drawing nothing beyond its outlines, never pays
for; the extended figures show how much of a pipeline's index that accounts for.

`surfaces` and `sheet`: the index's own pixels split in two, those where the plain render shows a surface and those
where it shows the sheet (marks beyond the outlines: offset lines, spilled shade). The exact motion keeps the
sheet still, so a mark there that moves with its object counts as change as a re-seeded one does; where the two
sheet errors are alike, the index cannot tell a coherent drawing from a boiling one on the sheet, and `surfaces`
is its figure for what lies on the objects.

`flow` (with `--flow`): the same figures along motion estimated as the papers estimate it, from the plain render
alone (`estimated_flow`: TV-L1 optical flow, scikit-image, back and forward; Ruder et al.'s consistency and
motion-boundary tests for the pixels counted). It cannot see a surface slide inside a smooth, textureless plain
render, and it is smooth across outlines, so it charges marks fixed to surfaces and forgives marks beside outlines:
beside the index, it shows how much a verdict owes to the exact motion.

The shots are made here as glTF files: `turn` (a torus turning about a tilted axis, a box beside it), `orbit` (the
camera dollying in along an arc around the still torus and box) and `bend` (a skinned tube bending at its middle
like an elbow); `--shots heldout` measures on three more of the same kinds that no film setting was chosen on
(`write_heldout_shots`), and `--scene F` on one file of the user's own (its first `--frames` frames, one shot named
after it). `film`: each pipeline's film setting (FILM_PIPELINE's variant file where one is named, with
`film_overrides`: `hold: 0` on every node that has a hold, then FILM's overrides as `--set` takes them), with its
sketchiness.
`--pipelines` also takes pipeline files (a user's own, or an alternative such as
pipelines/film/pencil_contours_object_space.yaml), measured as a shipped pipeline is; their film setting is the file
with its holds at 0.
`hold`: the index with `hold: N` on every node that has one. `sweep`: the pipeline's main parameters (SWEEP) scaled
by 0.5 and 2 on the `turn` shot, for the chart of coherence against sketchiness.
"""

from __future__ import annotations

import json
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import click
import numpy as np

from ... import films
from ...errors import PipelineError
from ...films import FILM, FILM_PIPELINE  # noqa: F401  (the film settings, re-exported for the bench's users)
from ...fsio import atomic_write_text
from ...output import motion as mo
from .gltfdoc import GltfDoc, quaternion

FPS = 24.0
SHOTS = ("turn", "orbit", "bend")
HOLDS = (1, 2, 4)
RESEED_STRIDE = 7919  # pipeline seed of frame t in the re-seeded baseline: the pipeline's + 7919 (t + 1)
TARGET = 0.8  # the index a film setting is to reach on every shot (issue 37; `summary` says which do)
BAND_PX = 6.0  # `extended`: background this close to an object moves with it (px at 256 px, scaled with size)
DARK = 0.1  # a pixel counts as drawn where it is this much darker than its 5x5 grey closing (sketchiness)
# each pipeline's film setting (nodegraph/films.py: FILM, FILM_PIPELINE), chosen by measurement with this bench:
# docs/animation.md, "Making films"
# node type -> the params that set how far drawn marks stray (scaled together by SWEEP_FACTORS)
SWEEP: dict[str, tuple[str, ...]] = {
    "sketch": ("edge_matrix", "shade_matrix"),
    "distortion_map": ("amplitude",),
    "particle_sketch": ("randomness",),
}
SWEEP_FACTORS = (0.5, 2.0)

PLAIN_YAML = """pipeline: coherence-plain
size: [256, 256]
scene: builtin:box
nodes:
  gbuf: {type: rasterize, params: {lit: true}}
outputs:
  image: gbuf.color
"""


# -- the shots ---------------------------------------------------------------------------------------------


class _Gltf(GltfDoc):
    """A small glTF document written with pygltflib: meshes, nodes, cameras and LINEAR animation channels."""

    def __init__(self) -> None:
        import pygltflib as g

        super().__init__(animations=[g.Animation(name="shot")])

    def mesh(self, vertices: np.ndarray, faces: np.ndarray, color: tuple[float, float, float],
             skin: tuple[np.ndarray, np.ndarray] | None = None) -> int:
        g = self.g
        attrs = {"POSITION": self.accessor(vertices.astype(np.float32), "VEC3", minmax=True)}
        if skin is not None:
            attrs["JOINTS_0"] = self.accessor(skin[0].astype(np.uint8), "VEC4", 5121)
            attrs["WEIGHTS_0"] = self.accessor(skin[1].astype(np.float32), "VEC4")
        self.doc.materials.append(g.Material(pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[*color, 1.0])))
        prim = g.Primitive(attributes=g.Attributes(**attrs), indices=self.accessor(faces.astype(np.uint32).ravel(),
                                                                                "SCALAR", 5125),
                           material=len(self.doc.materials) - 1)
        self.doc.meshes.append(g.Mesh(primitives=[prim]))
        return len(self.doc.meshes) - 1

    def node(self, root: bool = True, **kw: Any) -> int:
        self.doc.nodes.append(self.g.Node(**kw))
        if root:
            self.doc.scenes[0].nodes.append(len(self.doc.nodes) - 1)
        return len(self.doc.nodes) - 1

    def camera(self, eye: Any, target: Any) -> int:
        self.doc.cameras.append(self.g.Camera(type="perspective", perspective=self.g.Perspective(
            yfov=0.6, znear=0.1, zfar=50.0)))
        return self.node(camera=len(self.doc.cameras) - 1, translation=list(map(float, eye)),
                         rotation=look_rotation(eye, target))

    def animate(self, node: int, path: str, times: np.ndarray, values: np.ndarray) -> None:
        g = self.g
        kind = "VEC4" if path == "rotation" else "VEC3"
        an = self.doc.animations[0]
        an.samplers.append(g.AnimationSampler(input=self.accessor(np.asarray(times, np.float32), "SCALAR", minmax=True),
                                              output=self.accessor(np.asarray(values, np.float32), kind)))
        an.channels.append(g.AnimationChannel(sampler=len(an.samplers) - 1,
                                              target=g.AnimationChannelTarget(node=node, path=path)))

    def save(self, path: Path) -> Path:
        if not self.doc.animations[0].channels:
            self.doc.animations = []
        return self.write(path)


def look_rotation(eye: Any, target: Any) -> list[float]:
    """The (x, y, z, w) rotation of a glTF camera node at `eye` looking at `target` (up +Y): -Z towards it."""
    back = np.asarray(eye, np.float64) - np.asarray(target, np.float64)
    z = back / np.linalg.norm(back)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    m = np.stack([x, np.cross(z, x), z], axis=1)  # columns: the camera's axes in the world
    w = math.sqrt(max(1.0 + m[0, 0] + m[1, 1] + m[2, 2], 1e-12)) / 2.0
    return [(m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w), w]


def torus(major: float = 0.7, minor: float = 0.28, n_major: int = 48, n_minor: int = 20
          ) -> tuple[np.ndarray, np.ndarray]:
    u = np.linspace(0, 2 * math.pi, n_major, endpoint=False)
    v = np.linspace(0, 2 * math.pi, n_minor, endpoint=False)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    r = major + minor * np.cos(vv)
    verts = np.stack([r * np.cos(uu), minor * np.sin(vv), r * np.sin(uu)], axis=-1).reshape(-1, 3)
    i, k = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")
    a, b = i * n_minor + k, ((i + 1) % n_major) * n_minor + k
    c, d = ((i + 1) % n_major) * n_minor + (k + 1) % n_minor, i * n_minor + (k + 1) % n_minor
    faces = np.concatenate([np.stack([a, d, c], -1).reshape(-1, 3), np.stack([a, c, b], -1).reshape(-1, 3)])
    return verts, faces


def box(size: Any) -> tuple[np.ndarray, np.ndarray]:
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]) * size
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],
                      [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return corners, faces


def tube(rings: int = 40, segments: int = 20, radius: float = 0.22) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A capped tube along +x from -1 to 1 and its joint-1 weight (smooth over -0.35 < x < 0.35)."""
    xs = np.linspace(-1.0, 1.0, rings)
    ang = np.linspace(0, 2 * math.pi, segments, endpoint=False)
    ring = np.stack([np.cos(ang), np.sin(ang)], axis=1) * radius
    verts = np.concatenate([np.c_[np.full(segments, x), ring] for x in xs] + [[[-1.0, 0, 0], [1.0, 0, 0]]])
    faces = []
    for i in range(rings - 1):
        for k in range(segments):
            k1 = (k + 1) % segments
            a, b, c, d = i * segments + k, i * segments + k1, (i + 1) * segments + k1, (i + 1) * segments + k
            faces += [[a, b, c], [a, c, d]]
    c0, c1, last = rings * segments, rings * segments + 1, (rings - 1) * segments
    faces += [[c0, (k + 1) % segments, k] for k in range(segments)]
    faces += [[c1, last + k, last + (k + 1) % segments] for k in range(segments)]
    s = np.clip((verts[:, 0] + 0.35) / 0.7, 0.0, 1.0)
    return verts, np.array(faces), s * s * (3 - 2 * s)


def skinned_tube(f: _Gltf, verts: np.ndarray, faces: np.ndarray, w1: np.ndarray, color: tuple[float, float, float]
                 ) -> int:
    """A `tube` skinned to two joints into `f`: joint 0 at x = -1 (the root), joint 1 at x = 0 (its child, weights
    `w1`), the mesh node "tube"; returns joint 1's node index (what the shot turns)."""
    weights = np.stack([1 - w1, w1, 0 * w1, 0 * w1], axis=1)
    joints = np.tile([0, 1, 0, 0], (len(verts), 1))
    mesh = f.mesh(verts, faces, color=color, skin=(joints, weights))
    j1 = len(f.doc.nodes) + 1
    j0 = f.node(name="j0", translation=[-1.0, 0.0, 0.0], children=[j1])
    f.node(root=False, name="j1", translation=[1.0, 0.0, 0.0])
    ibm = np.stack([np.eye(4), np.eye(4)])
    ibm[0, 0, 3], ibm[1, 0, 3] = 1.0, 0.0  # inverse bind: joint 0 at x = -1, joint 1 at x = 0
    f.doc.skins.append(f.g.Skin(joints=[j0, j1], inverseBindMatrices=f.accessor(
        ibm.transpose(0, 2, 1).astype(np.float32).reshape(2, 16), "MAT4")))
    f.node(mesh=mesh, skin=0, name="tube")
    return j1


def write_shots(folder: Path, frames: int, shots: str = "report") -> dict[str, Path]:
    """The three shots as .glb files in `folder`, each animated over `frames` frames at 24 fps: the `report`
    shots, which the film settings were chosen on, or the `heldout` ones (`write_heldout_shots`)."""
    if shots == "heldout":
        return write_heldout_shots(folder, frames)
    if shots != "report":
        raise ValueError(f"shots: expected 'report' or 'heldout', got {shots!r}")
    seconds = (frames - 1) / FPS
    keys = np.arange(frames) / FPS
    out = {}
    # turn: the torus turns 60 degrees about a tilted axis; a box stands beside it
    f = _Gltf()
    ring = f.node(mesh=f.mesh(*torus(), color=(0.85, 0.6, 0.45)), name="torus")
    f.node(mesh=f.mesh(*box([0.5, 0.9, 0.5]), color=(0.55, 0.65, 0.85)), name="box", translation=[1.25, -0.05, -0.3])
    f.camera([1.6, 1.9, 4.6], [0.45, 0.0, 0.0])
    f.animate(ring, "rotation", np.array([0.0, seconds]),
              np.array([quaternion((0.3, 1.0, 0.4), 0.0), quaternion((0.3, 1.0, 0.4), 60.0)]))
    out["turn"] = f.save(folder / "turn.glb")
    # orbit: the camera moves 40 degrees around the still torus and box and comes in from 5.2 to 4.4
    f = _Gltf()
    f.node(mesh=f.mesh(*torus(), color=(0.85, 0.6, 0.45)), name="torus", rotation=quaternion((1, 0, 0), 30.0))
    f.node(mesh=f.mesh(*box([0.5, 0.9, 0.5]), color=(0.55, 0.65, 0.85)), name="box", translation=[1.25, -0.05, -0.3])
    s = np.linspace(0.0, 1.0, frames)
    ang = np.radians(-20.0 + 40.0 * s)
    dist = 5.2 - 0.8 * s
    eyes = np.stack([dist * np.sin(ang) + 0.45, 1.6 + 0 * s, dist * np.cos(ang)], axis=1)
    cam = f.camera(eyes[0], [0.45, 0.0, 0.0])
    f.animate(cam, "translation", keys, eyes)
    f.animate(cam, "rotation", keys, np.array([look_rotation(e, [0.45, 0.0, 0.0]) for e in eyes]))
    out["orbit"] = f.save(folder / "orbit.glb")
    # bend: a skinned tube; joint 1 (at the middle) turns 70 degrees about +Z
    f = _Gltf()
    j1 = skinned_tube(f, *tube(), color=(0.6, 0.7, 0.85))
    f.camera([0.3, 1.0, 4.6], [0.2, 0.4, 0.0])
    f.animate(j1, "rotation", np.array([0.0, seconds]),
              np.array([quaternion((0, 0, 1), 0.0), quaternion((0, 0, 1), 70.0)]))
    out["bend"] = f.save(folder / "bend.glb")
    return out


def write_heldout_shots(folder: Path, frames: int) -> dict[str, Path]:
    """Three more shots of the same kinds, which no film setting was chosen on (other shapes, axes, paths and
    light), to see whether the figures hold: `turn` a capped tube turning 50 degrees about an axis leaning towards
    the camera beside a slab; `orbit` the camera rising and pulling back along a 35-degree arc the other way
    round a fat torus and a tall box; `bend` a thicker skinned tube bending 60 degrees about the vertical, towards
    the camera, seen from above."""
    seconds = (frames - 1) / FPS
    keys = np.arange(frames) / FPS
    out = {}
    f = _Gltf()
    verts, faces, _ = tube(rings=24, segments=24, radius=0.3)
    rod = f.node(mesh=f.mesh(verts * [0.8, 1.0, 1.0], faces, color=(0.5, 0.7, 0.55)), name="rod")
    f.node(mesh=f.mesh(*box([1.0, 0.25, 0.7]), color=(0.8, 0.75, 0.5)), name="slab", translation=[0.2, -0.6, -0.6])
    f.camera([-1.2, 1.4, 4.4], [0.1, -0.1, 0.0])
    f.animate(rod, "rotation", np.array([0.0, seconds]),
              np.array([quaternion((0.2, 0.5, 1.0), 0.0), quaternion((0.2, 0.5, 1.0), 50.0)]))
    out["turn"] = f.save(folder / "turn.glb")
    f = _Gltf()
    f.node(mesh=f.mesh(*torus(0.6, 0.35, 40, 24), color=(0.75, 0.55, 0.7)), name="torus",
           rotation=quaternion((1, 0, 0), 45.0))
    f.node(mesh=f.mesh(*box([0.4, 1.3, 0.4]), color=(0.6, 0.6, 0.6)), name="post", translation=[-1.05, 0.1, 0.3])
    s = np.linspace(0.0, 1.0, frames)
    ang = np.radians(25.0 - 35.0 * s)
    dist = 4.2 + 0.6 * s
    eyes = np.stack([dist * np.sin(ang) - 0.3, 0.8 + 0.9 * s, dist * np.cos(ang)], axis=1)
    cam = f.camera(eyes[0], [-0.3, 0.0, 0.0])
    f.animate(cam, "translation", keys, eyes)
    f.animate(cam, "rotation", keys, np.array([look_rotation(e, [-0.3, 0.0, 0.0]) for e in eyes]))
    out["orbit"] = f.save(folder / "orbit.glb")
    f = _Gltf()
    j1 = skinned_tube(f, *tube(rings=32, segments=24, radius=0.28), color=(0.85, 0.65, 0.5))
    f.camera([0.2, 2.6, 3.6], [0.1, 0.0, 0.3])
    f.animate(j1, "rotation", np.array([0.0, seconds]),
              np.array([quaternion((0, 1, 0), 0.0), quaternion((0, 1, 0), -60.0)]))
    out["bend"] = f.save(folder / "bend.glb")
    return out


# -- measuring ---------------------------------------------------------------------------------------------


def luminance(img: np.ndarray) -> np.ndarray:
    """(H, W) float64 luminance (Rec. 709) of an image, composited over white where it has alpha."""
    a = np.asarray(img, np.float64)
    if a.ndim == 2:
        return a
    if a.shape[2] == 1:
        return a[..., 0]
    rgb = a[..., :3] if a.shape[2] >= 3 else np.repeat(a[..., :1], 3, axis=2)
    if a.shape[2] == 4:
        rgb = rgb * a[..., 3:] + (1.0 - a[..., 3:])
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


# figures beside the index's, measured over other pixels (docstring)
VARIANTS = ("with_boundaries", "extended", "surfaces", "sheet")


def estimated_flow(prev: np.ndarray, cur: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motion from frame `prev` to frame `cur` (luminance, row 0 at the top) as the papers estimate it: TV-L1
    optical flow (scikit-image) from `cur` back to `prev` and forward, and Ruder et al. 2016's non-occlusion mask:
    a pixel counts where the two flows agree (|w + w'(x + w)|^2 <= 0.01 (|w|^2 + |w'|^2) + 0.5), off a motion
    boundary (|grad w|^2 <= 0.01 |w|^2 + 0.002) and where it came from inside the picture. Returns (rows, cols)
    where each pixel of `cur` was in `prev`, and the mask."""
    from scipy.ndimage import map_coordinates
    from skimage.registration import optical_flow_tvl1

    back = np.stack(optical_flow_tvl1(cur, prev))  # (2, h, w): row and column offsets from cur into prev
    fwd = np.stack(optical_flow_tvl1(prev, cur))
    h, w = cur.shape
    rows, cols = np.mgrid[0:h, 0:w].astype(np.float64)
    src_r, src_c = rows + back[0], cols + back[1]
    fwd_at = np.stack([map_coordinates(f, [src_r, src_c], order=1, mode="nearest") for f in fwd])
    both = ((back + fwd_at) ** 2).sum(0)
    occluded = both > 0.01 * ((back ** 2).sum(0) + (fwd_at ** 2).sum(0)) + 0.5
    grad = sum(g ** 2 for f in back for g in np.gradient(f))
    boundary = grad > 0.01 * (back ** 2).sum(0) + 0.002
    inside = (src_r >= 0) & (src_r <= h - 1) & (src_c >= 0) & (src_c <= w - 1)
    return src_r, src_c, inside & ~occluded & ~boundary


class Shot:
    """One shot's motion fields and previous depths (from a plain G-buffer), and its plain floor; with `flow`, also
    the motion estimated from the plain render (`estimated_flow`) for the `flow` figures."""

    def __init__(self, session: Any, plain: Path, scene: Path, size: tuple[int, int], frames: int,
                 flow: bool = False) -> None:
        self.scene, self.frames = scene, frames
        self.variants = VARIANTS + (("flow",) if flow else ())
        pipe = session.load(plain, scene=str(scene), size=size)
        self.motion = [pipe.inspect("gbuf.motion", frame=t) for t in range(frames)]
        self.depth = [pipe.inspect("gbuf.depth", frame=t)[..., 0] for t in range(frames)]
        self.linear = [pipe.inspect("gbuf.linear_depth", frame=t)[..., 0] for t in range(frames)]
        self.band_px = BAND_PX * min(size) / 256.0
        self.extended = [extend_motion(m, self.band_px) for m in self.motion]
        self.masks = [self._masks(t) for t in range(1, frames)]
        plain_lum = [luminance(img) for _, img in pipe.frames(range(frames), dtype="float32")]
        self.flow = [estimated_flow(plain_lum[t - 1], plain_lum[t]) for t in range(1, frames)] if flow else []
        self.floor = self.errors(plain_lum)
        self.e_plain = self.floor["index"]

    def _masks(self, t: int) -> dict[str, np.ndarray]:
        """The pixels each figure counts for the pair (t - 1, t): `index` the reliable ones (visible in both
        frames, off motion boundaries), `with_boundaries` those visible in both, `extended` those of
        `extended_pixels`, `surfaces` and `sheet` the index's where the plain render shows a surface at t, and the
        sheet."""
        visible = mo.visible_both(self.motion[t], self.depth[t - 1])
        boundaries = mo.motion_boundaries(self.motion[t], self.linear[t])
        extended = extended_pixels(self.motion[t], self.depth[t - 1], self.extended[t], self.extended[t - 1][1])
        index = visible & ~boundaries
        covered = self.motion[t][..., 3] > 0
        return {"index": index, "with_boundaries": visible, "extended": extended & ~boundaries,
                "surfaces": index & covered, "sheet": index & ~covered}

    def error(self, lum: list[np.ndarray]) -> float:
        """Mean warping error over the consecutive pairs of frames (the index's pixels)."""
        return self.errors(lum)["index"]

    def errors(self, lum: list[np.ndarray]) -> dict[str, float]:
        """Mean warping error over the consecutive pairs of frames for each set of pixels (`_masks`): along the
        exact motion for all but `extended`, along the extended motion (`extend_motion`) for `extended`."""
        from scipy.ndimage import map_coordinates

        out: dict[str, list[float]] = {"index": [], **{v: [] for v in self.variants}}
        for t in range(1, len(lum)):
            masks = self.masks[t - 1]
            diff = np.abs(lum[t] - mo.warp(lum[t - 1], self.motion[t]))
            ext = np.abs(lum[t] - mo.warp(lum[t - 1], self.extended[t][0]))
            for key in out:
                if key == "flow":  # along the estimated motion, over its own mask
                    src_r, src_c, mask = self.flow[t - 1]
                    d = np.abs(lum[t] - map_coordinates(lum[t - 1], [src_r, src_c], order=1, mode="nearest"))
                    out[key].append(d[mask].mean() if mask.any() else np.nan)
                    continue
                d = ext if key == "extended" else diff
                out[key].append(d[masks[key]].mean() if masks[key].any() else np.nan)
        return {k: float(np.nanmean(v)) for k, v in out.items()}


def extend_motion(motion: np.ndarray, width: float) -> tuple[np.ndarray, np.ndarray]:
    """The motion field with the background within `width` px of a covered pixel moving as its nearest covered
    pixel does (marks drawn just beyond an outline, such as offset lines and spilled shade, move with the object
    they were drawn from), and the mask of those background pixels. Their z is set to 0, so that
    `visible_both` with a zero depth buffer keeps them where they come from inside the image; `Shot.errors` also
    leaves out those whose source was covered in the previous frame (an outline that slid over the surface)."""
    from scipy.ndimage import distance_transform_edt

    m = np.array(motion, dtype=np.float64)
    covered = m[..., 3] > 0.5
    if not covered.any():
        return m, np.zeros(covered.shape, bool)
    dist, (ri, ci) = distance_transform_edt(~covered, return_indices=True)
    band = ~covered & (dist <= width)
    h, w = covered.shape
    rows, cols = np.mgrid[0:h, 0:w].astype(np.float64)
    dx = m[ri, ci, 0] - (ci + 0.5)  # the nearest covered pixel's displacement (window x; y up)
    dy = m[ri, ci, 1] - (h - ri - 0.5)
    m[..., 0] = np.where(band, cols + 0.5 + dx, m[..., 0])
    m[..., 1] = np.where(band, h - rows - 0.5 + dy, m[..., 1])
    m[..., 2] = np.where(band, 0.0, m[..., 2])
    m[..., 3] = np.where(band, 1.0, m[..., 3])
    return m, band


def extended_pixels(motion: np.ndarray, prev_depth: np.ndarray, extended: tuple[np.ndarray, np.ndarray],
                    prev_band: np.ndarray) -> np.ndarray:
    """(h, w) bool: the pixels the `extended` figures count for a pair of frames (motion boundaries still to be
    left out), where each object owns the sheet within the band around it (`extend_motion`: `extended` is this
    frame's extended motion and band, `prev_band` the previous frame's band). As `visible_both` with the band
    counted as part of its object: a pixel off the band counts where it is visible in both frames, a band pixel
    where it came from inside the image and from the previous frame's sheet (not from a surface an outline slid
    over), and the sheet the band has just left (in the previous frame's band, in neither the object nor the band
    now) is left out, as the sheet an object has just uncovered is."""
    visible = mo.visible_both(motion, prev_depth)
    ext, band = extended
    inside = mo.visible_both(ext, prev_depth * 0.0)
    was_background = mo.sample(prev_depth, ext[..., 0], ext[..., 1]) >= 1.0
    vacated = (np.asarray(motion)[..., 3] <= 0.5) & ~band & prev_band
    return ((visible & ~band) | (band & inside & was_background)) & ~vacated


def coherence_index(e_pipe: float, e_plain: float, e_reseed: float) -> float | None:
    """1 = as coherent as the plain render, 0 = as incoherent as re-seeding every frame (clipped to [0, 1]); 1 too
    where the pipeline changes no more than the plain render does. None where the index says nothing: re-seeding
    changes no pixel at all (the same error to the last bit: a pipeline without seeded nodes, such as
    plotter_lines, whose raw errors are then its figures), or the pipeline changes more than the plain render
    while re-seeding does not raise the error above it."""
    if e_pipe == e_reseed:
        return None
    if e_pipe <= e_plain:  # no more change than the plain render, whatever re-seeding does
        return 1.0
    span = e_reseed - e_plain
    if not span > 1e-6:
        return None
    return float(min(max(1.0 - (e_pipe - e_plain) / span, 0.0), 1.0))


def grain_off(pipe: Any) -> dict[str, Any]:
    """Overrides that take paper grain and tint off the nodes that read a `paper` input."""
    out: dict[str, Any] = {}
    for nid, node in pipe.pipeline.nodes.items():
        fields = type(node.params).model_fields
        if "paper" in pipe.pipeline.connections.get(nid, {}):
            out.update({f"{nid}.{p}": 0.0 for p in ("grain", "paper_tint") if p in fields})
    return out


def held_nodes(pipe: Any) -> list[str]:
    return films.held_nodes(pipe.pipeline)


def film_pipeline(name: str) -> str:
    """The pipeline a film setting runs (films.film_pipeline); a usage error where the variant cannot be found."""
    try:
        return films.film_pipeline(name)
    except PipelineError as exc:
        raise click.UsageError(str(exc)) from None


def film_overrides(pipe: Any, name: str) -> dict[str, Any]:
    """A pipeline's film setting as `--set` overrides (films.film_overrides)."""
    return films.film_overrides(pipe.pipeline, name)


def sweep_overrides(pipe: Any, factor: float) -> dict[str, Any]:
    """The pipeline's SWEEP params scaled by `factor` (matrices entry by entry)."""
    out: dict[str, Any] = {}
    for nid, node in pipe.pipeline.nodes.items():
        for p in SWEEP.get(node.type_name, ()):
            value = getattr(node.params, p)
            out[f"{nid}.{p}"] = (np.asarray(value, np.float64) * factor).tolist()
    return out


def styled(session: Any, name: str, shot: Shot, size: tuple[int, int], overrides: dict[str, Any],
           reseed: bool = False) -> list[np.ndarray]:
    pipe = session.load(name, scene=str(shot.scene), size=size, set=overrides)
    if not reseed:
        return [luminance(img) for _, img in pipe.frames(range(shot.frames), output="image", dtype="float32")]
    base = pipe.pipeline.seed
    out = []
    for t in range(shot.frames):
        pipe.pipeline.seed = base + RESEED_STRIDE * (t + 1)
        out.append(luminance(pipe.render("image", frame=t, dtype="float32")))
    pipe.pipeline.seed = base
    return out


def sketchiness(session: Any, name: str, shot: Shot, size: tuple[int, int], overrides: dict[str, Any],
                first: np.ndarray | None = None) -> float:
    """Mean distance (px) of the dark pixels of frame 0 to the nearest true feature line."""
    from scipy.ndimage import distance_transform_edt, grey_closing

    from .groundtruth import line_drawing

    pipe = session.load(name, scene=str(shot.scene), size=size, set=overrides)
    lum = first if first is not None else luminance(pipe.render("image", frame=0, dtype="float32"))
    linear = pipe.inspect(_linear_depth_ref(pipe), frame=0)[..., 0][::-1]  # row 0 = bottom, as line_drawing takes
    truth = line_drawing(pipe.pipeline.scene.at(0), size, linear).lines[::-1]
    dark = grey_closing(lum, size=(5, 5)) - lum > DARK
    if not dark.any() or not truth.any():
        return float("nan")
    return float(distance_transform_edt(~truth)[dark].mean())


def _linear_depth_ref(pipe: Any) -> str:
    for nid, node in pipe.pipeline.nodes.items():
        if node.type_name == "rasterize" and not getattr(node.params, "enlarge", 0.0):
            return f"{nid}.linear_depth"
    raise click.UsageError(f"{pipe.pipeline.name}: no rasterize node without enlargement to read depth from")


def measure(name: str, session: Any, shots: dict[str, Shot], size: tuple[int, int], do_hold: bool = True,
            do_sweep: bool = True, echo: Any = click.echo) -> dict[str, Any]:
    """One pipeline's figures (module docstring)."""
    t0 = time.perf_counter()
    probe = session.load(name, size=size)
    base = grain_off(probe)
    variants = next(iter(shots.values())).variants

    def shot_figures(shot: Shot, overrides: dict[str, Any], reseed: dict[str, Any] | None = None,
                     source: str = name, grain: dict[str, Any] = base) -> dict[str, Any]:
        e_pipe = shot.errors(styled(session, source, shot, size, {**grain, **overrides}))
        if reseed is not None:
            e_reseed = {"index": reseed["e_reseed"], **{v: reseed[v]["e_reseed"] for v in variants}}
        else:
            e_reseed = shot.errors(styled(session, source, shot, size, {**grain, **overrides}, reseed=True))

        def figures(key: str) -> dict[str, Any]:
            return {"coherence_index": coherence_index(e_pipe[key], shot.floor[key], e_reseed[key]),
                    "e_pipeline": e_pipe[key], "e_plain": shot.floor[key], "e_reseed": e_reseed[key]}

        out = {**figures("index"), **{v: figures(v) for v in variants}}
        out["extended"]["band_px"] = shot.band_px
        return out

    result: dict[str, Any] = {"grain_off": base}
    default = {s: shot_figures(shot, {}) for s, shot in shots.items()}
    still = sweep_overrides(probe, 0.0)
    if still:  # beside the index: the error left with the strays set to 0 (lines moving over the surface, aliasing)
        for s, shot in shots.items():
            e_still = shot.errors(styled(session, name, shot, size, {**base, **still}))
            default[s]["e_no_uncertainty"] = e_still["index"]
            for v in variants:
                default[s][v]["e_no_uncertainty"] = e_still[v]
    result["default"] = {"overrides": {}, "shots": default}
    echo(f"  {name}: default {_indices(default)} ({time.perf_counter() - t0:.0f} s)")
    source = film_pipeline(name)
    film_probe = probe if source == name else session.load(source, size=size)
    film_base = grain_off(film_probe)
    film = film_overrides(film_probe, name)
    if film or source != name:
        result["film"] = {"overrides": film, "shots": {s: shot_figures(shot, film, source=source, grain=film_base)
                                                       for s, shot in shots.items()}}
        if source != name:
            result["film"]["pipeline"] = FILM_PIPELINE[name]
        echo(f"  {name}: film {_indices(result['film']['shots'])}")
    else:
        result["film"] = {"overrides": {}, "same_as": "default", "shots": default}
    held = held_nodes(probe)
    if do_hold and held:
        result["hold"] = {}
        for n in HOLDS:
            ov = {f"{nid}.hold": n for nid in held}
            result["hold"][str(n)] = {s: shot_figures(shot, ov, default[s]) for s, shot in shots.items()}
        echo(f"  {name}: hold " + ", ".join(f"{n}: {_indices(result['hold'][str(n)])}" for n in HOLDS))
    turn = shots.get("turn") or next(iter(shots.values()))
    result["sketchiness_px"] = sketchiness(session, name, turn, size, base)
    if "same_as" not in result["film"]:
        result["film"]["sketchiness_px"] = sketchiness(session, source, turn, size, {**film_base, **film})
    if do_sweep:
        points = [{"factor": 1.0, "sketchiness_px": result["sketchiness_px"],
                   "coherence_index": default[_key(shots, turn)]["coherence_index"]}]
        for factor in SWEEP_FACTORS:
            ov = sweep_overrides(probe, factor)
            if not ov:
                break
            fig = shot_figures(turn, ov)
            points.append({"factor": factor, "sketchiness_px": sketchiness(session, name, turn, size, {**base, **ov}),
                           **fig})
        result["sweep"] = {"params": sorted({k for k in sweep_overrides(probe, 1.0)}), "shot": _key(shots, turn),
                           "points": sorted(points, key=lambda p: p["factor"])}
    echo(f"  {name}: sketchiness {result['sketchiness_px']:.2f} px; {time.perf_counter() - t0:.0f} s")
    return result


def _key(shots: dict[str, Shot], shot: Shot) -> str:
    return next(k for k, v in shots.items() if v is shot)


def _indices(figures: dict[str, Any]) -> str:
    return " ".join(f"{s} {_fmt(f['coherence_index'])}" for s, f in figures.items())


def _fmt(v: float | None) -> str:
    return "-" if v is None else f"{v:.2f}"


def run(pipelines: list[str], size: tuple[int, int], frames: int, do_hold: bool = True, do_sweep: bool = True,
        echo: Any = click.echo, shots: str = "report", scene: Path | None = None, flow: bool = False
        ) -> dict[str, Any]:
    """Every pipeline's figures on the three shots of `shots`, or with `scene` on that one file's frames
    0 .. frames - 1 (a shot named after the file); with `flow`, also along motion estimated by optical flow."""
    import nodegraph as ng

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="coherence-") as tmp, ng.Session(cache=False) as session:
        folder = Path(tmp)
        plain = folder / "plain.yaml"
        atomic_write_text(plain, PLAIN_YAML)
        scenes = {scene.stem: scene} if scene is not None else write_shots(folder, frames, shots)
        measured = {}
        for s, path in scenes.items():
            measured[s] = Shot(session, plain, path, size, frames, flow=flow)
            echo(f"shot {s}: plain floor E = {measured[s].e_plain:.4f}")
            if not any(_moves(field) for field in measured[s].motion):
                echo(f"warning: nothing moves in frames 0-{frames - 1} of {path.name}: the figures only say whether "
                     "the drawing changes on a still picture (animate it, give it an orbit, or measure more --frames)")
        out: dict[str, Any] = {
            "size": list(size), "frames": frames, "fps": FPS, "shots": str(scene) if scene is not None else shots,
            "measure": "mean |L_t - warp(L_t-1, motion_t)| of luminance (0..1) over pixels visible in both frames, "
                       "mean over consecutive pairs; paper grain off" + (
                           "; `flow`: along TV-L1 optical flow of the plain render, Ruder et al.'s mask" if flow
                           else ""),
            "pipelines": {}}
        for name in pipelines:
            echo(f"{name} ...")
            out["pipelines"][name] = measure(name, session, measured, size, do_hold, do_sweep, echo)
        out["seconds"] = round(time.perf_counter() - t0, 1)
    return out


def _moves(motion: np.ndarray, tol: float = 1e-3) -> bool:
    """Whether any covered pixel of a motion field was elsewhere in the previous frame (`motion.displacement`)."""
    return bool(np.abs(mo.displacement(motion)).max() > tol)


def chart(result: dict[str, Any], path: Path) -> Path:
    """Coherence index (turn shot, or the first shot measured) against sketchiness for each pipeline's sweep."""
    from .accuracy_charts import _plt

    plt = _plt()
    fig, ax = plt.subplots(figsize=(8.0, 4.6))
    ax.set_prop_cycle(color=plt.get_cmap("tab20").colors)  # more pipelines than the default ten colours
    for name, r in result["pipelines"].items():
        first = "turn" if "turn" in r["default"]["shots"] else next(iter(r["default"]["shots"]))
        turn = r["default"]["shots"][first]
        pts = r.get("sweep", {}).get("points") or [{"factor": 1.0, "sketchiness_px": r["sketchiness_px"],
                                                    "coherence_index": turn["coherence_index"]}]
        pts = [p for p in pts if p["coherence_index"] is not None and math.isfinite(p["sketchiness_px"])]
        if not pts:
            continue
        line = ax.plot([p["sketchiness_px"] for p in pts], [p["coherence_index"] for p in pts], "-", lw=1,
                       label=name)[0]
        for p in pts:
            ax.scatter([p["sketchiness_px"]], [p["coherence_index"]], color=line.get_color(), zorder=3,
                       s=40 if p["factor"] == 1.0 else 14, marker="o" if p["factor"] == 1.0 else "s")
        film = r.get("film", {})
        film_turn = film.get("shots", {}).get(first, {}).get("coherence_index")
        if film.get("sketchiness_px") is not None and film_turn is not None and math.isfinite(film["sketchiness_px"]):
            ax.scatter([film["sketchiness_px"]], [film_turn], color=line.get_color(), zorder=4, s=70, marker="*")
    ax.set_xlabel("sketchiness: mean distance of drawn pixels from the true lines (px at "
                  f"{result['size'][0]}x{result['size'][1]})")
    shots = next(iter(result["pipelines"].values()))["default"]["shots"] if result["pipelines"] else {}
    ax.set_ylabel(f"coherence index, {'turn' if 'turn' in shots else next(iter(shots), 'turn')} shot\n"
                  "(1 = plain render, 0 = re-seeded every frame)")
    ax.set_ylim(-0.05, 1.05)
    ax.set_title("Coherence against sketchiness (dot: default; squares: main params x0.5 and x2; star: film "
                 "setting)", fontsize=9)
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    from ...fsio import atomic_output

    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=110, bbox_inches="tight", metadata={"Software": None}, format="png")
    plt.close(fig)
    return path


def _tile(img: np.ndarray) -> np.ndarray:
    """An (H, W, 3) uint8 tile of a float image (composited over white where it has alpha)."""
    a = np.asarray(img, np.float64)
    rgb = a[..., :3] if a.shape[2] >= 3 else np.repeat(a[..., :1], 3, axis=2)
    if a.shape[2] == 4:
        rgb = rgb * a[..., 3:] + (1.0 - a[..., 3:])
    return (np.clip(rgb, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def _sheet(rows: list[tuple[str, list[np.ndarray]]], header: str, path: Path) -> Path:
    """Rows of equal tiles, each row with its label above it, written as one PNG."""
    from PIL import Image, ImageDraw

    th, tw = rows[0][1][0].shape[:2]
    gap, label = 4, 14
    width = max(len(t) for _, t in rows) * (tw + gap) + gap
    height = label + len(rows) * (th + label + gap) + gap
    sheet = Image.new("RGB", (width, height), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    draw.text((gap, 1), header, fill=(0, 0, 0))
    y = label
    for text, tiles in rows:
        draw.text((gap, y + 1), text, fill=(0, 0, 0))
        for i, tile in enumerate(tiles):
            sheet.paste(Image.fromarray(tile), (gap + i * (tw + gap), y + label))
        y += th + label + gap
    path.parent.mkdir(parents=True, exist_ok=True)
    from ...fsio import atomic_output

    with atomic_output(path) as tmp:
        sheet.save(tmp, format="PNG")
    return path


def stills(names: list[str], path: Path, size: tuple[int, int] = (256, 256)) -> Path:
    """Each pipeline's frame 0 on its own scene, default beside film setting (paper grain on, as drawn)."""
    import nodegraph as ng

    rows = []
    with ng.Session(cache=False) as session:
        for name in names:
            source = film_pipeline(name)
            film = film_overrides(session.load(source, size=size), name)
            tiles = [_tile(session.load(src, size=size, set=ov).render("image", frame=0, dtype="float32"))
                     for src, ov in ((name, {}), (source, film))]
            rows.append((f"{name}: default | film", tiles))
    pairs = [(f"{a[0]}   /   {b[0]}", a[1] + b[1]) for a, b in zip(rows[::2], rows[1::2], strict=False)]
    if len(rows) % 2:
        pairs.append(rows[-1])
    return _sheet(pairs, "stills, each pipeline's own scene: default (left) and film setting (right)", path)


def contact_sheet(names: list[str], path: Path, size: tuple[int, int] = (160, 160), frames: int = 12,
                  shot: str = "orbit", first: int = 4, count: int = 4, scene: Path | None = None) -> Path:
    """`count` consecutive frames of `shot` (or of the file `scene`) per pipeline: the default, then the film
    setting (grain on)."""
    import nodegraph as ng

    rows = []
    with tempfile.TemporaryDirectory(prefix="coherence-") as tmp, ng.Session(cache=False) as session:
        if scene is not None:
            shot = scene.name
        shown = str(scene) if scene is not None else str(write_shots(Path(tmp), frames)[shot])
        first = min(first, max(frames - count, 0))
        span = range(first, first + count)
        for name in names:
            source = film_pipeline(name)
            film = film_overrides(session.load(source, size=size), name)
            for label, src, ov in (("default", name, {}), ("film", source, film)):
                pipe = session.load(src, scene=shown, size=size, set=ov)
                rows.append((f"{name}: {label}", [_tile(img) for _, img in pipe.frames(span, output="image",
                                                                                       dtype="float32")]))
    pairs = [(f"{a[0]}   /   {b[0]}", a[1] + b[1]) for a, b in zip(rows[::2], rows[1::2], strict=True)]
    return _sheet(pairs, f"{shot} shot, frames {first}-{first + count - 1} of {frames}: default (left four) and film "
                  "setting (right four)", path)


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"expected WxH such as 256x256, got {text!r}") from None
    if not (16 <= w <= 4096 and 16 <= h <= 4096):
        raise click.BadParameter(f"expected each side between 16 and 4096, got {text!r}")
    return w, h


@click.command(help="Temporal coherence of every shipped pipeline: the warping error of consecutive styled frames "
                    "along the exact motion, against the plain lit render and per-frame re-seeding, on three shots "
                    "made in code (turn, orbit, bend); coherence index 1 = plain, 0 = re-seeded.")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
@click.option("--pipelines", default=None,
              help="Comma-separated shipped pipelines or pipeline files with an `image` output (default: every "
                   "shipped one that has one).")
@click.option("--size", default="256x256", show_default=True, help="WxH of the frames.")
@click.option("--frames", default=12, show_default=True, type=click.IntRange(3, 240), help="Frames per shot.")
@click.option("--shots", type=click.Choice(["report", "heldout"]), default=None,
              help="The shots the film settings were chosen on (report, the default), or three held-out ones (other "
                   "shapes and paths).")
@click.option("--scene", "scene", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="Measure on this animated scene instead (a glTF file, a scene YAML with keyframes or an orbit, "
                   "or a mesh file, which orbits): its frames 0 .. --frames - 1, one shot named after the file.")
@click.option("--flow", is_flag=True,
              help="Also measure along motion estimated as the papers do (TV-L1 optical flow of the plain render, "
                   "scikit-image; Ruder et al.'s non-occlusion mask): the `flow` figures beside the index.")
@click.option("--no-hold", is_flag=True, help="Skip the hold N = 1, 2, 4 variants.")
@click.option("--no-sweep", is_flag=True, help="Skip the parameter sweep (and the chart's lines).")
@click.option("--chart", "chart_path", type=click.Path(path_type=Path), default=None,
              help="Write the chart of coherence against sketchiness (PNG), e.g. docs/charts/coherence.png.")
@click.option("--contact-sheet", "sheet_path", type=click.Path(path_type=Path), default=None,
              help="Also write 4 consecutive frames of the orbit shot (or of --scene's file) per pipeline, default "
                   "and film (PNG).")
@click.option("--stills", "stills_path", type=click.Path(path_type=Path), default=None,
              help="Also write each pipeline's still on its own scene, default beside film (PNG).")
def command(json_path: Path | None, pipelines: str | None, size: str, frames: int, shots: str | None,
            scene: Path | None, flow: bool, no_hold: bool, no_sweep: bool, chart_path: Path | None,
            sheet_path: Path | None, stills_path: Path | None) -> None:
    from ... import shipped

    if scene is not None and shots is not None:
        raise click.UsageError("give --scene (your own shot) or --shots (the built ones), not both")

    known = shipped.names()
    names = [p.strip() for p in pipelines.split(",") if p.strip()] if pipelines else [n for n in known
                                                                                       if _draws_image(n)]
    unknown = [n for n in names if n not in known and not Path(n).is_file()]
    if unknown:
        raise click.BadParameter(f"unknown pipeline(s) {', '.join(unknown)}; shipped: {', '.join(known)} (or a "
                                 "pipeline file)", param_hint="--pipelines")
    imageless = [n for n in names if not _draws_image(n)]
    if imageless:
        raise click.BadParameter(f"{', '.join(imageless)}: no `image` output to measure", param_hint="--pipelines")
    if flow:
        try:
            import skimage  # noqa: F401
        except ImportError:
            raise click.UsageError("--flow needs scikit-image (pip install scikit-image)") from None
    result = run(names, _size(size), frames, not no_hold, not no_sweep, shots=shots or "report", scene=scene,
                 flow=flow)
    click.echo(summary(result))
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json_path, json.dumps(result, indent=2) + "\n")
        click.echo(f"wrote {json_path}")
    if chart_path:
        click.echo(f"wrote {chart(result, chart_path)}")
    if sheet_path:
        click.echo(f"wrote {contact_sheet(names, sheet_path, frames=frames, scene=scene)}")
    if stills_path:
        click.echo(f"wrote {stills(names, stills_path)}")


def _draws_image(name: str) -> bool:
    """Whether a shipped pipeline or a pipeline file has an `image` output (vector-only pipelines have nothing to
    warp)."""
    from ... import shipped, yamlio

    return "image" in (yamlio.load(shipped.resolve(name)).get("outputs") or {})


def summary(result: dict[str, Any]) -> str:
    """A table: per pipeline, the index per shot (default, film), whether the film setting reaches TARGET on every
    shot by the index, `extended` and `surfaces` (and `flow` where measured: y / n / - where undefined), hold 1/2/4
    where measured, and sketchiness."""
    width = max([26, *map(len, result["pipelines"])])
    first = next(iter(result["pipelines"].values()), None)
    names = list(first["default"]["shots"]) if first else list(SHOTS)  # the three shots, or a --scene file's one
    flow = bool(first) and "flow" in next(iter(first["default"]["shots"].values()))
    measures = "i/e/s/f" if flow else "i/e/s  "
    lines = [f"{'pipeline':{width}s} " + " ".join(f"{s[:6]:>6s}" for s in names) + "   film " +
             " ".join(f"{s[:6]:>6s}" for s in names) + f"   {TARGET} {measures} hold1/2/4 (mean)  sketch px"]
    for name, r in result["pipelines"].items():
        d, f = r["default"]["shots"], r["film"]["shots"]
        holds = ""
        if "hold" in r:
            holds = "/".join(_fmt(_mean([f["coherence_index"] for f in r["hold"][str(n)].values()])) for n in HOLDS)
        film = r["film"].get("sketchiness_px")
        lines.append(f"{name:{width}s} " + " ".join(f"{_fmt(d[s]['coherence_index']) if s in d else '':>6s}"
                                               for s in names) + "        " +
                     " ".join(f"{_fmt(f[s]['coherence_index']) if s in f else '':>6s}" for s in names) +
                     f"   {_reaches(f, flow):11s} {holds:17s} {r['sketchiness_px']:.2f}" +
                     (f" (film {film:.2f})" if film else ""))
    return "\n".join(lines)


def _reaches(shots: dict[str, Any], flow: bool = False) -> str:
    """'y/n/y': whether every shot's index reaches TARGET, by the index, `extended` and `surfaces` (and `flow`)
    ('-': undefined on some shot)."""
    def one(get: Any) -> str:
        values = [get(f)["coherence_index"] for f in shots.values()]
        return "-" if any(v is None for v in values) else "y" if all(v >= TARGET for v in values) else "n"

    gets = [lambda f: f, lambda f: f["extended"], lambda f: f["surfaces"]] + ([lambda f: f["flow"]] if flow else [])
    return "/".join(one(get) for get in gets)


def _mean(values: list[float | None]) -> float | None:
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None
