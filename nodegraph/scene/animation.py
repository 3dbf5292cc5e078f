"""Animation: keyframe tracks, quaternions, skinning, morph targets, and the animator a scene carries.

A `Scene` with an `animation` (an `Animator`) is posed per frame by `Scene.at(frame)`: the result is an
ordinary static scene (meshes, transforms, camera at time t = frame / fps), so every node sees plain
geometry and its key covers the pose at that frame. Objects that do not move keep their very `Mesh`
and transform, so what depends on them alone (curvature, hatching) keeps its key across frames.

All evaluation is float64 NumPy on the CPU. Quaternions are glTF's (x, y, z, w).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from .timeline import MAX_FRAME, MAX_FRAMES

Interpolation = Literal["LINEAR", "STEP", "CUBICSPLINE", "SMOOTH"]
DEFAULT_FPS = 24.0


# --- quaternions ----------------------------------------------------------------------------------


def quat_normalize(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    return np.divide(q, n, out=np.broadcast_to([0.0, 0.0, 0.0, 1.0], q.shape).copy(), where=n > 0)


def quat_slerp(a: np.ndarray, b: np.ndarray, s: float) -> np.ndarray:
    """Spherical interpolation along the shorter arc (glTF's LINEAR for rotations)."""
    a, b = quat_normalize(a), quat_normalize(b)
    d = float(np.dot(a, b))
    if d < 0.0:
        b, d = -b, -d
    if d > 0.9995:  # nearly parallel: normalised lerp is exact to rounding
        return quat_normalize(a + s * (b - a))
    theta = math.acos(min(d, 1.0))
    sin_t = math.sin(theta)
    return (math.sin((1.0 - s) * theta) * a + math.sin(s * theta) * b) / sin_t


def quat_matrix(q: Any) -> np.ndarray:
    """(3, 3) rotation matrix of a unit quaternion (x, y, z, w); (..., 3, 3) of quaternions (..., 4)."""
    x, y, z, w = np.moveaxis(quat_normalize(np.asarray(q, dtype=np.float64)), -1, 0)
    m = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    return np.moveaxis(m, (0, 1), (-2, -1))


def trs_matrix(t: Any = (0, 0, 0), r: Any = (0, 0, 0, 1), s: Any = (1, 1, 1)) -> np.ndarray:
    """T @ R @ S as glTF defines a node's local transform."""
    m = np.eye(4)
    m[:3, :3] = quat_matrix(r) * np.asarray(s, dtype=np.float64)[None, :]
    m[:3, 3] = np.asarray(t, dtype=np.float64)
    return m


# --- tracks ---------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Track:
    """Keyframes `times` (k,) ascending and `values`: (k, n), or (k, 3, n) for CUBICSPLINE (in-tangent,
    value, out-tangent per key, as glTF stores them). `quaternion`: values are (x, y, z, w), LINEAR
    slerps and every result is normalised. `segment`: per-key interpolation of the segment that starts
    at that key (scene YAML keys may differ); None: `interpolation` throughout. Outside the keys the
    first or last value holds."""

    times: np.ndarray
    values: np.ndarray
    interpolation: Interpolation = "LINEAR"
    quaternion: bool = False
    segment: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=np.float64).reshape(-1)
        v = np.asarray(self.values, dtype=np.float64)
        cubic = self.interpolation == "CUBICSPLINE"
        v = v.reshape(len(t), 3, -1) if cubic else v.reshape(len(t), -1)
        if len(t) == 0:
            raise ValueError("an animation track needs at least one key")
        if not np.all(np.isfinite(t)) or not np.all(np.isfinite(v)):
            raise ValueError("animation keys must be finite")
        if np.any(np.diff(t) <= 0):
            raise ValueError("animation key times must be strictly increasing")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "values", v)

    @property
    def start(self) -> float:
        return float(self.times[0])

    @property
    def end(self) -> float:
        return float(self.times[-1])

    def _value(self, i: int) -> np.ndarray:
        return self.values[i, 1] if self.interpolation == "CUBICSPLINE" else self.values[i]

    def sample(self, t: float) -> np.ndarray:
        times = self.times
        if t <= times[0] or len(times) == 1:
            out = self._value(0)
        elif t >= times[-1]:
            out = self._value(len(times) - 1)
        else:
            i = int(np.searchsorted(times, t, side="right")) - 1
            t0, t1 = times[i], times[i + 1]
            dt = t1 - t0
            s = (t - t0) / dt
            kind = self.segment[i] if self.segment is not None else self.interpolation
            if kind == "STEP":
                out = self._value(i)
            elif kind == "CUBICSPLINE":
                v = self.values
                s2, s3 = s * s, s * s * s
                out = ((2 * s3 - 3 * s2 + 1) * v[i, 1] + (s3 - 2 * s2 + s) * dt * v[i, 2]
                       + (-2 * s3 + 3 * s2) * v[i + 1, 1] + (s3 - s2) * dt * v[i + 1, 0])
            else:
                if kind == "SMOOTH":  # ease in and out of both keys: zero velocity at each key
                    s = s * s * (3.0 - 2.0 * s)
                a, b = self._value(i), self._value(i + 1)
                out = quat_slerp(a, b, s) if self.quaternion else a + s * (b - a)
        out = np.array(out, dtype=np.float64)
        return quat_normalize(out) if self.quaternion else out

    def digest_into(self, h: Any) -> None:
        h.update(self.interpolation.encode())
        h.update(self.times.tobytes())
        h.update(self.values.tobytes())
        if self.segment is not None:
            h.update(",".join(self.segment).encode())


class AnimationNote(UserWarning):
    """What a file's animation plays (its clips, which one wins a shared channel): one line, said once."""


def loop_time(t: float, period: float) -> float:
    """The clip time of film time t for a clip that loops with `period` (its end, keys counted from 0): t
    itself up to the end, then each later cycle (k * period, (k + 1) * period] mapped onto (0, period], so
    every cycle closes on the last key; before 0 (negative frames) t as it is (the first key holds)."""
    if not (period > 0.0) or t <= period:
        return t
    return t - period * (math.ceil(t / period) - 1.0)


@dataclass(frozen=True, eq=False)
class LoopedTrack:
    """A track played in a loop of `period` seconds (`loop_time`); samples as `Track.sample`."""

    track: Track
    period: float

    @property
    def start(self) -> float:
        return self.track.start

    @property
    def end(self) -> float:
        return self.track.end

    def sample(self, t: float) -> np.ndarray:
        return self.track.sample(loop_time(t, self.period))

    def digest_into(self, h: Any) -> None:
        h.update(f"loop:{self.period!r}".encode())
        self.track.digest_into(h)


# --- deformation ----------------------------------------------------------------------------------


def skin_weights(joints: np.ndarray, weights: np.ndarray, n_joints: int) -> Any:
    """The (n, J) sparse matrix of skin weights (CSR; repeated joints of one vertex add up): built once per
    mesh, it turns skinning into one sparse product per frame (`skin_vertices`)."""
    import scipy.sparse as sp

    j = np.asarray(joints, dtype=np.int64)
    w = np.asarray(weights, dtype=np.float64)
    rows = np.repeat(np.arange(len(j)), j.shape[1])
    return sp.csr_matrix((w.ravel(), (rows, j.ravel())), shape=(len(j), int(n_joints)))


def skin_vertices(vertices: np.ndarray, joints: np.ndarray | None, weights: np.ndarray | Any,
                  joint_matrices: np.ndarray) -> np.ndarray:
    """Linear-blend skinning in float64: v' = (sum_k w_k J[j_k]) @ [v, 1], per vertex.

    vertices (n, 3); joints (n, k) joint indices and weights (n, k), or joints None and weights the sparse
    (n, J) matrix of `skin_weights`; joint_matrices (J, 4, 4), each the joint's world matrix times its
    inverse bind matrix. The blended (3, 4) matrix of every vertex is the weighted sum of its joints'
    matrices, all at once as a sparse (n, J) x (J, 12) product; then one einsum applies them."""
    v = np.asarray(vertices, dtype=np.float64)
    blended = skin_matrices(joints, weights, joint_matrices)
    return np.einsum("nij,nj->ni", blended[:, :, :3], v) + blended[:, :, 3]


def skin_matrices(joints: np.ndarray | None, weights: np.ndarray | Any, joint_matrices: np.ndarray) -> np.ndarray:
    """(n, 3, 4) the blended skin matrix of every vertex, sum_k w_k J[j_k] (arguments as `skin_vertices`)."""
    mats = np.asarray(joint_matrices, dtype=np.float64)
    w = weights if joints is None else skin_weights(joints, weights, len(mats))
    return np.asarray(w @ np.ascontiguousarray(mats[:, :3, :]).reshape(-1, 12)).reshape(-1, 3, 4)


def morph_vertices(base: np.ndarray, deltas: np.ndarray, weights: Sequence[float]) -> np.ndarray:
    """base (n, 3) + sum_i w_i deltas[i] (deltas: (targets, n, 3))."""
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    if len(w) == 0 or deltas.shape[0] == 0:
        return np.asarray(base, dtype=np.float64)
    return np.asarray(base, dtype=np.float64) + np.tensordot(w[: deltas.shape[0]], deltas[: len(w)], axes=1)


# --- the animator a scene carries -------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ObjectAnim:
    """How one scene object changes with time: `pose(t)` returns (mesh or None to keep the object's own,
    object->world matrix). `digest` names what drives it (file content, keys), for the scene's hash."""

    pose: Callable[[float], tuple[Any, np.ndarray]]
    digest: str


@dataclass(frozen=True, eq=False)
class CameraAnim:
    at: Callable[[float], Any]  # t -> Camera
    digest: str


@dataclass(frozen=True, eq=False)
class LightsAnim:
    at: Callable[[float], tuple[Any, ...]]  # t -> the scene's lights (nodegraph/scene/lights.py)
    digest: str


@dataclass(frozen=True, eq=False)
class Animator:
    """Per-object and camera animation of a scene, evaluated at t = frame / fps. `start`, `end`: the
    animation's time range in seconds (the default frame range of films: `frame_range`)."""

    objects: dict[int, ObjectAnim] = field(default_factory=dict)  # scene object index -> animation
    camera: CameraAnim | None = None
    fps: float = DEFAULT_FPS
    start: float = 0.0
    end: float = 0.0
    # posed meshes carry their rest pose (Mesh.rest, Mesh.skin_linear) for object-space noise and curvature;
    # False drops it, so both are computed on the posed surface (the shower-door comparison's "before")
    rest_pose: bool = True
    lights: LightsAnim | None = None  # lights on moving glTF nodes

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"fps must be a positive number, got {self.fps}")

    def time(self, frame: int) -> float:
        return float(frame) / self.fps

    def frame_range(self) -> range:
        """Frames covering [start, end] at fps: range(floor(start*fps), floor(end*fps) + 1)."""
        first = math.floor(self.start * self.fps + 1e-9)
        last = math.floor(self.end * self.fps + 1e-9)
        return range(first, last + 1)

    def digest(self) -> str:
        h = hashlib.sha256(f"animator:fps={self.fps!r}".encode())
        if not self.rest_pose:
            h.update(b"|posed-space")
        for i in sorted(self.objects):
            h.update(f"|o{i}:{self.objects[i].digest}".encode())
        if self.camera is not None:
            h.update(f"|camera:{self.camera.digest}".encode())
        if self.lights is not None:
            h.update(f"|lights:{self.lights.digest}".encode())
        return h.hexdigest()

    def pose(self, scene: Any, frame: int) -> Any:
        """The scene at `frame` as a static scene (no animator)."""
        t = self.time(frame)
        objects = list(scene.objects)
        for i, anim in self.objects.items():
            mesh, matrix = anim.pose(t)
            if mesh is not None and not self.rest_pose and mesh.rest is not None:
                mesh = mesh.without_rest()
            obj = objects[i]
            objects[i] = replace(obj, mesh=obj.mesh if mesh is None else mesh, transform=matrix)
        camera = scene.camera if self.camera is None else self.camera.at(t)
        extent = scene.extent if scene.extent is not None else scene.bounds()
        if self.lights is not None:
            return replace(scene, objects=tuple(objects), camera=camera, animation=None, extent=extent,
                           lights=tuple(self.lights.at(t)))
        return replace(scene, objects=tuple(objects), camera=camera, animation=None, extent=extent)


def with_fps(scene: Any, fps: float | None) -> Any:
    """The scene with its animation evaluated at `fps` frames per second (unchanged when static or None)."""
    if fps is None or getattr(scene, "animation", None) is None:
        return scene
    return replace(scene, animation=replace(scene.animation, fps=float(fps)))


def default_frames(scene: Any) -> list[int] | None:
    """The animation's frame range, or None for a static scene. The range a run takes by default is capped as
    a --frames range is: at most `MAX_FRAMES` frames, numbers within +-`MAX_FRAME`; a longer animation (a key
    at t = 1e7 s is 2.4e8 frames at 24 fps) is one line suggesting --frames, before any list is made."""
    from ..errors import SketchgraphError

    anim = getattr(scene, "animation", None)
    if anim is None:
        return None
    first, last = anim.start * anim.fps + 1e-9, anim.end * anim.fps + 1e-9
    span = f"the scene's animation runs {anim.start:g} s to {anim.end:g} s at {anim.fps:g} fps"
    if not (math.isfinite(first) and math.isfinite(last)) or min(first, last) < -MAX_FRAME or \
            max(first, last) >= MAX_FRAME + 1:
        raise SketchgraphError(f"{span}: frame numbers beyond {MAX_FRAME}; give --frames START:END (frame numbers "
                               f"between {-MAX_FRAME} and {MAX_FRAME}) to render part of it")
    count = math.floor(last) - math.floor(first) + 1
    if count > MAX_FRAMES:
        raise SketchgraphError(f"{span}: {count} frames, more than the {MAX_FRAMES} a run renders; give --frames "
                               "START:END to render part of it")
    return list(anim.frame_range())
