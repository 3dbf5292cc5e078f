"""How a bare mesh file is stood up and looked at: its up axis, its front, and named views.

A mesh file says nothing reliable about which way is up or which side is its front, so both are read
from the file format's convention and the mesh's shape (docs/scenes.md, "Framing a mesh file"):

- **Up** (`detect_up`): only Y and Z are guessed (X-up files exist but are rare: give `--up x`).
  1. A flat base decides: of Y and Z, the axis whose lowest 2% (of the extent along it) holds
     down-facing faces (normal within ~18 degrees of straight down) covering at least 20% of the box's
     footprint across that axis, and at least twice the other axis's share, is up: a figure standing on
     the ground, a vase, a building.
  2. Else the format's convention: STL (3D printing, CAD, most scanners) is Z-up.
  3. Else (OBJ, PLY, OFF have none) the mesh is Y-up unless it is at least 1.5 times taller along Z
     than along Y: a standing scan exported Z-up.
- **Front** (`detect_front`, in the Y-up frame): characters and animals are mirror-symmetric left to
  right, not front to back. Of X and Z, the axis across whose mid-plane the surface is *least*
  mirror-symmetric is the front-back axis (the other is left-right); the front is the end the top 30%
  of the surface (by height) leans to, against the middle of the bounding box: the head leads (a head,
  a face, ears, a nose sit ahead of the body). Measured on the shared meshes (lean: cow +0.05, spot
  -0.27, ogre +0.08, bunny -0.25, suzanne +0.03 of the length), this finds the front of each; the
  surface's skew along the axis got three of the four animals wrong (a rounded back or rump outweighs
  a head). Where neither axis is clearly less symmetric, or the lean is
  under 2% of the length, glTF's convention holds: the front faces +Z (+X when X is the front-back axis).

Views are directions (target -> eye) in the mesh's own frame (side s, up u, front f), s = u x f:
front f, back -f, right s (the side on the right of the front view), left -s, top u (the front at the
bottom of the picture), three-quarter [0.55, 0.45, 1.0] in (s, u, f) (the default framing of scene
files, about 29 degrees round toward the right and 22 degrees up), widest: the old choice, the side
that shows the largest projected area (scene.best_view_direction).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np

from .views import UP_AXES, VIEWS

Up = Literal["x", "y", "z"]
View = Literal["three-quarter", "front", "back", "left", "right", "top", "widest"]

Z_UP_FORMATS = (".stl",)
BASE_BAND = 0.02  # the lowest share of the extent that counts as "the bottom"
BASE_COS = 0.95  # a face is down-facing when its normal is within acos(0.95) ~ 18 degrees of down
BASE_SHARE = 0.20  # a flat base covers at least this share of the footprint ...
BASE_RATIO = 2.0  # ... and at least twice the other axis's share
TALL_RATIO = 1.5  # a mesh without a base or convention is Z-up when this much taller along Z than along Y
SYMMETRY_MARGIN = 0.005  # one axis is "clearly" less symmetric when its asymmetry exceeds the other's by this
TOP_SHARE = 0.30  # the top of the surface, by height, whose lean says where the front is
LEAN_MIN = 0.02  # a lean below this share of the front-back length says nothing
THREE_QUARTER = (0.55, 0.45, 1.0)  # (side, up, front)


def check_up(up: str | None) -> str | None:
    if up is None or up == "auto":
        return None
    if up not in UP_AXES:
        raise ValueError(f"up: expected one of x, y, z or auto, found {up!r}")
    return up


def check_view(view: str | None) -> str | None:
    if view is None:
        return None
    if view not in VIEWS:
        raise ValueError(f"view: expected one of {', '.join(VIEWS)}, found {view!r}")
    return view


def up_rotation(up: str) -> np.ndarray:
    """4x4 rotation taking the axis `up` to +Y: z: -90 degrees about X (+Z -> +Y, +Y -> -Z: Blender's
    -Y front becomes +Z, glTF's); x: +90 degrees about Z (+X -> +Y, +Y -> -X); y: identity."""
    m = np.eye(4)
    if up == "z":
        m[:3, :3] = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]
    elif up == "x":
        m[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    elif up != "y":
        raise ValueError(f"up: expected x, y or z, found {up!r}")
    return m


def _faces(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area2 = np.linalg.norm(cross, axis=1)
    n = np.divide(cross, area2[:, None], out=np.zeros_like(cross), where=area2[:, None] > 0)
    return n, area2 / 2.0


def base_share(vertices: Any, faces: Any, axis: int) -> float:
    """Area of the down-facing faces in the lowest BASE_BAND of the extent along `axis`, over the box's
    footprint across it (1.0: a full flat bottom)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if len(f) == 0:
        return 0.0
    lo, hi = v.min(axis=0), v.max(axis=0)
    ext = hi - lo
    others = [k for k in range(3) if k != axis]
    footprint = float(ext[others[0]] * ext[others[1]])
    if not footprint > 0.0 or not ext[axis] > 0.0:
        return 0.0
    n, area = _faces(v, f)
    low = (v[f][:, :, axis] <= lo[axis] + BASE_BAND * ext[axis]).all(axis=1)
    down = -n[:, axis] >= BASE_COS
    return float(area[low & down].sum()) / footprint


def detect_up(vertices: Any, faces: Any, suffix: str = "") -> str:
    """'y' or 'z' by the rule in the module docstring."""
    v = np.asarray(vertices, dtype=np.float64)
    if len(v) == 0:
        return "y"
    by, bz = base_share(v, faces, 1), base_share(v, faces, 2)
    if by >= BASE_SHARE and by >= BASE_RATIO * bz:
        return "y"
    if bz >= BASE_SHARE and bz >= BASE_RATIO * by:
        return "z"
    if suffix.lower() in Z_UP_FORMATS:
        return "z"
    ext = v.max(axis=0) - v.min(axis=0)
    return "z" if ext[2] >= TALL_RATIO * ext[1] > 0.0 else "y"


def surface_samples(vertices: Any, faces: Any, n: int = 6000, seed: int = 0) -> np.ndarray:
    """`n` points spread over the surface by area (fixed seed: the same mesh, the same points)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    _, area = _faces(v, f)
    total = float(area.sum())
    if len(f) == 0 or not total > 0.0:
        return v.copy()
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(f), size=n, p=area / total)
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    a, b, c = v[f[pick, 0]], v[f[pick, 1]], v[f[pick, 2]]
    return (1 - s)[:, None] * a + (s * (1 - r2))[:, None] * b + (s * r2)[:, None] * c


def asymmetry(points: np.ndarray, axis: int, scale: float) -> float:
    """Share of the points whose mirror image across the mid-plane (through the mean) perpendicular to
    `axis` lies farther than 4% of `scale` from every point: 0 for a mirror-symmetric surface."""
    from scipy.spatial import cKDTree

    mirrored = points.copy()
    c = float(points[:, axis].mean())
    mirrored[:, axis] = 2.0 * c - mirrored[:, axis]
    d, _ = cKDTree(points).query(mirrored, k=1)
    return float((d > 0.04 * scale).mean())


def detect_front(vertices: Any, faces: Any) -> np.ndarray:
    """The unit front direction (+-X or +-Z) of a Y-up mesh, by the rule in the module docstring."""
    v = np.asarray(vertices, dtype=np.float64)
    if len(v) == 0 or len(np.asarray(faces)) == 0:
        return np.array([0.0, 0.0, 1.0])
    p = surface_samples(v, faces)
    scale = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) or 1.0
    ax, az = asymmetry(p, 0, scale), asymmetry(p, 2, scale)
    if ax > az + SYMMETRY_MARGIN:
        axis = 0  # not symmetric across X: X runs front to back (the Z mid-plane is the mirror)
    elif az > ax + SYMMETRY_MARGIN:
        axis = 2
    else:
        return np.array([0.0, 0.0, 1.0])
    lo, hi = v.min(axis=0), v.max(axis=0)
    top = p[:, 1] >= hi[1] - TOP_SHARE * (hi[1] - lo[1])
    length = float(hi[axis] - lo[axis])
    middle = (float(lo[axis]) + float(hi[axis])) / 2.0
    lean = (float(p[top, axis].mean()) - middle) / length if top.any() and length > 0 else 0.0
    out = np.zeros(3)
    out[axis] = -1.0 if lean <= -LEAN_MIN else 1.0
    return out


def view_direction(view: str, front: Any, up: Any = (0.0, 1.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """(direction target -> eye, camera up) of a named view for a mesh facing `front` (not 'widest')."""
    f = np.asarray(front, dtype=np.float64)
    u = np.asarray(up, dtype=np.float64)
    s = np.cross(u, f)
    table = {"front": f, "back": -f, "right": s, "left": -s, "top": u}
    if view == "three-quarter":
        a, b, c = THREE_QUARTER
        d = a * s + b * u + c * f
    elif view in table:
        d = table[view]
    else:
        raise ValueError(f"view: expected one of {', '.join(v for v in VIEWS if v != 'widest')}, found {view!r}")
    d = d / np.linalg.norm(d)
    return d, (-f if view == "top" else u)


def suffix_of(source: str | Path | None) -> str:
    return Path(str(source)).suffix.lower() if source else ""


def describe(up: str, front: np.ndarray) -> str:
    k = int(np.argmax(np.abs(front)))
    return f"up {up}, front {'+' if front[k] > 0 else '-'}{'xyz'[k]}"


__all__ = ["UP_AXES", "VIEWS", "check_up", "check_view", "detect_front", "detect_up", "up_rotation",
           "view_direction"]
