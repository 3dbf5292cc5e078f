"""Scenes: objects (mesh + transform + flat color), a camera, a light and an optional orbit.

A scene comes from `builtin:NAME`, a scene YAML file or a bare mesh file (see `load_scene`).
Matrices are float64, row-major NumPy arrays acting on column vectors (`p' = M @ p`); upload them
to GL transposed (`m.T.astype("f4").tobytes()`) or with `transpose=True`.
"""

from __future__ import annotations

import difflib
import functools
import hashlib
import json
import math
import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationInfo,
    WithJsonSchema,
    field_validator,
    model_validator,
)

from .. import yamlio
from ..errors import Location, MeshError, PipelineError
from ..fsio import show_path
from . import framing, keyframes, primitives, views
from .animation import DEFAULT_FPS, Animator, CameraAnim, ObjectAnim
from .lights import Light
from .meshes import GLTF_EXTENSIONS, SUPPORTED_EXTENSIONS, Mesh, load_mesh, merge_meshes

if TYPE_CHECKING:
    from .gltf import GltfInstance

SCENE_EXTENSIONS = (".yaml", ".yml")
DEFAULT_MESH_COLOR = (0.91, 0.78, 0.55)  # warm light ochre
DEFAULT_LIGHT = (-0.4, 0.6, 0.7)

Vec = tuple[float, float, float]


# --- math ---------------------------------------------------------------------------------------


def _unit(v: Any, what: str = "vector") -> np.ndarray:
    a = np.asarray(v, dtype=np.float64).reshape(3)
    n = float(np.linalg.norm(a))
    if not math.isfinite(n) or n == 0.0:
        raise ValueError(f"{what} must be a finite non-zero vector, got {a.tolist()}")
    return a / n


def _cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of two 3-vectors, the same float64 operations as np.cross (so the same bits) at an eighth of its
    cost on such short arrays; cameras are built and asked for their matrices every frame."""
    a0, a1, a2 = (float(x) for x in a)
    b0, b1, b2 = (float(x) for x in b)
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def translation(t: Any) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = np.asarray(t, dtype=np.float64)
    return m


def scaling(s: Any) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = np.diag(np.broadcast_to(np.asarray(s, dtype=np.float64), (3,)))
    return m


def rotation(axis: Any, degrees: float) -> np.ndarray:
    """4x4 right-handed rotation by `degrees` about `axis` (counter-clockwise looking down the axis)."""
    x, y, z = _unit(axis, "rotation axis")
    a = math.radians(degrees)
    c, s, t = math.cos(a), math.sin(a), 1.0 - math.cos(a)
    m = np.eye(4)
    m[:3, :3] = [[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                 [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                 [t * x * z - s * y, t * y * z + s * x, t * z * z + c]]
    return m


def euler_xyz(degrees: Any) -> np.ndarray:
    """Rotation about X, then Y, then Z (fixed axes), angles in degrees."""
    rx, ry, rz = (float(d) for d in degrees)
    return rotation((0, 0, 1), rz) @ rotation((0, 1, 0), ry) @ rotation((1, 0, 0), rx)


def compose(translate: Any = (0, 0, 0), rotate: Any = (0, 0, 0), scale: Any = 1.0) -> np.ndarray:
    """T @ R @ S: scale, then rotate (X, Y, Z degrees), then translate."""
    return translation(translate) @ euler_xyz(rotate) @ scaling(scale)


def _frozen(a: Any, shape: tuple[int, ...]) -> np.ndarray:
    out = np.array(a, dtype=np.float64).reshape(shape)
    out.flags.writeable = False
    return out


def _floats(a: Any) -> list[float]:
    return [float(x) for x in np.asarray(a, dtype=np.float64).ravel()]


# --- camera -------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Camera:
    """A perspective or orthographic camera; OpenGL conventions (right-handed, looks down -z in view space).
    An orthographic camera (`projection="orthographic"`) sees along its one view direction: `ortho_half` is
    half the extent it spans across the image's shorter side (its height with `fov_vertical`, as glTF's
    `ymag`), in world units; `fov_y_deg` is then unused. Its eye still places the near and far planes."""

    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray
    fov_y_deg: float = 35.0
    near: float = 0.1
    far: float = 100.0
    fov_vertical: bool = False
    """False: `fov_y_deg` spans the shorter image side (a framed subject stays in a tall picture too); True: it
    spans the image's height whatever its shape, as a glTF camera's `yfov` does (`ortho_half` likewise)."""
    projection: Literal["perspective", "orthographic"] = "perspective"
    ortho_half: float = 1.0

    def __post_init__(self) -> None:
        for name in ("eye", "target", "up"):
            object.__setattr__(self, name, _frozen(getattr(self, name), (3,)))
        object.__setattr__(self, "fov_y_deg", float(self.fov_y_deg))
        object.__setattr__(self, "near", float(self.near))
        object.__setattr__(self, "far", float(self.far))
        object.__setattr__(self, "ortho_half", float(self.ortho_half))
        if self.projection not in PROJECTIONS:
            raise ValueError(f"camera type must be one of {', '.join(PROJECTIONS)}, got {self.projection!r}")
        if not 0.0 < self.fov_y_deg < 180.0:
            raise ValueError(f"camera fov must be in (0, 180) degrees, got {self.fov_y_deg}")
        if self.orthographic:
            if not (0.0 < self.ortho_half < math.inf):
                raise ValueError(f"orthographic camera needs a finite half height > 0, got {self.ortho_half}")
            if not (0.0 <= self.near < self.far < math.inf):
                raise ValueError(f"orthographic camera needs 0 <= near < far, got near={self.near}, far={self.far}")
        elif not 0.0 < self.near < self.far:
            raise ValueError(f"camera needs 0 < near < far, got near={self.near}, far={self.far}")
        forward = self.target - self.eye
        if np.linalg.norm(forward) == 0.0:
            raise ValueError("camera eye and target coincide")
        if np.linalg.norm(_cross3(forward, self.up)) <= 1e-9 * np.linalg.norm(forward) * np.linalg.norm(self.up):
            raise ValueError("camera up vector is parallel to the viewing direction (or zero)")

    @property
    def distance(self) -> float:
        return float(np.linalg.norm(self.target - self.eye))

    @property
    def orthographic(self) -> bool:
        return self.projection == "orthographic"

    def toward_eye(self) -> np.ndarray:
        """The eye in homogeneous world coordinates (4,): (eye, 1) for a perspective camera, the direction
        towards the viewer (-forward, 0) for an orthographic one, whose eye is at infinity. A surface point p
        sees the viewer along e[:3] - e[3] p."""
        if self.orthographic:
            return np.r_[-self.basis()[2], 0.0]
        return np.r_[self.eye, 1.0]

    def target_half(self) -> float:
        """Half the extent of the view across the shorter image side (the height with `fov_vertical`) in the
        plane through the target: what a perspective and an orthographic camera both show there."""
        if self.orthographic:
            return self.ortho_half
        return self.distance * math.tan(math.radians(self.fov_y_deg) / 2.0)

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, true up, forward) unit vectors in world space."""
        f = _unit(self.target - self.eye)
        r = _unit(_cross3(f, self.up))
        return r, _cross3(r, f), f

    def view_matrix(self) -> np.ndarray:
        """World -> view (4, 4); computed once per camera (the keys and the nodes of a frame all ask), a copy
        returned each time."""
        m = self.__dict__.get("_view")
        if m is None:
            r, u, f = self.basis()
            m = np.eye(4)
            m[0, :3], m[1, :3], m[2, :3] = r, u, -f
            m[:3, 3] = -m[:3, :3] @ self.eye
            object.__setattr__(self, "_view", m)
        return m.copy()

    def tan_half(self, aspect: float = 1.0) -> tuple[float, float]:
        """tan of the half field of view across x and y. `fov_y_deg` spans the shorter image side, so a
        framed subject stays in the picture whether the image is wide or tall; with `fov_vertical`, the height."""
        t = math.tan(math.radians(self.fov_y_deg) / 2.0)
        return (t * aspect, t) if aspect >= 1.0 or self.fov_vertical else (t, t / aspect)

    def half_extent(self, aspect: float = 1.0) -> tuple[float, float]:
        """An orthographic camera's half width and half height in world units (the rule of `tan_half`)."""
        t = self.ortho_half
        return (t * aspect, t) if aspect >= 1.0 or self.fov_vertical else (t, t / aspect)

    def projection_matrix(self, aspect: float = 1.0) -> np.ndarray:
        """Projection to clip space; z_ndc in [-1, 1] maps near to -1 and far to +1. Orthographic: x and y
        scaled by the half extents, z linear in the view depth, w = 1."""
        n, fa = self.near, self.far
        if self.orthographic:
            hx, hy = self.half_extent(aspect)
            m = np.zeros((4, 4))
            m[0, 0] = 1.0 / hx
            m[1, 1] = 1.0 / hy
            m[2, 2] = -2.0 / (fa - n)
            m[2, 3] = -(fa + n) / (fa - n)
            m[3, 3] = 1.0
            return m
        tan_x, tan_y = self.tan_half(aspect)
        m = np.zeros((4, 4))
        m[0, 0] = 1.0 / tan_x
        m[1, 1] = 1.0 / tan_y
        m[2, 2] = (fa + n) / (n - fa)
        m[2, 3] = 2.0 * fa * n / (n - fa)
        m[3, 2] = -1.0
        return m

    def view_projection(self, aspect: float = 1.0) -> np.ndarray:
        return self.projection_matrix(aspect) @ self.view_matrix()

    def project(self, points: Any, aspect: float = 1.0) -> np.ndarray:
        """World points (k, 3) -> NDC (k, 3)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        clip = np.c_[p, np.ones(len(p))] @ self.view_projection(aspect).T
        return clip[:, :3] / clip[:, 3:4]

    def params(self) -> dict[str, Any]:
        out = {"eye": _floats(self.eye), "target": _floats(self.target), "up": _floats(self.up),
               "fov_y_deg": self.fov_y_deg, "near": self.near, "far": self.far}
        if self.fov_vertical:  # only then: the keys of every other camera stay as they were
            out["fov_vertical"] = True
        if self.orthographic:  # likewise: perspective cameras keep their keys
            out["projection"] = self.projection
            out["ortho_half"] = self.ortho_half
        return out

    def with_lens(self, projection: str | None = None, fov: float | None = None, zoom: float | None = None) -> Camera:
        """The camera as `--camera-type`, `--fov` and `--zoom` change it. A change of type keeps what the view
        shows in the plane through the target (`target_half`); `fov` (perspective only) sets the field of view
        and moves the eye along the view axis so that plane keeps its extent (near and far move with it);
        `zoom` then magnifies the view by that factor (the field of view's tangent, or the orthographic
        extent, divided by it)."""
        cam = self
        if projection is not None and projection != cam.projection:
            if projection not in PROJECTIONS:
                raise ValueError(f"camera type must be one of {', '.join(PROJECTIONS)}, got {projection!r}")
            half = cam.target_half()
            if projection == "orthographic":
                cam = replace(cam, projection="orthographic", ortho_half=half)
            else:
                fov_deg = math.degrees(2.0 * math.atan(half / cam.distance))
                cam = replace(cam, projection="perspective", fov_y_deg=fov_deg, near=max(cam.near, cam.far * 1e-6))
        if fov is not None:
            if cam.orthographic:
                raise ValueError("--fov sets a perspective camera's field of view; an orthographic camera is sized "
                                 "by --zoom (or give --camera-type perspective)")
            fov = float(fov)
            if not 0.0 < fov < 180.0:
                raise ValueError(f"fov must be in (0, 180) degrees, got {fov:g}")
            half, dist = cam.target_half(), cam.distance
            new_dist = half / math.tan(math.radians(fov) / 2.0)
            shift = new_dist - dist
            forward = cam.basis()[2]
            far = cam.far + shift
            near = max(cam.near + shift, 1e-3 * half, far * 1e-6)
            cam = replace(cam, eye=cam.target - forward * new_dist, fov_y_deg=fov, near=near,
                          far=max(far, near * 1.001))
        if zoom is not None:
            zoom = float(zoom)
            if not (0.0 < zoom < math.inf):
                raise ValueError(f"zoom must be a number > 0, got {zoom:g}")
            if cam.orthographic:
                cam = replace(cam, ortho_half=cam.ortho_half / zoom)
            else:
                t = math.tan(math.radians(cam.fov_y_deg) / 2.0) / zoom
                cam = replace(cam, fov_y_deg=math.degrees(2.0 * math.atan(t)))
        return cam


PROJECTIONS = ("perspective", "orthographic")


def near_far_for(eye: Any, center: Any, radius: float) -> tuple[float, float]:
    """Near/far planes hugging a bounding sphere seen from `eye`."""
    dist = float(np.linalg.norm(np.asarray(center, dtype=np.float64) - np.asarray(eye, dtype=np.float64)))
    radius = float(radius)
    if not radius > 0.0:  # a point: no absolute floor, which would clip meshes smaller than it
        radius = max(dist * 1e-3, 1e-300)
    near = max(dist - 1.05 * radius, 1e-3 * radius)
    far = max(dist + 1.05 * radius, near * 1.001)
    return near, far


def frame_camera(bmin: Any, bmax: Any, fov_y_deg: float = 35.0, direction: Any = (0.55, 0.45, 1.0),
                 margin: float = 1.08, up: Any = (0.0, 1.0, 0.0)) -> Camera:
    """A camera looking at the bounding box's centre from `direction` (target -> eye), far enough
    that the bounding sphere (times `margin`) fits the field of view, which spans the shorter image
    side (Camera.tan_half): framed for every aspect ratio."""
    lo, hi = np.asarray(bmin, dtype=np.float64), np.asarray(bmax, dtype=np.float64)
    center = (lo + hi) / 2.0
    radius = float(np.linalg.norm(hi - lo)) / 2.0
    if not radius > 0.0:
        radius = max(float(np.abs(center).max()) * 1e-3, 1e-3)
    d = _unit(direction, "camera direction")
    dist = radius * margin / math.sin(math.radians(fov_y_deg) / 2.0)
    eye = center + d * dist
    upv = np.asarray(up, dtype=np.float64)
    if np.linalg.norm(np.cross(d, upv)) < 1e-6:
        upv = np.array([0.0, 0.0, -1.0]) if d[1] > 0 else np.array([0.0, 0.0, 1.0])
    near, far = near_far_for(eye, center, radius)
    return Camera(eye=eye, target=center, up=upv, fov_y_deg=fov_y_deg, near=near, far=far)


@dataclass(frozen=True, eq=False)
class Orbit:
    """Turn the camera about `axis` through `center` (None: the camera target) by degrees per frame."""

    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))
    degrees_per_frame: float = 6.0
    center: np.ndarray | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "axis", _frozen(_unit(self.axis, "orbit axis"), (3,)))
        object.__setattr__(self, "degrees_per_frame", float(self.degrees_per_frame))
        if self.center is not None:
            object.__setattr__(self, "center", _frozen(self.center, (3,)))

    def params(self) -> dict[str, Any]:
        return {"axis": _floats(self.axis), "degrees_per_frame": self.degrees_per_frame,
                "center": None if self.center is None else _floats(self.center)}


# --- scene --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SceneObject:
    mesh: Mesh
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))  # object -> world, (4, 4) float64
    color: Vec = DEFAULT_MESH_COLOR  # flat, unlit RGB in [0, 1]
    sketchy: bool = True
    name: str = ""
    index: int = -1  # position in Scene.objects (set by Scene); object ids in buffers can use index + 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "transform", _frozen(self.transform, (4, 4)))
        object.__setattr__(self, "color", tuple(float(c) for c in self.color))
        if len(self.color) != 3:
            raise ValueError(f"object color needs 3 components, got {self.color}")
        object.__setattr__(self, "name", self.name or self.mesh.name)

    @property
    def mirrored(self) -> bool:
        """True when the transform flips handedness (front faces become clockwise)."""
        return bool(np.linalg.det(self.transform[:3, :3]) < 0)

    def normal_matrix(self) -> np.ndarray:
        """(3, 3) inverse transpose of the linear part, for transforming normals."""
        return np.linalg.inv(self.transform[:3, :3]).T

    def world_vertices(self) -> np.ndarray:
        t = self.transform
        return self.mesh.vertices @ t[:3, :3].T + t[:3, 3]

    def world_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        if self.mesh.n_vertices == 0:
            return np.zeros(3), np.zeros(3)
        if np.array_equal(self.transform, np.eye(4)):
            return self.mesh.bounds()
        w = self.world_vertices()
        return w.min(axis=0), w.max(axis=0)


@dataclass(frozen=True, eq=False)
class Scene:
    name: str
    objects: tuple[SceneObject, ...]
    camera: Camera
    light_direction: np.ndarray = field(default_factory=lambda: _unit(DEFAULT_LIGHT))
    light_space: Literal["view", "world"] = "view"
    orbit: Orbit | None = None
    background: Vec = (1.0, 1.0, 1.0)
    source: str | None = None
    animation: Any = None  # an animation.Animator: the scene moves (see `at`); None: static
    # a posed scene: the animated scene's bounds, which sizes relative to the scene (`scale_bounds`) use, so
    # they stay fixed over the animation; None: `bounds()`
    extent: tuple[np.ndarray, np.ndarray] | None = None
    # punctual lights (nodegraph/scene/lights.py): where there are any they shade instead of the scene light,
    # their irradiance times `exposure`
    lights: tuple[Light, ...] = ()
    exposure: float = 1.0
    _cache: dict[str, Any] = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        objs = tuple(o if o.index == i else replace(o, index=i) for i, o in enumerate(self.objects))
        object.__setattr__(self, "objects", objs)
        object.__setattr__(self, "light_direction", _frozen(_unit(self.light_direction, "light direction"), (3,)))
        object.__setattr__(self, "background", tuple(float(c) for c in self.background))
        if self.light_space not in ("view", "world"):
            raise ValueError(f"light space must be 'view' or 'world', got {self.light_space!r}")

    def at(self, frame: int) -> Scene:
        """The scene posed at `frame` (t = frame / fps) as a static scene; itself when static."""
        if self.animation is None:
            return self
        key = ("pose", int(frame))
        hit = self._cache.get(key)
        if hit is None:
            # a few poses: keys and computes of one frame share one; frame 0 stays (rasterize's `spin` turns every
            # frame against it)
            poses = [k for k in self._cache if isinstance(k, tuple) and k[0] == "pose" and k[1] != 0]
            for k in poses[: max(0, len(poses) - 3)]:
                del self._cache[k]
            hit = self._cache[key] = self.animation.pose(self, int(frame))
            hit._cache["posed_from"] = self  # the animated scene: rasterize's `motion` poses the frame before
        return hit

    def animated_source(self) -> Scene | None:
        """The animated scene this one is a pose of (`at`), or None."""
        return self._cache.get("posed_from")

    def camera_at(self, frame: int) -> Camera:
        """The camera for `frame`: eye, target and up turned rigidly about the orbit axis."""
        if self.animation is not None:
            return self.at(frame).camera_at(frame)
        if self.orbit is None or frame == 0 or self.orbit.degrees_per_frame == 0.0:
            return self.camera
        key = ("camera", int(frame))  # asked for several times per frame (keys, nodes): build it once
        cached = self._cache.get(key)
        if cached is not None:
            return cached
        if len(self._cache) > 256:
            for k in [k for k in self._cache if isinstance(k, tuple) and k[0] == "camera"]:
                del self._cache[k]
        cam = self.camera
        center = cam.target if self.orbit.center is None else self.orbit.center
        r = rotation(self.orbit.axis, frame * self.orbit.degrees_per_frame)[:3, :3]
        out = replace(cam, eye=center + r @ (cam.eye - center), target=center + r @ (cam.target - center),
                      up=r @ cam.up)
        self._cache[key] = out
        return out

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World-space bounding box of all objects."""
        if "bounds" not in self._cache:
            if not self.objects:
                self._cache["bounds"] = (np.zeros(3), np.zeros(3))
            else:
                b = [o.world_bounds() for o in self.objects]
                self._cache["bounds"] = (np.min([lo for lo, _ in b], axis=0), np.max([hi for _, hi in b], axis=0))
        lo, hi = self._cache["bounds"]
        return lo.copy(), hi.copy()

    def scale_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounds that sizes relative to the scene measure (noise cycles and enlargement per scene
        diagonal): the same at every frame of an animation (`extent`), else `bounds()`."""
        if self.extent is None:
            return self.bounds()
        return self.extent[0].copy(), self.extent[1].copy()

    def select(self, which: Literal["all", "sketchy", "non_sketchy"] = "all") -> list[SceneObject]:
        """Objects in scene order; each keeps its `index` so object ids agree across selections."""
        if which == "all":
            return list(self.objects)
        if which == "sketchy":
            return [o for o in self.objects if o.sketchy]
        if which == "non_sketchy":
            return [o for o in self.objects if not o.sketchy]
        raise ValueError(f"select: expected 'all', 'sketchy' or 'non_sketchy', got {which!r}")

    def n_triangles(self) -> int:
        return sum(o.mesh.n_faces for o in self.objects)

    def content_hash(self) -> str:
        """Digest of everything that changes pixels (not names or the source path); cached."""
        if "hash" not in self._cache:
            doc = {
                "objects": [{"mesh": o.mesh.content_hash(), "transform": _floats(o.transform),
                             "color": list(o.color), "sketchy": o.sketchy} for o in self.objects],
                "camera": self.camera.params(),
                "light": {"direction": _floats(self.light_direction), "space": self.light_space},
                "orbit": None if self.orbit is None else self.orbit.params(),
                "background": list(self.background),
            }
            if self.animation is not None:  # static scenes keep their keys
                doc["animation"] = self.animation.digest()
            if self.extent is not None:
                doc["extent"] = [_floats(b) for b in self.extent]
            if self.lights:  # scenes without lights keep their keys
                doc["lights"] = [lt.params() for lt in self.lights]
                doc["exposure"] = float(self.exposure)
            text = json.dumps(doc, sort_keys=True, separators=(",", ":"))
            self._cache["hash"] = hashlib.sha256(text.encode()).hexdigest()
        return self._cache["hash"]


# --- scene YAML ---------------------------------------------------------------------------------


def _three(value: Any) -> Any:
    if isinstance(value, (list, tuple)) and len(value) == 3:
        return value
    raise ValueError("expected a list of 3 numbers [x, y, z]")


def _nonzero(value: Vec) -> Vec:
    if not all(math.isfinite(x) for x in value) or not any(value):
        raise ValueError("expected a finite non-zero vector")
    return value


def _rgb(value: Any) -> Any:
    if isinstance(value, (list, tuple)) and len(value) == 3:
        return value
    raise ValueError("expected a color [r, g, b] with 3 numbers in [0, 1]")


def _in_unit(value: Vec) -> Vec:
    if not all(0.0 <= x <= 1.0 for x in value):
        raise ValueError("expected color components in [0, 1]")
    return value


def _scale(value: Any) -> Any:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return (value, value, value)
    if isinstance(value, (list, tuple)) and len(value) == 3:
        return value
    raise ValueError("expected a positive number or [sx, sy, sz]")


def _positive(value: Vec) -> Vec:
    if not all(x > 0 and math.isfinite(x) for x in value):
        raise ValueError("expected positive scale factors (mirroring is not supported)")
    return value


def _triple(item: dict[str, Any]) -> dict[str, Any]:
    return {"type": "array", "prefixItems": [item] * 3, "minItems": 3, "maxItems": 3}


_POSITIVE = {"type": "number", "exclusiveMinimum": 0}
Vec3 = Annotated[Vec, BeforeValidator(_three)]
Dir3 = Annotated[Vec, BeforeValidator(_three), AfterValidator(_nonzero)]
# the JSON Schema says what the validators accept (for `sketchgraph schema --scene`)
Color = Annotated[Vec, BeforeValidator(_rgb), AfterValidator(_in_unit),
                  WithJsonSchema(_triple({"type": "number", "minimum": 0, "maximum": 1}))]
Scale3 = Annotated[Vec, BeforeValidator(_scale), AfterValidator(_positive),
                   WithJsonSchema({"anyOf": [_POSITIVE, _triple(_POSITIVE)]})]


MAX_MAGNITUDE = 1e12
"""Largest magnitude of any number in a scene file: float64 keeps about 15 significant digits, so coordinates
up to 1e12 still hold a mesh 1e-3 across (the limit nodegraph/scene/origin.py recentres within); beyond it a
value (a light direction squared, a camera's near plane) overflows or loses the shape later."""


def _bounded(value: Any) -> Any:
    if isinstance(value, float) and abs(value) > MAX_MAGNITUDE:
        raise ValueError(f"expected numbers of magnitude at most {MAX_MAGNITUDE:g}")
    if isinstance(value, (tuple, list)):
        for item in value:
            _bounded(item)
    return value


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, defer_build=True)  # every float finite

    @field_validator("*", mode="after")
    @classmethod
    def _magnitudes(cls, value: Any) -> Any:
        """Every number of every field at most `MAX_MAGNITUDE` in magnitude (finite is checked already)."""
        return _bounded(value)


class TransformSpec(_Spec):
    translate: Vec3 = Field((0.0, 0.0, 0.0), description="Translation [x, y, z], applied last.")
    rotate: Vec3 = Field((0.0, 0.0, 0.0), description="Rotation in degrees about X, then Y, then Z (fixed "
                         "axes), applied after scaling.")
    scale: Scale3 = Field((1.0, 1.0, 1.0), description="Uniform scale (a number) or [sx, sy, sz]; positive.")

    def matrix(self) -> np.ndarray:
        return compose(self.translate, self.rotate, self.scale)


class ObjectSpec(_Spec):
    name: str | None = Field(None, description="Object name (default: the mesh file's stem or the "
                             "primitive type with its index).")
    mesh: str | None = Field(None, description="Mesh file (.obj, .ply, .off, .stl; .gltf/.glb as one still "
                             "mesh), relative to the scene file. Give this, 'primitive' or 'gltf'.")
    gltf: str | None = Field(None, description="A glTF 2.0 file (.gltf, .glb), relative to the scene file: its "
                             "objects, skins, morph targets and animation, placed by 'transform'.")
    animation: str | int | None = Field(None, description="With 'gltf': the animation to play, by name or index, or "
                                        "all (default: all, together, as glTF viewers play them; the command "
                                        "line's --animation wins).")
    animation_end: Literal["hold", "loop"] | None = Field(None, description="With 'gltf': what a clip shorter than "
                                                          "the longest does after its last key: hold its last pose "
                                                          "(default) or loop.")
    animate: keyframes.ObjectAnimateSpec | None = Field(None, description="Keyframes of translate, rotate and "
                                                        "scale (each replaces that part of 'transform').")
    primitive: dict[str, Any] | None = Field(None, description="A procedural mesh: {type: NAME, ...params}; "
                                             "types: " + ", ".join(primitives.PRIMITIVES) + ".")
    transform: TransformSpec = Field(default_factory=TransformSpec, description="Object-to-world transform.")
    color: Color = Field(DEFAULT_MESH_COLOR, description="Flat, unlit color [r, g, b] in [0, 1] (the shade "
                         "map).")
    sketchy: bool = Field(True, description="Draw sketchily (false: plain 3D geometry composed by depth).")
    up: Literal["x", "y", "z", "-x", "-y", "-z", "auto"] | None = Field(None, description="With 'mesh': the file's "
                                                      "up axis (-y: upside down), turned to +Y before 'transform' "
                                                      "(auto: the format's convention unless the shape clearly says "
                                                      "otherwise, as for a bare mesh file); default: as written.")

    @model_validator(mode="after")
    def _one_source(self) -> ObjectSpec:
        if sum(x is not None for x in (self.mesh, self.primitive, self.gltf)) != 1:
            raise ValueError("give exactly one of 'mesh' (a file), 'primitive' ({type: ...}) or 'gltf' (a glTF file)")
        if self.gltf is None and (self.animation is not None or self.animation_end is not None):
            raise ValueError("'animation' and 'animation_end' are for a 'gltf' file's animations")
        if self.gltf is not None and self.animate is not None:
            raise ValueError("'animate' keyframes are for meshes and primitives; a glTF file plays its own animation")
        if self.up is not None and self.mesh is None:
            raise ValueError("'up' stands a mesh file up (primitives are +Y up, glTF files are Y-up)")
        return self


class CameraSpec(_Spec):
    eye: Vec3 | None = Field(None, description="Camera position [x, y, z] in world space (with 'target'; or "
                             "give 'view').")
    target: Vec3 | None = Field(None, description="Point the camera looks at.")
    view: Literal["three-quarter", "front", "back", "left", "right", "top"] | None = Field(
        None, description="Instead of eye and target: frame the scene's bounding box from this side, the "
        "front being +Z (three-quarter: from [0.55, 0.45, 1.0]).")
    up: Dir3 = Field((0.0, 1.0, 0.0), description="Up direction; must not be parallel to target - eye.")
    type: Literal["perspective", "orthographic"] = Field("perspective", description="Projection: perspective, "
                                                         "or orthographic (parallel lines stay parallel).")
    fov: float = Field(35.0, gt=0.0, lt=180.0, description="Perspective: field of view in degrees across the "
                       "image's shorter side.")
    height: float | None = Field(None, gt=0.0, allow_inf_nan=False, description="Orthographic: the extent of "
                                 "the image's height in world units (default: what a 35-degree view shows in "
                                 "the plane through the target).")
    near: float | None = Field(None, gt=0.0, description="Near plane distance (default: hug the scene's "
                               "bounding sphere).")
    far: float | None = Field(None, gt=0.0, description="Far plane distance (default: hug the scene's "
                              "bounding sphere).")
    animate: keyframes.CameraAnimateSpec | None = Field(None, description="Keyframes of eye, target, up and fov "
                                                        "(each replaces that value).")

    @model_validator(mode="after")
    def _placed(self) -> CameraSpec:
        if self.view is None and (self.eye is None or self.target is None):
            raise ValueError("give 'eye' and 'target', or a 'view' (front, back, left, right, top, three-quarter)")
        if self.view is not None and (self.eye is not None or self.target is not None):
            raise ValueError("'view' frames the scene itself: give it or 'eye' and 'target', not both")
        if self.type == "perspective" and self.height is not None:
            raise ValueError("'height' sizes an orthographic camera: add type: orthographic, or give 'fov'")
        if self.type == "orthographic" and "fov" in self.model_fields_set:
            raise ValueError("'fov' is a perspective camera's: an orthographic camera takes 'height'")
        return self

    def lens(self, camera: Camera) -> Camera:
        """`camera` (placed and framed as a perspective one) with this spec's type and height."""
        if self.type == "perspective":
            return camera
        camera = camera.with_lens("orthographic")
        if self.height is not None:
            camera = replace(camera, ortho_half=self.height / 2.0, fov_vertical=True)
        return camera


class LightSpec(_Spec):
    direction: Dir3 = Field(DEFAULT_LIGHT, description="Direction toward the light (normalised on load).")
    space: Literal["view", "world"] = Field("view", description="Space of 'direction': 'view' moves with the "
                                            "camera, 'world' stays fixed in the scene.")


class PunctualLightSpec(_Spec):
    type: Literal["directional", "point", "spot"] = Field(description="directional (intensity in lux), point or "
                                                          "spot (candela), as KHR_lights_punctual defines them.")
    name: str | None = Field(None, description="Light name (for messages).")
    position: Vec3 = Field((0.0, 0.0, 0.0), description="World position [x, y, z] of a point or spot light.")
    direction: Dir3 = Field((0.0, 0.0, -1.0), description="World direction a directional or spot light shines "
                            "along (from the light towards what it lights).")
    color: Color = Field((1.0, 1.0, 1.0), description="Linear RGB colour [r, g, b] in [0, 1].")
    intensity: float = Field(1.0, ge=0.0, description="Lux (directional) or candela (point, spot).")
    range: float | None = Field(None, gt=0.0, description="Point and spot: distance at which the light has faded "
                                "to 0 (window clamp(1 - (d/range)^4, 0, 1)); default: infinite.")
    inner_cone: float = Field(0.0, ge=0.0, lt=90.0, description="Spot: full-strength half angle in degrees.")
    outer_cone: float = Field(45.0, gt=0.0, le=90.0, description="Spot: half angle in degrees beyond which it "
                              "is dark; more than inner_cone.")

    @model_validator(mode="after")
    def _cone(self) -> PunctualLightSpec:
        if self.type == "spot" and not self.inner_cone < self.outer_cone:
            raise ValueError(f"spot: inner_cone ({self.inner_cone}) must be less than outer_cone ({self.outer_cone})")
        return self

    def light(self, index: int) -> Light:
        d = _unit(self.direction, "light direction")
        helper = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
        z = -d  # the light shines down its local -Z
        x = _unit(_cross3(helper, z))
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, _cross3(z, x), z, self.position
        return Light(self.type, self.color, self.intensity, None if self.type == "directional" else self.range,
                     math.radians(self.inner_cone), math.radians(self.outer_cone), m, self.name or f"light{index}")


class OrbitSpec(_Spec):
    axis: Dir3 = Field((0.0, 1.0, 0.0), description="Axis the camera turns about (right-handed).")
    degrees_per_frame: float = Field(6.0, description="Degrees turned per frame.")
    center: Vec3 | None = Field(None, description="A point on the axis (default: the camera target).")


class SceneSpec(_Spec):
    scene: str | None = Field(None, description="Scene name (default: the file's stem).")
    objects: list[ObjectSpec] = Field(min_length=1, description="The objects, drawn in this order; object "
                                      "ids follow it.")
    camera: CameraSpec | None = Field(None, description="Camera; framed from the scene's bounding box when "
                                      "omitted; a name or index picks a camera of the scene's glTF objects.")
    fps: float = Field(24.0, gt=0, le=1000, description="Frames per second: frame f shows time f / fps.")
    light: LightSpec = Field(default_factory=LightSpec, description="Directional light for shading nodes (where "
                             "the scene has no punctual lights).")
    lights: list[PunctualLightSpec] = Field(default_factory=list, description="Punctual lights (with those of the "
                                            "scene's glTF objects): where there are any, shading follows their "
                                            "irradiance instead of 'light' (docs/scenes.md, Lights).")
    exposure: float | None = Field(None, gt=0.0, description="Factor on the punctual lights' irradiance; default: "
                                   "1 / the brightest point of the surface at the first frame.")
    orbit: OrbitSpec | None = Field(None, description="Turn the camera per frame (for frame sequences).")
    background: Color = Field((1.0, 1.0, 1.0), description="Background (paper) color [r, g, b].")


# primitive parameter models: one per primitive, named as the function's parameters


class _PrimSpec(_Spec):
    type: str = Field(description="Primitive type.")


class PlaneSpec(_PrimSpec):
    type: Literal["plane"] = Field(description="A square in the XZ plane facing +Y.")
    size: float = Field(1.0, gt=0, description="Edge length.")
    subdiv: int = Field(1, ge=1, le=512, description="Cells per edge.")


class BoxSpec(_PrimSpec):
    type: Literal["box"] = Field(description="An axis-aligned box centred at the origin.")
    size: Scale3 = Field((1.0, 1.0, 1.0), description="Edge lengths [x, y, z] (or one number).")


class SphereSpec(_PrimSpec):
    type: Literal["sphere"] = Field(description="An icosphere.")
    radius: float = Field(1.0, gt=0, description="Radius.")
    subdiv: int = Field(3, ge=0, le=7, description="Subdivisions of the icosahedron (20 * 4**subdiv faces).")


class UVSphereSpec(_PrimSpec):
    type: Literal["uv_sphere"] = Field(description="A latitude/longitude sphere about +Y.")
    radius: float = Field(1.0, gt=0, description="Radius.")
    n_u: int = Field(32, ge=3, le=4096, description="Segments around the axis.")
    n_v: int = Field(16, ge=2, le=4096, description="Rings from pole to pole.")


class CylinderSpec(_PrimSpec):
    type: Literal["cylinder"] = Field(description="A cylinder about +Y, centred at the origin.")
    radius: float = Field(0.5, gt=0, description="Radius.")
    height: float = Field(1.0, gt=0, description="Height along Y.")
    segments: int = Field(32, ge=3, le=4096, description="Segments around the axis.")
    caps: bool = Field(True, description="Close both ends.")


class ConeSpec(_PrimSpec):
    type: Literal["cone"] = Field(description="A closed cone about +Y, apex up.")
    radius: float = Field(0.5, gt=0, description="Base radius.")
    height: float = Field(1.0, gt=0, description="Height along Y.")
    segments: int = Field(32, ge=3, le=4096, description="Segments around the axis.")


class TorusSpec(_PrimSpec):
    type: Literal["torus"] = Field(description="A ring torus about +Y.")
    R: float = Field(1.0, gt=0, description="Major radius (centre of the tube).")
    r: float = Field(0.25, gt=0, description="Tube radius (less than R).")
    n_major: int = Field(48, ge=3, le=4096, description="Segments around the axis.")
    n_minor: int = Field(24, ge=3, le=4096, description="Segments around the tube.")

    @field_validator("r")
    @classmethod
    def _ring(cls, r: float, info: ValidationInfo) -> float:
        big = info.data.get("R")
        if big is not None and r >= big:
            raise ValueError(f"expected a tube radius below R = {big} (a ring torus)")
        return r


class EllipsoidSpec(_PrimSpec):
    type: Literal["ellipsoid"] = Field(description="An icosphere scaled to semi-axes a, b, c.")
    a: float = Field(1.0, gt=0, description="Semi-axis along X.")
    b: float = Field(0.75, gt=0, description="Semi-axis along Y.")
    c: float = Field(0.5, gt=0, description="Semi-axis along Z.")
    subdiv: int = Field(3, ge=0, le=7, description="Icosphere subdivisions.")


class ArchSpec(_PrimSpec):
    type: Literal["arch"] = Field(description="A semicircular arch in the XY plane springing at y = 0.")
    span: float = Field(1.0, gt=0, description="Clear span (diameter of the intrados).")
    thickness: float = Field(0.15, gt=0, description="Radial thickness of the ring.")
    depth: float = Field(0.3, gt=0, description="Depth along Z.")
    segments: int = Field(16, ge=4, le=4096, description="Segments along the half circle (rounded up to a "
                          "multiple of 4).")
    spandrels: bool = Field(False, description="Fill the corners above the ring to a rectangle.")


PRIMITIVE_SPECS: dict[str, type[_PrimSpec]] = {
    "plane": PlaneSpec, "box": BoxSpec, "sphere": SphereSpec, "uv_sphere": UVSphereSpec,
    "cylinder": CylinderSpec, "cone": ConeSpec, "torus": TorusSpec, "ellipsoid": EllipsoidSpec, "arch": ArchSpec,
}


def json_schema() -> dict[str, Any]:
    """JSON Schema of scene files: SceneSpec, with `primitive` spelled out per type (PRIMITIVE_SPECS)."""
    from ..schemas import DIALECT, hoist_defs

    schema = SceneSpec.model_json_schema()
    defs = schema.setdefault("$defs", {})
    variants = []
    for name, spec in PRIMITIVE_SPECS.items():
        sub = hoist_defs(spec.model_json_schema(), defs, name)
        sub.pop("title", None)
        sub["description"] = sub["properties"]["type"].get("description", name)
        variants.append(sub)
    obj = defs["ObjectSpec"]
    prim = obj["properties"]["primitive"]
    obj["properties"]["primitive"] = {"description": prim.get("description", ""), "oneOf": variants}
    # ObjectSpec._one_source: a mesh file or a primitive, not both
    sources = ("mesh", "primitive", "gltf")
    obj["oneOf"] = [{"required": [k], "not": {"anyOf": [{"required": [o]} for o in sources if o != k]}}
                    for k in sources]
    defs["CameraSpec"]["oneOf"] = [{"required": ["eye", "target"], "not": {"required": ["view"]}},
                                   {"required": ["view"], "not": {"anyOf": [{"required": ["eye"]},
                                                                            {"required": ["target"]}]}}]
    cam = schema["properties"]["camera"]  # `camera: NAME | INDEX` picks a glTF camera (scene_from_yaml)
    cam["anyOf"] = [c for c in cam["anyOf"] if c.get("type") != "null"] + [
        {"type": "string", "description": "a camera of the scene's glTF objects, by name"},
        {"type": "integer", "minimum": 0, "description": "a camera of the scene's glTF objects, by index"},
        {"type": "null"}]
    schema["$schema"] = DIALECT
    schema["title"] = "sketchgraph scene"
    return schema


def primitive_mesh(spec: _PrimSpec) -> Mesh:
    params = spec.model_dump(exclude={"type"})
    return primitives.PRIMITIVES[spec.type](**params)


def _build_primitive(data: Any, file: str, path: tuple[Any, ...], root: Any) -> Mesh:
    if not isinstance(data, dict):
        raise PipelineError(f"'primitive' must be a mapping like {{type: box}}, found {yamlio.describe(data)}",
                            yamlio.locate(root, path, file))
    kind = data.get("type")
    if kind is None:
        raise PipelineError("primitive: missing required field 'type' (one of "
                            + ", ".join(PRIMITIVE_SPECS) + ")", yamlio.locate(root, path, file))
    if kind not in PRIMITIVE_SPECS:
        raise PipelineError(f"unknown primitive type {kind!r}{yamlio.suggest(str(kind), PRIMITIVE_SPECS)}; "
                            "choose one of " + ", ".join(PRIMITIVE_SPECS),
                            yamlio.locate(root, (*path, "type"), file))
    spec = yamlio.validate(PRIMITIVE_SPECS[kind], data, file, prefix=path, root=root, what=f"primitive {kind}")
    return primitive_mesh(spec)


def scene_from_yaml(path: str | Path, camera_choice: str | int | None = None, view: str | None = None,
                    allow_outside: bool = False) -> Scene:
    """Load a scene YAML file; every error is a one-line PipelineError with file:line:col. `camera_choice`
    (`--camera`) picks a camera of the scene's glTF objects instead of its `camera:`; `view` (`--view`)
    frames a scene without `camera:` from that side (as `camera: {view: ...}`)."""
    p = Path(path)
    file = str(path)
    data = yamlio.load(p)
    if not isinstance(data, dict):
        raise PipelineError(f"a scene file must be a mapping with 'objects:', found {yamlio.describe(data)}",
                            Location(file, 1, 1))
    named_camera = data.get("camera")
    checked = data
    if isinstance(named_camera, (str, int)) and not isinstance(named_camera, bool):  # a glTF camera by name/index
        checked = {k: v for k, v in data.items() if k != "camera"}
    else:
        named_camera = None
    spec = yamlio.validate(SceneSpec, checked, file, root=data, what="scene")
    base = p.parent
    objects: list[SceneObject] = []
    moving = _Moving(spec.fps)
    for i, obj in enumerate(spec.objects):
        where = ("objects", i)
        if obj.gltf is not None:
            loc = yamlio.locate(data, (*where, "gltf"), file)
            try:
                moving.add_gltf(objects, obj, _resolve(base, obj.gltf), obj.transform.matrix(), "color" in
                                obj.model_fields_set, allow_outside=allow_outside)
            except (MeshError, PipelineError) as exc:
                raise PipelineError(str(exc), loc) from None
            continue
        if obj.mesh is not None:
            mesh_path = _resolve(base, obj.mesh)
            loc = yamlio.locate(data, (*where, "mesh"), file)
            try:
                os.stat(mesh_path)
            except FileNotFoundError:
                raise PipelineError(f"object {i}: mesh file not found: {show_path(mesh_path)} (mesh paths are "
                                    "relative to the scene file)", loc) from None
            except (OSError, ValueError):
                pass  # load_mesh says what is wrong
            from .gltf import load_any_mesh  # imported where a mesh file is read: 8-22 ms a process otherwise

            try:
                mesh = load_any_mesh(mesh_path, allow_outside)
            except MeshError as exc:
                raise PipelineError(str(exc), loc) from None
            if obj.up is not None:
                mesh, _ = stand_up(mesh, obj.up, str(mesh_path))
            default_name = mesh_path.stem
        else:
            mesh = _build_primitive(data["objects"][i]["primitive"], file, (*where, "primitive"), data)
            default_name = f"{mesh.name}{i}"
        if obj.animate is not None:
            try:
                moving.add_keyframes(len(objects), obj.animate, obj.transform)
            except ValueError as exc:
                raise PipelineError(f"animate: {exc}", yamlio.locate(data, (*where, "animate"), file)) from None
        objects.append(SceneObject(mesh=mesh, transform=obj.transform.matrix(), color=obj.color,
                                   sketchy=obj.sketchy, name=obj.name or default_name))
    lo, hi = moving.bounds(objects)
    center, radius = (lo + hi) / 2.0, float(np.linalg.norm(hi - lo)) / 2.0
    choice = camera_choice if camera_choice is not None else named_camera
    if choice is not None:
        try:
            camera = moving.gltf_camera(choice, center, radius)
        except (MeshError, PipelineError, ValueError) as exc:
            raise PipelineError(f"camera: {exc}", yamlio.locate(data, ("camera",), file)) from None
    elif view is not None and view != "widest" and spec.camera is None:
        direction, cam_up = framing.view_direction(view, (0.0, 0.0, 1.0))
        camera = frame_camera(lo, hi, direction=direction, up=cam_up)
    elif view is not None:
        raise PipelineError(f"--view {view}: frames a scene without a camera (or give camera: {{view: ...}})"
                            if view != "widest" else "--view widest frames a mesh file, not a scene file",
                            yamlio.locate(data, ("camera",), file) if spec.camera is not None else Location(file, 1, 1))
    elif spec.camera is None:
        camera = frame_camera(lo, hi)
    elif spec.camera.view is not None:
        c = spec.camera
        direction, cam_up = framing.view_direction(c.view, (0.0, 0.0, 1.0))
        try:
            camera = frame_camera(lo, hi, fov_y_deg=c.fov, direction=direction,
                                  up=c.up if "up" in c.model_fields_set else cam_up)
            if c.near is not None or c.far is not None:
                near = c.near if c.near is not None else camera.near
                camera = replace(camera, near=near, far=c.far if c.far is not None else max(camera.far, near * 1.001))
            camera = c.lens(camera)
            if c.animate is not None:
                moving.add_camera_keyframes(camera, c.animate)
        except ValueError as exc:
            raise PipelineError(f"camera: {exc}", yamlio.locate(data, ("camera",), file)) from None
    else:
        c = spec.camera
        near, far = near_far_for(c.eye, center, radius)
        try:
            camera = Camera(eye=c.eye, target=c.target, up=c.up, fov_y_deg=c.fov,
                            near=c.near if c.near is not None else near,
                            far=c.far if c.far is not None else max(far, (c.near or 0.0) * 1.001))
            camera = c.lens(camera)
            if c.animate is not None:
                moving.add_camera_keyframes(camera, c.animate)
        except ValueError as exc:
            raise PipelineError(f"camera: {exc}", yamlio.locate(data, ("camera",), file)) from None
    orbit = None
    if spec.orbit is not None:
        orbit = Orbit(axis=spec.orbit.axis, degrees_per_frame=spec.orbit.degrees_per_frame,
                      center=spec.orbit.center)
    moving.fixed_lights = [lt.light(k) for k, lt in enumerate(spec.lights)]
    return Scene(name=spec.scene or p.stem, objects=tuple(objects), camera=camera,
                 light_direction=spec.light.direction, light_space=spec.light.space, orbit=orbit,
                 background=spec.background, source=file, animation=moving.animator(),
                 **moving.lit(objects, spec.exposure))


def _resolve(base: Path, name: str) -> Path:
    path = Path(name).expanduser()
    return (path if path.is_absolute() else base / path).absolute()


def _bounds_of(objects: list[SceneObject]) -> tuple[np.ndarray, np.ndarray]:
    b = [o.world_bounds() for o in objects]
    return np.min([lo for lo, _ in b], axis=0), np.max([hi for _, hi in b], axis=0)


def best_view_direction(mesh: Mesh, elevation_deg: float = 25.0, azimuths: int = 16) -> np.ndarray:
    """Of `azimuths` directions about +Y at `elevation_deg`, the one from which the mesh shows the
    largest projected area (sum over faces of area x max(0, n . d)): a cow is seen from the side, not
    end-on, whatever way its file faces. Ties go to the first azimuth (from +Z towards +X)."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces)
    if len(f) == 0:
        return _unit(np.array([0.55, 0.45, 1.0]))
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # 2 x area x unit normal
    el = math.radians(elevation_deg)
    az = np.arange(azimuths) * (2.0 * math.pi / azimuths)
    dirs = np.stack([np.sin(az) * math.cos(el), np.full_like(az, math.sin(el)), np.cos(az) * math.cos(el)], axis=1)
    visible = np.maximum(cross @ dirs.T, 0.0).sum(axis=0)
    return dirs[int(np.argmax(visible))]


def stand_up(mesh: Mesh, up: str | None, source: str | None = None) -> tuple[Mesh, str]:
    """The mesh turned so that its up axis (`up`: x, y, z, -x, -y, -z; None or 'auto': the file format's
    convention unless the shape clearly says otherwise, framing.orient, said in one FramingWarning) is +Y,
    and the axis used. A Y-up mesh is returned as it is."""
    given = framing.check_up(up)
    suffix = framing.suffix_of(source or mesh.source)
    if given is None:
        axis, rule, feet = _detect_up(mesh, suffix)
        if rule:
            framing.warn_notes(mesh.name, [framing.up_note(axis, framing.convention(suffix)[0], rule, feet)])
    else:
        axis = given
    if axis == "y":
        return mesh, axis
    return mesh.transformed(framing.up_rotation(axis)), axis


def _detect_up(mesh: Mesh, suffix: str) -> tuple[str, str, int]:
    """framing.up_choice (the up axis, the rule that chose it, the feet), kept on disk (nodegraph/scene/meshstore.py:
    scipy.spatial's import alone is 0.47 s); the suffix counts only as a Z-up format or not."""
    from . import meshstore

    def make() -> list[int]:
        up, rule, feet = framing.up_choice(mesh.vertices, mesh.faces, suffix)
        return [framing.SIGNED_AXES.index(up), framing.UP_RULES.index(rule), feet]

    what = "up-z" if suffix.lower() in framing.Z_UP_FORMATS else "up"
    index, rule, feet = (int(x) for x in meshstore.memo(mesh, what, make, (framing.__file__,), always=True))
    return framing.SIGNED_AXES[index], framing.UP_RULES[rule], feet


def mesh_front_choice(mesh: Mesh) -> framing.FrontChoice:
    """framing.front_choice of a stood-up (Y-up) mesh (the front and the feature-line lengths that chose it),
    kept on disk."""
    from . import meshstore

    return framing.FrontChoice.decode(meshstore.memo(
        mesh, "front", lambda: framing.front_choice(mesh.vertices, mesh.faces).encode(), (framing.__file__,),
        always=True))  # scipy.spatial's import alone is 0.47 s


def mesh_front(mesh: Mesh) -> np.ndarray:
    """The unit front of a stood-up (Y-up) mesh (mesh_front_choice)."""
    return mesh_front_choice(mesh).front


def fit_camera(points: Any, direction: Any, up: Any = (0.0, 1.0, 0.0), fill: float | None = None,
               fov_y_deg: float = 35.0) -> Camera:
    """A camera looking along -`direction` whose picture shows `points` centred, their projected bounding box
    spanning `fill` (default framing.DEFAULT_FILL) of the shorter side (framing.fit_view)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    fill = framing.check_fill(fill) or framing.DEFAULT_FILL
    eye, target, cam_up = framing.fit_view(p, direction, up, fov_y_deg, fill)
    lo, hi = p.min(axis=0), p.max(axis=0)
    radius = float(np.linalg.norm(hi - lo)) / 2.0
    near, far = near_far_for(eye, (lo + hi) / 2.0, radius)
    return Camera(eye=eye, target=target, up=cam_up, fov_y_deg=fov_y_deg, near=near, far=far)


def motion_camera(first: Any, motion: Any, lo: Any, hi: Any, direction: Any, up: Any = (0.0, 1.0, 0.0),
                  fill: float | None = None, fov_y_deg: float = 35.0) -> Camera:
    """A camera for a moving subject without one (framing.motion_view): `first`, the points its faces use at
    the first frame; `motion`, points of it over the animation; `lo`, `hi`, its bounds over the whole
    animation (near and far hug them)."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    fill = framing.check_fill(fill) or framing.DEFAULT_FILL
    eye, target, cam_up = framing.motion_view(first, motion, direction, up, fov_y_deg, fill)
    near, far = near_far_for(eye, (lo + hi) / 2.0, float(np.linalg.norm(hi - lo)) / 2.0)
    return Camera(eye=eye, target=target, up=cam_up, fov_y_deg=fov_y_deg, near=near, far=far)


def mesh_camera(mesh: Mesh, view: str | None = None, fill: float | None = None,
                front: Any = None) -> Camera:
    """The camera of a bare (Y-up) mesh: a named view (framing.VIEWS; default three-quarter, or face-on for a
    flat or thin subject) of the side `front` (default: mesh_front) faces, framed on the vertices faces use
    so the subject spans `fill` of the picture's shorter side (framing.fit_view)."""
    chosen = framing.check_view(view) or "three-quarter"
    points = framing.used_vertices(mesh.vertices, mesh.faces)
    if chosen == "widest":
        return fit_camera(points, best_view_direction(mesh), fill=fill)
    front = mesh_front(mesh) if front is None else np.asarray(front, dtype=np.float64)
    direction, up = framing.view_direction(chosen, front)
    if view is None:
        normal = framing.broad_side(mesh.vertices, mesh.faces)
        if normal is not None:
            direction, up = framing.face_on(normal, front)
    return fit_camera(points, direction, up, fill=fill)


def scene_for_mesh(mesh: Mesh, source: str | None = None, view: str | None = None, up: str | None = None,
                   fill: float | None = None) -> Scene:
    """One sketchy object, stood up (`stand_up`), seen from `view` (default: three-quarter front; see
    nodegraph/scene/framing.py) of its front (`--front`, views.FRONT: the file's axis it faces; else found,
    `mesh_front_choice`), framed to span `fill` of the picture, with a 6 degrees/frame orbit about +Y."""
    mesh, axis = stand_up(mesh, up, source)
    given = views.front_of(source or mesh.source)
    if given is not None:
        front = _given_front(given, axis)
    else:
        choice = mesh_front_choice(mesh)
        front = choice.front
        note = choice.note(framing.up_rotation(axis))
        if note:
            framing.warn_notes(mesh.name, [note])
    return Scene(name=mesh.name, objects=(SceneObject(mesh, np.eye(4), DEFAULT_MESH_COLOR, True, mesh.name),),
                 camera=mesh_camera(mesh, view, fill, front), orbit=Orbit(), source=source or mesh.source)


def _given_front(given: str, up: str) -> np.ndarray:
    """The front `--front` gives (an axis of the file) in the stood-up frame of a mesh stood up along `up`."""
    axis = given.removeprefix("+")
    if axis not in views.UP_AXES:
        raise PipelineError(f"front: expected one of {', '.join(views.UP_AXES)} or auto, found {given!r}")
    front = framing.up_rotation(up)[:3, :3] @ framing.axis_vector(axis)
    if abs(front[1]) > 0.5:
        a, b = (k for k in "xyz" if k != up[-1])
        raise PipelineError(f"--front {axis}: the mesh stands up along {up[-1]}, so its front faces across it: "
                            f"{a}, -{a}, {b} or -{b}")
    return np.round(front)


def mesh_scene(path: str | Path, view: str | None = None, up: str | None = None, fill: float | None = None) -> Scene:
    """A mesh file as a one-object scene (scene_for_mesh)."""
    return scene_for_mesh(load_mesh(path), str(path), view=view, up=up, fill=fill)


# --- built-in scenes ----------------------------------------------------------------------------


def _single(name: str, mesh: Mesh, color: Vec) -> Scene:
    lo, hi = mesh.bounds()
    return Scene(name=name, objects=(SceneObject(mesh, np.eye(4), color, True, name),),
                 camera=frame_camera(lo, hi), orbit=Orbit(), source=f"builtin:{name}")


def _builtin_box() -> Scene:
    return _single("box", primitives.box((1.0, 1.0, 1.0)), (0.85, 0.62, 0.42))


def _builtin_sphere() -> Scene:
    return _single("sphere", primitives.sphere(1.0, 4), (0.55, 0.68, 0.82))


def _builtin_torus() -> Scene:
    return _single("torus", primitives.torus(1.0, 0.35, 64, 32), (0.80, 0.52, 0.60))


def _builtin_primitives() -> Scene:
    """Every primitive in a row on a floor, for visual checks."""
    items: list[tuple[Mesh, np.ndarray, Vec]] = [
        (primitives.box((0.8, 0.8, 0.8)), compose((0.0, 0.4, 0.0), (0, 25, 0)), (0.85, 0.62, 0.42)),
        (primitives.sphere(0.45, 3), compose((1.2, 0.45, 0.0)), (0.55, 0.68, 0.82)),
        (primitives.uv_sphere(0.45, 24, 12), compose((2.4, 0.45, 0.0)), (0.62, 0.78, 0.60)),
        (primitives.cylinder(0.35, 0.9, 32), compose((3.6, 0.45, 0.0)), (0.90, 0.80, 0.50)),
        (primitives.cone(0.4, 0.9, 32), compose((4.8, 0.45, 0.0)), (0.80, 0.45, 0.35)),
        (primitives.torus(0.4, 0.14, 48, 20), compose((0.6, 0.14, 1.3)), (0.80, 0.52, 0.60)),
        (primitives.ellipsoid(0.5, 0.3, 0.35, 3), compose((1.9, 0.3, 1.3)), (0.70, 0.60, 0.85)),
        (primitives.arch(0.6, 0.15, 0.25, 16, False), compose((3.2, 0.0, 1.3)), (0.93, 0.84, 0.66)),
        (primitives.arch(0.6, 0.15, 0.25, 16, True), compose((4.4, 0.0, 1.3)), (0.88, 0.74, 0.55)),
        (primitives.plane(6.4, 8), compose((2.4, 0.0, 0.65)), (0.72, 0.74, 0.68)),
    ]
    objs = tuple(SceneObject(m, t, c, True, m.name) for m, t, c in items)
    lo, hi = _bounds_of(list(objs))
    return Scene(name="primitives", objects=objs, camera=frame_camera(lo, hi, direction=(0.35, 0.6, 1.0)),
                 orbit=Orbit(), source="builtin:primitives")


# cloister palette: distinct flat colors so the shade map reads as patches
_SANDSTONE = (0.88, 0.76, 0.54)
_PALE_STONE = (0.80, 0.76, 0.66)
_OCHRE = (0.78, 0.63, 0.42)
_WALL = (0.94, 0.87, 0.71)
_BEAM = (0.68, 0.56, 0.42)
_TERRACOTTA = (0.78, 0.37, 0.23)
_PLASTER = (0.74, 0.69, 0.64)
_FLOOR = (0.62, 0.66, 0.58)
_LAWN = (0.47, 0.63, 0.36)
_GREY = (0.66, 0.65, 0.62)
_WATER = (0.42, 0.60, 0.76)
_TOWER = (0.84, 0.72, 0.56)


def _block(lo: Any, hi: Any, name: str = "block") -> Mesh:
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return primitives.box(hi - lo).transformed(translation((lo + hi) / 2.0), name)


def _hexahedron(corners: Any, name: str) -> Mesh:
    """A box-like solid from 8 corners indexed by bits (x, y, z) as in `primitives.box`."""
    return Mesh(name, np.asarray(corners, dtype=np.float64), primitives.box().faces)


@dataclass(frozen=True)
class _ArcadeLayout:
    """One arcade in local coordinates: bays of 1 along +x at z = 0, the garth at +z, the walk at -z."""

    columns: tuple[float, ...]
    bays: tuple[int, ...]
    beam_x: tuple[float, float]
    wall_x: tuple[float, float]
    roof_front_x: tuple[float, float]
    roof_back_x: tuple[float, float]
    corner_fill: bool = False  # fill the square above column 0 where the other arcade's arches butt


# heights (floor top at y = 0)
_PLINTH_TOP, _SHAFT_TOP, _ECHINUS_TOP, _SPRING = 0.10, 0.78, 0.83, 0.90
_SPAN, _ARCH_T, _ARCH_D = 0.8, 0.1, 0.24
_BEAM_TOP = _SPRING + _SPAN / 2 + _ARCH_T + 0.12
_ROOF_FRONT_Z, _ROOF_BACK_Z, _ROOF_FRONT_Y, _ROOF_BACK_Y, _ROOF_T = 0.27, -1.0, _BEAM_TOP + 0.07, 1.97, 0.07
_WALL_Z, _WALL_TOP = (-1.2, -1.0), 2.15


def _arcade(layout: _ArcadeLayout, tag: str) -> list[tuple[str, Mesh, Vec]]:
    plinths, shafts, capitals, arches = [], [], [], []
    for x in layout.columns:
        plinths.append(_block((x - 0.14, 0.0, -0.14), (x + 0.14, _PLINTH_TOP, 0.14)))
        h = _SHAFT_TOP - _PLINTH_TOP
        shafts.append(primitives.cylinder(0.075, h, 24).transformed(translation((x, _PLINTH_TOP + h / 2, 0))))
        e = _ECHINUS_TOP - _SHAFT_TOP
        capitals.append(primitives.cylinder(0.1, e, 24).transformed(translation((x, _SHAFT_TOP + e / 2, 0))))
        capitals.append(_block((x - 0.14, _ECHINUS_TOP, -0.14), (x + 0.14, _SPRING, 0.14)))
    for k in layout.bays:
        a = primitives.arch(_SPAN, _ARCH_T, _ARCH_D, 24, spandrels=True)
        arches.append(a.transformed(translation((k + 0.5, _SPRING, 0.0))))
    top = _SPRING + _SPAN / 2 + _ARCH_T
    if layout.corner_fill:
        arches.append(_block((-_ARCH_D / 2, _SPRING, -_ARCH_D / 2), (0.0, top, 0.0)))
    beam = _block((layout.beam_x[0], top, -0.15), (layout.beam_x[1], _BEAM_TOP, 0.15))
    wall = _block((layout.wall_x[0], 0.0, _WALL_Z[0]), (layout.wall_x[1], _WALL_TOP, _WALL_Z[1]))
    # lean-to roof: a slab from the beam up to the back wall, its ends along the given x ranges
    (f0, f1), (b0, b1) = layout.roof_front_x, layout.roof_back_x
    zf, zb = _ROOF_FRONT_Z, _ROOF_BACK_Z
    yf, yb, t = _ROOF_FRONT_Y, _ROOF_BACK_Y, _ROOF_T
    corners = [(f0, yf - t, zf), (f1, yf - t, zf), (f0, yf, zf), (f1, yf, zf),
               (b0, yb - t, zb), (b1, yb - t, zb), (b0, yb, zb), (b1, yb, zb)]
    # box bit order is (x, y, z) with z growing: the back (z = zb) must come first
    corners = corners[4:] + corners[:4]
    roof = _hexahedron(corners, "roof")
    return [
        (f"{tag}.plinths", merge_meshes(plinths, "plinths"), _PALE_STONE),
        (f"{tag}.shafts", merge_meshes(shafts, "shafts"), _SANDSTONE),
        (f"{tag}.capitals", merge_meshes(capitals, "capitals"), _OCHRE),
        (f"{tag}.arches", merge_meshes(arches, "arches"), _WALL),
        (f"{tag}.beam", beam, _BEAM),
        (f"{tag}.roof", roof, _TERRACOTTA),
        (f"{tag}.wall", wall, _PLASTER),
    ]


def _builtin_cloister() -> Scene:
    """Two arcades meeting at a corner (an L of a cloister walk) around a garth with a well."""
    south = _ArcadeLayout(columns=tuple(float(x) for x in range(6)), bays=tuple(range(5)),
                          beam_x=(-0.15, 5.14), wall_x=(-1.2, 5.2), roof_front_x=(_ROOF_FRONT_Z, 5.3),
                          roof_back_x=(_ROOF_BACK_Z, 5.3), corner_fill=True)
    # the west arcade is built along +x too and turned by +90 degrees about Y, then moved by +5 in z:
    # local x maps to world z = 5 - x, so its corner end is local x = 5 (the south arcade's column 0)
    west = _ArcadeLayout(columns=tuple(float(x) for x in range(5)), bays=tuple(range(5)),
                         beam_x=(-0.14, 4.85), wall_x=(-0.2, 6.0), roof_front_x=(-0.3, 5.0 - _ROOF_FRONT_Z),
                         roof_back_x=(-0.3, 5.0 - _ROOF_BACK_Z))
    west_transform = translation((0.0, 0.0, 5.0)) @ rotation((0, 1, 0), 90.0)
    objects: list[SceneObject] = []
    for tag, layout, transform in (("south", south, np.eye(4)), ("west", west, west_transform)):
        for name, mesh, color in _arcade(layout, tag):
            objects.append(SceneObject(mesh, transform, color, True, name))
    g0, g1 = 5.75, 3.0  # garth extent and well position
    well_h = 0.36
    ground = [
        ("floor", _block((-1.3, -0.12, -1.3), (g0, 0.0, g0)), _FLOOR),
        ("lawn", _block((0.35, 0.0, 0.35), (g0, 0.03, g0)), _LAWN),
        ("well", primitives.cylinder(0.32, well_h, 32).transformed(translation((g1, 0.03 + well_h / 2, g1))),
         _GREY),
        ("well.rim", primitives.torus(0.32, 0.045, 48, 12).transformed(translation((g1, 0.03 + well_h, g1))),
         _PALE_STONE),
        ("well.water", primitives.cylinder(0.27, 0.01, 32).transformed(
            translation((g1, 0.03 + well_h + 0.006, g1))), _WATER),
    ]
    # a bell tower behind the corner: a square shaft under a pyramid roof (a 4-sided cone turned 45 deg)
    tower_c, tower_w, tower_h = -1.95, 1.4, 3.5
    ground += [
        ("tower", _block((tower_c - tower_w / 2, -0.12, tower_c - tower_w / 2),
                         (tower_c + tower_w / 2, tower_h, tower_c + tower_w / 2)), _TOWER),
        ("tower.roof", primitives.cone(tower_w / math.sqrt(2.0) * 1.1, 1.1, 4).transformed(
            compose((tower_c, tower_h + 0.55, tower_c), (0.0, 45.0, 0.0))), _TERRACOTTA),
    ]
    objects += [SceneObject(m, np.eye(4), c, True, n) for n, m, c in ground]
    lo, hi = _bounds_of(objects)
    # three-quarter view from the garth, slightly above, toward the corner and the tower
    target = np.array([1.7, 1.0, 1.0])
    eye = target + np.array([4.6, 2.9, 9.0])
    radius = float(np.linalg.norm(hi - lo)) / 2.0
    near, far = near_far_for(eye, (lo + hi) / 2.0, radius)
    camera = Camera(eye=eye, target=target, up=(0.0, 1.0, 0.0), fov_y_deg=44.0, near=near, far=far)
    return Scene(name="cloister", objects=tuple(objects), camera=camera,
                 light_direction=DEFAULT_LIGHT, light_space="view",
                 orbit=Orbit(center=np.array([2.2, 0.0, 2.2])), source="builtin:cloister")


BUILTIN_SCENES: dict[str, Callable[[], Scene]] = {
    "cloister": _builtin_cloister,
    "box": _builtin_box,
    "sphere": _builtin_sphere,
    "torus": _builtin_torus,
    "primitives": _builtin_primitives,
}


@functools.cache
def builtin_scene(name: str) -> Scene:
    if name not in BUILTIN_SCENES:
        close = difflib.get_close_matches(name, list(BUILTIN_SCENES), n=1, cutoff=0.5)
        hint = f" (did you mean 'builtin:{close[0]}'?)" if close else ""
        raise PipelineError(f"unknown built-in scene 'builtin:{name}'{hint}; available: "
                            + ", ".join(f"builtin:{n}" for n in BUILTIN_SCENES))
    return BUILTIN_SCENES[name]()


def load_scene(spec: str, base_dir: Path | None = None, view: str | None = None, up: str | None = None,
               allow_outside: bool = False, fill: float | None = None) -> Scene:
    """`_load_scene`, then the lens of the command line (`--camera-type`, `--fov`, `--zoom`: views.LENS) applied
    to its camera (`with_lens`)."""
    return with_lens(_load_scene(spec, base_dir, view, up, allow_outside, fill), *views.LENS.get())


def with_lens(scene: Scene, camera_type: str | None = None, fov: float | None = None,
              zoom: float | None = None) -> Scene:
    """The scene seen through its camera changed by `Camera.with_lens` at every frame (an animated camera
    too); itself when all three are None. A bad value is one PipelineError line."""
    if camera_type is None and fov is None and zoom is None:
        return scene
    try:
        camera = scene.camera.with_lens(camera_type, fov, zoom)
    except ValueError as exc:
        raise PipelineError(str(exc)) from None
    anim = scene.animation
    if anim is not None and anim.camera is not None:
        moving = anim.camera

        def at(t: float) -> Camera:
            return moving.at(t).with_lens(camera_type, fov, zoom)

        lens = json.dumps([camera_type, fov, zoom])
        anim = replace(anim, camera=CameraAnim(at, f"{moving.digest}|lens:{lens}"))
    return replace(scene, camera=camera, animation=anim)


def _load_scene(spec: str, base_dir: Path | None = None, view: str | None = None, up: str | None = None,
                allow_outside: bool = False, fill: float | None = None) -> Scene:
    """`builtin:NAME`, a scene YAML (.yaml/.yml) or a mesh file (.obj/.ply/.off/.stl); relative paths
    start at `base_dir` (default: the current directory). `view` and `up` (`--view`, `--up`; see
    nodegraph/scene/framing.py) frame a mesh file or a still glTF file; `view` also a scene file without a camera.
    `allow_outside`: glTF files may read buffers and images outside their folder (trusted files only).
    `fill` (`--fill`): the share of the picture's shorter side a mesh file or a still glTF file spans."""
    spec = str(spec).strip()
    try:
        view, up, fill = framing.check_view(view), framing.check_up(up), framing.check_fill(fill)
    except ValueError as exc:
        raise PipelineError(str(exc)) from None
    front = views.FRONT.get()
    if spec.startswith("builtin:"):
        if view is not None or up is not None or fill is not None:
            raise PipelineError(f"--view/--up/--fill frame a mesh file; {spec} has its own camera")
        if isinstance(front, str):
            raise PipelineError(f"--front faces a mesh file; {spec} has its own camera")
        return builtin_scene(spec.removeprefix("builtin:"))
    path = Path(spec).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    ext = path.suffix.lower()
    if ext in GLTF_EXTENSIONS:
        if not path.exists():
            raise PipelineError(f"scene file not found: {path.absolute()}")
        if isinstance(front, str):
            raise PipelineError(f"--front faces a mesh file; a glTF file faces +Z (`--view` picks the side) ({spec})")
        try:
            return scene_from_gltf(path, view=view, up=up, allow_outside=allow_outside, fill=fill)
        except MeshError as exc:
            raise PipelineError(str(exc)) from None
    if ext not in SCENE_EXTENSIONS + SUPPORTED_EXTENSIONS:
        hint = yamlio.suggest(spec, [f"builtin:{n}" for n in BUILTIN_SCENES]) if ":" in spec else ""
        raise PipelineError(f"scene '{spec}': expected builtin:NAME, a scene file ({', '.join(SCENE_EXTENSIONS)}) "
                            f"or a mesh file ({', '.join(SUPPORTED_EXTENSIONS + GLTF_EXTENSIONS)}){hint}")
    try:
        os.stat(path)
    except FileNotFoundError:
        raise PipelineError(f"scene file not found: {show_path(path.absolute())}") from None
    except (OSError, ValueError):
        pass  # the loaders check the file and say what is wrong with it
    if ext in SCENE_EXTENSIONS:
        if up is not None:
            raise PipelineError(f"--up stands a mesh file up; in a scene file give 'up:' per mesh object ({spec})")
        if fill is not None:
            raise PipelineError(f"--fill frames a mesh file; a scene file is framed by its camera ({spec})")
        if isinstance(front, str):
            raise PipelineError(f"--front faces a mesh file; in a scene file the camera and `view:` face the "
                                f"objects ({spec})")
        return scene_from_yaml(path, view=view, allow_outside=allow_outside)
    return mesh_scene(path, view=view, up=up, fill=fill)


# --- animated scenes ------------------------------------------------------------------------------------


class _Moving:
    """What moves in a scene being built: keyframed objects, glTF files placed in it, the camera."""

    def __init__(self, fps: float):
        self.fps = float(fps)
        self.objects: dict[int, ObjectAnim] = {}
        self.camera: CameraAnim | None = None
        self.instances: list[GltfInstance] = []
        self.ranges: list[tuple[float, float]] = []
        self.fixed_lights: list[Light] = []  # `lights:` of a scene YAML

    def add_gltf(self, objects: list[SceneObject], spec: Any, path: Path, root: np.ndarray, color_given: bool,
                 prefix: bool = True, allow_outside: bool = False, command_line: bool = True) -> None:
        """The file's objects, playing `spec.animation` with `spec.animation_end` (default: all clips, held);
        `command_line`: --animation and --animation-end (`views.ANIMATION`, `views.ANIMATION_END`) win."""
        from .gltf import GltfInstance, load_asset

        asset = load_asset(path, allow_outside)
        which, end = spec.animation, spec.animation_end
        if command_line:
            which = views.ANIMATION.get() if views.ANIMATION.get() is not None else which
            end = views.ANIMATION_END.get() or end
        end = end or "hold"
        inst = GltfInstance(asset, np.asarray(root, dtype=np.float64), asset.animation(which, end))
        first = len(objects)
        head = spec.name or path.stem
        for name, mesh, matrix, color in inst.objects_at(0.0):
            objects.append(SceneObject(mesh=mesh, transform=matrix, color=spec.color if color_given else color,
                                       sketchy=spec.sketchy, name=f"{head}/{name}" if prefix else name))
        self.objects.update(inst.object_anims(first))
        self.instances.append(inst)
        if inst.anim is not None:
            self.ranges.append((inst.anim.start, inst.anim.end))

    def add_keyframes(self, index: int, spec: keyframes.ObjectAnimateSpec, base: TransformSpec) -> None:
        found = keyframes.tracks(spec, self.fps, {"translate": 3, "rotate": 3, "scale": 3})
        if "scale" in found and not np.all(found["scale"].values > 0):
            raise ValueError("scale: expected positive scale factors (mirroring is not supported)")
        fixed = {"translate": base.translate, "rotate": base.rotate, "scale": base.scale}

        def pose(t: float) -> tuple[None, np.ndarray]:
            part = {k: (found[k].sample(t) if k in found else v) for k, v in fixed.items()}
            return None, compose(part["translate"], part["rotate"], part["scale"])

        h = hashlib.sha256(json.dumps(fixed).encode())
        for name in sorted(found):
            h.update(name.encode())
            found[name].digest_into(h)
        self.objects[index] = ObjectAnim(pose, h.hexdigest())
        self.ranges.append(keyframes.time_range(found) or (0.0, 0.0))

    def add_camera_keyframes(self, camera: Camera, spec: keyframes.CameraAnimateSpec) -> None:
        found = keyframes.tracks(spec, self.fps, {"eye": 3, "target": 3, "up": 3, "fov": 1})
        if not found:
            return
        if "fov" in found and camera.orthographic:
            raise ValueError("fov: an orthographic camera has no field of view (animate eye, target or up)")

        def at(t: float) -> Camera:
            kw = {k: found[k].sample(t) for k in ("eye", "target", "up") if k in found}
            if "fov" in found:
                kw["fov_y_deg"] = float(found["fov"].sample(t)[0])
            return replace(camera, **kw)

        for track in found.values():  # every key is a valid camera (up not along the view, fov in range)
            for t in track.times:
                at(float(t))
        h = hashlib.sha256(json.dumps(camera.params()).encode())
        for name in sorted(found):
            h.update(name.encode())
            found[name].digest_into(h)
        self.camera = CameraAnim(at, h.hexdigest())
        self.ranges.append(keyframes.time_range(found) or (0.0, 0.0))

    def gltf_camera(self, choice: str | int | None, center: np.ndarray, radius: float) -> Camera | None:
        """A camera of the placed glTF files by name or index (None: the first perspective one, if any)."""
        error: PipelineError | None = None
        for inst in self.instances:
            try:
                ci = inst.find_camera(choice)
            except PipelineError as exc:
                error = error or exc
                continue
            if ci is None:
                continue
            camera = Camera(**inst.camera_params(ci, 0.0, center, radius))
            if inst.camera_moves(ci):
                def at(t: float, inst: GltfInstance = inst, ci: int = ci) -> Camera:
                    return Camera(**inst.camera_params(ci, t, center, radius))

                self.camera = CameraAnim(at, f"{inst.digest()}|camera{ci}")
            return camera
        if choice is None:
            return None
        if error is not None:
            raise error
        raise PipelineError(f"camera {choice!r}: the scene has no glTF object with cameras")

    def lights_at(self, t: float) -> tuple[Light, ...]:
        """The scene's punctual lights at time t: the glTF files' (in file order), then the scene file's."""
        from . import lights

        found = [lt for inst in self.instances for lt in inst.lights_at(t)] + self.fixed_lights
        return tuple(found[: lights.MAX_LIGHTS])  # `lit` says what is dropped

    def lit(self, objects: list[SceneObject], exposure: float | None = None) -> dict[str, Any]:
        """Scene(...) keywords for the lights at t = 0 and their exposure (None: lights.auto_exposure over
        `objects`, the scene at t = 0)."""
        from . import lights

        found = lights.drawn([lt for inst in self.instances for lt in inst.lights_at(0.0)] + self.fixed_lights,
                             ", ".join(inst.asset.path.name for inst in self.instances))
        if not found:
            if exposure is not None:
                warnings.warn("exposure: the scene has no punctual lights (`lights:` or a glTF file's), so it has no "
                              "effect; the scene light shades it", lights.LightWarning, stacklevel=2)
            return {}
        return {"lights": found, "exposure": lights.auto_exposure(found, objects) if exposure is None else exposure}

    def animator(self) -> Animator | None:
        from .animation import LightsAnim

        moving = [inst for inst in self.instances if inst.lights_move()]
        lights_anim = None
        if moving:
            lights_anim = LightsAnim(self.lights_at, "|".join(f"{inst.digest()}|lights" for inst in self.instances))
        if not self.objects and self.camera is None and lights_anim is None:
            return None
        return Animator(objects=dict(self.objects), camera=self.camera, fps=self.fps, lights=lights_anim,
                        start=min([0.0] + [a for a, _ in self.ranges]), end=max([0.0] + [b for _, b in self.ranges]))

    def bounds(self, objects: list[SceneObject], samples: int = 9, points: list[np.ndarray] | None = None,
               most: int = 2048) -> tuple[np.ndarray, np.ndarray]:
        """World bounds over the animation (sampled at `samples` times), for framing and near/far. `points`: a
        list that gets, per sample and moving object, up to about `most` of its world vertices (every k-th,
        and the extreme one along each axis), for framing the motion (framing.motion_view)."""
        lo, hi = _bounds_of(objects)
        if not self.objects or not self.ranges:
            return lo, hi
        a, b = min(r[0] for r in self.ranges), max(r[1] for r in self.ranges)
        for t in np.linspace(a, b, samples):
            for i, anim in self.objects.items():
                mesh, matrix = anim.pose(float(t))
                o = SceneObject(mesh=objects[i].mesh if mesh is None else mesh, transform=matrix)
                if points is not None and o.mesh.n_vertices:
                    w = o.world_vertices()
                    extreme = np.r_[w.argmin(axis=0), w.argmax(axis=0)]
                    points.append(np.vstack([w[:: max(1, len(w) // most)], w[extreme]]))
                    olo, ohi = w.min(axis=0), w.max(axis=0)
                else:
                    olo, ohi = o.world_bounds()
                lo, hi = np.minimum(lo, olo), np.maximum(hi, ohi)
        return lo, hi


def scene_from_gltf(path: str | Path, camera: str | int | None = None, animation: str | int | None = None,
                    fps: float = DEFAULT_FPS, view: str | None = None, up: str | None = None,
                    allow_outside: bool = False, fill: float | None = None,
                    animation_end: str | None = None) -> Scene:
    """A glTF file as a scene: its objects (colour from the material), seen through its first perspective
    camera (or `camera`, by name or index), playing all its animations together (or `animation`: one by name or
    index, or "all"; None: --animation, else all), a shorter clip holding its last pose or looping
    (`animation_end`: hold, loop; None: --animation-end, else hold). Without a camera, a file whose objects move
    is framed by framing.motion_view (readable at the first frame, the motion kept in view as far as that
    allows); a file whose objects do not move gets a mesh file's view (and orbit when nothing is animated).
    `up` (x, y, z) turns the file so that axis is +Y (glTF is Y-up: nothing is guessed); `view`
    (framing.VIEWS) picks the side a file without a camera is seen from, the front being +Z as glTF has it,
    framed so that it spans `fill` of the picture's shorter side (framing.fit_view)."""
    p = Path(path).expanduser().absolute()
    if animation is None:
        animation = views.ANIMATION.get()
    if animation_end is None:
        animation_end = views.ANIMATION_END.get()
    if animation_end not in (None, *views.ANIMATION_ENDS):
        raise PipelineError(f"animation end {animation_end!r}: expected one of {', '.join(views.ANIMATION_ENDS)}")
    spec = ObjectSpec(gltf=str(p), animation=animation, animation_end=animation_end)
    moving = _Moving(fps)
    objects: list[SceneObject] = []
    moving.add_gltf(objects, spec, p, framing.up_rotation(framing.check_up(up) or "y"), False, prefix=False,
                    allow_outside=allow_outside, command_line=False)
    motion: list[np.ndarray] = []
    lo, hi = moving.bounds(objects, points=motion)
    center, radius = (lo + hi) / 2.0, float(np.linalg.norm(hi - lo)) / 2.0
    cam = moving.gltf_camera(camera, center, radius)
    if cam is not None and view is not None:
        raise PipelineError(f"--view frames a file without a camera; {p.name} looks through its own camera")
    anim = moving.animator()
    orbit = None
    if cam is None:
        still = not moving.objects  # nothing drawn moves (a clip may still turn a light)
        # framed on the vertices faces use (at the first frame), to span `fill`
        merged = merge_meshes([o.mesh.transformed(o.transform) for o in objects], p.stem)
        points = framing.used_vertices(merged.vertices, merged.faces)
        if view is not None and view != "widest":
            direction, cam_up = framing.view_direction(view, (0.0, 0.0, 1.0))
        else:
            direction = best_view_direction(merged) if still else np.array(framing.THREE_QUARTER)
            cam_up = np.array([0.0, 1.0, 0.0])
        if still:
            cam = fit_camera(points, direction, cam_up, fill)
        else:
            cam = motion_camera(points, np.vstack(motion) if motion else points, lo, hi, direction, cam_up, fill)
        orbit = Orbit() if anim is None else None
    return Scene(name=p.stem, objects=tuple(objects), camera=cam, orbit=orbit, source=str(p), animation=anim,
                 **moving.lit(objects))


def select_camera(scene: Scene, which: str | int | None) -> Scene:
    """The scene reloaded to look through one of its glTF cameras, by name or index (`--camera`), with the
    command line's lens (views.LENS)."""
    if which is None:
        return scene
    src = scene.source or ""
    ext = Path(src).suffix.lower()
    if ext in GLTF_EXTENSIONS:
        try:
            return with_lens(scene_from_gltf(src, camera=which), *views.LENS.get())
        except MeshError as exc:
            raise PipelineError(str(exc)) from None
    if ext in SCENE_EXTENSIONS:
        return with_lens(scene_from_yaml(src, camera_choice=which), *views.LENS.get())
    raise PipelineError(f"--camera {which}: picks a camera of a glTF file (.gltf, .glb, or a scene YAML with "
                        f"'gltf:' objects); the scene is {src or scene.name}")
