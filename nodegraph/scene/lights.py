"""Punctual lights (KHR_lights_punctual, and `lights:` in scene YAML): directional, point and spot lights with
colour and intensity, placed by a world matrix, and what the shading nodes make of several of them.

A scene with lights shades by irradiance instead of the one unit scene light's N.L (docs/scenes.md, "Lights"):

    E(p, n) = sum over lights of colour * intensity * falloff(d) * spot(p) * max(n . l, 0)

with l the unit direction from p towards the light and, as the KHR_lights_punctual spec recommends:
directional lights (lux) falloff = 1; point and spot lights (candela) falloff = 1 / d^2, times
clamp(1 - (d / range)^4, 0, 1) when a range is given; spot lights
spot = clamp(cos_angle * scale + offset, 0, 1)^2 with scale = 1 / max(0.001, cos(inner) - cos(outer)) and
offset = -cos(outer) * scale (1 inside the inner cone, 0 outside the outer one).

Exposure: the scene multiplies E by one `exposure`, fixed for the whole animation. By default (`auto_exposure`)
it is 1 / the largest colour channel of E over the surface at the first frame (each face's corners and
centroid, on whichever side of the face is lit more), so the brightest lit point of the first frame is 1, as
a unit light facing a surface is under the scene light. The shading nodes read exposure * E: `rasterize` with
`lit` per colour channel (clamped to 1), the tone nodes (pencil_shade, tone bands) its luminance (Rec. 709
weights), which for white lights is the same number.

Matrices are float64, row-major, acting on column vectors, as in nodegraph/scene/scene.py. A light shines
down its node's local -Z; its node's scale moves it but changes neither its range nor its intensity (the
extension's rule).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

LightKind = Literal["directional", "point", "spot"]

MAX_LIGHTS = 8
"""Lights a shader takes (uniform arrays); beyond it the first MAX_LIGHTS in scene order are drawn, with a
one-line note."""

LUMINANCE = (0.2126, 0.7152, 0.0722)  # Rec. 709: the brightness of a colour, for tone
MAX_EXPOSURE_SAMPLES = 400_000  # faces sampled per scene for `auto_exposure` (an even stride beyond it)


class LightWarning(UserWarning):
    """Lights beyond MAX_LIGHTS are dropped, none lights the surface, or `exposure:` is given without lights."""


@dataclass(frozen=True, eq=False)
class Light:
    """One punctual light. `color` is linear RGB, `intensity` lux (directional) or candela (point, spot);
    `range` None is infinite; cone angles in radians (spot only); `matrix` the light's node -> world."""

    kind: LightKind
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0
    range: float | None = None
    inner_cone: float = 0.0
    outer_cone: float = math.pi / 4.0
    matrix: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = ""

    def __post_init__(self) -> None:
        if self.kind not in ("directional", "point", "spot"):
            raise ValueError(f"light type must be directional, point or spot, got {self.kind!r}")
        m = np.array(self.matrix, dtype=np.float64).reshape(4, 4)
        m.flags.writeable = False
        object.__setattr__(self, "matrix", m)
        object.__setattr__(self, "color", tuple(float(c) for c in self.color))
        if len(self.color) != 3 or not all(math.isfinite(c) and c >= 0.0 for c in self.color):
            raise ValueError(f"light colour must be 3 finite numbers >= 0, got {self.color}")
        if not (math.isfinite(self.intensity) and self.intensity >= 0.0):
            raise ValueError(f"light intensity must be a finite number >= 0, got {self.intensity}")
        if self.range is not None and not (math.isfinite(self.range) and self.range > 0.0):
            raise ValueError(f"light range must be > 0, got {self.range}")
        if not 0.0 <= self.inner_cone < self.outer_cone <= math.pi / 2.0:
            raise ValueError(f"spot cone angles need 0 <= inner < outer <= pi/2, got inner {self.inner_cone}, "
                             f"outer {self.outer_cone}")
        if not np.all(np.isfinite(m)):
            raise ValueError("light matrix must be finite")

    @property
    def position(self) -> np.ndarray:
        return self.matrix[:3, 3].copy()

    @property
    def direction(self) -> np.ndarray:
        """Unit world direction the light shines along (its node's -Z)."""
        d = -self.matrix[:3, 2]
        n = float(np.linalg.norm(d))
        return d / n if n > 0.0 else np.array([0.0, 0.0, -1.0])

    def cone(self) -> tuple[float, float]:
        """(scale, offset) of the spot factor clamp(cos * scale + offset, 0, 1)^2; (0, 1) for other lights."""
        if self.kind != "spot":
            return 0.0, 1.0
        ci, co = math.cos(self.inner_cone), math.cos(self.outer_cone)
        scale = 1.0 / max(0.001, ci - co)
        return scale, -co * scale

    def params(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": self.kind, "color": list(self.color), "intensity": float(self.intensity),
                               "matrix": [float(x) for x in self.matrix.ravel()]}
        if self.range is not None:
            out["range"] = float(self.range)
        if self.kind == "spot":
            out["cone"] = [float(self.inner_cone), float(self.outer_cone)]
        return out


def irradiance(lights: Sequence[Light], points: Any, normals: Any) -> np.ndarray:
    """(k, 3) float64 irradiance E at world `points` (k, 3) with unit `normals` (k, 3) (module docstring)."""
    return _both_sides(lights, points, normals)[0]


def _both_sides(lights: Sequence[Light], points: Any, normals: Any) -> tuple[np.ndarray, np.ndarray]:
    """(E with `normals`, E with the normals reversed), each (k, 3): one pass over the lights."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    out = np.zeros((len(p), 3))
    back = np.zeros((len(p), 3))
    for light in lights:
        if light.kind == "directional":
            to_light = np.broadcast_to(-light.direction, p.shape)
            amount = np.ones(len(p))
        else:
            delta = light.position - p
            d2 = np.einsum("ij,ij->i", delta, delta)
            d = np.sqrt(d2)
            with np.errstate(divide="ignore", invalid="ignore"):
                to_light = np.where(d[:, None] > 0.0, delta / d[:, None], 0.0)
                amount = np.where(d2 > 0.0, 1.0 / d2, 0.0)
            if light.range is not None:
                amount = amount * np.clip(1.0 - (d / light.range) ** 4, 0.0, 1.0)
            if light.kind == "spot":
                scale, offset = light.cone()
                cos = -(to_light @ light.direction)
                amount = amount * np.clip(cos * scale + offset, 0.0, 1.0) ** 2
        cos = np.einsum("ij,ij->i", n, to_light) * (amount * light.intensity)
        out += np.outer(np.maximum(cos, 0.0), light.color)
        back += np.outer(np.maximum(-cos, 0.0), light.color)
    return out, back


def auto_exposure(lights: Sequence[Light], objects: Sequence[Any]) -> float:
    """1 / the largest colour channel of E over the objects' surfaces (each face's corners and centroid, the
    face's normal on whichever side E is larger): the brightest lit point is 1. 1.0 when nothing is lit."""
    lights = list(lights)[:MAX_LIGHTS]
    best = 0.0
    for obj in objects:
        mesh = obj.mesh
        faces = np.asarray(mesh.faces)
        if not len(faces) or not lights:
            continue
        if len(faces) > MAX_EXPOSURE_SAMPLES:
            faces = faces[:: -(-len(faces) // MAX_EXPOSURE_SAMPLES)]
        v = obj.world_vertices() if hasattr(obj, "world_vertices") else np.asarray(mesh.vertices, np.float64)
        tri = v[faces]  # (m, 3, 3)
        cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        length = np.linalg.norm(cross, axis=1)
        keep = length > 0.0
        if not keep.any():
            continue
        tri, nrm = tri[keep], cross[keep] / length[keep, None]
        pts = np.concatenate([tri[:, 0], tri[:, 1], tri[:, 2], tri.mean(axis=1)])
        nn = np.concatenate([nrm] * 4)
        front, back = _both_sides(lights, pts, nn)
        e = np.maximum(front.max(axis=1), back.max(axis=1))
        best = max(best, float(e.max()))
    return 1.0 / best if best > 0.0 and math.isfinite(1.0 / best) else 1.0


def drawn(lights: Sequence[Light], where: str = "") -> tuple[Light, ...]:
    """The first MAX_LIGHTS lights; one LightWarning line when more are dropped."""
    if len(lights) <= MAX_LIGHTS:
        return tuple(lights)
    warnings.warn(f"{where + ': ' if where else ''}{len(lights)} lights: the first {MAX_LIGHTS} are drawn, "
                  f"{len(lights) - MAX_LIGHTS} dropped ({', '.join(lt.name or lt.kind for lt in lights[MAX_LIGHTS:])})",
                  LightWarning, stacklevel=2)
    return tuple(lights[:MAX_LIGHTS])


def view_uniforms(lights: Sequence[Light], view: Any, exposure: float) -> dict[str, np.ndarray]:
    """The uniforms of nodegraph/gpu/shaders/lights.glsl for `lights` seen through `view` (world -> view, 4x4):
    u_light_pos (xyz: view-space position, or direction towards the light for a directional one; w: 0
    directional, 1 point or spot), u_light_dir (xyz: view-space direction the light shines along; w: range, 0
    infinite), u_light_color (colour * intensity * exposure), u_light_cone (spot scale, offset)."""
    v = np.asarray(view, dtype=np.float64)
    lights = list(lights)[:MAX_LIGHTS]
    pos = np.zeros((len(lights), 4))
    axis = np.zeros((len(lights), 4))
    color = np.zeros((len(lights), 3))
    cone = np.zeros((len(lights), 2))
    for i, lt in enumerate(lights):
        d = v[:3, :3] @ lt.direction
        d = d / max(float(np.linalg.norm(d)), 1e-300)
        if lt.kind == "directional":
            pos[i] = (*(-d), 0.0)
        else:
            pos[i] = (*(v[:3, :3] @ lt.position + v[:3, 3]), 1.0)
        axis[i] = (*d, lt.range or 0.0)
        color[i] = np.asarray(lt.color) * lt.intensity * exposure
        cone[i] = lt.cone()
    return {"u_light_pos": pos, "u_light_dir": axis, "u_light_color": color, "u_light_cone": cone}
