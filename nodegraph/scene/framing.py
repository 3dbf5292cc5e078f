"""How a bare mesh file is stood up and looked at: its up axis, its front, the side it is seen from and
how much of the picture it fills (docs/scenes.md, "Framing a mesh file").

**The file's convention holds** unless the mesh's shape says strongly, by a measure named here, that it is
wrong; each override is said in one line (`FramingWarning`) with the option that undoes it:

- OBJ, PLY, OFF and glTF are Y-up with the front toward +Z; STL (3D printing, CAD, scanners) is Z-up with
  the front toward -Y (Blender's convention), which `up_rotation("z")` turns into +Z.
- **Up** (`orient`), of the six signed axes:
  0. *It stands on legs one way only.* `stance` finds, for each axis up (the mirror plane's axis left out, see
     1), the contacts of a 20,000-sample surface in the lowest LEG_BAND of the extent, grouped into feet (links
     of LEG_LINK of the diagonal); the mesh stands that way when it has two or more feet, its centre of mass
     projects at least LEG_MARGIN of the diagonal inside their convex hull, and the feet stay apart up to
     LEG_HEIGHT of the height (legs, wheels: not the bumps of a flank lying on the ground). When exactly one
     axis stands so and no side of another axis has a flat base (below) the mesh can rest on (the other end
     of the legs' own axis may: a table's top), that axis is up: a convention that disagrees is overridden
     with one line, and one that agrees holds. A standing animal, insect, bird or figure with its feet apart
     stands on its feet and on nothing else, a table or a stool on its legs or its top; a chair also rests on
     its back, a figure on a plinth on the plinth, so for them the legs decide nothing (measured: `sketchgraph
     bench orientation`; the constants were set before the first measurement, the flat-base condition after
     the tune set's figure, which also stands on its nose and toes, and the same-axis exception after the
     bench's first fresh wave).
  1. *The mirror plane is vertical.* Characters, animals, vehicles and most made things are mirror-symmetric
     left to right. When one of the three axis mid-planes is the mirror plane (`mirror_plane`: the surface
     is its own mirror image across it, by `mirror_distance`, MIRROR_RATIO times more closely than across
     either other axis, axes the subject is thin along left out; where no plane is, a clean mirror by
     `asymmetry`: at most MIRROR_MAX, the other two at least MIRROR_GAP more) and its axis is the convention's
     up, that axis runs left to right, not up: a Z-up figure turned a quarter about Z and read as Y-up lies on
     its side. Measured on the tune set, the true mirror plane wins by 1.44 (the boxes figure) to 15.7 (the
     chair), and no mesh of the three sets has its best plane across its true up. Up is then one of the
     other two axes: the other convention's (Z for a Y-up format, Y for STL) unless it cannot rest on
     either end of it (`resting_support`), and of its two ends the one with the more stable resting poses
     and the flatter base below (the sign is the weakest part of the guess, and the line says `--up`).
     No axis mid-plane is the mirror plane when a principal plane of the surface off the axes
     (`off_axis_mirror`) mirrors it MIRROR_RATIO times more closely still: the mesh is turned off the axes
     (a model set at 20-65 degrees about its up in its file), and which axis mid-plane mirrors it least badly
     says nothing. OFF_AXIS_DEG was set on the orientation bench's turned presentations. Of such a mesh the
     axes within TURNED_DEG of its turned mirror plane's normal (`turned_mirror`) are left out of the legs'
     rule, as the axis across an axis mirror plane is.
  2. *A flat base.* Else, when the mesh cannot rest on the convention's bottom at all (no stable resting
     pose with that up), an axis whose lowest BASE_BAND of the extent holds down-facing faces covering at
     least BASE_SHARE of the bounding box's footprint, BASE_RATIO times the convention's own, on which the
     mesh rests stably (its centre of mass over the base), is up. A car on wheels or a chair on legs rests
     on them, so its flat roof or back never stands it up (the override that stood a car on its tail); a
     Z-up figure on a plinth written as an OBJ lies on its back as the file says (`--up z`; as an STL it
     stands).
  3. Else the convention.
  Stable resting poses (the quasi-static model of trimesh's `compute_stable_poses`: a face of the convex
  hull is a pose when the surface's centroid projects inside it, with the solid angle it subtends from the
  centroid as its probability) do *not* say which way a thing was made to stand: measured on the shared
  meshes, standing upright is the most probable pose of none of them (spot 0.10, cow 0.10, bunny 0.11, ogre
  0.02, suzanne 0.00: animals and figures fall on their sides). They serve only as evidence for an end.
- **Front** (`orient`, in the stood-up, Y-up frame): the front lies in the mirror plane that runs left to right,
  so along Z (the convention's) or along X. Of the two horizontal axes, the one across which the surface is its
  own mirror image (`mirror_distance`: the mean distance from each surface sample's mirror image to the nearest
  sample) at least MIRROR_RATIO times more closely than across the other is the mirror plane
  (`upright_mirror`; not for a subject thin along either: a flat cut-out mirrors itself across its thickness);
  else a clean mirror plane across Z (`mirror_axis`) puts the front along X; else Z. The ratio was chosen on the
  tune set, where the true mirror plane wins by 1.44 (the boxes figure, whose nose and feet are the only
  difference front to back) to 15.7 (the chair); the horse of the wild set, a posed scan with its legs apart and
  its head turned aside, still mirrors itself 1.7 times more closely left to right; a teapot, mirror-symmetric
  across Z, is seen from its spout or handle end. Of the two ends of that axis, first the legs
  (`head_ends`): a mesh that stands (`stance`, up +Y) on HEAD_FEET or more feet faces the end where HEAD_SHARE or
  more of its surface reaches past its feet (by HEAD_GAP of the diagonal), at least HEAD_RATIO times the share
  past them at the other end: an animal's head and neck stand out beyond its forelegs, its rump hardly beyond
  its hind legs. Not for built things, HEAD_BUILT or more of whose surface faces along the axes
  (`axis_facing`: furniture, vehicles of boxes), whose backs and tails (a bed's headboard, a tricycle's body)
  stand out as far. The constants were set before the rule's first measurement, HEAD_BUILT after it (see
  docs/scenes.md); an animal whose rear outweighs its head (a lizard's tail, an ant's abdomen) or a pram pushed
  by a handle behind it is seen from behind. Where the legs decide nothing along that axis but decide along the
  other horizontal axis, that axis's end is the front (`FrontChoice.legs_axis`): the mirror measure leaves out
  the axes a subject is thin along, so a long, slim animal (a tiger with its tail, under a fifth as wide as long)
  facing X has its axis taken as the convention's Z. Where the legs do not decide,
  the + end is the front unless the - end shows decisively more detail: `visible_detail` measures, from each
  end, the projected length of the *feature lines* seen there (edges whose faces meet at more than
  FEATURE_DEG, Blender's auto-smooth angle; both faces turned the same way, so the silhouette, the same from
  both ends, does not count), lines behind the surface left out by a DETAIL_RES z-buffer rastered in NumPy.
  The - end is the front when it shows at least DETAIL_MARGIN times as much, each side counted with
  DETAIL_FLOOR of the picture's width added (a few stray edges decide nothing), and the line says so, by how
  much, and that `--view back` looks at the file's front. Measured (`sketchgraph bench orientation`, its
  tune set): a modelled face decides (ogre 1.5x its back, suzanne 1.8x, the bunny 1.7x); a box, a ball and
  a car with a bonnet and a boot show about as much from both ends (1.0x) and keep the convention; a
  smooth or coarse animal whose face is a plain muzzle does not decide: spot's face shows 1.15x its rump and
  tail, and the cow's rear 1.2x its face, so the margin stands above 1.2 (both are now decided by their legs).
  The measure, the angle and the margin were chosen on the tune set.
  Measured on the sets kept apart: `sketchgraph bench orientation` (docs/scenes.md, "How often it is right").

**Framing** (`fit_view`): the camera looks along the view's direction at the vertices faces use (a vertex
no face uses is never drawn, so it never frames anything), and is placed so the projected bounding box of
those vertices is centred and spans `fill` (default DEFAULT_FILL) of the picture's shorter side. A flat or
thin subject (`broad_side`: its thinnest principal extent under THIN of the middle one) is seen face-on by
default, from the side of its broad face the default view is on.

Views are directions (target -> eye) in the mesh's own frame (side s, up u, front f), s = u x f:
front f, back -f, right s (the side on the right of the front view), left -s, top u (the front at the
bottom of the picture), three-quarter [0.55, 0.45, 1.0] in (s, u, f) (the default framing of scene
files, about 29 degrees round toward the right and 22 degrees up), widest: the side that shows the largest
projected area (scene.best_view_direction).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .views import UP_AXES, VIEWS

Up = Literal["x", "y", "z", "-x", "-y", "-z"]
View = Literal["three-quarter", "front", "back", "left", "right", "top", "widest"]

Z_UP_FORMATS = (".stl",)
BASE_BAND = 0.02  # the lowest share of the extent that counts as "the bottom"
BASE_COS = 0.95  # a face is down-facing when its normal is within acos(0.95) ~ 18 degrees of down
BASE_SHARE = 0.20  # a flat base covers at least this share of the footprint ...
BASE_RATIO = 2.0  # ... and at least this many times the convention's own base
MIRROR_MAX = 0.05  # a clean mirror plane: at most this share of the surface has no mirror image across it ...
MIRROR_GAP = 0.12  # ... and each other axis plane at least this much more
MIRROR_RATIO = 1.3  # a mirror plane differs from its image this many times less than across the other axes
TURNED_DEG = 50.0  # of a mesh turned off the axes, an axis this near its mirror plane's normal is not up (legs)
OFF_AXIS_DEG = 3.0  # a principal axis this far from every coordinate axis is off the axes (sampling moves it less)
FEATURE_DEG = 30.0  # an edge is a feature line when its two faces meet at more than this (Blender's auto-smooth)
DETAIL_MARGIN = 1.3  # the far end of the front axis is the front when it shows this many times the feature lines
DETAIL_FLOOR = 0.25  # ... each side counted with this share of the picture's width of line added
DETAIL_RES = 128  # pixels across the z-buffer that hides feature lines behind the surface
POSE_COS = 0.94  # a resting pose counts for an axis when its up is within ~20 degrees of it
LEG_SAMPLES = 20000  # surface samples the stance is measured on
LEG_BAND = 0.03  # the contacts: the samples in the lowest share of the extent
LEG_LINK = 0.04  # contacts closer than this share of the diagonal belong to one foot
LEG_MIN = 0.03  # a foot holds at least this share of the contacts
LEG_HEIGHT = 0.12  # legs: the feet stay apart up to this share of the height
LEG_MARGIN = 0.01  # the centre of mass lies this share of the diagonal inside the feet's polygon
HEAD_FEET = 3  # the front's legs rule: a mesh standing on at least this many feet ...
HEAD_GAP = 0.02  # ... whose surface reaches past its feet by more than this share of the diagonal ...
HEAD_SHARE = 0.08  # ... with at least this share of its surface at one end of the front axis ...
HEAD_RATIO = 2.0  # ... and this many times the share at the other end faces that end (its head) ...
HEAD_BUILT = 0.4  # ... unless this share of its surface faces along the axes (furniture, vehicles: built, not grown)
HEAD_BUILT_DEG = 10.0  # ... a face facing along an axis when its normal is within this angle of it
DEFAULT_FILL = 0.85  # the projected box of the subject over the picture's shorter side
FILL_MAX = 4.0
THIN = 0.2  # a subject whose thinnest principal extent is under this share of the middle one is flat
THREE_QUARTER = (0.55, 0.45, 1.0)  # (side, up, front)
SIGNED_AXES: tuple[str, ...] = ("x", "y", "z", "-x", "-y", "-z")


class FramingWarning(UserWarning):
    """The framing of a mesh file overrode the file's convention (one line, with the option that undoes it)."""


def axis_vector(axis: str) -> np.ndarray:
    out = np.zeros(3)
    out["xyz".index(axis[-1])] = -1.0 if axis.startswith("-") else 1.0
    return out


def axis_name(vec: Any) -> str:
    v = np.asarray(vec, dtype=np.float64)
    k = int(np.argmax(np.abs(v)))
    return ("-" if v[k] < 0 else "") + "xyz"[k]


def check_up(up: str | None) -> str | None:
    if up is None or up == "auto":
        return None
    up = up[1:] if up.startswith("+") else up
    if up not in UP_AXES:
        raise ValueError(f"up: expected one of {', '.join(UP_AXES)} or auto, found {up!r}")
    return up


def check_view(view: str | None) -> str | None:
    if view is None:
        return None
    if view not in VIEWS:
        raise ValueError(f"view: expected one of {', '.join(VIEWS)}, found {view!r}")
    return view


def check_fill(fill: float | None) -> float | None:
    if fill is None:
        return None
    try:
        value = float(fill)
    except (TypeError, ValueError):
        raise ValueError(f"fill: expected a number in (0, {FILL_MAX:g}], found {fill!r}") from None
    if not 0.0 < value <= FILL_MAX:
        raise ValueError(f"fill: expected a share of the picture's shorter side in (0, {FILL_MAX:g}] (0.85: 85%), "
                         f"found {fill!r}")
    return value


def up_rotation(up: str) -> np.ndarray:
    """4x4 rotation taking the axis `up` to +Y: z: -90 degrees about X (+Z -> +Y, +Y -> -Z: Blender's
    -Y front becomes +Z, glTF's); x: +90 degrees about Z (+X -> +Y, +Y -> -X); y: identity; -y: 180 degrees
    about Z (the front +Z kept); -z: +90 degrees about X (+Y becomes the front); -x: -90 degrees about Z."""
    m = np.eye(4)
    table = {"z": [[1, 0, 0], [0, 0, 1], [0, -1, 0]], "x": [[0, -1, 0], [1, 0, 0], [0, 0, 1]],
             "-y": [[-1, 0, 0], [0, -1, 0], [0, 0, 1]], "-z": [[1, 0, 0], [0, 0, -1], [0, 1, 0]],
             "-x": [[0, 1, 0], [-1, 0, 0], [0, 0, 1]]}
    up = up[1:] if up.startswith("+") else up
    if up in table:
        m[:3, :3] = table[up]
    elif up != "y":
        raise ValueError(f"up: expected one of {', '.join(SIGNED_AXES)}, found {up!r}")
    return m


def convention(suffix: str) -> tuple[str, np.ndarray]:
    """(up axis, front direction in the file's coordinates) of a file format."""
    if suffix.lower() in Z_UP_FORMATS:
        return "z", np.array([0.0, -1.0, 0.0])
    return "y", np.array([0.0, 0.0, 1.0])


def used_vertices(vertices: Any, faces: Any) -> np.ndarray:
    """The vertices faces use (all of them where there are no faces)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if len(f) == 0:
        return v
    used = np.zeros(len(v), bool)
    used[f.ravel()] = True
    return v[used]


def _faces(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area2 = np.linalg.norm(cross, axis=1)
    n = np.divide(cross, area2[:, None], out=np.zeros_like(cross), where=area2[:, None] > 0)
    return n, area2 / 2.0


def base_shares(vertices: Any, faces: Any, axes: tuple[str, ...] = SIGNED_AXES) -> dict[str, float]:
    """Per signed axis: the area of the down-facing faces in the lowest BASE_BAND of the extent along it, over
    the box's footprint across it (1.0: a full flat bottom). Only the vertices faces use count."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    out = dict.fromkeys(axes, 0.0)
    if len(f) == 0:
        return out
    u = used_vertices(v, f)
    lo, hi = u.min(axis=0), u.max(axis=0)
    ext = hi - lo
    n, area = _faces(v, f)
    corner_lo, corner_hi = v[f].min(axis=1), v[f].max(axis=1)
    for axis in axes:
        k, sign = "xyz".index(axis[-1]), (-1.0 if axis.startswith("-") else 1.0)
        others = [j for j in range(3) if j != k]
        footprint = float(ext[others[0]] * ext[others[1]])
        if not footprint > 0.0 or not ext[k] > 0.0:
            continue
        if sign > 0:
            low = corner_hi[:, k] <= lo[k] + BASE_BAND * ext[k]
        else:
            low = corner_lo[:, k] >= hi[k] - BASE_BAND * ext[k]
        down = -sign * n[:, k] >= BASE_COS
        out[axis] = float(area[low & down].sum()) / footprint
    return out


def base_share(vertices: Any, faces: Any, axis: int | str) -> float:
    """`base_shares` of one axis (an index: the positive axis; or a signed name such as '-z')."""
    name = axis if isinstance(axis, str) else "xyz"[int(axis)]
    name = name[1:] if name.startswith("+") else name
    return base_shares(vertices, faces, (name,))[name]


def surface_samples(vertices: Any, faces: Any, n: int = 6000, seed: int = 0) -> np.ndarray:
    """`n` points spread over the surface by area (fixed seed: the same mesh, the same points)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if len(f) == 0:
        return v.copy()
    _, area = _faces(v, f)
    total = float(area.sum())
    if not total > 0.0:
        return used_vertices(v, f)
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


def mirror_distance(points: np.ndarray, axis: int, scale: float) -> float:
    """Mean distance from the mirror image of each point across the mid-plane (through the mean) perpendicular to
    `axis` to the nearest point, over `scale`: about the samples' spacing for a mirror-symmetric surface, more the
    more the surface differs from its mirror image (a finer measure than `asymmetry`, which counts only points
    whose image is farther than 4%: a nose, toes or a tail count here)."""
    from scipy.spatial import cKDTree

    mirrored = points.copy()
    mirrored[:, axis] = 2.0 * float(points[:, axis].mean()) - mirrored[:, axis]
    d, _ = cKDTree(points).query(mirrored, k=1)
    return float(d.mean()) / scale


def mirror_plane(points: np.ndarray, scale: float, axes: tuple[int, ...] = (0, 1, 2),
                 principal: bool = True, off: float | None = None) -> int | None:
    """Of `axes`, the one whose mid-plane is the surface's (`points`) mirror plane: its `mirror_distance` at most
    1 / MIRROR_RATIO of every other's, of the axes along which the surface is not thin (under THIN of the largest
    extent along `axes`: a flat or slender subject mirrors itself across its thickness whatever it shows), and
    (`principal`) of the principal planes' (`off_axis_mirror`, or `off` where found already); None when none is,
    or fewer than two axes are not thin."""
    ext = np.ptp(points, axis=0)
    top = max(float(ext[k]) for k in axes)
    kept = [k for k in axes if ext[k] >= THIN * top]
    if len(kept) < 2:
        return None
    d = {k: mirror_distance(points, k, scale) for k in kept}
    best = min(kept, key=d.__getitem__)
    if not all(MIRROR_RATIO * d[best] <= d[k] for k in kept if k != best):
        return None
    if principal and MIRROR_RATIO * (off_axis_mirror(points, scale) if off is None else off) <= d[best]:
        return None
    return best


def plane_distance(points: np.ndarray, normal: np.ndarray, scale: float) -> float:
    """`mirror_distance` across the plane through the points' mean with unit normal `normal` (any direction)."""
    from scipy.spatial import cKDTree

    n = np.asarray(normal, dtype=np.float64)
    side = (points - points.mean(axis=0)) @ n
    d, _ = cKDTree(points).query(points - 2.0 * side[:, None] * n, k=1)
    return float(d.mean()) / scale


def off_axis_mirror(points: np.ndarray, scale: float) -> float:
    """The smallest `plane_distance` across the planes whose normals are the principal axes of `points` (a mirror
    plane's normal is one: reflection leaves the covariance unchanged) that lie more than OFF_AXIS_DEG from every
    coordinate axis; inf when none does. An axis-aligned mesh's principal axes are its axes, whose mid-planes
    `mirror_plane` weighs itself (or leaves out, the surface being thin along them); a mesh turned about its up by
    other than a quarter turn, or tilted a few degrees, has its mirror plane, or the broad plane of a flat
    cut-out, among these, and then an axis mid-plane that mirrors the surface less badly than the others is not
    its mirror plane (a box robot turned 30 degrees, whose top and bottom halves mirror each other roughly; a rock
    tilted 7 degrees from its nearest plane of symmetry)."""
    return principal_mirror(points, scale)[0]


def principal_mirror(points: np.ndarray, scale: float) -> tuple[float, np.ndarray | None]:
    """(`off_axis_mirror`, the unit normal of that plane or None)."""
    c = points - points.mean(axis=0)
    _, vecs = np.linalg.eigh(c.T @ c)
    best, normal = math.inf, None
    for k in range(3):
        if float(np.abs(vecs[:, k]).max()) < math.cos(math.radians(OFF_AXIS_DEG)):
            d = plane_distance(points, vecs[:, k], scale)
            if d < best:
                best, normal = d, vecs[:, k]
    return best, normal


def turned_mirror(points: np.ndarray, scale: float,
                  found: tuple[float, np.ndarray | None] | None = None) -> np.ndarray | None:
    """The unit normal of the mirror plane of a mesh turned off the axes: the principal plane (`principal_mirror`,
    or `found` where found already) that mirrors the surface MIRROR_RATIO times more closely than every axis
    mid-plane; None when there is none."""
    d, normal = principal_mirror(points, scale) if found is None else found
    if normal is None or MIRROR_RATIO * d > min(mirror_distance(points, k, scale) for k in range(3)):
        return None
    return normal


def clean_mirror(points: np.ndarray, scale: float, asym: Any, off: float | None = None) -> int | None:
    """`mirror_axis` of the `asymmetry` values, unless a principal plane (`off_axis_mirror`, or `off` where found
    already) mirrors the surface MIRROR_RATIO times more closely than that axis's mid-plane."""
    k = mirror_axis(asym)
    if k is None:
        return None
    if MIRROR_RATIO * (off_axis_mirror(points, scale) if off is None else off) <= mirror_distance(points, k, scale):
        return None
    return k


def upright_mirror(points: np.ndarray, scale: float) -> int | None:
    """The mirror plane of a stood-up (Y-up) surface, left to right: `mirror_plane` of its horizontal axes, 0 (X)
    or 2 (Z), or None. The principal planes are not weighed here: of a mesh turned about its up off the axes, or
    of one that is no mirror image of itself (a grand piano), the horizontal axis that mirrors it more closely
    still says along which axis it is seen best."""
    return mirror_plane(points, scale, (0, 2), principal=False)


def mirror_axis(asym: Any) -> int | None:
    """The axis whose mid-plane is the one clean mirror plane (`asymmetry` values per axis), or None."""
    a = np.asarray(asym, dtype=np.float64)
    k = int(np.argmin(a))
    others = np.delete(a, k)
    if a[k] <= MIRROR_MAX and (others >= a[k] + MIRROR_GAP).all():
        return k
    return None


def surface_centroid(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """The centroid of the surface (a uniform shell): the centre of mass an open scan still has."""
    _, area = _faces(v, f)
    total = float(area.sum())
    if not total > 0.0:
        return used_vertices(v, f).mean(axis=0)
    return (v[f].mean(axis=1) * area[:, None]).sum(axis=0) / total


def _solid_angles(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Solid angle of each triangle (a, b, c) seen from the origin (Van Oosterom and Strackee's formula)."""
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
    det = np.abs(np.einsum("ij,ij->i", a, np.cross(b, c)))
    dot = np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", a, c) * lb + np.einsum("ij,ij->i", b, c) * la
    return 2.0 * np.arctan2(det, la * lb * lc + dot)


def resting_poses(vertices: Any, faces: Any) -> tuple[np.ndarray, np.ndarray]:
    """(up directions (k, 3), probabilities (k,)) of the stable resting poses of the mesh on a plane: the
    faces of its convex hull (coplanar ones merged) over which the surface centroid lies, each weighted by
    the solid angle it subtends from the centroid, normalised over the stable ones."""
    from scipy.spatial import ConvexHull, QhullError

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    pts = used_vertices(v, f)
    if len(f) == 0 or len(pts) < 4:
        return np.zeros((0, 3)), np.zeros(0)
    try:
        hull = ConvexHull(pts)
    except (QhullError, ValueError):
        return np.zeros((0, 3)), np.zeros(0)  # flat or degenerate: no volume to rest
    com = surface_centroid(v, f)
    n, off = hull.equations[:, :3], hull.equations[:, 3]
    scale = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))) or 1.0
    key = np.round(np.c_[n * 200.0, off / scale * 200.0]).astype(np.int64)
    _, group = np.unique(key, axis=0, return_inverse=True)
    group = np.asarray(group).ravel()
    a, b, c = (pts[hull.simplices[:, j]] for j in range(3))
    omega = _solid_angles(a - com, b - com, c - com)
    q = com - (n @ com + off)[:, None] * n  # the centroid dropped onto each face's plane
    e0, e1, e2 = b - a, c - a, q - a
    d00, d01, d11 = (e0 * e0).sum(1), (e0 * e1).sum(1), (e1 * e1).sum(1)
    d20, d21 = (e2 * e0).sum(1), (e2 * e1).sum(1)
    den = d00 * d11 - d01 * d01
    ok = den > 0
    den = np.where(ok, den, 1.0)
    y, z = (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den
    inside = ok & (y >= -1e-9) & (z >= -1e-9) & (y + z <= 1.0 + 1e-9)
    k = int(group.max()) + 1
    stable = np.bincount(group, inside.astype(np.float64), minlength=k) > 0
    weight = np.bincount(group, omega, minlength=k) * stable
    normal = np.zeros((k, 3))
    np.add.at(normal, group, n * omega[:, None])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    total = float(weight.sum())
    if not total > 0.0:
        return np.zeros((0, 3)), np.zeros(0)
    keep = weight > 0
    return -normal[keep], weight[keep] / total


@dataclass(frozen=True)
class Stance:
    """How a mesh stands with a given axis up (`stance`): its `feet` (separate contacts), how far its centre of
    mass lies inside their polygon (`margin`, a share of the diagonal; negative outside), whether they stay
    apart up to LEG_HEIGHT of the height (`legs`), and the feet's contact samples (`contacts`, (k, 3); empty
    where there are fewer than two feet)."""

    feet: int
    margin: float
    legs: bool
    contacts: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), compare=False, repr=False)

    @property
    def stands(self) -> bool:
        return self.feet >= 2 and self.legs and self.margin >= LEG_MARGIN


def _groups(points: np.ndarray, radius: float) -> np.ndarray:
    """Labels of the groups of `points` linked by steps of at most `radius` (single linkage)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = len(points)
    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def stance(points: np.ndarray, com: np.ndarray, up: str, diag: float) -> Stance:
    """How the surface (`points`, samples) stands with the signed axis `up` up: the samples in the lowest LEG_BAND
    of its extent are the contacts, grouped into feet (links of LEG_LINK of the diagonal; groups under LEG_MIN of
    the contacts dropped); the centre of mass `com` must project inside the feet's convex hull, and the feet
    must lie in separate groups of the samples up to LEG_HEIGHT of the height (legs, wheels: not the bumps of a
    flank lying on the ground)."""
    from scipy.spatial import ConvexHull, QhullError

    a = axis_vector(up)
    h = points @ a
    lo, ext = float(h.min()), float(np.ptp(h))
    if not ext > 0.0 or not diag > 0.0:
        return Stance(0, -1.0, False)
    low = np.nonzero(h <= lo + LEG_BAND * ext)[0]
    foot = _groups(points[low], LEG_LINK * diag)
    sizes = np.bincount(foot)
    feet = np.nonzero(sizes >= max(3, LEG_MIN * len(low)))[0]
    if len(feet) < 2:
        return Stance(len(feet), -1.0, False)
    plane = [k for k in range(3) if abs(a[k]) < 0.5]
    contacts = points[low[np.isin(foot, feet)]]
    contact = contacts[:, plane]
    try:
        hull = ConvexHull(contact)
    except (QhullError, ValueError):
        return Stance(len(feet), -1.0, False, contacts)
    margin = float(-(hull.equations[:, :2] @ com[plane] + hull.equations[:, 2]).max()) / diag
    column = np.nonzero(h <= lo + LEG_HEIGHT * ext)[0]
    groups = _groups(points[column], LEG_LINK * diag)
    where = np.searchsorted(column, low)  # low is a subset of column, both sorted
    apart = len({int(groups[where[np.nonzero(foot == k)[0][0]]]) for k in feet})
    return Stance(len(feet), margin, apart >= 2, contacts)


def resting_support(ups: np.ndarray, probs: np.ndarray, axis: str) -> float:
    """The probability of the resting poses whose up lies within ~20 degrees of the signed `axis`."""
    if len(probs) == 0:
        return 0.0
    return float(probs[ups @ axis_vector(axis) >= POSE_COS].sum())


def feature_lines(vertices: Any, faces: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ends a (k, 3), ends b (k, 3), the two faces' unit normals (k, 2, 3)) of the mesh's feature lines: the
    edges (vertices welded at 1e-6 of the diagonal) shared by exactly two non-degenerate faces that meet at
    more than FEATURE_DEG. A neighbour wound the other way has its normal turned, so an inconsistently wound
    file reads as if it were consistent."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(f) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 2, 3))
    u = used_vertices(v, f)
    lo = np.array([u[:, k].min() for k in range(3)])
    diag = float(np.linalg.norm(np.array([u[:, k].max() for k in range(3)]) - lo)) or 1.0
    p0 = v[f[:, 0]]
    cross = np.cross(v[f[:, 1]] - p0, v[f[:, 2]] - p0)
    area2 = np.sqrt(np.einsum("ij,ij->i", cross, cross))
    cells = np.round((v - lo) / (1e-6 * diag)).clip(0, (1 << 20) - 1).astype(np.int64)  # 20 bits an axis
    _, wid = np.unique((cells[:, 0] << 40) | (cells[:, 1] << 20) | cells[:, 2], return_inverse=True)
    wf = wid.ravel()[f]
    good = (area2 > 1e-14 * diag * diag) & (wf[:, 0] != wf[:, 1]) & (wf[:, 1] != wf[:, 2]) & (wf[:, 2] != wf[:, 0])
    keep = np.flatnonzero(good)
    n = cross[keep] / area2[keep, None]
    wf = wf[keep]
    a, b = wf.ravel(), wf[:, [1, 2, 0]].ravel()  # half-edge 3 * face + corner runs a -> b
    key = np.minimum(a, b) * (int(wf.max()) + 1) + np.maximum(a, b)
    srt = np.argsort(key)
    key = key[srt]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1], True])
    two = start[:-1][np.diff(start) == 2]
    h1, h2 = srt[two], srt[two + 1]
    n1, n2 = np.take(n, h1 // 3, axis=0), np.take(n, h2 // 3, axis=0)
    n2 *= np.where(a[h1] == b[h2], 1.0, -1.0)[:, None]  # consistent winding runs the shared edge both ways
    sharp = np.einsum("ij,ij->i", n1, n2) < math.cos(math.radians(FEATURE_DEG))
    h1 = h1[sharp]
    face, corner = keep[h1 // 3], h1 % 3
    return v[f[face, corner]], v[f[face, (corner + 1) % 3]], np.stack([n1[sharp], n2[sharp]], axis=1)


def _zbuffer(p2: np.ndarray, depth: np.ndarray, f: np.ndarray, res: int) -> tuple[np.ndarray, np.ndarray]:
    """(largest, smallest) depth per pixel (res * res, row-major; -inf / +inf where empty) of the triangles
    `f` over the points `p2` (in pixels, pixel (i, j) covering [i, i + 1) x [j, j + 1)): every pixel centre
    inside a triangle, and every vertex (a triangle smaller than a pixel covers no centre)."""
    zmax = np.full(res * res, -np.inf)
    zmin = np.full(res * res, np.inf)
    pix = np.clip(np.floor(p2).astype(np.int64), 0, res - 1)
    at = pix[:, 1] * res + pix[:, 0]
    np.maximum.at(zmax, at, depth)
    np.minimum.at(zmin, at, depth)
    t = p2[f]
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    lo = np.ceil(np.minimum(np.minimum(a, b), c) - 0.5).astype(np.int64)  # not .min(axis=1): 20x slower
    hi = np.floor(np.maximum(np.maximum(a, b), c) - 0.5).astype(np.int64)
    nx, ny = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0), np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    count = nx * ny
    big = np.flatnonzero(count > 0)
    ends = np.cumsum(count[big])
    first = 0
    while first < len(big):  # at most about 2**20 (triangle, pixel) pairs at a time: a file of long slivers
        last = max(int(np.searchsorted(ends, (ends[first - 1] if first else 0) + (1 << 20), "right")), first + 1)
        tri = big[first:last]
        first = last
        c = count[tri]
        tri = np.repeat(tri, c)
        k = np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c)
        ix, iy = lo[tri, 0] + k % nx[tri], lo[tri, 1] + k // nx[tri]
        p0, e1, e2 = t[tri, 0], t[tri, 1] - t[tri, 0], t[tri, 2] - t[tri, 0]
        qx, qy = ix + 0.5 - p0[:, 0], iy + 0.5 - p0[:, 1]
        den = e1[:, 0] * e2[:, 1] - e2[:, 0] * e1[:, 1]
        ok = np.abs(den) > 1e-12
        den = np.where(ok, den, 1.0)
        s, r = (qx * e2[:, 1] - e2[:, 0] * qy) / den, (e1[:, 0] * qy - qx * e1[:, 1]) / den
        inside = ok & (s >= -1e-9) & (r >= -1e-9) & (s + r <= 1.0 + 1e-9) & (ix >= 0) & (iy >= 0) & (ix < res) \
            & (iy < res)
        dz = depth[f[tri[inside]]]
        d = dz[:, 0] + s[inside] * (dz[:, 1] - dz[:, 0]) + r[inside] * (dz[:, 2] - dz[:, 0])
        at = iy[inside] * res + ix[inside]
        np.maximum.at(zmax, at, d)
        np.minimum.at(zmin, at, d)
    return zmax, zmin


def visible_detail(vertices: Any, faces: Any, axis: int, lines: tuple[np.ndarray, np.ndarray, np.ndarray] | None
                   = None) -> tuple[float, float, float]:
    """(detail seen from +axis, from -axis, the picture's width), looking along the axis (orthographic): the
    projected length of the feature lines (`feature_lines`) whose two faces are both turned toward the viewer or
    both away (a silhouette edge, the same from both ends, is left out), times the share of the line that is in
    front in a DETAIL_RES z-buffer of the surface (the share of points along it no farther behind the nearest
    surface than 1.5 pixels, plus the slope of its face). Lengths are in the mesh's units."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(f) == 0:
        return 0.0, 0.0, 0.0
    a, b, nn = feature_lines(v, f) if lines is None else lines
    others = [j for j in range(3) if j != axis]
    u = used_vertices(v, f)
    lo = u.min(axis=0)
    width = float(max(np.ptp(u[:, others[0]]), np.ptp(u[:, others[1]])))
    if not width > 0.0 or len(a) == 0:
        return 0.0, 0.0, width
    px = width / DETAIL_RES
    zmax, zmin = _zbuffer((v[:, others] - lo[others]) / px, v[:, axis], f, DETAIL_RES)
    nd = nn[:, :, axis]
    keep = nd[:, 0] * nd[:, 1] >= -1e-6  # not a silhouette edge
    a, b, nd = a[keep], b[keep], nd[keep]
    length = np.linalg.norm((b - a)[:, others], axis=1)
    m = np.clip(np.ceil(length / px), 1, 16).astype(np.int64)
    line = np.repeat(np.arange(len(a)), m)
    t = (np.arange(int(m.sum())) - np.repeat(np.cumsum(m) - m, m) + 0.5) / np.repeat(m, m)
    p = a[line] + t[:, None] * (b - a)[line]
    pix = np.clip(np.floor((p[:, others] - lo[others]) / px).astype(np.int64), 0, DETAIL_RES - 1)
    at = pix[:, 1] * DETAIL_RES + pix[:, 0]
    facing = np.abs(nd).max(axis=1)[line]
    tol = px * (1.5 + np.minimum(np.sqrt(np.maximum(1.0 - facing ** 2, 0.0)) / np.maximum(facing, 0.1), 10.0))
    out = []
    for seen in (p[:, axis] >= zmax[at] - tol, p[:, axis] <= zmin[at] + tol):
        share = np.bincount(line, seen.astype(np.float64), minlength=len(a)) / m
        out.append(float((length * share).sum()))
    return out[0], out[1], width


@dataclass
class FrontChoice:
    """The front `front_choice` picks: `front` (a unit axis in the stood-up, Y-up frame), the feature-line length
    seen from the + and - ends of its axis, the picture's width, and whether the axis is X because the mesh
    is mirror-symmetric across Z."""

    front: np.ndarray
    plus: float = 0.0
    minus: float = 0.0
    width: float = 0.0
    across_z: bool = False
    feet: int = 0  # the legs rule (`head_ends`): the feet it stands on, 0 where it did not decide
    beyond_plus: float = 0.0  # ... the share of the surface past the feet at the + and - ends
    beyond_minus: float = 0.0
    legs_axis: bool = False  # the legs rule chose the axis: it decided across the mirror's axis, not along it

    @property
    def detail_axis(self) -> int:
        """The axis the mirror plane chose, along which the feature lines were measured."""
        return 0 if self.across_z else 2

    @property
    def axis(self) -> int:
        return 2 - self.detail_axis if self.legs_axis else self.detail_axis

    def ratio(self) -> float:
        """How many times the feature lines of the other end of the mirror's axis the + end, or the - end where the
        front is the - end of that axis, shows (with the floor)."""
        floor = DETAIL_FLOOR * self.width
        mine, other = (self.plus, self.minus) if self.front[self.detail_axis] >= 0 else (self.minus, self.plus)
        return (mine + floor) / (other + floor) if other + floor > 0.0 else 1.0

    def encode(self) -> np.ndarray:
        return np.r_[self.front, self.plus, self.minus, self.width, float(self.across_z), self.feet,
                     self.beyond_plus, self.beyond_minus, float(self.legs_axis)]

    @classmethod
    def decode(cls, a: Any) -> FrontChoice:
        a = np.asarray(a, dtype=np.float64).ravel()
        if len(a) == 3:
            return cls(a.copy())
        extra = (int(a[7]), float(a[8]), float(a[9]), *((bool(a[10]),) if len(a) >= 11 else ())) \
            if len(a) >= 10 else ()
        return cls(a[:3].copy(), float(a[3]), float(a[4]), float(a[5]), bool(a[6]), *extra)

    def note(self, to_file: Any = None) -> str | None:
        """The one line that says the front is not the file's +Z (None when it is): where it is and why, in
        the file's axes (`to_file`: the rotation that stood the mesh up, `up_rotation(up)[:3, :3]`)."""
        rot = np.eye(3) if to_file is None else np.asarray(to_file, dtype=np.float64)[:3, :3]
        if np.allclose(self.front, (0.0, 0.0, 1.0)):
            return None
        toward, other = (("" if n.startswith("-") else "+") + n for n in (axis_name(rot.T @ self.front),
                                                                         axis_name(rot.T @ -self.front)))
        r = self.ratio()
        if self.feet:
            mine, theirs = ((self.beyond_plus, self.beyond_minus) if self.front[self.axis] > 0 else
                            (self.beyond_minus, self.beyond_plus))
            why = (f"it stands on {self.feet} feet and {mine:.0%} of its surface reaches past them toward {toward}, "
                   f"{theirs:.0%} toward {other} (a head)")
            if self.legs_axis:
                along = axis_name(rot.T[:, self.detail_axis])[-1]
                keep = axis_name(rot.T @ np.array([0.0, 0.0, 1.0]))
                return (f"seen from {toward}: {why}, and neither end of {along} stands out so; `--front {keep}` keeps "
                        f"the file's front")
            if self.across_z:
                return (f"seen with its front toward {toward}: it is mirror-symmetric across "
                        f"{axis_name(rot.T[:, 2])[-1]}, which runs left to right; {why}; `--view back` looks at "
                        f"{other}")
            return f"seen from {toward}: {why}; `--view back` looks at the file's front"
        if self.across_z:
            why = (f"{toward} shows {r:.1f}x the feature lines of {other}" if r >= DETAIL_MARGIN else
                   f"its feature lines do not say which end ({r:.1f}x those of {other})")
            return (f"seen with its front toward {toward}: it is mirror-symmetric across {axis_name(rot.T[:, 2])[-1]}, "
                    f"which runs left to right; {why}; `--view back` looks at {other}")
        return (f"seen from {toward}: {r:.1f}x the feature lines of the file's front ({other}); `--view back` looks "
                f"at the file's front")


def front_choice(vertices: Any, faces: Any, mirror: int | None = -1) -> FrontChoice:
    """The front of a stood-up (Y-up) mesh by the rule in the module docstring: along X when the upright mirror
    plane (`upright_mirror`) is across Z or, where that does not decide, `mirror` (the axis of the clean mirror
    plane, `mirror_axis`; -1: find it) is Z, else along Z; the end of that axis the legs rule picks (`head_ends`), or
    where it picks none there, the end it picks along the other horizontal axis; else the - end of the first axis
    when it shows at least DETAIL_MARGIN times the feature lines of the + end (`visible_detail`), else the + end."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if len(f) == 0 or len(v) == 0:
        return FrontChoice(np.array([0.0, 0.0, 1.0]))
    u = used_vertices(v, f)
    scale = float(np.linalg.norm(u.max(axis=0) - u.min(axis=0))) or 1.0
    p = surface_samples(v, f)
    upright = upright_mirror(p, scale)
    if upright is not None:
        mirror = upright
    elif mirror == -1:
        mirror = mirror_axis([asymmetry(p, k, scale) for k in range(3)])
    across_z = mirror == 2
    axis = 0 if across_z else 2
    plus, minus, width = visible_detail(v, f, axis)
    front = np.zeros(3)
    front[axis] = 1.0
    choice = FrontChoice(front, plus, minus, width, across_z)
    head, other = head_ends(v, f, (axis, 2 - axis), scale)
    if head is None and other is not None:  # the legs say nothing along the mirror's axis, but do across it
        head, choice.legs_axis = other, True
        choice.front = np.zeros(3)
    if head is not None:
        sign, choice.feet, choice.beyond_plus, choice.beyond_minus = head
        choice.front[choice.axis] = sign
        return choice
    floor = DETAIL_FLOOR * width
    if minus + floor >= DETAIL_MARGIN * (plus + floor) and minus > 0.0:
        choice.front[axis] = -1.0
    return choice


def axis_facing(vertices: np.ndarray, faces: np.ndarray) -> float:
    """The share of the surface area whose face normals lie within HEAD_BUILT_DEG of one of the axes."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area = np.linalg.norm(n, axis=1)
    ok = area > 0.0
    if not ok.any():
        return 0.0
    along = np.abs(n[ok]).max(axis=1) >= math.cos(math.radians(HEAD_BUILT_DEG)) * area[ok]
    return float(area[ok][along].sum() / area[ok].sum())


def head_ends(vertices: np.ndarray, faces: np.ndarray, axes: tuple[int, ...], diag: float
              ) -> list[tuple[float, int, float, float] | None]:
    """The front's legs rule on a stood-up (Y-up) mesh, along each of `axes`: where it stands on HEAD_FEET or more
    feet (`stance`), the shares of its surface (LEG_SAMPLES samples) that reach more than HEAD_GAP of the diagonal
    past the feet's contacts toward the + and - ends of the axis; the end with at least HEAD_SHARE and HEAD_RATIO
    times the other's share is the front (an animal's head and neck stand out beyond its forelegs further than its
    rump beyond its hind legs). Not for a built thing, HEAD_BUILT of whose surface faces along the axes
    (`axis_facing`): a bed's headboard, a chair's back or a tricycle's body stand out beyond its legs or wheels at
    its back. For each axis (sign of that end, feet, share +, share -), or None where the rule does not decide."""
    if axis_facing(vertices, faces) >= HEAD_BUILT:
        return [None] * len(axes)
    p = surface_samples(vertices, faces, LEG_SAMPLES)
    st = stance(p, surface_centroid(vertices, faces), "y", diag)
    if not st.stands or st.feet < HEAD_FEET:
        return [None] * len(axes)
    gap = HEAD_GAP * diag
    out: list[tuple[float, int, float, float] | None] = []
    for axis in axes:
        c = st.contacts[:, axis]
        plus = float(np.mean(p[:, axis] > c.max() + gap))
        minus = float(np.mean(p[:, axis] < c.min() - gap))
        if plus >= HEAD_SHARE and plus >= HEAD_RATIO * minus:
            out.append((1.0, st.feet, plus, minus))
        elif minus >= HEAD_SHARE and minus >= HEAD_RATIO * plus:
            out.append((-1.0, st.feet, plus, minus))
        else:
            out.append(None)
    return out


@dataclass
class Orientation:
    """The result of `orient`: `up` (a signed axis of the file), `front` (a unit vector in the stood-up,
    Y-up frame) and the lines that say what overrode the file's convention."""

    up: str
    front: np.ndarray
    notes: list[str] = field(default_factory=list)
    evidence: dict[str, Any] = field(default_factory=dict)
    rule: str = ""  # what overrode the convention's up: "legs", "mirror", "base" ("": nothing)
    feet: int = 0  # the feet it stands on (rule "legs")

    def encode(self) -> np.ndarray:
        return np.r_[SIGNED_AXES.index(self.up), self.front]


def orient(vertices: Any, faces: Any, suffix: str = "", up: str | None = None, front: bool = True) -> Orientation:
    """The up axis and the front of a mesh file by the rules in the module docstring (`up`: given by the user,
    only the front is found; `front` False: only the up axis, the front left +Z)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    conv_up, _ = convention(suffix)
    notes: list[str] = []
    evidence: dict[str, Any] = {}
    if len(f) == 0 or len(v) == 0:
        return Orientation(up or conv_up, np.array([0.0, 0.0, 1.0]))
    p = surface_samples(v, f)
    u = used_vertices(v, f)
    scale = float(np.linalg.norm(u.max(axis=0) - u.min(axis=0))) or 1.0
    asym = [asymmetry(p, k, scale) for k in range(3)]
    principal = principal_mirror(p, scale)  # found once for the three rules below that weigh it
    mirror = mirror_plane(p, scale, off=principal[0])
    if mirror is None:
        mirror = clean_mirror(p, scale, asym, principal[0])
    evidence["asymmetry"] = [round(a, 3) for a in asym]
    evidence["mirror"] = None if mirror is None else "xyz"[mirror]
    chosen = up
    rule, feet = "", 0
    if chosen is None:
        chosen = conv_up
        ups, probs = resting_poses(v, f)
        rest = {a: resting_support(ups, probs, a) for a in SIGNED_AXES}
        flat = base_shares(v, f)
        evidence["rest"] = {a: round(x, 3) for a, x in rest.items()}
        evidence["base"] = {a: round(x, 3) for a, x in flat.items()}
        dense = surface_samples(v, f, LEG_SAMPLES)
        com = surface_centroid(v, f)
        across = set() if mirror is None else {"xyz"[mirror]}
        turned = turned_mirror(p, scale, principal) if mirror is None else None
        if turned is not None:  # turned off the axes: the axes near its mirror plane's normal run left to right
            across = {"xyz"[k] for k in range(3) if abs(float(turned[k])) >= math.cos(math.radians(TURNED_DEG))}
            evidence["turned_mirror"] = [round(float(x), 3) for x in turned]
        stances = {a: stance(dense, com, a, scale) for a in SIGNED_AXES if a[-1] not in across}
        standing = [a for a, st in stances.items() if st.stands]
        evidence["feet"] = {a: st.feet for a, st in stances.items() if st.stands}
        rivals = [a for a in SIGNED_AXES if a not in standing and flat[a] >= BASE_SHARE and rest[a] > 0.0
                  and not (len(standing) == 1 and a[-1] == standing[0][-1])]
        if len(standing) == 1 and not rivals:
            if standing[0] != conv_up:
                chosen, rule, feet = standing[0], "legs", stances[standing[0]].feet
        elif mirror is not None and "xyz"[mirror] == conv_up:
            alt = "y" if conv_up == "z" else "z"
            other = next(a for a in "xyz" if a not in (conv_up, alt))
            axis = alt if max(rest[alt], rest["-" + alt]) > 0.0 or max(rest[other], rest["-" + other]) == 0.0 \
                else other
            score = {s: rest[s] + flat[s] for s in (axis, "-" + axis)}
            chosen = axis if score[axis] >= score["-" + axis] else "-" + axis
            rule = "mirror"
        else:
            own = flat[conv_up]
            best = max((a for a in SIGNED_AXES if a != conv_up and (mirror is None or a[-1] != "xyz"[mirror])),
                       key=lambda a: flat[a])
            if flat[best] >= BASE_SHARE and flat[best] >= BASE_RATIO * own and rest[best] > 0.0 \
                    and rest[conv_up] == 0.0:
                chosen, rule = best, "base"
        if rule:
            notes.append(up_note(chosen, conv_up, rule, feet))
    if not front:
        return Orientation(chosen, np.array([0.0, 0.0, 1.0]), notes, evidence, rule, feet)
    # the front, on the stood-up mesh
    rot = up_rotation(chosen)[:3, :3]
    turned_asym = [asym["xyz".index(axis_name(rot.T[:, k])[-1])] for k in range(3)]
    choice = front_choice(v @ rot.T, f, mirror_axis(turned_asym))
    evidence["detail"] = {"+" + "xyz"[choice.detail_axis]: round(choice.plus, 6), "-" + "xyz"[choice.detail_axis]:
                          round(choice.minus, 6), "width": round(choice.width, 6), "ratio": round(choice.ratio(), 3)}
    note = choice.note(rot)
    if note:
        notes.append(note)
    return Orientation(chosen, choice.front, notes, evidence, rule, feet)


UP_RULES = ("", "legs", "mirror", "base")


def up_note(up: str, conv_up: str, rule: str, feet: int = 0) -> str:
    """The line that says why `orient` stood a mesh up along `up` rather than the convention's `conv_up`."""
    why = {"legs": f"it stands on {feet} feet (legs, wheels) that way and on nothing else",
           "mirror": f"the mesh is mirror-symmetric across {conv_up}, so {conv_up} runs left to right, not up",
           "base": "a flat base"}[rule]
    return f"stood up along {up}: {why}; `--up {conv_up}` keeps the file's axis"


def up_choice(vertices: Any, faces: Any, suffix: str = "") -> tuple[str, str, int]:
    """(the up axis `orient` finds, the rule that chose it (UP_RULES; "" for the convention), the feet it stands on
    (rule "legs"))."""
    o = orient(vertices, faces, suffix, front=False)
    return o.up, o.rule, o.feet


def detect_up(vertices: Any, faces: Any, suffix: str = "") -> str:
    """The up axis `orient` finds (a signed axis name: 'y', 'z', '-x', ...)."""
    return up_choice(vertices, faces, suffix)[0]


def detect_front(vertices: Any, faces: Any) -> np.ndarray:
    """The unit front direction of a Y-up mesh (+Z unless the rules in the module docstring say otherwise)."""
    return front_choice(vertices, faces).front


def broad_side(vertices: Any, faces: Any) -> np.ndarray | None:
    """The unit normal of a flat or thin subject's broad face (its thinnest principal axis, by area), or None
    when the subject is not thin (thinnest extent at least THIN of the middle one)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if len(f) == 0:
        return None
    _, area = _faces(v, f)
    total = float(area.sum())
    if not total > 0.0:
        return None
    centres = v[f].mean(axis=1)
    mean = (centres * area[:, None]).sum(axis=0) / total
    d = centres - mean
    cov = (d * area[:, None]).T @ d / total
    _, vecs = np.linalg.eigh(cov)
    u = used_vertices(v, f) - mean
    ext = (u @ vecs).max(axis=0) - (u @ vecs).min(axis=0)  # eigh sorts ascending: thinnest first
    if not ext[1] > 0.0 or ext[0] >= THIN * ext[1]:
        return None
    return vecs[:, 0]


def fit_view(points: Any, direction: Any, up: Any, fov_y_deg: float, fill: float) -> tuple[np.ndarray, np.ndarray,
                                                                                           np.ndarray]:
    """(eye, target, up) of a camera looking along -`direction` whose picture shows `points` centred, their
    projected bounding box spanning `fill` of the shorter side (the field of view's span)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    upv = np.asarray(up, dtype=np.float64)
    if np.linalg.norm(np.cross(d, upv)) < 1e-6:
        upv = np.array([0.0, 0.0, -1.0]) if d[1] > 0 else np.array([0.0, 0.0, 1.0])
    fwd = -d
    right = np.cross(fwd, upv)
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, fwd)
    lo, hi = p.min(axis=0), p.max(axis=0)
    centre = (lo + hi) / 2.0
    radius = float(np.linalg.norm(hi - lo)) / 2.0
    if not radius > 0.0:
        radius = max(float(np.abs(centre).max()) * 1e-3, 1e-3)
    t = math.tan(math.radians(fov_y_deg) / 2.0)
    goal = fill * t
    eye = centre + d * (radius / math.sin(math.atan(goal)))
    rel0 = p - centre  # projections relative to the box centre, in float64 (far-away meshes keep their shape)
    depth_c = float(np.dot(centre - eye, fwd))
    for _ in range(60):
        off = eye - centre
        z = rel0 @ fwd - off @ fwd
        z = np.maximum(z, 1e-6 * radius)
        x = (rel0 @ right - off @ right) / z
        y = (rel0 @ cam_up - off @ cam_up) / z
        xc, yc = (x.max() + x.min()) / 2.0, (y.max() + y.min()) / 2.0
        half = max(x.max() - x.min(), y.max() - y.min()) / 2.0
        depth_c = float(np.dot(centre - eye, fwd))
        if not half > 0.0:
            break
        step = right * (xc * depth_c) + cam_up * (yc * depth_c) + d * (depth_c * (half / goal - 1.0))
        # never closer than a tenth of the radius in front of the nearest point
        eye = eye + step
        near = float((rel0 @ fwd - (eye - centre) @ fwd).min())
        if near < 0.1 * radius:
            eye = eye - d * (0.1 * radius - near)
        if abs(half / goal - 1.0) < 1e-6 and abs(xc) + abs(yc) < 1e-6 * goal:
            break
    depth_c = float(np.dot(centre - eye, fwd))
    return eye, eye + fwd * depth_c, cam_up


MOTION_MIN_SHARE = 0.5  # an animated subject at its first frame spans at least this share of its still framing


def projected(points: Any, eye: Any, target: Any, up: Any) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of `points` seen from `eye` looking at `target`: tangents of the angles off the view axis (the
    image plane at distance 1; the field of view's half-span is tan(fov / 2) in these units)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3) - np.asarray(eye, dtype=np.float64)
    fwd = np.asarray(target, dtype=np.float64) - np.asarray(eye, dtype=np.float64)
    fwd = fwd / np.linalg.norm(fwd)
    right = np.cross(fwd, np.asarray(up, dtype=np.float64))
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, fwd)
    z = np.maximum(p @ fwd, 1e-12)
    return (p @ right) / z, (p @ cam_up) / z


def half_span(points: Any, eye: Any, target: Any, up: Any) -> float:
    """Half the larger side of the projected bounding box of `points` (in `projected`'s units)."""
    x, y = projected(points, eye, target, up)
    return float(max(x.max() - x.min(), y.max() - y.min())) / 2.0


def motion_view(first: Any, motion: Any, direction: Any, up: Any, fov_y_deg: float, fill: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(eye, target, up) framing an animated subject without a camera: readable at its first frame, the motion
    kept in view as far as that allows. `first`: the points the subject's faces use at the first frame;
    `motion`: points of it over the whole animation (its vertices at sampled times). The rule:

    1. `wide` = fit_view of first + motion (the whole motion centred, spanning `fill`). When the first frame's
       subject spans at least MOTION_MIN_SHARE of what it spans in its still framing (fit_view of `first`
       alone), `wide` is the view: all the motion is in the picture.
    2. Otherwise the camera stands where the first frame's subject spans exactly MOTION_MIN_SHARE of its still
       size (fit_view of `first` at fill * MOTION_MIN_SHARE, from the same direction), then slides sideways
       (the same distance and direction) toward where the centre of the motion's bounding box is seen, as far
       as the first frame's subject stays within `fill` of the picture; the motion beyond leaves the picture
       (a subject walking toward the camera may pass beside or behind it)."""
    first = np.asarray(first, dtype=np.float64).reshape(-1, 3)
    both = np.vstack([first, np.asarray(motion, dtype=np.float64).reshape(-1, 3)])
    still = fit_view(first, direction, up, fov_y_deg, fill)
    wide = fit_view(both, direction, up, fov_y_deg, fill)
    size = half_span(first, *still)
    if not size > 0.0 or half_span(first, *wide) >= MOTION_MIN_SHARE * size * (1.0 - 1e-9):
        return wide
    eye, target, cam_up = fit_view(first, direction, up, fov_y_deg, fill * MOTION_MIN_SHARE)
    limit = fill * math.tan(math.radians(fov_y_deg) / 2.0)  # the first frame's box stays within +-limit
    middle = (both.min(axis=0) + both.max(axis=0)) / 2.0
    fwd = target - eye
    depth = float(np.linalg.norm(fwd))
    fwd = fwd / depth
    right = np.cross(fwd, cam_up)
    right /= np.linalg.norm(right)
    for _ in range(20):  # a slide moves near points more than far ones: settle in a few steps
        fx, fy = projected(first, eye, target, cam_up)
        mx, my = projected(middle, eye, target, cam_up)
        shift = [min(max(float(m[0]), f.max() - limit), f.min() + limit) for f, m in ((fx, mx), (fy, my))]
        move = (right * shift[0] + np.cross(right, fwd) * shift[1]) * depth
        eye, target = eye + move, target + move
        if abs(shift[0]) + abs(shift[1]) < 1e-9 * limit:
            break
    return eye, target, cam_up


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


def face_on(normal: Any, front: Any, up: Any = (0.0, 1.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """(direction, camera up) straight at a thin subject's broad face, from the side the three-quarter view
    is on; the camera's up is the mesh's up, or the front's opposite when looking straight down."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    tq, _ = view_direction("three-quarter", front, up)
    if float(n @ tq) < 0.0:
        n = -n
    u = np.asarray(up, dtype=np.float64)
    cam_up = u - n * float(n @ u)
    if np.linalg.norm(cam_up) < 1e-3:
        cam_up = -np.asarray(front, dtype=np.float64)
    return n, cam_up / np.linalg.norm(cam_up)


def warn_notes(name: str, notes: list[str]) -> None:
    for note in notes:
        warnings.warn(f"{name}: {note}", FramingWarning, stacklevel=3)


def suffix_of(source: str | Path | None) -> str:
    return Path(str(source)).suffix.lower() if source else ""


def describe(up: str, front: np.ndarray) -> str:
    return f"up {up}, front {axis_name(front)}"


__all__ = ["DEFAULT_FILL", "MOTION_MIN_SHARE", "UP_AXES", "UP_RULES", "VIEWS", "FramingWarning", "FrontChoice",
           "Orientation", "Stance", "broad_side", "check_fill", "check_up", "check_view", "detect_front", "detect_up",
           "feature_lines", "fit_view", "front_choice", "motion_view", "orient", "stance", "up_choice", "up_note",
           "up_rotation", "view_direction", "visible_detail"]
