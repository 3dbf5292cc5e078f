"""Geometry far from the origin: what nodes that draw meshes upload, so float32 precision on the GPU
depends on the scene's size, not on where it is.

The GPU sees float32. A unit sphere at 1e8 in world space has an ulp of 8 units there: drawn with
world-space matrices it collapses. So geometry is drawn relative to two float64 origins:

- a world origin `O` (`world_origin`): the camera's eye, or exactly 0 when the scene's bounding box and
  the eye both lie within `RECENTRE_RATIO` bounding radii of the world origin (every shipped scene);
- a per-mesh object-space origin `c` (`mesh_origin`): the mesh's bounding-box centre, or exactly 0 when
  that centre lies within `RECENTRE_RATIO` of the mesh's own bounding radii of its origin.

Vertex positions are uploaded as `p - c` (subtracted in float64, then rounded to float32) and the matrices
as `view · T(O)` and `T(-O) · model · T(c)`, both formed in float64 (`relative_matrices`); their product
is `view · model · T(c)`, so the vertex `p - c` lands exactly where `p` did. Where both origins are 0
the uploaded arrays and matrices are the ones used before, bit for bit.

"Object-space position" (rasterize.position, read by object_noise) is `p - c`: the object-space
coordinates themselves for every mesh whose origin is 0, and coordinates about the mesh's own
bounding-box centre for a mesh far from its origin (float32 could not hold its coordinates otherwise).
It never depends on the camera or on the world origin.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

# a box centre (or the eye) further than this many bounding radii from its origin is re-centred; within it
# float32 keeps at least 24 - 6 bits for the geometry itself (3.8e-6 of the radius)
RECENTRE_RATIO = 64.0
# float64 coordinates lose all but ~10 bits of an object's size beyond this position/size ratio
FLOAT64_RATIO = 1e12
FLOAT32_MAX = float(np.finfo(np.float32).max)


class PrecisionWarning(RuntimeWarning):
    """A scene that float32 (or float64) coordinates cannot represent even relative to the camera."""


def _radius(lo: np.ndarray, hi: np.ndarray) -> float:
    return float(np.linalg.norm(hi - lo)) / 2.0


def _far(centre_distance: float, radius: float) -> bool:
    if not math.isfinite(centre_distance):
        return True
    if radius > 0.0:
        return centre_distance > RECENTRE_RATIO * radius
    return centre_distance > 0.0


def mesh_origin(mesh: Any) -> np.ndarray:
    """The object-space origin `c` positions of `mesh` are uploaded relative to: its bounding-box centre
    when that lies more than RECENTRE_RATIO bounding radii from the origin, else exactly 0."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in mesh.bounds())
    centre = (lo + hi) / 2.0
    if _far(float(np.linalg.norm(centre)), _radius(lo, hi)):
        return centre
    return np.zeros(3)


def world_origin(scene: Any, camera: Any) -> np.ndarray:
    """The world origin `O` geometry is drawn relative to: the camera's eye when the scene's box centre or
    the eye lies more than RECENTRE_RATIO scene radii from the world origin, else exactly 0."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.bounds())
    radius = _radius(lo, hi)
    eye = np.asarray(camera.eye, dtype=np.float64)
    far = max(float(np.linalg.norm((lo + hi) / 2.0)), float(np.linalg.norm(eye)))
    if scene.objects and _far(far, radius):
        return eye.copy()
    return np.zeros(3)


def relative_matrices(view: np.ndarray, model: np.ndarray, world: np.ndarray,
                      local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(view · T(world), T(-world) · model · T(local)), formed in float64; the inputs unchanged (the same
    arrays) where both origins are 0."""
    view = np.asarray(view, dtype=np.float64)
    model = np.asarray(model, dtype=np.float64)
    if not world.any() and not local.any():
        return view, model
    v = view.copy()
    v[:3, 3] = view[:3, :3] @ world + view[:3, 3]
    m = model.copy()
    m[:3, 3] = (model[:3, :3] @ local + model[:3, 3]) - world
    return v, m


def positions(mesh: Any, render_arrays: Any, local: np.ndarray) -> np.ndarray:
    """(k, 3) float32 positions of `render_arrays` relative to `local` (subtracted in float64)."""
    if not local.any():
        return render_arrays.positions
    p = np.asarray(mesh.vertices, dtype=np.float64)[render_arrays.source_vertex] - local
    return p.astype(np.float32)


_WARNED: set[str] = set()


def problem(scene: Any, camera: Any) -> str | None:
    """Why this scene cannot be drawn faithfully even relative to the camera, or None."""
    eye = np.asarray(camera.eye, dtype=np.float64)
    world = world_origin(scene, camera)
    for obj in scene.objects:
        lo, hi = (np.asarray(b, dtype=np.float64) for b in obj.world_bounds())
        name = obj.name or f"object {obj.index}"
        if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
            return f"object '{name}' has coordinates that are not finite"
        if max(np.abs(lo - world).max(), np.abs(hi - world).max()) > FLOAT32_MAX:
            return f"object '{name}' lies beyond float32's range ({FLOAT32_MAX:.3g}) even relative to the camera"
        mlo, mhi = (np.asarray(b, dtype=np.float64) for b in obj.mesh.bounds())
        radius = _radius(mlo, mhi)
        centre = float(np.linalg.norm((mlo + mhi) / 2.0))
        if obj.mesh.n_vertices and radius > 0.0 and centre / radius > FLOAT64_RATIO:
            return (f"mesh of object '{name}' is {radius:.3g} across at {centre:.3g} from its origin: even float64 "
                    "coordinates lose its shape (keep the mesh near its origin and place it with a transform)")
    if not np.isfinite(eye).all():
        return "the camera's eye is not finite"
    return None


def hash_extra(scene: Any, frame: int) -> dict[str, str] | None:
    """What a geometry node adds to its key: None where both origins are 0 for every object (the keys
    and the pixels of the drawing before re-centring existed), a marker otherwise."""
    if scene is None or not scene.objects:
        return None
    if world_origin(scene, scene.camera_at(frame)).any() or any(mesh_origin(o.mesh).any() for o in scene.objects):
        return {"origin": "relative"}
    return None


def warn_once(scene: Any, camera: Any) -> None:
    """One PrecisionWarning per scene and process when `problem` finds one."""
    key = scene.content_hash()
    if key in _WARNED:
        return
    _WARNED.add(key)
    why = problem(scene, camera)
    if why:
        warnings.warn(f"scene '{scene.name}' cannot be represented on the GPU: {why}; the image will be wrong",
                      PrecisionWarning, stacklevel=3)
