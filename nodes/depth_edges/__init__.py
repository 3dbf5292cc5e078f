"""depth_edges: Curtis' edge map from a depth map (Curtis, "Loose and Sketchy Animation", 1998): tent blur,
Sobel, magnitude, threshold."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, model_validator

from nodegraph.errors import NodeError
from nodegraph.gpu import footprint
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import Texture

from .._shared import scaled_kernels as kernels

_PORTS = {"edges": "LOC_EDGES", "gradient": "LOC_GRADIENT", "magnitude": "LOC_MAGNITUDE"}


class DepthEdges(Node):
    """The template of where ink is needed, exactly as Curtis' pseudocode computes it: the depth map
    blurred by the 3x3 tent [1 2 1; 2 4 2; 1 2 1] / 16, Curtis' Sobel pair (gx, gy) of the blurred depth
    (= -8 x its gradient, x right, y up; see nodes/_shared/filters.py), mag = sqrt(gx^2 + gy^2), and
    edge = mag >= threshold. Borders clamp to the edge pixel. A depth step s gives a ridge of magnitude
    s * [1, 3, 3, 1] across it, so `threshold` 0.03 finds steps of 0.01 and more.

    Curtis' filters work per pixel, so a sloped surface (a floor at a grazing angle) that stays under
    the threshold at 800 px crosses it at 400 px, where each pixel spans twice the depth, and a depth step
    peaks at 3 s whatever the size. So with `reference_height: pipeline` (default) the tent and the Sobel
    pair have their footprint in pixels at the pipeline's `reference_size` (docs/sizes.md; default 800 on
    the shorter side): at px_scale = shorter side / reference_size the kernels are Curtis', a function
    of the offset in reference pixels, sampled at this image's pixels (scaled_kernels.py: the tent's half-width
    2 px_scale, the difference I(x + px_scale) - I(x - px_scale) of the linearly interpolated image). At the
    reference size this is Curtis' computation exactly; at other sizes a slope gives the same gradient,
    a step of s the same 3 s peak above the reference size and 2 s at half of it (the per-pixel filters
    times px_scale gave 6 s at 1600 px and 1.5 s at 400), and the edge band is as wide in the picture.
    `reference_height` H instead keeps Curtis' per-pixel filters and scales the gradient by height / H
    (slopes match, steps do not); None: Curtis' per-pixel gradient.

    The method wants depth in [0, 1] with 1 = background. `mode: linear` (default) takes
    rasterize.linear_depth (view distance, 0 = background) and maps [near, far] to [0, 1]: the same depth
    difference gives the same edge strength near and far. `mode: window` takes a depth that is already in
    [0, 1] with 1 = background (rasterize.depth, a depth image) and uses it as it is; window depth is
    hyperbolic, so far edges come out weaker."""

    version = "2"
    shaders = ("depth_edges.glsl",)
    @property
    def context_keys(self) -> frozenset[str]:  # type: ignore[override]
        keys = {"size", "camera"}
        if self.params.reference_height == "pipeline":
            keys.add("px_scale")
        return frozenset(keys)
    inputs = {
        "depth": Input(Texture("R32F"), "mode: linear: rasterize.linear_depth (0 = background); mode: window: "
                       "a depth in [0, 1] with 1 = background (rasterize.depth)."),
    }
    outputs = {
        "edges": Output(Texture("R8"), "Binary edge map: 1 where mag >= threshold, else 0."),
        "gradient": Output(Texture("RG32F"), "Curtis' Sobel pair (gx, gy) of the blurred depth (times height / "
                           "reference_height; per reference pixel with `pipeline`); feeds force_field."),
        "magnitude": Output(Texture("R32F"), "mag = sqrt(gx^2 + gy^2)."),
    }

    class Params(NodeParams):
        threshold: float = Field(0.03, gt=0, description="Edge where the gradient magnitude of the blurred "
                                 "depth (in [0, 1] depth units, times 8) is at least this; a depth step s peaks "
                                 "at 3 s.")
        mode: Literal["linear", "window"] = Field(
            "linear", description="linear: the input is linear view depth (0 = background), mapped to [0, 1] by "
            "`range`; window: the input already is depth in [0, 1] with 1 = background, used as it is.")
        reference_height: int | Literal["pipeline"] | None = Field(
            "pipeline", description="Express the gradient per pixel of an image this tall (times height / "
            "reference_height), so `threshold` means the same slope at every size; pipeline (default): the "
            "tent and Sobel with their footprint in pixels at the pipeline's reference_size (slopes and steps "
            "alike); None: per pixel of this image, Curtis'.")
        range: tuple[float, float] | None = Field(
            None, description="mode: linear only: the view distances mapped to 0 and 1 (clamped); default: the "
            "camera's near and far planes.")

        @model_validator(mode="after")
        def _range(self) -> DepthEdges.Params:
            if self.range is not None and not self.range[1] > self.range[0]:
                raise ValueError(f"range: expected [near, far] with far > near, got {list(self.range)}")
            return self

    def check_size(self, size: tuple[int, int], inputs: dict[str, tuple[int, int, int] | None]) -> str | None:
        w, h = (inputs.get("depth") or size)[:2]
        if w < 2 or h < 2:
            return f"needs a depth image of at least 2x2 pixels (the tent and gradient read neighbours), got {w}x{h}"
        return None

    def depth_range(self, ctx: RunContext) -> tuple[float, float]:
        """The linear depths mapped to 0 and 1."""
        if self.params.range is not None:
            return self.params.range
        cam = ctx.camera
        if cam is None:
            raise NodeError("mode: linear needs the scene's camera or an explicit `range` [near, far]; set range, "
                            "or use mode: window for a depth in [0, 1]", self.id, self.type_name)
        return float(cam.near), float(cam.far)

    def gradient_scale(self, height: int) -> float:
        """The factor on the gradient of the per-pixel filters (1 with the scaled kernels of `pipeline`)."""
        ref = self.params.reference_height
        return 1.0 if ref is None or ref == "pipeline" else height / ref

    def kernels(self, px_scale: float = 1.0) -> kernels.Kernels:
        """The tent (half-width 2 px) and Sobel weights: at px_scale with `pipeline`, else Curtis'."""
        return kernels.kernels(2.0, px_scale if self.params.reference_height == "pipeline" else 1.0)

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        depth = inputs["depth"]
        size = depth.size
        ports = [port for port in _PORTS if port in needed]
        k = self.kernels(ctx.px_scale)
        fp = footprint.of(depth)
        rects = blanks = None
        if fp is not None:
            # outside the depth's footprint grown by the window (along x for the x pass, then along y) every
            # fetch reads the blank depth: the outputs there are what the passes give on a constant
            rects = kernels.pass_rects(fp.rect, k, size)
            # linear depth's background 0 maps to 1 whatever the range: an animated camera's near and far planes
            # need no new evaluation each frame
            ranged = self.params.mode == "linear" and fp.blank[0] != 0.0
            key = ("depth_edges", self.params.model_dump_json(), tuple(ports), depth.fmt, fp.blank, size[1],
                   ctx.px_scale, kernels.split(k), self.depth_range(ctx) if ranged else None)
            blanks = footprint.blank_results(
                ctx.gl, key, [(depth.fmt, fp.blank)],
                lambda src: list(self._draw(ctx, src[0], size[1], ports, k, keep_across=True).values()))
            if blanks is None:
                rects = None
        return self._draw(ctx, depth, size[1], ports, k, rects, blanks)

    def _draw(self, ctx: RunContext, depth: Any, height: int, ports: list[str], k: kernels.Kernels,
              rects: tuple[Any, ...] | None = None, blanks: list[tuple[float, ...]] | None = None,
              keep_across: bool = False) -> dict[str, Any]:
        """The passes over `depth` (the image's, or a 1x1 one for `footprint.blank_results`; `height`: the image's,
        for the gradient's scale): the x pass and the y pass, or the four split ones for wide kernels
        (`kernels.draw`). `rects`/`blanks`: where each pass draws and the values outside (the intermediate
        passes' first, then the outputs'). `keep_across`: return the intermediate textures too, first."""
        p = self.params
        size = depth.size
        linear = p.mode == "linear"
        defines: dict[str, Any] = {_PORTS[port]: i for i, port in enumerate(ports)}
        targets = {port: ctx.target(port, size, filter="nearest" if port == "edges" else "linear") for port in ports}
        out = kernels.draw(ctx, "depth_edges.glsl", k, size,
                           ({"DEPTH_MODE": int(linear)}, {"t_depth": depth},
                            {"u_range": self.depth_range(ctx) if linear else (0.0, 1.0)}),
                           (defines, {}, {"u_threshold": p.threshold, "u_scale": self.gradient_scale(height)},
                            [targets[port] for port in ports]),
                           rects, blanks, keep=keep_across)
        if keep_across:
            return {**{f"across{i}": t for i, t in enumerate(out[:-len(ports)])}, **targets}
        return targets


NODE = DepthEdges
