"""distortion_map: the shaken drawing planes of multiple contour drawing (Lee et al. 2006, §4.1.1)."""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from nodegraph.errors import NodeError
from nodegraph.node import HashContext, Input, Node, NodeParams, Output, RunContext
from nodegraph.types import Texture, TextureArray

from .._shared.pencil import MAX_AMPLITUDE


class DistortionMap(Node):
    """`layers` screen-space offset maps, one per attempt at drawing the contours. Layer k shifts the pixel
    at texture coordinates (u, v) by (a_k cos(b_k u + c_k), a_k sin(b_k v + c_k)) pixels, with amplitude
    a_k drawn uniformly from [amplitude_min, 1] x amplitude x image height, frequency b_k = 2 pi f with f
    uniform in `frequency` (cycles per image) and phase c_k uniform in [0, 2 pi), all from the node seed.
    Every offset component is bounded by amplitude x height, so the strokes stay on the shape. The maps
    are smooth and low-frequency: locally each layer is a small shift and stretch, so contours come out
    as several slightly different, roughly parallel attempts (the paper finds 3 to 5 layers best). The
    coefficients stay for the whole sequence by default; `hold: N` draws new ones every N frames.

    `space: object` is the object-space alternative for films (our addition; the paper's maps are screen-space):
    layer k's phases are b_k (g . e_k) / D + c_k and b_k (g . f_k) / D + c'_k instead of b_k u + c_k and
    b_k v + c_k, where g is the object-space position under the pixel (`position`, from rasterize; off the
    objects the nearest covered pixel's), e_k and f_k are unit directions drawn from the node seed, D is the
    diagonal of the scene's bounding box (so `frequency` counts cycles per scene diagonal) and c'_k = c_k. The
    offsets stay in pixels on screen with the same bound; a crease or a drawn feature line keeps its shake as
    its object turns, but an outline reads the position of the rim, which slides over the surface as the view
    turns (docs/pencil.md, Object-space distortion)."""

    version = "1"
    persist = "never"  # ~10 ms to compute, cheaper than a disk read of 3 x 800 x 800 x 2 halves
    inputs = {
        "position": Input(Texture("RGBA32F"), "Object-space position, alpha = coverage (rasterize.position): "
                          "with `space: object` the offsets are functions of it.", optional=True),
    }
    outputs = {"out": Output(TextureArray("RG16F"), "Offsets in pixels (x, y), one layer per attempt.")}

    class Params(NodeParams):
        layers: int = Field(3, ge=1, le=8, description="Number of offset maps (drawing attempts); 3 to 5 read "
                            "best.")
        amplitude: float = Field(0.004, ge=0, le=MAX_AMPLITUDE, description="Largest offset of any component, "
                                 "as a fraction of the image height (the bound; at most 0.02 keeps lines on "
                                 "the shape).")
        amplitude_min: float = Field(0.4, ge=0, le=1, description="Smallest layer amplitude as a fraction of "
                                     "`amplitude`.")
        frequency: tuple[float, float] = Field((0.5, 2.0), description="Range of frequencies in cycles per "
                                               "image width (u) or height (v).")
        animate: bool = Field(False, description="Draw new coefficients every frame (boiling lines); the older "
                              "spelling of `hold: 1`.")
        space: Literal["screen", "object"] = Field(
            "screen", description="screen: the offsets vary with the pixel's texture coordinates (the paper's); "
            "object: with the object-space position under it (`position` connected; `frequency` then counts cycles "
            "per scene diagonal), so the shake sticks to the surface in a film.")
        hold: int | None = Field(None, ge=0, le=100_000, description="Frames per change of the coefficients (the "
                                 "boil rate of the lines): 0 keeps them for the whole sequence, N draws new ones "
                                 "every N frames (frame // N * N). Default: 0, or 1 with `animate: true`.")

        @model_validator(mode="after")
        def _check(self) -> DistortionMap.Params:
            lo, hi = self.frequency
            if not 0.0 <= lo <= hi <= 64.0:
                raise ValueError(f"frequency needs 0 <= lo <= hi <= 64, got {list(self.frequency)}")
            return self

    # hold: covered by the held frame in the key; space: keyed through hash_extra where it is not the default, so
    # the screen-space maps keep their keys
    key_omits = frozenset({"hold", "space"})

    @property
    def hold(self) -> int:  # type: ignore[override]
        p = self.params
        return p.hold if p.hold is not None else (1 if p.animate else 0)

    @property
    def context_keys(self) -> frozenset[str]:  # type: ignore[override]
        keys = {"size", "seed", "frame"} if self.hold != 0 else {"size", "seed"}
        if self.params.space == "object":
            keys.add("scene")  # D, the scene's diagonal
        return frozenset(keys)

    def hash_extra(self, ctx: HashContext) -> Any:
        return {"space": "object"} if self.params.space == "object" else None

    def coefficients(self, seed: int, height: int) -> np.ndarray:
        """(layers, 3) float64 rows (a in pixels, b in radians per texture unit, c in radians)."""
        p = self.params
        u = np.random.default_rng(seed).random((p.layers, 3))
        a = p.amplitude * height * (p.amplitude_min + (1.0 - p.amplitude_min) * u[:, 0])
        lo, hi = p.frequency
        b = 2.0 * math.pi * (lo + (hi - lo) * u[:, 1])
        c = 2.0 * math.pi * u[:, 2]
        return np.stack([a, b, c], axis=1)

    def offsets(self, seed: int, size: tuple[int, int]) -> np.ndarray:
        """(layers, H, W, 2) float32 offsets in pixels at the pixel centres (row 0 = bottom)."""
        w, h = size
        coef = self.coefficients(seed, h)
        u = (np.arange(w) + 0.5) / w
        v = (np.arange(h) + 0.5) / h
        a, b, c = (coef[:, k, None] for k in range(3))
        ox = (a * np.cos(b * u[None, :] + c)).astype(np.float32)  # (layers, W)
        oy = (a * np.sin(b * v[None, :] + c)).astype(np.float32)  # (layers, H)
        out = np.empty((len(coef), h, w, 2), dtype=np.float32)
        out[..., 0] = ox[:, None, :]
        out[..., 1] = oy[:, :, None]
        return out

    def axes(self, seed: int) -> np.ndarray:
        """(layers, 2, 3) float64 unit directions e_k, f_k along which layer k's x and y offsets vary (`space:
        object`), from a stream of their own so the screen-space coefficients are unchanged."""
        v = np.random.default_rng([seed, 1]).normal(size=(self.params.layers, 2, 3))
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    def object_offsets(self, seed: int, position: np.ndarray, diag: float) -> np.ndarray:
        """(layers, H, W, 2) float32 offsets in pixels for an (H, W, 4) object-space position texture (alpha =
        coverage; row 0 = bottom). Uncovered pixels take the nearest covered pixel's position (all zero offsets
        where nothing is covered)."""
        from scipy.ndimage import distance_transform_edt

        h, w = position.shape[:2]
        coef = self.coefficients(seed, h)
        covered = position[..., 3] > 0
        if not covered.any():
            return np.zeros((len(coef), h, w, 2), np.float32)
        g = np.asarray(position[..., :3], dtype=np.float64)
        if not covered.all():
            _, (ri, ci) = distance_transform_edt(~covered, return_indices=True)
            g = g[ri, ci]
        phase = np.einsum("hwc,lkc->lkhw", g, self.axes(seed)) / (diag if diag > 0 else 1.0)
        a, b, c = (coef[:, k, None, None] for k in range(3))
        out = np.empty((len(coef), h, w, 2), dtype=np.float32)
        out[..., 0] = a * np.cos(b * phase[:, 0] + c)
        out[..., 1] = a * np.sin(b * phase[:, 1] + c)
        return out

    def output_shape(self, port: str, size: tuple[int, int]) -> tuple[int, int, int]:
        return (size[0], size[1], self.params.layers)

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        if self.params.space == "object":
            pos = inputs.get("position")
            if pos is None:
                raise NodeError("distortion_map: `space: object` needs `position` connected (in: {position: "
                                "gbuf.position})")
            if tuple(pos.size) != tuple(ctx.size):
                raise NodeError(f"distortion_map: position is {pos.size[0]}x{pos.size[1]}, the image "
                                f"{ctx.size[0]}x{ctx.size[1]}: connect a rasterize of the image's size")
            lo, hi = ctx.scene.scale_bounds() if ctx.scene is not None else ((0.0,) * 3, (1.0,) * 3)
            diag = float(np.linalg.norm(np.asarray(hi, dtype=np.float64) - np.asarray(lo, dtype=np.float64)))
            data = self.object_offsets(ctx.seed, pos.read(), diag)
        else:
            data = self.offsets(ctx.seed, ctx.size)
        return {"out": ctx.gl.texture_array(ctx.size, data.shape[0], "RG16F", data, repeat=False, mipmaps=False)}


NODE = DistortionMap
