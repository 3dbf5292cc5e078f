"""particle_sketch: Curtis' loose and sketchy particle drawing from an edge map and a force field (Curtis,
"Loose and Sketchy Animation", 1998).

The float64 CPU core (force field, particle system, measures) is in `core`, the compiled sequential
sketcher in `jit`; both use `common` (parameters, result) and `rng` (counter-based random numbers), and the
filters are `nodes/_shared/filters.py`. This node wraps `core.simulate`; its strokes are written as SVG by
`nodegraph.output.strokes.to_svg` (the strokes_svg node). `python -m nodegraph_nodes.particle_sketch.bench`
measures the core on synthetic depth, `sketchgraph bench particles` the node chain on a real scene
(docs/particles.md).
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from nodegraph.errors import NodeError
from nodegraph.gpu import footprint
from nodegraph.node import HashContext, Input, Node, NodeParams, Output, RunContext
from nodegraph.types import SCENE, STROKES, Texture
from nodegraph.values import Footprint, Strokes

from .._shared.surface_points import surface_points
from . import core
from .common import Sites
from .rng import mix_np

Color = tuple[float, float, float]
# the core's params that are lengths in pixels (the random force is one per unit time, like the field)
_SCALED = ("n", "m", "line_width", "erase_width", "randomness")
_CORE_FIELDS = ("strokes", "n", "m", "mass", "drag", "randomness", "step", "max_steps", "line_width",
                "erase_width", "integrator", "retries", "batch")


class ParticleSketch(Node):
    """Draws a fixed number of strokes, one particle each (Curtis, "Loose and Sketchy Animation", 1998). A particle
    starts at a random position that is within `n` px of an edge pixel and not within `m` px of a drawn line (at
    most `retries` tries; when none is found the drawing is complete and the run ends early). From rest it moves
    with acceleration (ff - drag v + r) / mass, r a random force of amplitude `randomness` per component, integrated
    by RK4 (or Euler) with time step `step`; each step draws an antialiased segment `line_width` wide and erases the
    same segment from the edge map, so an edge is not traced twice. It dies when it leaves the image, when it is no
    longer within `n` px of a remaining edge pixel, or after `max_steps` steps.

    The method is sequential: each particle erases what the next would trace. With `batch` 1 (default) it
    runs so, one particle at a time, compiled with Numba; the output equals the pure-Python reference's
    bit for bit. With `batch` B > 1, B particles advance in lock-step with NumPy; every lock-step inks
    and erases all its segments before the next one, and a finished lane restarts at once against the
    maps as they are then. Concurrent strokes do not see each other's start, so batching adds parallel
    strokes (a heavier outline at large B): docs/particles.md measures what it changes.

    Random numbers come from the pipeline seed, the node id, `seed` and the frame the seeds are held from:
    frame // hold * hold (`hold` 1: new strokes every frame, the classic squiggle; k: the same particle seeds
    for k frames; 0: never new ones). Within a hold the drawing changes only where its inputs do, and the
    node's key is the same, so held frames come from the cache.

    `starts: surface` (not in Curtis' method; the object-space alternative for films) takes the starts from
    points fixed on the scene's surfaces instead of random positions (`_shared.surface_points`: low-discrepancy
    points on every face, one per `site_spacing`^2 px^2 of its area on screen, visible by `linear_depth` and
    `object_id`), in an order fixed by a hash of face, point and seed: each stroke starts at the next of them
    that passes the `n` and `m` tests, and draws its random forces from its point's key. From frame to frame the
    same surface points start strokes with the same forces, in the same order, so the drawing moves with its
    objects; strokes still change where the edges slide over the surface (silhouettes) and where a start
    accepted in one frame is refused in the next. Starts lie on surfaces only, never on the background beside
    a silhouette. The drawing ends when the points run out."""

    version = "3"
    # keyed through hash_extra where they matter (starts: surface), so random-start keys stay as they were
    key_omits = frozenset({"starts", "site_spacing", "depth_tolerance"})
    shaders = ("particle_sketch.glsl",)
    context_keys = frozenset({"size", "seed", "px_scale"})
    inputs = {
        "edges": Input(Texture("R8"), "Binary edge map, 1 = ink needed (depth_edges.edges)."),
        "force": Input(Texture("RG32F"), "Force field in pixels, x right, y up (force_field.out)."),
        "linear_depth": Input(Texture("R32F"), "Linear view depth (rasterize.linear_depth): which surface points "
                              "are visible, for `starts: surface`.", optional=True),
        "object_id": Input(Texture("R32F"), "Object index + 1 (rasterize.object_id), for `starts: surface`.",
                           optional=True),
        "scene": Input(SCENE, "Scene whose surfaces `starts: surface` reads; the pipeline's scene when not "
                       "connected.", optional=True),
    }
    outputs = {
        "image": Output(Texture("RGBA8"), "The drawing: `color` lines on `paper`, alpha 1."),
        "ink": Output(Texture("R8"), "Ink coverage in [0, 1] (antialiased), for compositing (composite.mask)."),
        "strokes": Output(STROKES, "One polyline per stroke, the particle positions in pixels (x right, y up); "
                          "strokes_svg writes them as SVG."),
        "remaining": Output(Texture("R8"), "The edge map left after erasing (1 = never traced)."),
    }

    class Params(NodeParams):
        strokes: int = Field(2000, ge=0, le=1_000_000, description="Particles to launch; fewer are drawn when "
                             "the edge map runs out of valid starts first.")
        n: float = Field(2.0, ge=0, le=32, allow_inf_nan=False, description="A start, and every later position, "
                         "must be within n px (at the reference size) of a remaining edge pixel.")
        m: float = Field(2.0, ge=0, le=32, allow_inf_nan=False, description="A start must not be within m px "
                         "(at the reference size) of a drawn line.")
        mass: float = Field(6.0, gt=0, allow_inf_nan=False, description="Particle mass: more is more inertia "
                            "(strokes overshoot corners and curves).")
        drag: float = Field(1.0, ge=0, allow_inf_nan=False, description="Drag coefficient: more keeps strokes "
                            "closer to the edge map (and slower: speed about 1 / drag px per unit time).")
        randomness: float = Field(0.35, ge=0, allow_inf_nan=False, description="Amplitude of the random force "
                                  "per component (drawn anew each step): livelier, wobblier strokes.")
        step: float = Field(3.0, gt=0, le=64, allow_inf_nan=False, description="Time step; with the saturated "
                            "force field a particle moves about step / drag px per step.")
        max_steps: int = Field(25, ge=1, le=100_000, description="Steps after which a stroke ends anyway.")
        line_width: float = Field(1.2, gt=0, le=16, allow_inf_nan=False, description="Ink line width in px at "
                                  "the reference size (antialiased).")
        erase_width: float | None = Field(None, ge=0, le=32, allow_inf_nan=False, description="Width erased "
                                          "from the edge map along each segment; default: line_width. Keep it "
                                          "below 2 n.")
        color: Color = Field((0.1, 0.1, 0.12), description="Line colour (RGB, 0..1).")
        paper: Color = Field((0.98, 0.97, 0.94), description="Paper colour of `image` (RGB, 0..1).")
        integrator: Literal["rk4", "euler"] = Field("rk4", description="Classic RK4, or explicit Euler (cheaper, "
                                                    "drifts more off curved edges).")
        hold: int = Field(1, ge=0, le=100_000, description="Keep the particle seeds for this many frames (1: "
                          "new strokes every frame; 0: never new ones).")
        seed: int = Field(0, ge=0, le=2**32 - 1, description="Mixed into the seed from the pipeline seed and the "
                          "node id: another drawing with the same pipeline.")
        batch: int = Field(1, ge=1, le=65_536, description="1: one particle at a time, as Curtis describes "
                           "(compiled); B > 1: B particles in lock-step (NumPy), which adds parallel strokes.")
        retries: int = Field(5000, ge=1, le=10_000_000, description="Random start positions tried per stroke "
                             "before the drawing counts as complete.")
        starts: Literal["random", "surface"] = Field("random", description="`random`: uniform random positions "
                                                     "(Curtis); `surface`: points fixed on the surfaces, in a fixed "
                                                     "order, each with its own random forces, so a film's strokes "
                                                     "follow their objects (needs linear_depth and object_id).")
        site_spacing: float = Field(2.0, ge=0.25, le=32, allow_inf_nan=False, description="`starts: surface`: "
                                    "about one surface point per site_spacing^2 px^2 of each face on screen (px at "
                                    "the reference size).")
        depth_tolerance: float = Field(0.02, gt=0, le=1, allow_inf_nan=False, description="`starts: surface`: a "
                                       "point is visible within this fraction of its depth of the depth buffer.")

    def core_params(self, px_scale: float = 1.0) -> core.ParticleParams:
        """The core's params at px_scale: distances and the random force times px_scale (as written at 1)."""
        values = {name: getattr(self.params, name) for name in _CORE_FIELDS}
        if px_scale != 1.0:
            for name in _SCALED:
                if values[name] is not None:
                    values[name] = values[name] * px_scale
        return core.ParticleParams(**values)

    def seed_frame(self, frame: int) -> int:
        """The frame whose seed the particles use at `frame`."""
        return self.held_frame(frame)  # the engine's hold convention (nodegraph.node.held_frame)

    def hash_extra(self, ctx: HashContext) -> Any:
        if self.params.starts == "surface":  # the points move with the pose and camera of the frame itself
            p = self.params
            return {"seed_frame": self.seed_frame(ctx.frame), "pose_frame": ctx.frame,
                    "surface": [p.site_spacing, p.depth_tolerance]}
        return {"seed_frame": self.seed_frame(ctx.frame)}

    def rng(self, ctx: RunContext) -> np.random.Generator:
        return np.random.default_rng([ctx.seed_for_frame(self.seed_frame(ctx.frame)), self.params.seed])

    def sites(self, ctx: RunContext, inputs: dict[str, Any], size: tuple[int, int], rng: np.random.Generator,
              edges: np.ndarray) -> Sites | None:
        """The surface points of `starts: surface` (None for random starts), in an order drawn from `rng`: a hash
        of each point's key and one number from `rng`, so the seed changes which points start first."""
        p = self.params
        if p.starts != "surface":
            return None
        if inputs.get("linear_depth") is None or inputs.get("object_id") is None:
            raise NodeError("starts: surface needs the linear_depth and object_id inputs (rasterize.linear_depth, "
                            "rasterize.object_id)", self.id, self.type_name)
        for name in ("linear_depth", "object_id"):
            if inputs[name].size != size:
                raise NodeError(f"input {name!r} {inputs[name].size[0]}x{inputs[name].size[1]} differs from the edge "
                                f"map's {size[0]}x{size[1]}", self.id, self.type_name)
        scene = ctx.input_scene(inputs)
        w, h = size
        cam = scene.camera_at(ctx.frame)
        depth = inputs["linear_depth"].read()[..., 0].astype(np.float64)
        ids = np.rint(inputs["object_id"].read()[..., 0]).astype(np.int64)
        # only points within n px of an edge pixel can ever start a stroke (the edges only shrink): the others
        # are left out before sorting, which leaves the order of the rest as it was
        near = core.dilate(edges, p.n * ctx.px_scale)
        rows, keys = surface_points(scene, cam.view_matrix(), cam.projection_matrix(w / h), depth, ids, size,
                                    p.site_spacing * ctx.px_scale, p.depth_tolerance, most=1 << 22, keep=near)
        salt = np.uint64(rng.integers(0, 2**63))
        order = np.argsort(mix_np(keys ^ salt), kind="stable")
        return Sites(rows[order, :2], keys[order])

    def simulate(self, ctx: RunContext, edges: Any, force: Any, inputs: dict[str, Any] | None = None
                 ) -> core.SketchResult:
        """Read back the edge map and the field, and draw (CPU); `inputs` has what `starts: surface` reads."""
        if edges.size != force.size:
            raise NodeError(f"inputs 'edges' {edges.size[0]}x{edges.size[1]} and 'force' {force.size[0]}x"
                            f"{force.size[1]} differ in size; feed both from one depth map", self.id, self.type_name)
        e = edges.read()[..., 0] >= 0.5 if edges.fmt != "R8" else edges.read_native()[..., 0] >= 128  # v / 255 >= 0.5
        # float32 as read back: the sketcher promotes to float64 before combining values, so the strokes
        # are bit-identical to a float64 copy's (checked), without a 10 MB conversion per frame
        ff = force.read()[..., :2]
        s = ctx.px_scale
        if s != 1.0:
            ff = ff * np.float32(s)  # pixels per unit time at this size: the trajectories scale with the image
        try:
            rng = self.rng(ctx)
            sites = self.sites(ctx, inputs or {}, edges.size, rng, e)
            return core.simulate(e, ff, self.core_params(s), rng, sites=sites)
        except ValueError as exc:  # the core checks its arrays (a force field with NaN or inf)
            raise NodeError(str(exc), self.id, self.type_name) from None

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        gl = ctx.gl
        size = inputs["edges"].size
        res = self.simulate(ctx, inputs["edges"], inputs["force"], inputs)
        out: dict[str, Any] = {}
        if "strokes" in needed:
            out["strokes"] = Strokes(list(res.strokes), size, p.line_width * ctx.px_scale, p.color)
        if "remaining" in needed:
            out["remaining"] = gl.upload(res.edges.astype(np.float32), ctx.format("remaining"), filter="nearest")
        if "ink" in needed or "image" in needed:
            # the ink at its planned format when it is an output; otherwise float32, uploaded as is
            ink = gl.upload(res.sketch, ctx.format("ink") if "ink" in needed else "R32F")
            ink.footprint = _ink_footprint(res.sketch)  # no ink outside the strokes' pixels
            if "image" in needed:
                out["image"] = ctx.target("image", size)
                prog = ctx.program("particle_sketch.glsl")
                uniforms = {"u_color": tuple(p.color), "u_paper": tuple(p.paper)}
                rect = blanks = None
                if footprint.of(ink) is not None:
                    # outside the ink, the paper: what the pass gives on no ink, asked of the pass itself
                    key = ("particle_sketch", tuple(p.color), tuple(p.paper), ink.fmt, out["image"].fmt)

                    def one(src: list[Any]) -> list[Any]:
                        img = gl.texture((1, 1), out["image"].fmt)
                        gl.fullscreen(prog, [img], textures={"t_ink": src[0]}, uniforms=uniforms)
                        return [img]

                    blanks = footprint.blank_results(gl, key, [(ink.fmt, (0.0,))], one)
                    rect = ink.footprint.rect if blanks is not None else None  # type: ignore[union-attr]
                gl.fullscreen(prog, [out["image"]], textures={"t_ink": ink}, uniforms=uniforms, rect=rect,
                              blanks=blanks)
            if "ink" in needed:
                out["ink"] = ink
            else:
                gl.release(ink)
        return out


def _ink_footprint(sketch: np.ndarray) -> Footprint:
    """The pixels holding ink (`sketch`: (H, W) coverage, row 0 at the bottom as uploaded): their bounding
    rectangle, 0 outside it (an empty rectangle for a drawing without strokes). 0.3 ms at 800x800."""
    rows = np.flatnonzero(sketch.any(axis=1))
    if rows.size == 0:
        return Footprint((0, 0, 0, 0), (0.0,))
    cols = np.flatnonzero(sketch.any(axis=0))
    return Footprint((int(cols[0]), int(rows[0]), int(cols[-1] - cols[0] + 1), int(rows[-1] - rows[0] + 1)), (0.0,))


NODE = ParticleSketch
