"""stroke_style: the seeds' sketchy stylisation applied along vector strokes (uncertainty at the surface point,
repeated and shaken strokes, pressure, width by depth or curvature, tapering, overshoot)."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from nodegraph.errors import NodeError
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import SCENE, STROKES

from . import style as st


class StrokeStyle(Node):
    """Sketchy strokes from clean ones (docs/strokes.md, "Stylisation"). Every input stroke is drawn `repeats`
    times (Nienhaus & Döllner 2004, §3.4: edges sketched repeatedly, each with its own uncertainty); each copy:

    * **uncertainty** (§3.2 and §4.3, geometry-controlled): each vertex moves perpendicular to the stroke on the
      screen by `amplitude` x fbm(q x k + o_c), q the surface point the vertex lies on in the object's rest pose
      (face and barycentric coordinates on the rest mesh: the same point of a skinned surface in every frame),
      k = `scale` cycles per scene diagonal, o_c the copy's domain offset (improved Perlin noise, signed fbm of
      `octaves`: nodes/_shared/noise.py). The paper offsets texture lookups in image space by 2D noise; along a
      vector stroke only the perpendicular part changes the line (our choice). Vertices without a surface point
      (particle strokes) take screen-space noise;
    * **shake** (Lee et al. 2006, multiple contour drawing: 3-5 attempts through smoothly distorted planes): the
      copy shifts by `shake` x a 2D noise of very low frequency (`shake_scale` cycles per diagonal) at the surface
      point: a near-constant offset per stroke, where Lee's report uses a screen-wide sinusoid with random
      coefficients (ours sticks to the surface, so it holds from frame to frame);
    * **pressure**: tone x `repeat_tone`^copy x (1 - `pressure` x clip(0.5 + fbm, 0, 1)) along the stroke;
    * **overshoot**: open strokes run `overshoot` px past both ends along their end tangents (x (1 +
      `overshoot_jitter` x noise at the end point), at most `overshoot_cap` x the stroke's length;
    * **width**: x clip(z_ref / depth, lo, hi) (`width_by: depth`, z_ref the view depth of the scene's centre:
      nearer is thicker) or lo + (hi - lo) x min(1, curvature x `curvature_radius`) (`width_by: curvature`:
      bends thicker), tapered to `taper_floor` over `taper` px at both ends of open strokes.

    Lengths are pixels at the reference size (x px_scale). The noise domain comes from the pipeline seed and the
    node id; `hold: 0` (default) keeps it for the whole sequence (the strokes move only with the surface), `hold:
    N` draws new offsets every N frames (a boil)."""

    version = "1"
    key_omits = frozenset({"hold"})  # covered by the held frame in the key
    inputs = {
        "strokes": Input(STROKES, "Strokes with surface points (mesh_lines.strokes)."),
        "scene": Input(SCENE, "Scene the strokes were found on; the pipeline's scene when not connected.",
                       optional=True),
    }
    outputs = {"out": Output(STROKES, "The stylised strokes: `repeats` copies of each.")}

    class Params(NodeParams):
        repeats: int = Field(2, ge=1, le=16, description="Copies of each stroke, each with its own noise "
                             "(Nienhaus & Döllner §3.4; Lee et al.'s 3-5 attempts).")
        amplitude: float = Field(7.0, ge=0, le=200, description="Uncertainty: pixels of perpendicular offset per "
                                 "unit of noise (fbm mostly within +-0.6).")
        scale: float = Field(10.0, gt=0, le=1e4, description="Uncertainty noise cycles per scene diagonal, on the "
                             "surface.")
        octaves: int = Field(2, ge=1, le=8, description="Octaves of the uncertainty noise.")
        shake: float = Field(2.0, ge=0, le=200, description="Shaken contours: pixels of smooth 2D shift of each "
                             "copy per unit of noise.")
        shake_scale: float = Field(1.5, gt=0, le=1e4, description="Shake noise cycles per scene diagonal.")
        pressure: float = Field(0.35, ge=0, le=1, description="Tone varies along a stroke by up to this much.")
        repeat_tone: float = Field(0.8, ge=0, le=1, description="Tone of copy c times repeat_tone^c.")
        overshoot: float = Field(8.0, ge=0, le=500, description="Pixels an open stroke runs past each end.")
        overshoot_jitter: float = Field(0.5, ge=0, le=1, description="Overshoot varies by this fraction.")
        overshoot_cap: float = Field(0.5, ge=0, le=10, description="Overshoot is at most this fraction of the "
                                     "stroke's length (short strokes do not sprout whiskers).")
        width_by: Literal["none", "depth", "curvature"] = Field("depth", description="depth: nearer strokes "
                                                               "thicker; curvature: bends thicker.")
        width_range: tuple[float, float] = Field((0.6, 1.6), description="(lo, hi) bounds of the width factor.")
        curvature_radius: float = Field(20.0, gt=0, le=1e4, description="Bends of this radius (px) or tighter "
                                        "get the full `hi` width (width_by: curvature).")
        taper: float = Field(8.0, ge=0, le=1000, description="Pixels over which open strokes taper at each end.")
        taper_floor: float = Field(0.2, ge=0, le=1, description="Width factor at the very ends.")
        spacing: float = Field(1.0, gt=0.05, le=64, description="Pixels between overshoot vertices.")
        hold: int = Field(0, ge=0, le=100_000, description="Frames per change of the noise: 0 keeps it for the "
                          "whole sequence, N draws new noise every N frames (a boil).")

    @property
    def context_keys(self) -> frozenset[str]:  # type: ignore[override]
        keys = {"seed", "scene", "camera", "px_scale", "size"}
        if self.params.hold != 0:
            keys.add("frame")
        return frozenset(keys)

    def style(self, px_scale: float, diagonal: float) -> st.Style:
        p = self.params
        lo, hi = p.width_range
        if not 0 < lo <= hi:
            raise NodeError(f"width_range {p.width_range}: need 0 < lo <= hi", self.id, self.type_name)
        d = diagonal if diagonal > 0 else 1.0
        return st.Style(repeats=p.repeats, amplitude=p.amplitude * px_scale, frequency=p.scale / d,
                        octaves=p.octaves, shake=p.shake * px_scale, shake_frequency=p.shake_scale / d,
                        pressure=p.pressure, repeat_tone=p.repeat_tone, overshoot=p.overshoot * px_scale,
                        overshoot_jitter=p.overshoot_jitter, overshoot_cap=p.overshoot_cap,
                        spacing=p.spacing * px_scale, width_by=p.width_by,
                        width_range=(lo, hi), curvature_radius=p.curvature_radius * px_scale,
                        taper=p.taper * px_scale, taper_floor=p.taper_floor,
                        screen_frequency=p.scale / (800.0 * px_scale * np.sqrt(2.0)))

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        strokes = inputs["strokes"]
        scene = inputs.get("scene") or ctx.scene
        rest: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        diagonal, z_ref = 1.0, None
        if scene is not None:
            lo, hi = scene.scale_bounds()
            diagonal = float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))
            used = np.unique(strokes["obj"][strokes["obj"] >= 0])
            if len(used) and int(used[-1]) >= len(scene.objects):
                raise NodeError(f"strokes name object {int(used[-1])} but the scene has {len(scene.objects)}: "
                                "connect the scene the strokes were found on", self.id, self.type_name)
            for o in used.tolist():
                shape = scene.objects[o].mesh.topology_mesh()  # the rest pose of a posed mesh, else the mesh
                rest[o] = (shape.vertices, shape.faces)
            cam = scene.camera_at(ctx.frame)
            centre = 0.5 * (np.asarray(lo, np.float64) + np.asarray(hi, np.float64))
            z_ref = float(-(cam.view_matrix() @ np.r_[centre, 1.0])[2])
        points = st.surface_points(strokes, rest)
        out = st.stylise(strokes, points, self.style(ctx.px_scale, diagonal), ctx.seed, z_ref)
        return {"out": out}


NODE = StrokeStyle
