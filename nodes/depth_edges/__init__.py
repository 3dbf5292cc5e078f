"""depth_edges: Curtis' edge map from a depth map (seed 004): tent blur, Sobel, magnitude, threshold."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, model_validator

from nodegraph.errors import NodeError
from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import Texture

_PORTS = {"edges": "LOC_EDGES", "gradient": "LOC_GRADIENT", "magnitude": "LOC_MAGNITUDE"}


class DepthEdges(Node):
    """The template of where ink is needed, exactly as the seed's pseudocode computes it: the depth map
    blurred by the 3x3 tent [1 2 1; 2 4 2; 1 2 1] / 16, the seed's Sobel pair (gx, gy) of the blurred depth
    (= -8 x its gradient, x right, y up; see nodes/_shared/filters.py), mag = sqrt(gx^2 + gy^2), and
    edge = mag >= threshold. Borders clamp to the edge pixel. A depth step s gives a ridge of magnitude
    s * [1, 3, 3, 1] across it, so `threshold` 0.03 finds steps of 0.01 and more.

    The seed thresholds a per-pixel gradient, so a sloped surface (a floor at a grazing angle) that stays
    under the threshold at 800 px crosses it at 400 px, where each pixel spans twice the depth, and the
    floor turns into edges. So the gradient is expressed per pixel at the pipeline's `reference_size`
    (docs/sizes.md; default 800 on the shorter side): multiplied by px_scale = shorter side /
    reference_size. At the reference size this is the seed's computation exactly; at other sizes slopes of
    the same steepness give the same edges, and a depth step counts when s >= threshold / 3 / px_scale
    (smaller images keep only larger steps). `reference_height` H instead scales by height / H (its
    meaning before pipelines had a reference size; the default used to be 800, which equals the pipeline
    reference for a square or landscape image at the default reference_size); None: the seed's per-pixel
    gradient.

    The method wants depth in [0, 1] with 1 = background. `mode: linear` (default) takes
    rasterize.linear_depth (view distance, 0 = background) and maps [near, far] to [0, 1]: the same depth
    difference gives the same edge strength near and far. `mode: window` takes a depth that is already in
    [0, 1] with 1 = background (rasterize.depth, a depth image) and uses it as it is; window depth is
    hyperbolic, so far edges come out weaker."""

    version = "1"
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
        "gradient": Output(Texture("RG32F"), "The seed's Sobel pair (gx, gy) of the blurred depth (times height / "
                           "reference_height); feeds force_field."),
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
            "reference_height), so `threshold` means the same slope at every size; pipeline (default): per "
            "pixel at the pipeline's reference_size (times px_scale = shorter side / reference_size); None: "
            "per pixel of this image, the seed's.")
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

    def gradient_scale(self, height: int, px_scale: float = 1.0) -> float:
        ref = self.params.reference_height
        if ref == "pipeline":
            return px_scale
        return 1.0 if ref is None else height / ref

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        p = self.params
        gl = ctx.gl
        depth = inputs["depth"]
        size = depth.size
        linear = p.mode == "linear"
        across = gl.texture(size, "RG32F", filter="nearest")  # the x pass: (smooth, diff) of the tent along x
        try:
            gl.fullscreen(ctx.program("depth_edges.glsl", {"PASS": 0, "DEPTH_MODE": int(linear)}), [across],
                          textures={"t_depth": depth},
                          uniforms={"u_range": self.depth_range(ctx) if linear else (0.0, 1.0)})
            ports = [port for port in _PORTS if port in needed]
            defines: dict[str, Any] = {_PORTS[port]: i for i, port in enumerate(ports)}
            defines["PASS"] = 1
            targets = {port: ctx.target(port, size, filter="nearest" if port == "edges" else "linear")
                       for port in ports}
            gl.fullscreen(ctx.program("depth_edges.glsl", defines), [targets[port] for port in ports],
                          textures={"t_x": across},
                          uniforms={"u_threshold": p.threshold, "u_scale": self.gradient_scale(size[1], ctx.px_scale)})
        finally:
            gl.release(across)
        return targets


NODE = DepthEdges
