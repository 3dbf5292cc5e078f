"""sketch: perturbed edge map times perturbed shade map (Nienhaus & Döllner 2004, §3.2, §3.4)."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from nodegraph.errors import NodeError
from nodegraph.gpu import footprint
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import Texture

from .._shared.params import Color
from .._shared.params import Matrix2 as Matrix


class EdgeLayer(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    matrix: Matrix = Field(description="2x2 degree of uncertainty for this layer, in texture units.")
    color: Color = Field((0.1, 0.1, 0.12), description="Edge colour of this layer (RGB, 0..1).")


class Sketch(Node):
    """Applies uncertainty: the noise offset (off_s, off_t), multiplied by a 2x2 matrix, shifts the
    coordinates that read the edge map; a second matrix shifts those that read the shade map. The
    perturbed edge intensity e blends the perturbed shade colour towards the edge colour
    (color = mix(shade, edge_color, e); with a black edge colour this is the paper's product
    shade * (1 - e)). Where the shade map is empty the paper colour shows. Offsets are in texture
    units (1.0 = the image width or height). With `edge_layers` the edge map is applied repeatedly,
    each layer with its own matrix and colour (paper §3.4); `use_shade: false` drops the shade map.

    With `depth` connected, the `depth` output is the perturbed depth for the depth sprite: the depth
    map read (nearest texel) once per edge layer at that layer's shifted coordinates and once at the
    shade map's (when `use_shade`), the minimum of them all (paper §3.3 and §3.4: "depth information
    must be adjusted by accessing the depth map multiple times"). Connect it to
    `depth_sprite.sketch_depth`; `offsets` only holds the first layer's shift. With `depth` connected,
    pixels whose perturbed depth is the far plane are paper (nothing of the object lands there), which is
    exactly what the depth sprite shows over paper: `depth_sprite` with nothing under it then passes this
    colour through, and the sketch pass is the paper's single final pass (§3.5).

    The shifts are in the picture's axes. With `spin` connected (our addition; the paper's shifts keep the
    picture's axes) each shift, once through its matrix, is turned in pixels by the angle the surface under the
    pixel has turned in the picture since frame 0 (`rasterize.spin` of the rasterize node the offsets were read
    on): a part turning in the picture's plane (a bending arm, a wheel, a rolling camera) carries its marks'
    shifts with it, sheared matrices included, instead of keeping them pointing the same way on the screen while
    its lines turn under them. At frame 0 and in a still the turn is 0 and the image is the same as without it.
    `object_noise`'s own `spin` input turns the noise pair before the matrices instead: the same for matrices that
    only scale and turn ([[a, b], [-b, a]]; the shipped pipelines' are, or nearly, but chalk's), but a sheared
    matrix's slant then stays on the page (chalk's film setting keeps it there, like a hand's drag)."""

    version = "3"
    shaders = ("sketch.glsl",)
    inputs = {
        "edges": Input(Texture("R16F"), "Edge intensities (edge_detect.out)."),
        "shade": Input(Texture("RGBA8"), "Shade map: flat colours, alpha = coverage (rasterize.color)."),
        "offset": Input(Texture("RG16F"), "Uncertainty values (off_s, off_t) (perlin_noise.out or "
                        "object_noise.out)."),
        "depth": Input(Texture("R32F"), "Window depth of the same objects (rasterize.depth); needed only for "
                       "the `depth` output.", optional=True),
        "spin": Input(Texture("RG32F"), "The surface's turn in the picture since frame 0 (rasterize.spin, "
                      "same size): every shift is turned by it after its matrix, so marks turn with the surface "
                      "(a film setting; docs/animation.md, Making films).", optional=True),
    }
    outputs = {
        "color": Output(Texture("RGBA16F"), "The sketchy drawing; alpha = coverage of ink or colour."),
        "offsets": Output(Texture("RGBA16F"), "Applied shifts: xy for the (first) edge layer, zw for the shade "
                                              "map, in texture units; depth_sprite reads them."),
        "depth": Output(Texture("R32F"), "Perturbed window depth: minimum of the depth map over every edge "
                        "layer's shift and the shade shift (1 = nothing); for depth_sprite.sketch_depth."),
    }

    class Params(NodeParams):
        edge_matrix: Matrix = Field(((0.008, 0.0), (0.0, 0.008)), description="2x2 degree of uncertainty for the "
                                    "edge map: [[a, b], [c, d]] times (off_s, off_t), in texture units.")
        shade_matrix: Matrix = Field(((-0.012, 0.0), (0.0, -0.012)), description="2x2 degree of uncertainty for the "
                                     "shade map.")
        edge_color: Color = Field((0.1, 0.1, 0.12), description="Edge colour (RGB, 0..1).")
        edge_layers: tuple[EdgeLayer, ...] = Field((), description="Repeated edges: if given, replaces "
                                                   "edge_matrix/edge_color with one layer per entry (paper §3.4).")
        edge_strength: float = Field(1.0, ge=0, le=4, description="Multiplier on the edge intensity.")
        use_shade: bool = Field(True, description="Include the shade map (false: edges only, on paper).")
        paper: Color = Field((0.98, 0.97, 0.94), description="Paper colour where nothing is drawn.")
        line_contrast: float = Field(0.1, ge=0, le=1, description="Lines stay visible over dark fills (a dark "
                                     "texture or material): where the shade under a line is less than this much "
                                     "lighter than the line's colour (luminance of the display values), the line "
                                     "is drawn towards the paper colour, wholly where the fill is as dark as the "
                                     "line; 0: always the line colour. Fills lighter than that are untouched.")

        @model_validator(mode="after")
        def _layers(self) -> Sketch.Params:
            if len(self.edge_layers) > 8:
                raise ValueError("at most 8 edge layers")
            return self

    def layers(self) -> list[EdgeLayer]:
        p = self.params
        return list(p.edge_layers) or [EdgeLayer(matrix=p.edge_matrix, color=p.edge_color)]

    def unread_inputs(self, needed: frozenset[str], sources: dict[str, tuple[str, str, str]]) -> set[str]:
        """The planner's question: which connected inputs a run for `needed` does not read ({input: (source
        node type, id, port)}). Without the `depth` output the depth map only answers "does a surface lie
        behind this texel" (z < 1). When shade and depth are one rasterize node's `color` and `depth`, the
        shade's alpha answers that exactly: both are written by the same fragments, alpha 1 (tone bands keep
        it), and a written depth passed "<" against the cleared far plane 1.0, so it is below 1; elsewhere
        alpha is 0 and depth 1. The depth is then not read (nor, if nothing else wants it, written by the
        G-buffer pass): the same pixels with one texture fewer in this pass and one attachment fewer there."""
        shade, depth = sources.get("shade"), sources.get("depth")
        if ("depth" not in needed and shade is not None and depth is not None and shade[0] == depth[0] == "rasterize"
                and shade[1] == depth[1] and (shade[2], depth[2]) == ("color", "depth")):
            return {"depth"}
        return set()

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        ports = [port for port in ("color", "offsets", "depth") if port in needed]
        if "depth" in ports and "depth" not in inputs:
            raise NodeError("output 'depth' needs input 'depth' (connect rasterize.depth)", self.id, self.type_name)
        layers = self.layers()
        defines: dict[str, Any] = {f"LOC_{port.upper()}": i for i, port in enumerate(ports)}
        defines["LAYERS"] = len(layers)
        size = inputs["shade"].size
        targets = {port: ctx.target(port, size, filter="nearest" if port == "depth" else "linear") for port in ports}
        textures = {"t_edges": inputs["edges"], "t_shade": inputs["shade"], "t_offset": inputs["offset"]}
        spin = inputs.get("spin")
        # offset and spin are read texel for texel on the output's grid: another size would read past their edges
        for name, tex in (("offset", inputs["offset"]), ("spin", spin)):
            if tex is not None and tex.size != size:
                raise NodeError(f"{name} is {tex.size[0]}x{tex.size[1]} but shade is {size[0]}x{size[1]}: connect "
                                f"one made at the drawing's size", self.id, self.type_name)
        if spin is not None:
            defines["HAS_SPIN"] = 1
            textures["t_spin"] = spin
        if "depth" in inputs:  # the key depends on the connection, so the colour does too, never on `needed`
            defines["HAS_DEPTH"] = 1
            if inputs["depth"] is None:  # unread (see unread_inputs): the shade's alpha answers the far test
                defines["COVER_FROM_SHADE"] = 1
            else:
                textures["t_depth"] = inputs["depth"]
        prog = ctx.program("sketch.glsl", defines)
        mats = np.stack([np.asarray(layer.matrix, dtype=np.float32) for layer in layers])  # row-major: bind transposes
        colors = np.asarray([layer.color for layer in layers], dtype=np.float32)
        shade_matrix = np.asarray(p.shade_matrix, dtype=np.float32)
        rect = self._rect(ports, textures, [shade_matrix, *mats], size, turned=spin is not None)
        blanks = {"color": (*p.paper, 0.0), "depth": (1.0,)}
        ctx.gl.fullscreen(prog, [targets[port] for port in ports],
                          textures=textures,
                          uniforms={"u_shade_matrix": shade_matrix,
                                    "u_edge_matrix": mats, "u_edge_color": colors,
                                    "u_edge_strength": p.edge_strength, "u_use_shade": float(p.use_shade),
                                    "u_paper": tuple(p.paper), "u_line_contrast": p.line_contrast},
                          rect=rect, blanks=[blanks.get(port, ()) for port in ports])
        return targets

    @staticmethod
    def _rect(ports: list[str], textures: dict[str, Any], matrices: list[np.ndarray],
              size: tuple[int, int], turned: bool = False) -> tuple[int, int, int, int] | None:
        """Where the pass can draw anything but paper: every lookup at a shifted coordinate lands on a blank
        texel (no edge, no shade coverage, no surface behind) at a pixel farther than the largest shift (matrix
        times the offset's bound, plus the bilinear footprint) from the footprints of the maps read there; such
        a pixel is paper with coverage 0 and depth 1. None (the whole image) when the offsets' bound or a map's
        footprint is unknown, or the `offsets` output is wanted (it differs everywhere)."""
        bound = getattr(textures["t_offset"], "absmax", None)
        if "offsets" in ports or bound is None or len(bound) < 2:
            return None
        rects = []
        for name, tex in textures.items():
            if name in ("t_offset", "t_spin"):
                continue
            fp = footprint.of(tex)
            if fp is None or tex.size != size:
                return None
            blank = fp.blank
            ok = {"t_edges": blank[0] == 0.0,
                  "t_shade": len(blank) == 4 and blank[3] == 0.0 and all(np.isfinite(blank)),
                  "t_depth": blank[0] >= 1.0}.get(name, False)
            if not ok:
                return None
            rects.append(fp.rect)
        a = np.abs(np.asarray(bound[:2], dtype=np.float64))
        shift = np.max([np.abs(np.asarray(m, dtype=np.float64)) @ a for m in matrices], axis=0) * np.asarray(size)
        if turned:  # a shift turned by `spin` (in pixels) keeps its length, not its components
            shift = np.full(2, np.linalg.norm(shift))
        return footprint.grow(footprint.union(rects), int(np.ceil(shift[0])) + 2, int(np.ceil(shift[1])) + 2, size)


NODE = Sketch
