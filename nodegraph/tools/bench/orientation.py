"""`sketchgraph bench orientation`: how often the framing of a mesh file stands it up and faces it the right way
(nodegraph/scene/framing.py, `orient`), on meshes whose up and front are known, each presented in the 24
axis-aligned rotations and once as a Z-up STL, and, for the front alone, turned four ways about +Y.

The meshes are kept in four sets, and the figures are given for each apart:

- **tune**: what the rules and thresholds were chosen on (the shared spot, cow, stanford-bunny, ogre, suzanne
  and teapot, the boxes-figure of tests/nodegraph/test_framing.py, and the chair and car generated here: their
  first run stood them on their back and roof, and the flat-base rule was changed for it). The front's measure
  (feature lines over FEATURE_DEG seen from each end, `framing.visible_detail`), its angle and DETAIL_MARGIN
  were chosen on these alone: spot, cow, bunny, ogre, suzanne, chair, car and figure, plus fandisk and teapot
  (no known front) for what they would do;
- **report**: shapes generated here and not looked at while choosing them (a head with a nose and ears, a
  four-legged animal of boxes, a vase, a table, a van; and, made for the front and first measured with the
  measure and margin fixed, a face with a nose, eyes under brows and a mouth, an animal with a snout, eyes
  and ears, a car with a sloping windshield and headlights). The head, the box animal and the van were seen
  once in an exploratory table of a curvature-weighted variant that was not kept;
- **fresh**: shapes generated here after the stance rule (`framing.stance`, legs one way only) was fixed, in six
  waves. The stance's constants were set before its first measurement; its flat-base condition came after the
  tune set's figure, in a first look that printed the tune, report and wild sets together. The first wave (two
  mannequins, feet apart and together, an insect, a dog, a bird, a tricycle, a bench, a pedestal table, a
  bottle, a lamp, an arch) was written then and measured; the exception for a flat base at the other end of the
  legs' own axis came after it. The second wave (a stool, a bed, a truck, a desk, a statue on a plinth, a cat, a
  box robot, a shelf) was written after that and measured once: the one set no part of the rule has seen. The
  third wave (a grazing horse, a giraffe, an elephant, a lizard, a leaning chair, a hatchback, a sheep, a
  dachshund, a wheelbarrow) was written with the front's legs rule (`framing.head_ends`) set and before its first
  measurement; its condition on built things (HEAD_BUILT) came after it. The fourth (a bear, a crocodile, a
  rhino, a mouse, a tortoise, an office chair, a pram, a grand piano) was written after that and measured once,
  and the fifth (a kangaroo, a camel, a deer, a shopping cart, a wheelchair, an ant, a pig, a tiger) after the
  fourth's figures, with nothing changed, and measured once. The sixth (a horse with its head turned aside, a
  goat, a fox, a hippo, a sitting dog, a two-legged dinosaur, a sofa, a rocking horse, a wine glass, a park bench)
  was written by someone who had not seen the rules, while the legs' choice of the front's axis
  (`FrontChoice.legs_axis`) was being written, and measured once with and without it;
- **wild** (`--wild DIR`, where the files are): ten files of a public collection of test meshes (WILD_KNOWN),
  judged also as their files have them (`as_distributed`). They were first measured with the rules as they
  stood; the upright mirror plane (`framing.upright_mirror`) came after, its ratio set below the tune set's
  smallest, the report and wild values printed beside them.

Presentations fall in four cases: *convention* (the file's convention is right: up +Y and front +Z as an
OBJ, or Z-up with the front -Y as an STL), *front turned* (up +Y, the front any other way), *up turned* (the 20
rotations where +Y is not up) and *turned off the axes* (up +Y, turned OFF_AXIS_YAWS about it: a model set at an
angle in its file, whose up is right as the file has it; only the up is judged). For each: the share whose up is
found, the share (of those) whose front is found (meshes with a known front), and how often the framing said it
overrode the convention (`notes`): a right override on a turned presentation, a false one on a convention
presentation.

The *front sign* table gives the up (Y) and judges the front alone, on every mesh with a known front turned so
that it faces +Z (the convention right: any override is false), -Z (the file faces away: the convention is
wrong) and +-X, each as a plain, a noisy (NOISE of the diagonal), a scaled (a thousandth, moved off the
origin) and a mirrored copy (left to right, so the front stays).
"""

from __future__ import annotations

import contextlib
import itertools
import json
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from unittest import mock

import click
import numpy as np

from ...fsio import atomic_write_text
from ...scene import framing, primitives
from ...scene.meshes import Mesh, merge_meshes
from .sides import SHARED_MESHES

# (file stem, front in the file) of the shared meshes: fronts read from renders of the four sides; all Y-up
SHARED_KNOWN: dict[str, tuple[float, float, float] | None] = {
    "spot": (0, 0, -1), "cow": (1, 0, 0), "stanford-bunny": (-1, 0, 0), "ogre": (0, 0, 1), "suzanne": (0, 0, 1),
    "teapot": None,  # the spout to +X: which side is its front is a matter of taste
}


GROUPS = ("tune", "report", "fresh", "wild")


@dataclass
class Case:
    name: str
    mesh: Mesh  # Y-up
    front: np.ndarray | None  # in the mesh's frame; None: no known front
    group: str  # "tune" or "report"


def _place(mesh: Mesh, lo: Any, hi: Any) -> Mesh:
    """`mesh` (centred at the origin) scaled and moved to fill the box lo..hi."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    mlo, mhi = mesh.bounds()
    s = (hi - lo) / np.where(mhi - mlo > 0, mhi - mlo, 1.0)
    m = np.diag([*s, 1.0])
    m[:3, 3] = (lo + hi) / 2.0 - s * (mlo + mhi) / 2.0
    return mesh.transformed(m)


def _box(lo: Any, hi: Any) -> Mesh:
    return _place(primitives.box(1.0), lo, hi)


def _along(mesh: Mesh, axis: str) -> Mesh:
    """A +Y-axis primitive turned to run along `axis` (x or z)."""
    r = np.eye(4)
    if axis == "x":
        r[:3, :3] = [[0, 1, 0], [-1, 0, 0], [0, 0, 1]]
    elif axis == "z":
        r[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]
    return mesh.transformed(r)


def head() -> Mesh:
    """A head on a neck: a sphere, a nose pointing +Z, two ears at +-X."""
    parts = [primitives.sphere(1.0, 3), _place(_along(primitives.cone(0.5, 1.0, 24), "z"), (-0.18, -0.1, 0.85),
                                                (0.18, 0.25, 1.35)),
             _place(primitives.sphere(1.0, 2), (-1.15, 0.0, -0.15), (-0.85, 0.5, 0.15)),
             _place(primitives.sphere(1.0, 2), (0.85, 0.0, -0.15), (1.15, 0.5, 0.15)),
             _place(primitives.cylinder(0.5, 1.0, 24), (-0.45, -1.6, -0.45), (0.45, -0.6, 0.45))]
    return merge_meshes(parts, "head")


def chair() -> Mesh:
    """Four legs, a seat, a back at -Z: the front (where one sits) toward +Z."""
    legs = [_box((x - 0.04, 0.0, z - 0.04), (x + 0.04, 0.5, z + 0.04)) for x in (-0.42, 0.42) for z in (-0.42, 0.42)]
    return merge_meshes([*legs, _box((-0.5, 0.5, -0.5), (0.5, 0.58, 0.5)), _box((-0.5, 0.58, -0.5), (0.5, 1.5, -0.42))],
                        "chair")


def car() -> Mesh:
    """A long body on four wheels, the cabin set back: the bonnet toward +Z."""
    wheels = [_place(_along(primitives.cylinder(0.5, 1.0, 24), "x"), (x - 0.1, 0.0, z - 0.3), (x + 0.1, 0.6, z + 0.3))
              for x in (-0.55, 0.55) for z in (-0.95, 0.95)]
    body = [_box((-0.5, 0.25, -1.4), (0.5, 0.75, 1.4)), _box((-0.45, 0.75, -1.0), (0.45, 1.2, 0.3))]
    return merge_meshes([*wheels, *body], "car")


def quadruped() -> Mesh:
    """A body on four legs, a neck and a head ahead and above: the front toward +Z."""
    legs = [_box((x - 0.08, 0.0, z - 0.08), (x + 0.08, 0.8, z + 0.08)) for x in (-0.18, 0.18) for z in (-0.6, 0.6)]
    return merge_meshes([*legs, _box((-0.28, 0.8, -0.8), (0.28, 1.3, 0.8)), _box((-0.1, 1.2, 0.6), (0.1, 1.8, 0.85)),
                         _box((-0.14, 1.7, 0.55), (0.14, 1.95, 1.15)), _box((-0.03, 0.9, -1.1), (0.03, 1.25, -0.8))],
                        "quadruped")


def vase() -> Mesh:
    """A body of revolution on a flat foot: up +Y, no front."""
    return merge_meshes([_place(primitives.sphere(1.0, 3), (-0.5, 0.15, -0.5), (0.5, 1.1, 0.5)),
                         _place(primitives.cylinder(0.5, 1.0, 32), (-0.3, 0.0, -0.3), (0.3, 0.3, 0.3)),
                         _place(primitives.cylinder(0.5, 1.0, 32), (-0.18, 1.0, -0.18), (0.18, 1.5, 0.18))], "vase")


def figure() -> Mesh:
    """The boxes-figure of tests/nodegraph/test_framing.py: a base, feet and a nose toward +Z, arms, a head."""
    parts = [_box((-0.6, 0.0, -0.4), (0.6, 0.1, 0.4)),
             _box((-0.3, 0.1, -0.12), (-0.08, 0.2, 0.35)), _box((0.08, 0.1, -0.12), (0.3, 0.2, 0.35)),
             _box((-0.3, 0.2, -0.15), (0.3, 1.1, 0.15)),
             _box((-0.45, 0.55, -0.08), (-0.3, 1.05, 0.08)), _box((0.3, 0.55, -0.08), (0.45, 1.05, 0.08)),
             _box((-0.2, 1.1, -0.18), (0.2, 1.5, 0.18)), _box((-0.05, 1.22, 0.18), (0.05, 1.34, 0.38))]
    return merge_meshes(parts, "figure")


def table() -> Mesh:
    """A square top on four legs: up +Y, no front."""
    legs = [_box((x - 0.05, 0.0, z - 0.05), (x + 0.05, 0.7, z + 0.05)) for x in (-0.6, 0.6) for z in (-0.4, 0.4)]
    return merge_meshes([*legs, _box((-0.7, 0.7, -0.5), (0.7, 0.78, 0.5))], "table")


def van() -> Mesh:
    """A tall box body on four wheels with a short bonnet toward +Z."""
    wheels = [_place(_along(primitives.cylinder(0.5, 1.0, 24), "x"), (x - 0.1, 0.0, z - 0.25), (x + 0.1, 0.5, z + 0.25))
              for x in (-0.5, 0.5) for z in (-0.8, 0.9)]
    return merge_meshes([*wheels, _box((-0.5, 0.25, -1.1), (0.5, 1.4, 0.7)), _box((-0.5, 0.25, 0.7), (0.5, 0.75, 1.2))],
                        "van")


def _prism(profile: Any, x0: float, x1: float, name: str = "prism") -> Mesh:
    """A closed prism: the convex polygon `profile` of (z, y) points, extruded along X from x0 to x1."""
    q = np.asarray(profile, float)
    k = len(q)
    v = np.array([[x, y, z] for x in (x0, x1) for z, y in q])
    faces = [[0, i, i + 1] for i in range(1, k - 1)] + [[k, k + i + 1, k + i] for i in range(1, k - 1)]
    for i in range(k):
        j = (i + 1) % k
        faces += [[i, j, k + j], [i, k + j, k + i]]
    f = np.array(faces)
    centre = v.mean(axis=0)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    inward = np.einsum("ij,ij->i", n, v[f].mean(axis=1) - centre) < 0
    f[inward] = f[inward][:, ::-1]
    return Mesh(name, v, f)


def face() -> Mesh:
    """A head with a face toward +Z: a nose, two eyes under two brows, a mouth; ears at +-X, a neck below."""
    eyes = [_place(primitives.sphere(1.0, 2), (x - 0.12, 0.2, 0.78), (x + 0.12, 0.44, 1.0)) for x in (-0.35, 0.35)]
    brows = [_box((x - 0.2, 0.52, 0.7), (x + 0.2, 0.6, 0.9)) for x in (-0.35, 0.35)]
    mouth = _place(primitives.sphere(1.0, 2), (-0.3, -0.52, 0.8), (0.3, -0.38, 0.97))
    nose = _place(_along(primitives.cone(0.5, 1.0, 24), "z"), (-0.15, -0.15, 0.9), (0.15, 0.2, 1.3))
    ears = [_place(primitives.sphere(1.0, 2), (x - 0.15, 0.0, -0.15), (x + 0.15, 0.5, 0.15)) for x in (-1.0, 1.0)]
    neck = _place(primitives.cylinder(0.5, 1.0, 24), (-0.45, -1.6, -0.45), (0.45, -0.6, 0.45))
    return merge_meshes([primitives.sphere(1.0, 3), nose, *eyes, *brows, mouth, *ears, neck], "face")


def animal() -> Mesh:
    """A four-legged animal: a rounded body on four legs, a neck and a head with a snout, eyes and ears at the +Z
    end, a thin tail at the -Z end."""
    legs = [_place(primitives.cylinder(0.5, 1.0, 16), (x - 0.08, 0.0, z - 0.08), (x + 0.08, 0.9, z + 0.08))
            for x in (-0.2, 0.2) for z in (-0.6, 0.6)]
    body = _place(primitives.sphere(1.0, 3), (-0.35, 0.7, -0.9), (0.35, 1.3, 0.9))
    neck = _place(primitives.cylinder(0.5, 1.0, 16), (-0.09, 1.1, 0.72), (0.09, 1.5, 0.9))
    head = _place(primitives.sphere(1.0, 3), (-0.2, 1.4, 0.7), (0.2, 1.75, 1.1))
    snout = _place(_along(primitives.cylinder(0.5, 1.0, 16), "z"), (-0.1, 1.42, 1.0), (0.1, 1.58, 1.25))
    eyes = [_place(primitives.sphere(1.0, 2), (x - 0.04, 1.61, 0.99), (x + 0.04, 1.69, 1.07)) for x in (-0.12, 0.12)]
    ears = [_place(primitives.cone(0.5, 1.0, 12), (x - 0.05, 1.7, 0.85), (x + 0.05, 1.9, 0.95)) for x in (-0.12, 0.12)]
    tail = _place(_along(primitives.cylinder(0.5, 1.0, 8), "z"), (-0.03, 1.0, -1.25), (0.03, 1.06, -0.85))
    return merge_meshes([*legs, body, neck, head, snout, *eyes, *ears, tail], "animal")


def sedan() -> Mesh:
    """A car-like box on four wheels: a cabin with a sloping windshield, two headlights, a grille and a bumper at
    the +Z end; a steeper rear window and a bumper at the -Z end."""
    wheels = [_place(_along(primitives.cylinder(0.5, 1.0, 24), "x"), (x - 0.1, 0.0, z - 0.3), (x + 0.1, 0.6, z + 0.3))
              for x in (-0.55, 0.55) for z in (-0.95, 0.95)]
    cabin = _prism([(-1.0, 0.75), (0.45, 0.75), (0.05, 1.2), (-0.75, 1.2)], -0.45, 0.45, "cabin")
    lights = [_place(_along(primitives.cylinder(0.5, 1.0, 24), "z"), (x - 0.09, 0.46, 1.4), (x + 0.09, 0.64, 1.46))
              for x in (-0.32, 0.32)]
    bumpers = [_box((-0.52, 0.25, 1.4), (0.52, 0.35, 1.5)), _box((-0.52, 0.25, -1.5), (0.52, 0.35, -1.4))]
    return merge_meshes([*wheels, _box((-0.5, 0.25, -1.4), (0.5, 0.75, 1.4)), cabin, *lights,
                         _box((-0.18, 0.4, 1.4), (0.18, 0.62, 1.43)), *bumpers], "sedan")


def _posed(mesh: Mesh, at: Any, turn_z: float = 0.0, turn_x: float = 0.0) -> Mesh:
    """`mesh` turned by `turn_x` about X, then `turn_z` about Z (radians), then moved to `at`."""
    cz, sz, cx, sx = np.cos(turn_z), np.sin(turn_z), np.cos(turn_x), np.sin(turn_x)
    m = np.eye(4)
    m[:3, :3] = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
        [[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    m[:3, 3] = at
    return mesh.transformed(m)


def _rod(radius: float, length: float, at: Any, turn_z: float = 0.0, turn_x: float = 0.0) -> Mesh:
    return _posed(primitives.cylinder(radius, length, 16), at, turn_z, turn_x)


def mannequin(apart: bool) -> Mesh:
    """A figure of ellipsoids and rods, arms down, feet pointing +Z: its feet 0.24 apart, or side by side."""
    x = 0.12 if apart else 0.07
    parts = [_posed(primitives.ellipsoid(0.22, 0.32, 0.13, 3), (0, 1.25, 0)),
             _posed(primitives.sphere(0.12, 3), (0, 1.72, 0.01)),
             _rod(0.065, 0.85, (-x, 0.45, 0)), _rod(0.065, 0.85, (x, 0.45, 0)),
             _rod(0.045, 0.65, (-0.28, 1.2, 0), -0.12), _rod(0.045, 0.65, (0.28, 1.2, 0), 0.12),
             *(_box((c - 0.06, 0.0, -0.05), (c + 0.06, 0.05, 0.18)) for c in (-x, x))]
    return merge_meshes(parts, "mannequin")


def insect() -> Mesh:
    """A long body on six splayed legs, the head at +Z."""
    legs = [_rod(0.025, 0.55, (side * 0.38, 0.2, z), side * 0.9) for z in (-0.35, 0.0, 0.35) for side in (-1, 1)]
    return merge_meshes([_posed(primitives.ellipsoid(0.25, 0.15, 0.6, 3), (0, 0.35, 0)),
                         _posed(primitives.sphere(0.13, 3), (0, 0.4, 0.7)), *legs], "insect")


def bench() -> Mesh:
    """A seat on two slab legs: up +Y, no front."""
    return merge_meshes([_box((-1.0, 0.45, -0.25), (1.0, 0.52, 0.25)), _box((-0.9, 0.0, -0.22), (-0.82, 0.45, 0.22)),
                         _box((0.82, 0.0, -0.22), (0.9, 0.45, 0.22))], "bench")


def pedestal() -> Mesh:
    """A round top on one post on a round foot: up +Y, no front."""
    return merge_meshes([_rod(0.5, 0.04, (0, 0.75, 0)), _rod(0.05, 0.7, (0, 0.38, 0)), _rod(0.3, 0.04, (0, 0.02, 0))],
                        "pedestal")


def tricycle() -> Mesh:
    """A box body on three wheels, the single wheel at +Z."""
    wheels = [_rod(0.2, 0.08, (x, 0.2, z), np.pi / 2) for x, z in ((-0.35, -0.35), (0.35, -0.35), (0.0, 0.45))]
    return merge_meshes([_box((-0.3, 0.25, -0.5), (0.3, 0.55, 0.5)), *wheels], "tricycle")


def dog() -> Mesh:
    """An ellipsoid body on four legs, a head ahead at +Z, a tail raised at -Z."""
    legs = [_rod(0.05, 0.45, (x, 0.23, z)) for x in (-0.12, 0.12) for z in (-0.3, 0.3)]
    return merge_meshes([_posed(primitives.ellipsoid(0.2, 0.2, 0.45, 3), (0, 0.55, 0)),
                         _posed(primitives.ellipsoid(0.13, 0.12, 0.2, 3), (0, 0.72, 0.55)),
                         _rod(0.03, 0.3, (0, 0.7, -0.5), 0.0, -0.8), *legs], "dog")


def bird() -> Mesh:
    """A body on two thin legs with flat feet, the head at +Z."""
    return merge_meshes([_posed(primitives.ellipsoid(0.15, 0.15, 0.25, 3), (0, 0.5, 0)),
                         _posed(primitives.sphere(0.08, 3), (0, 0.68, 0.2)),
                         _rod(0.012, 0.35, (-0.06, 0.18, 0.02)), _rod(0.012, 0.35, (0.06, 0.18, 0.02)),
                         _box((-0.1, 0.0, -0.02), (-0.02, 0.01, 0.1)), _box((0.02, 0.0, -0.02), (0.1, 0.01, 0.1))],
                        "bird")


def bottle() -> Mesh:
    """A cylinder with a neck: up +Y, no front."""
    return merge_meshes([_rod(0.15, 0.6, (0, 0.3, 0)), _rod(0.05, 0.25, (0, 0.72, 0))], "bottle")


def lamp() -> Mesh:
    """A round foot, a pole and a conical shade: up +Y, no front."""
    return merge_meshes([_rod(0.2, 0.04, (0, 0.02, 0)), _rod(0.02, 0.8, (0, 0.44, 0)),
                         _posed(primitives.cone(0.25, 0.25, 24), (0, 0.9, 0))], "lamp")


def stool() -> Mesh:
    """A round seat on three splayed legs: up +Y, no front."""
    legs = [_rod(0.03, 0.62, (0.22 * np.cos(a), 0.3, 0.22 * np.sin(a)), 0.12 * np.sin(a), -0.12 * np.cos(a))
            for a in (0.3, 0.3 + 2 * np.pi / 3, 0.3 + 4 * np.pi / 3)]
    return merge_meshes([_rod(0.25, 0.05, (0, 0.62, 0)), *legs], "stool")


def bed() -> Mesh:
    """A mattress on four short legs, a headboard at -Z: the foot end toward +Z."""
    legs = [_box((x - 0.05, 0.0, z - 0.05), (x + 0.05, 0.15, z + 0.05)) for x in (-0.7, 0.7) for z in (-0.95, 0.95)]
    mattress, headboard = _box((-0.75, 0.15, -1.0), (0.75, 0.45, 1.0)), _box((-0.75, 0.15, -1.08), (0.75, 0.9, -1.0))
    return merge_meshes([*legs, mattress, headboard], "bed")


def truck() -> Mesh:
    """A cab and a longer cargo box on six wheels, the cab toward +Z."""
    wheels = [_rod(0.22, 0.12, (x, 0.22, z), np.pi / 2) for x in (-0.45, 0.45) for z in (-1.1, -0.55, 0.9)]
    cab, cargo = _box((-0.45, 0.3, 0.55), (0.45, 1.1, 1.3)), _box((-0.5, 0.3, -1.5), (0.5, 1.3, 0.45))
    return merge_meshes([*wheels, cab, cargo], "truck")


def desk() -> Mesh:
    """A top on two full-depth side panels, a drawer block under one end: up +Y, the knee space toward +Z."""
    panels = [_box((x0, 0.0, -0.35), (x0 + 0.04, 0.72, 0.35)) for x0 in (-0.8, 0.76)]
    top, drawers = _box((-0.8, 0.72, -0.35), (0.8, 0.76, 0.35)), _box((0.3, 0.45, -0.33), (0.76, 0.72, 0.3))
    return merge_meshes([top, *panels, drawers], "desk")


def statue() -> Mesh:
    """The mannequin with its feet apart on a round plinth: up +Y, the front toward +Z."""
    figure_ = mannequin(True).transformed(np.array([[1, 0, 0, 0], [0, 1, 0, 0.2], [0, 0, 1, 0], [0, 0, 0, 1.0]]))
    return merge_meshes([_rod(0.4, 0.2, (0, 0.1, 0)), figure_], "statue")


def cat() -> Mesh:
    """A body on four thin legs, a head at +Z, a tail lying on the ground behind."""
    legs = [_rod(0.03, 0.3, (x, 0.15, z)) for x in (-0.08, 0.08) for z in (-0.22, 0.22)]
    return merge_meshes([_posed(primitives.ellipsoid(0.12, 0.12, 0.3, 3), (0, 0.36, 0)),
                         _posed(primitives.sphere(0.1, 3), (0, 0.5, 0.33)), *legs,
                         _rod(0.025, 0.5, (0, 0.03, -0.5), 0.0, np.pi / 2)], "cat")


def robot() -> Mesh:
    """A box torso and head on two box legs with flat feet toward +Z."""
    return merge_meshes([_box((-0.3, 0.8, -0.15), (0.3, 1.5, 0.15)), _box((-0.15, 1.5, -0.12), (0.15, 1.8, 0.12)),
                         _box((-0.25, 0.05, -0.08), (-0.1, 0.8, 0.08)), _box((0.1, 0.05, -0.08), (0.25, 0.8, 0.08)),
                         _box((-0.27, 0.0, -0.1), (-0.08, 0.05, 0.2)), _box((0.08, 0.0, -0.1), (0.27, 0.05, 0.2))],
                        "robot")


def shelf() -> Mesh:
    """A tall open box of boards standing on its bottom board: up +Y, its open side toward +Z."""
    boards = [_box((-0.5, y, -0.2), (0.5, y + 0.03, 0.2)) for y in (0.0, 0.5, 1.0, 1.47)]
    return merge_meshes([*boards, _box((-0.5, 0.0, -0.2), (-0.47, 1.5, 0.2)), _box((0.47, 0.0, -0.2), (0.5, 1.5, 0.2)),
                         _box((-0.5, 0.0, -0.2), (0.5, 1.5, -0.18))], "shelf")


def horse_grazing() -> Mesh:
    """A long body on four legs, the neck reaching forward and down to a head just above the ground at +Z, a tail
    hanging behind."""
    legs = [_rod(0.05, 0.8, (x, 0.4, z)) for x in (-0.15, 0.15) for z in (-0.5, 0.5)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.22, 0.22, 0.6, 3), (0, 0.95, 0)),
                         _rod(0.08, 0.7, (0, 0.68, 0.82), 0.0, -0.69),
                         _posed(primitives.ellipsoid(0.08, 0.09, 0.18, 3), (0, 0.28, 1.05)),
                         _rod(0.03, 0.5, (0, 0.72, -0.7), 0.0, 0.42)], "horse-grazing")


def giraffe() -> Mesh:
    """A body on four long legs, a long neck rising forward to a small head at +Z, a thin tail."""
    legs = [_rod(0.04, 1.2, (x, 0.6, z)) for x in (-0.12, 0.12) for z in (-0.4, 0.4)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.2, 0.22, 0.5, 3), (0, 1.3, 0)),
                         _rod(0.07, 1.1, (0, 1.85, 0.6), 0.0, 0.42),
                         _posed(primitives.ellipsoid(0.07, 0.08, 0.18, 3), (0, 2.38, 0.9)),
                         _rod(0.02, 0.5, (0, 1.1, -0.55), 0.0, 0.2)], "giraffe")


def elephant() -> Mesh:
    """A big body on four thick legs, a head with ears and a hanging trunk at +Z, a thin tail."""
    legs = [_rod(0.15, 0.9, (x, 0.45, z)) for x in (-0.3, 0.3) for z in (-0.55, 0.55)]
    ears = [_posed(primitives.ellipsoid(0.05, 0.3, 0.25, 2), (x, 1.65, 0.75)) for x in (-0.38, 0.38)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.5, 0.5, 0.8, 3), (0, 1.3, 0)),
                         _posed(primitives.sphere(0.35, 3), (0, 1.6, 0.85)), _rod(0.07, 1.0, (0, 0.95, 1.1), 0.0, 0.15),
                         *ears, _rod(0.02, 0.5, (0, 1.1, -0.82), 0.0, 0.3)], "elephant")


def lizard() -> Mesh:
    """A low body on four splayed legs, a head at +Z and a long, thick, tapering tail lying behind."""
    legs = [_rod(0.03, 0.3, (side * 0.2, 0.1, z), side * 0.9) for z in (-0.25, 0.25) for side in (-1, 1)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.12, 0.07, 0.35, 3), (0, 0.18, 0)),
                         _posed(primitives.ellipsoid(0.08, 0.05, 0.14, 3), (0, 0.2, 0.45)),
                         _posed(primitives.cone(0.07, 0.9, 16), (0, 0.17, -0.8), 0.0, -np.pi / 2)], "lizard")


def leaning_chair() -> Mesh:
    """Four legs, a seat and a back leaning out behind the back legs: the front (where one sits) toward +Z."""
    legs = [_box((x - 0.03, 0.0, z - 0.03), (x + 0.03, 0.45, z + 0.03)) for x in (-0.4, 0.4) for z in (-0.4, 0.4)]
    back = _posed(_box((-0.45, -0.4, -0.03), (0.45, 0.4, 0.03)), (0, 0.88, -0.6), 0.0, -0.35)
    return merge_meshes([*legs, _box((-0.45, 0.45, -0.45), (0.45, 0.5, 0.45)), back], "leaning-chair")


def hatchback() -> Mesh:
    """A body on four wheels with a long bonnet at +Z and a short tail, the cabin over the back."""
    wheels = [_rod(0.2, 0.12, (x, 0.2, z), np.pi / 2) for x in (-0.5, 0.5) for z in (-0.7, 0.75)]
    return merge_meshes([*wheels, _box((-0.5, 0.2, -1.0), (0.5, 0.6, 1.4)), _box((-0.45, 0.6, -1.0), (0.45, 1.0, 0.3))],
                        "hatchback")


def sheep() -> Mesh:
    """A round body on four short legs, a small head at +Z."""
    legs = [_rod(0.04, 0.3, (x, 0.15, z)) for x in (-0.12, 0.12) for z in (-0.25, 0.25)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.25, 0.22, 0.4, 3), (0, 0.5, 0)),
                         _posed(primitives.ellipsoid(0.08, 0.1, 0.13, 3), (0, 0.55, 0.45))], "sheep")


def dachshund() -> Mesh:
    """A long body on four short legs, a head at +Z, a tail raised behind."""
    legs = [_rod(0.04, 0.15, (x, 0.075, z)) for x in (-0.08, 0.08) for z in (-0.3, 0.3)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.1, 0.1, 0.45, 3), (0, 0.22, 0)),
                         _posed(primitives.ellipsoid(0.07, 0.07, 0.14, 3), (0, 0.32, 0.5)),
                         _rod(0.015, 0.25, (0, 0.3, -0.5), 0.0, -0.7)], "dachshund")


def wheelbarrow() -> Mesh:
    """A tray on one wheel at +Z and two short legs, its handles running out behind."""
    legs = [_box((x - 0.02, 0.0, -0.32), (x + 0.02, 0.35, -0.28)) for x in (-0.2, 0.2)]
    handles = [_rod(0.02, 0.8, (x, 0.5, -0.6), 0.0, np.pi / 2) for x in (-0.25, 0.25)]
    return merge_meshes([_rod(0.18, 0.08, (0, 0.18, 0.55), np.pi / 2), _box((-0.3, 0.35, -0.3), (0.3, 0.6, 0.45)),
                         *legs, *handles], "wheelbarrow")


def bear() -> Mesh:
    """A bulky body on four thick legs, a head with a snout and round ears at +Z, a stub of a tail."""
    legs = [_rod(0.11, 0.55, (x, 0.275, z)) for x in (-0.2, 0.2) for z in (-0.45, 0.45)]
    ears = [_posed(primitives.sphere(0.06, 2), (x, 1.18, 0.72)) for x in (-0.12, 0.12)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.33, 0.35, 0.7, 3), (0, 0.8, 0)),
                         _posed(primitives.sphere(0.2, 3), (0, 1.0, 0.75)),
                         _posed(primitives.ellipsoid(0.09, 0.08, 0.12, 2), (0, 0.95, 0.97)), *ears,
                         _posed(primitives.sphere(0.06, 2), (0, 0.85, -0.72))], "bear")


def crocodile() -> Mesh:
    """A long, flat body on four short splayed legs, a long snout at +Z and a long, thick tail at -Z."""
    legs = [_rod(0.04, 0.2, (side * 0.22, 0.07, z), side * 1.0) for z in (-0.35, 0.35) for side in (-1, 1)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.2, 0.1, 0.55, 3), (0, 0.16, 0)),
                         _posed(primitives.ellipsoid(0.1, 0.06, 0.35, 3), (0, 0.17, 0.8)),
                         _posed(primitives.cone(0.14, 1.2, 16), (0, 0.15, -1.05), 0.0, -np.pi / 2)], "crocodile")


def rhino() -> Mesh:
    """A heavy body on four legs, a long head with a horn at +Z, a thin tail."""
    legs = [_rod(0.1, 0.6, (x, 0.3, z)) for x in (-0.22, 0.22) for z in (-0.5, 0.5)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.35, 0.35, 0.75, 3), (0, 0.85, 0)),
                         _posed(primitives.ellipsoid(0.15, 0.17, 0.3, 3), (0, 0.8, 0.85)),
                         _posed(primitives.cone(0.06, 0.25, 12), (0, 0.95, 1.05), 0.0, 0.4),
                         _rod(0.015, 0.3, (0, 0.8, -0.78), 0.0, 0.2)], "rhino")


def mouse() -> Mesh:
    """A small body on four short legs, a pointed head at +Z, a long thin tail lying on the ground behind."""
    legs = [_rod(0.015, 0.06, (x, 0.03, z)) for x in (-0.04, 0.04) for z in (-0.07, 0.07)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.06, 0.055, 0.12, 3), (0, 0.1, 0)),
                         _posed(primitives.cone(0.045, 0.1, 16), (0, 0.11, 0.16), 0.0, np.pi / 2),
                         _rod(0.006, 0.25, (0, 0.006, -0.24), 0.0, np.pi / 2)], "mouse")


def tortoise() -> Mesh:
    """A domed shell on four short legs, a head on a short neck at +Z, a small tail."""
    legs = [_rod(0.05, 0.15, (x, 0.075, z)) for x in (-0.2, 0.2) for z in (-0.22, 0.22)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.3, 0.2, 0.38, 3), (0, 0.22, 0)),
                         _rod(0.045, 0.2, (0, 0.2, 0.42), 0.0, 1.2),
                         _posed(primitives.ellipsoid(0.06, 0.055, 0.08, 2), (0, 0.25, 0.55)),
                         _rod(0.015, 0.08, (0, 0.15, -0.4), 0.0, -1.2)], "tortoise")


def office_chair() -> Mesh:
    """A seat and a back at -Z on a post and five splayed feet: the front (where one sits) toward +Z."""
    feet = []
    for k in range(5):
        a = 2 * np.pi * k / 5
        spoke = _rod(0.02, 0.35, (0, 0, 0), 0.0, np.pi / 2)
        m = np.eye(4)
        m[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
        m[:3, 3] = [0.17 * np.sin(a), 0.04, 0.17 * np.cos(a)]
        feet.append(spoke.transformed(m))
    return merge_meshes([*feet, _rod(0.03, 0.4, (0, 0.25, 0)), _posed(primitives.ellipsoid(0.25, 0.04, 0.24, 3),
                                                                         (0, 0.47, 0)),
                         _posed(primitives.ellipsoid(0.22, 0.3, 0.04, 3), (0, 0.8, -0.24))], "office-chair")


def pram() -> Mesh:
    """A round body on four wheels, a hood over its -Z end and a handle rising out behind it: the front (the
    end it is pushed toward) toward +Z."""
    wheels = [_rod(0.12, 0.04, (x, 0.12, z), np.pi / 2) for x in (-0.25, 0.25) for z in (-0.3, 0.3)]
    return merge_meshes([*wheels, _posed(primitives.ellipsoid(0.25, 0.18, 0.4, 3), (0, 0.5, 0)),
                         _posed(primitives.sphere(0.22, 3), (0, 0.65, -0.25)),
                         *(_rod(0.015, 0.7, (x, 0.8, -0.55), 0.0, -0.6) for x in (-0.15, 0.15)),
                         _rod(0.015, 0.3, (0, 1.08, -0.74), np.pi / 2)], "pram")


def piano() -> Mesh:
    """A grand piano: a case on three legs, the keyboard at +Z, the case's long tail running back on one side."""
    legs = [_box((x - 0.04, 0.0, z - 0.04), (x + 0.04, 0.6, z + 0.04))
            for x, z in ((-0.6, 0.4), (0.6, 0.4), (-0.3, -1.2))]
    return merge_meshes([*legs, _box((-0.7, 0.6, -0.5), (0.7, 0.95, 0.5)), _box((-0.7, 0.6, -1.5), (0.1, 0.95, -0.5)),
                         _box((-0.7, 0.7, 0.5), (0.7, 0.78, 0.75))], "piano")


def kangaroo() -> Mesh:
    """A body leaning forward on two long feet and a thick tail resting on the ground behind, a head at +Z."""
    feet = [_box((x - 0.05, 0.0, -0.1), (x + 0.05, 0.04, 0.25)) for x in (-0.1, 0.1)]
    legs = [_rod(0.06, 0.45, (x, 0.25, -0.02), 0.0, -0.3) for x in (-0.1, 0.1)]
    return merge_meshes([*feet, *legs, _posed(primitives.ellipsoid(0.17, 0.3, 0.2, 3), (0, 0.7, 0.05), 0.0, 0.35),
                         _posed(primitives.ellipsoid(0.07, 0.08, 0.14, 3), (0, 1.08, 0.22)),
                         _posed(primitives.cone(0.08, 0.8, 16), (0, 0.2, -0.45), 0.0, -1.2)], "kangaroo")


def camel() -> Mesh:
    """A humped body on four long legs, a long neck curving forward and up to a head at +Z."""
    legs = [_rod(0.05, 1.0, (x, 0.5, z)) for x in (-0.15, 0.15) for z in (-0.45, 0.45)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.25, 0.25, 0.6, 3), (0, 1.15, 0)),
                         _posed(primitives.sphere(0.22, 3), (0, 1.4, -0.05)),
                         _rod(0.07, 0.6, (0, 1.1, 0.75), 0.0, 1.0), _rod(0.06, 0.4, (0, 1.45, 0.98), 0.0, 0.15),
                         _posed(primitives.ellipsoid(0.07, 0.07, 0.16, 3), (0, 1.65, 1.08))], "camel")


def deer() -> Mesh:
    """A body on four thin legs, a neck rising to a head at +Z with antlers branching up and back, a short tail."""
    legs = [_rod(0.03, 0.8, (x, 0.4, z)) for x in (-0.1, 0.1) for z in (-0.35, 0.35)]
    antlers = [_rod(0.015, 0.35, (x, 1.5, 0.42), x * 3.0, -0.5) for x in (-0.06, 0.06)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.16, 0.18, 0.45, 3), (0, 0.95, 0)),
                         _rod(0.05, 0.4, (0, 1.15, 0.42), 0.0, 0.5),
                         _posed(primitives.ellipsoid(0.06, 0.07, 0.13, 3), (0, 1.35, 0.55)), *antlers,
                         _rod(0.02, 0.12, (0, 1.0, -0.47), 0.0, -0.8)], "deer")


def shopping_cart() -> Mesh:
    """A wire basket on four small wheels, its handle at the back (-Z), the front (the end it is pushed toward) +Z."""
    wheels = [_rod(0.05, 0.03, (x, 0.05, z), np.pi / 2) for x in (-0.22, 0.22) for z in (-0.35, 0.35)]
    frame = [_rod(0.012, 0.8, (x, 0.12, 0.0), 0.0, np.pi / 2) for x in (-0.22, 0.22)]
    posts = [_rod(0.012, 0.55, (x, 0.4, -0.38)) for x in (-0.22, 0.22)]
    return merge_meshes([*wheels, *frame, *posts, _box((-0.25, 0.45, -0.4), (0.25, 0.85, 0.45)),
                         _rod(0.015, 0.5, (0, 0.92, -0.55), np.pi / 2)], "shopping-cart")


def wheelchair() -> Mesh:
    """A seat on two large wheels at the back and two casters at the front (+Z), a back and push handles behind."""
    big = [_rod(0.3, 0.03, (x, 0.3, -0.1), np.pi / 2) for x in (-0.3, 0.3)]
    casters = [_rod(0.06, 0.03, (x, 0.06, 0.35), np.pi / 2) for x in (-0.22, 0.22)]
    return merge_meshes([*big, *casters, _box((-0.25, 0.45, -0.2), (0.25, 0.5, 0.3)),
                         _box((-0.25, 0.5, -0.25), (0.25, 0.95, -0.2)),
                         *(_rod(0.012, 0.2, (x, 0.95, -0.32), 0.0, np.pi / 2) for x in (-0.23, 0.23)),
                         *(_rod(0.012, 0.38, (x, 0.25, 0.32)) for x in (-0.22, 0.22))], "wheelchair")


def ant() -> Mesh:
    """Six legs under a thorax, a head with antennae at +Z and a large abdomen behind."""
    legs = [_rod(0.012, 0.35, (side * 0.16, 0.12, z), side * 0.8) for z in (-0.08, 0.02, 0.12) for side in (-1, 1)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.07, 0.06, 0.13, 3), (0, 0.25, 0.03)),
                         _posed(primitives.ellipsoid(0.07, 0.06, 0.08, 3), (0, 0.27, 0.24)),
                         _posed(primitives.ellipsoid(0.11, 0.1, 0.2, 3), (0, 0.24, -0.3)),
                         *(_rod(0.006, 0.15, (x, 0.35, 0.32), x * 6.0, 0.6) for x in (-0.03, 0.03))], "ant")


def pig() -> Mesh:
    """A round body on four short legs, a head with a flat snout at +Z, a curly tail stub."""
    legs = [_rod(0.05, 0.22, (x, 0.11, z)) for x in (-0.13, 0.13) for z in (-0.3, 0.3)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.25, 0.22, 0.45, 3), (0, 0.42, 0)),
                         _posed(primitives.sphere(0.15, 3), (0, 0.5, 0.48)),
                         _rod(0.06, 0.08, (0, 0.47, 0.64), 0.0, np.pi / 2),
                         _posed(primitives.sphere(0.04, 2), (0, 0.5, -0.47))], "pig")


def tiger() -> Mesh:
    """A long body on four legs, a head at +Z, a long thin tail curving up behind."""
    legs = [_rod(0.06, 0.55, (x, 0.275, z)) for x in (-0.13, 0.13) for z in (-0.45, 0.45)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.2, 0.2, 0.65, 3), (0, 0.7, 0)),
                         _posed(primitives.sphere(0.17, 3), (0, 0.8, 0.7)),
                         _rod(0.025, 0.7, (0, 0.75, -0.95), 0.0, -1.2)], "tiger")


def _yawed(mesh: Mesh, angle: float, pivot: Any = (0.0, 0.0, 0.0)) -> Mesh:
    """`mesh` turned by `angle` (radians) about the vertical line through `pivot`: +Z toward +X for a positive one."""
    c, s, p = np.cos(angle), np.sin(angle), np.asarray(pivot, float)
    m = np.eye(4)
    m[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
    m[:3, 3] = p - m[:3, :3] @ p
    return mesh.transformed(m)


def horse_turned() -> Mesh:
    """A body on four legs as a scan stands (a foreleg forward, a hind leg under), the neck and head turned 40
    degrees to one side, a tail hanging behind."""
    legs = [_rod(0.045, 0.98, (x, 0.49, z), 0.0, a)
            for x, z, a in ((-0.11, 0.49, -0.17), (0.11, 0.4, 0.0), (-0.11, -0.44, 0.1), (0.12, -0.36, -0.05))]
    ears = [_posed(primitives.cone(0.025, 0.1, 12), (x, 1.69, 0.8)) for x in (-0.04, 0.04)]
    neck_head = merge_meshes([_rod(0.08, 0.6, (0, 1.3, 0.62), 0.0, 0.6), *ears,
                              _posed(primitives.ellipsoid(0.08, 0.1, 0.26, 3), (0, 1.55, 0.95), 0.0, 0.7)], "head")
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.2, 0.24, 0.55, 3), (0, 0.98, 0)),
                         _yawed(neck_head, np.radians(40), (0, 0, 0.45)),
                         _rod(0.03, 0.55, (0.03, 0.72, -0.62), 0.0, 0.35)], "horse-turned")


def goat() -> Mesh:
    """A body on four short legs, a head at +Z with a beard under its chin and horns curving back, a short tail."""
    legs = [_rod(0.03, 0.46, (x, 0.23, z)) for x in (-0.09, 0.09) for z in (-0.25, 0.25)]
    horns = []
    for x in (-0.04, 0.04):
        p = np.array([x, 0.87, 0.43])
        for a, r in ((-0.3, 0.02), (-1.0, 0.016), (-1.7, 0.012)):
            d = np.array([0.0, np.cos(a), np.sin(a)])
            horns.append(_rod(r, 0.09, p + 0.045 * d, 0.0, a))
            p = p + 0.09 * d
    ears = [_posed(primitives.ellipsoid(0.05, 0.015, 0.025, 2), (x, 0.83, 0.4)) for x in (-0.08, 0.08)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.15, 0.16, 0.36, 3), (0, 0.5, 0)),
                         _rod(0.055, 0.3, (0, 0.64, 0.32), 0.0, 0.6),
                         _posed(primitives.ellipsoid(0.07, 0.08, 0.14, 3), (0, 0.78, 0.45), 0.0, 0.6),
                         _posed(primitives.cone(0.03, 0.12, 12), (0, 0.63, 0.53), 0.0, np.pi), *horns, *ears,
                         _rod(0.02, 0.1, (0, 0.6, -0.38), 0.0, -0.6)], "goat")


def fox() -> Mesh:
    """A slim body on four thin legs, a head with a pointed snout and ears at +Z, a large bushy tail held out low
    behind."""
    legs = [_rod(0.022, 0.36, (x, 0.18, z)) for x in (-0.06, 0.06) for z in (-0.2, 0.2)]
    ears = [_posed(primitives.cone(0.03, 0.09, 12), (x, 0.6, 0.32)) for x in (-0.045, 0.045)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.1, 0.11, 0.3, 3), (0, 0.38, 0)),
                         _posed(primitives.ellipsoid(0.085, 0.08, 0.095, 3), (0, 0.5, 0.34)),
                         _posed(primitives.cone(0.04, 0.14, 16), (0, 0.48, 0.47), 0.0, np.pi / 2), *ears,
                         _posed(primitives.ellipsoid(0.06, 0.065, 0.2, 3), (0, 0.29, -0.46), 0.0, -0.5)], "fox")


def hippo() -> Mesh:
    """A heavy barrel body on four very short, thick legs, a big broad head with a wide muzzle at +Z."""
    legs = [_rod(0.08, 0.3, (x, 0.15, z)) for x in (-0.18, 0.18) for z in (-0.32, 0.32)]
    bumps = [_posed(primitives.sphere(r, 2), (x, y, z)) for r, y, z in ((0.035, 0.66, 0.5), (0.035, 0.62, 0.62),
                                                                        (0.03, 0.53, 0.9)) for x in (-0.1, 0.1)]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.3, 0.27, 0.55, 3), (0, 0.42, 0)),
                         _posed(primitives.ellipsoid(0.22, 0.18, 0.25, 3), (0, 0.48, 0.6)),
                         _posed(primitives.ellipsoid(0.24, 0.14, 0.16, 3), (0, 0.42, 0.8)), *bumps,
                         _rod(0.02, 0.1, (0, 0.45, -0.57), 0.0, -0.8)], "hippo")


def dog_sitting() -> Mesh:
    """A dog sitting: its haunches and hind paws on the ground, forelegs straight, the head up at +Z, the tail lying
    behind."""
    paired = (((0.07, 0.1, 0.15), (0.11, 0.1, -0.05)), ((0.04, 0.025, 0.07), (0.1, 0.025, 0.1)),  # haunches, paws
              ((0.035, 0.02, 0.05), (0.06, 0.02, 0.13)), ((0.02, 0.07, 0.04), (0.09, 0.66, 0.11)))  # fore paws, ears
    pairs = [_posed(primitives.ellipsoid(*axes, 2), (side * x, y, z)) for side in (-1, 1) for axes, (x, y, z) in paired]
    return merge_meshes([_posed(primitives.ellipsoid(0.13, 0.25, 0.15, 3), (0, 0.3, -0.02), 0.0, 0.4), *pairs,
                         *(_rod(0.028, 0.44, (x, 0.22, 0.1)) for x in (-0.06, 0.06)),
                         _rod(0.06, 0.2, (0, 0.56, 0.1), 0.0, 0.3),
                         _posed(primitives.ellipsoid(0.085, 0.085, 0.1, 3), (0, 0.68, 0.14)),
                         _posed(primitives.ellipsoid(0.045, 0.04, 0.07, 2), (0, 0.65, 0.25)),
                         _rod(0.02, 0.28, (0, 0.025, -0.28), 0.0, np.pi / 2)], "dog-sitting")


def dinosaur() -> Mesh:
    """A two-legged dinosaur: a body leaning forward, a big head with a jaw at +Z, a long tail behind balancing it,
    two thick legs on feet pointing +Z, two tiny arms."""
    legs = [part for x in (-0.14, 0.14) for part in (
        _posed(primitives.ellipsoid(0.07, 0.17, 0.12, 3), (x, 0.58, -0.02), 0.0, 0.3),
        _rod(0.04, 0.45, (x, 0.24, 0.0), 0.0, -0.15), _box((x - 0.05, 0.0, -0.06), (x + 0.05, 0.04, 0.16)))]
    return merge_meshes([*legs, _posed(primitives.ellipsoid(0.15, 0.19, 0.38, 3), (0, 0.75, 0), 0.0, 0.2),
                         _rod(0.08, 0.2, (0, 0.92, 0.38), 0.0, 0.9),
                         _posed(primitives.ellipsoid(0.1, 0.13, 0.22, 3), (0, 1.0, 0.56)),
                         _posed(primitives.ellipsoid(0.08, 0.04, 0.18, 2), (0, 0.88, 0.58)),
                         _posed(primitives.cone(0.13, 1.0, 16), (0, 0.7, -0.75), 0.0, -1.75),
                         *(_rod(0.015, 0.14, (x, 0.68, 0.36), 0.0, 2.21) for x in (-0.1, 0.1))], "dinosaur")


def sofa() -> Mesh:
    """A base on four short feet, two seat cushions, a back at -Z and two arm rests: the front (where one sits)
    toward +Z."""
    feet = [_box((x - 0.04, 0.0, z - 0.04), (x + 0.04, 0.08, z + 0.04)) for x in (-0.92, 0.92) for z in (-0.37, 0.37)]
    cushions = [_box((x0, 0.3, -0.25), (x0 + 0.79, 0.44, 0.43)) for x0 in (-0.8, 0.01)]
    arms = [_box((x0, 0.08, -0.45), (x0 + 0.2, 0.6, 0.45)) for x0 in (-1.0, 0.8)]
    return merge_meshes([*feet, _box((-0.8, 0.08, -0.45), (0.8, 0.3, 0.43)), *cushions, *arms,
                         _box((-0.8, 0.3, -0.45), (0.8, 0.85, -0.25))], "sofa")


def rocking_horse() -> Mesh:
    """A toy horse on two curved rockers: a body on four splayed legs, a head with a handle at +Z, a tail."""
    th = np.linspace(-0.5, 0.5, 11)
    rockers = [_prism([(r * np.sin(a), 1.3 - r * np.cos(a)) for r, a in ((1.3, th[k]), (1.3, th[k + 1]),
                                                                         (1.24, th[k + 1]), (1.24, th[k]))],
                      x - 0.025, x + 0.025) for x in (-0.2, 0.2) for k in range(10)]
    legs = [_rod(0.03, 0.6, (sx * 0.13, 0.335, sz * 0.305), sx * 0.26, -sz * 0.4) for sx in (-1, 1) for sz in (-1, 1)]
    return merge_meshes([*rockers, *legs, _posed(primitives.ellipsoid(0.12, 0.12, 0.33, 3), (0, 0.6, 0)),
                         _rod(0.07, 0.4, (0, 0.8, 0.3), 0.0, 0.5),
                         _posed(primitives.ellipsoid(0.065, 0.08, 0.18, 3), (0, 0.98, 0.42), 0.0, 0.6),
                         *(_posed(primitives.cone(0.025, 0.08, 12), (x, 1.08, 0.36)) for x in (-0.03, 0.03)),
                         _rod(0.012, 0.22, (0, 0.98, 0.38), np.pi / 2),
                         _rod(0.025, 0.3, (0, 0.48, -0.4), 0.0, 0.6)], "rocking-horse")


def wine_glass() -> Mesh:
    """A thin-walled bowl on a stem on a round foot, a body of revolution: up +Y, no front."""
    inside = [(0.0, 0.6), (0.07, 0.61), (0.16, 0.66), (0.25, 0.73), (0.29, 0.82), (0.3, 0.9), (0.29, 1.0)]
    outside = [(0.3, 1.0), (0.31, 0.9), (0.3, 0.8), (0.26, 0.7), (0.18, 0.61), (0.08, 0.56), (0.03, 0.52)]
    foot = [(0.03, 0.05), (0.3, 0.02), (0.3, 0.0), (0.0, 0.0)]
    return primitives.revolve(inside + outside + foot, 32, "wine-glass")


def park_bench() -> Mesh:
    """Slats for a seat and a back leaning back at -Z on two cast side frames (legs, a rail, an arm rest): the
    front (where one sits) toward +Z."""
    def bar(half: Any, at: Any, tilt: float = 0.0) -> Mesh:
        return _posed(_box(-np.asarray(half), half), at, 0.0, tilt)

    frames = [part for x in (-0.8, 0.8) for part in (
        bar((0.025, 0.23, 0.03), (x, 0.23, 0.24)), bar((0.025, 0.23, 0.03), (x, 0.23, -0.27), 0.2),
        bar((0.025, 0.26, 0.03), (x, 0.69, -0.3), -0.27), bar((0.025, 0.025, 0.28), (x, 0.41, 0.0)),
        bar((0.03, 0.02, 0.28), (x, 0.64, 0.02)), bar((0.02, 0.1, 0.02), (x, 0.53, 0.24)))]
    seat = [_box((-0.85, 0.43, z), (0.85, 0.46, z + 0.08)) for z in (-0.27, -0.16, -0.05, 0.06, 0.17)]
    back = [bar((0.85, 0.045, 0.012), (0, y, -0.25 - 0.27 * (y - 0.45)), -0.27) for y in (0.56, 0.7, 0.84)]
    return merge_meshes([*frames, *seat, *back], "park-bench")


# the fresh set: shapes written after the stance rule (framing.stance) was fixed, in six waves (module docstring):
# mannequin .. lamp and the arch first, stool .. shelf after the same-axis exception, horse-grazing .. wheelbarrow
# with the front's legs rule set, bear .. piano after its condition on built things, kangaroo .. tiger after that,
# horse-turned .. park-bench as a sixth, after the front's legs rule was measured
GENERATED = {"head": (head, (0, 0, 1), "report"), "quadruped": (quadruped, (0, 0, 1), "report"),
             "vase": (vase, None, "report"), "table": (table, None, "report"), "van": (van, (0, 0, 1), "report"),
             "face": (face, (0, 0, 1), "report"), "animal": (animal, (0, 0, 1), "report"),
             "sedan": (sedan, (0, 0, 1), "report"),
             "chair": (chair, (0, 0, 1), "tune"), "car": (car, (0, 0, 1), "tune"),
             "mannequin-together": (lambda: mannequin(False), (0, 0, 1), "fresh"),
             "mannequin-apart": (lambda: mannequin(True), (0, 0, 1), "fresh"), "insect": (insect, (0, 0, 1), "fresh"),
             "bench": (bench, None, "fresh"), "pedestal": (pedestal, None, "fresh"),
             "tricycle": (tricycle, (0, 0, 1), "fresh"), "dog": (dog, (0, 0, 1), "fresh"),
             "bird": (bird, (0, 0, 1), "fresh"),
             "bottle": (bottle, None, "fresh"), "lamp": (lamp, None, "fresh"),
             "arch": (lambda: merge_meshes([primitives.arch()], "arch"), None, "fresh"),
             "stool": (stool, None, "fresh"), "bed": (bed, (0, 0, 1), "fresh"), "truck": (truck, (0, 0, 1), "fresh"),
             "desk": (desk, (0, 0, 1), "fresh"), "statue": (statue, (0, 0, 1), "fresh"),
             "cat": (cat, (0, 0, 1), "fresh"),
             "robot": (robot, (0, 0, 1), "fresh"), "shelf": (shelf, (0, 0, 1), "fresh"),
             "horse-grazing": (horse_grazing, (0, 0, 1), "fresh"), "giraffe": (giraffe, (0, 0, 1), "fresh"),
             "elephant": (elephant, (0, 0, 1), "fresh"), "lizard": (lizard, (0, 0, 1), "fresh"),
             "leaning-chair": (leaning_chair, (0, 0, 1), "fresh"), "hatchback": (hatchback, (0, 0, 1), "fresh"),
             "sheep": (sheep, (0, 0, 1), "fresh"), "dachshund": (dachshund, (0, 0, 1), "fresh"),
             "wheelbarrow": (wheelbarrow, (0, 0, 1), "fresh"),
             "bear": (bear, (0, 0, 1), "fresh"), "crocodile": (crocodile, (0, 0, 1), "fresh"),
             "rhino": (rhino, (0, 0, 1), "fresh"), "mouse": (mouse, (0, 0, 1), "fresh"),
             "tortoise": (tortoise, (0, 0, 1), "fresh"), "office-chair": (office_chair, (0, 0, 1), "fresh"),
             "pram": (pram, (0, 0, 1), "fresh"), "piano": (piano, (0, 0, 1), "fresh"),
             "kangaroo": (kangaroo, (0, 0, 1), "fresh"), "camel": (camel, (0, 0, 1), "fresh"),
             "deer": (deer, (0, 0, 1), "fresh"), "shopping-cart": (shopping_cart, (0, 0, 1), "fresh"),
             "wheelchair": (wheelchair, (0, 0, 1), "fresh"), "ant": (ant, (0, 0, 1), "fresh"),
             "pig": (pig, (0, 0, 1), "fresh"), "tiger": (tiger, (0, 0, 1), "fresh"),
             "horse-turned": (horse_turned, (0, 0, 1), "fresh"), "goat": (goat, (0, 0, 1), "fresh"),
             "fox": (fox, (0, 0, 1), "fresh"), "hippo": (hippo, (0, 0, 1), "fresh"),
             "dog-sitting": (dog_sitting, (0, 0, 1), "fresh"), "dinosaur": (dinosaur, (0, 0, 1), "fresh"),
             "sofa": (sofa, (0, 0, 1), "fresh"), "rocking-horse": (rocking_horse, (0, 0, 1), "fresh"),
             "wine-glass": (wine_glass, None, "fresh"), "park-bench": (park_bench, (0, 0, 1), "fresh")}


# The wild set: files of a public collection of test meshes (github.com/alecjacobson/common-3d-test-models, its
# data/ folder; horse.ply is inside horse.zip) that were never loaded while the rules were chosen, judged once
# they were fixed. (up in the file, front in the file; None: a flat cut-out, seen from its broad side), read from
# renders of the six sides. The CAD parts there (fandisk, rocker-arm) have no up or front and are left out.
WILD_KNOWN: dict[str, tuple[str, tuple[float, float, float] | None]] = {
    "homer.obj": ("y", (0, 0, 1)), "cheburashka.obj": ("y", (0, 0, 1)), "beast.obj": ("y", (0, 0, 1)),
    "igea.ply": ("y", (0, 0, 1)), "beetle.obj": ("y", (0, 0, 1)), "beetle-alt.obj": ("y", (0, 0, 1)),
    "nefertiti.obj": ("z", (0, -1, 0)), "horse.ply": ("z", (-1, 0, 0)), "woody.obj": ("y", None),
    "alligator.obj": ("y", None),
}


@dataclass
class WildCase(Case):
    file_up: str = "y"  # the up axis in the file
    suffix: str = ".obj"

    def as_distributed(self) -> np.ndarray:
        """The rotation from the stood-up mesh back to the file's own frame."""
        return framing.up_rotation(self.file_up)[:3, :3].T


def wild_cases(wild_dir: Path, only: tuple[str, ...] = ()) -> list[WildCase]:
    """The meshes of WILD_KNOWN found in `wild_dir`, stood up (Y-up) by their known up."""
    import warnings

    from ...scene.meshes import MeshWarning, load_mesh

    out = []
    for name, (up, front) in WILD_KNOWN.items():
        path = Path(wild_dir) / name
        stem = path.stem
        if not path.exists() or (only and stem not in only):
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MeshWarning)
            mesh = load_mesh(path)
        rot = framing.up_rotation(up)
        known = None if front is None else rot[:3, :3] @ np.array(front, float)
        out.append(WildCase(stem, mesh.transformed(rot), known, "wild", up, path.suffix))
    return out


def cases(meshes_dir: Path | None = SHARED_MESHES, only: tuple[str, ...] = ()) -> list[Case]:
    out = [Case(name, make(), None if front is None else np.array(front, float), group)
           for name, (make, front, group) in GENERATED.items()]
    out.append(Case("figure", figure(), np.array([0.0, 0.0, 1.0]), "tune"))
    if meshes_dir is not None and Path(meshes_dir).is_dir():
        import warnings

        from ...scene.meshes import MeshWarning, load_mesh

        for stem, front in SHARED_KNOWN.items():
            path = Path(meshes_dir) / f"{stem}.obj"
            if path.exists():
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", MeshWarning)
                    mesh = load_mesh(path)
                out.append(Case(stem, mesh, None if front is None else np.array(front, float), "tune"))
    return [c for c in out if not only or c.name in only]


def rotations() -> list[np.ndarray]:
    """The 24 proper rotations that map axes to axes (identity first)."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1, -1), repeat=3):
            m = np.zeros((3, 3))
            m[range(3), perm] = signs
            if np.linalg.det(m) > 0:
                out.append(m)
    out.sort(key=lambda m: 0 if np.array_equal(m, np.eye(3)) else 1)
    return out


def judge(case: Case, rot: np.ndarray, suffix: str = ".obj") -> dict[str, Any]:
    """Present `case.mesh` turned by `rot` as a `suffix` file and compare what `orient` finds with the truth."""
    v = case.mesh.vertices @ rot.T
    faces = case.mesh.faces if np.linalg.det(rot) > 0 else case.mesh.faces[:, ::-1]
    true_up = rot @ np.array([0.0, 1.0, 0.0])
    true_front = None if case.front is None else rot @ case.front
    conv_up, conv_front = framing.convention(suffix)
    o = framing.orient(v, faces, suffix)
    found_up = framing.axis_vector(o.up)
    found_front = framing.up_rotation(o.up)[:3, :3].T @ o.front  # back in the file's frame
    up_ok = bool(np.allclose(found_up, true_up))
    if np.allclose(true_up, framing.axis_vector(conv_up)):
        kind = "convention" if true_front is None or np.allclose(true_front, conv_front) else "front turned"
    else:
        kind = "up turned"
    return {"mesh": case.name, "group": case.group, "kind": kind, "up_ok": up_ok,
            "front_ok": None if true_front is None or not up_ok else bool(np.allclose(found_front, true_front)),
            "overrode": bool(o.notes), "up": o.up, "true_up": framing.axis_name(true_up)}


OFF_AXIS_YAWS = (20, 40, 65)  # degrees about +Y: a mesh turned so that no axis mid-plane is its mirror plane


def judge_yawed(case: Case, degrees: float) -> dict[str, Any]:
    """`case.mesh` turned `degrees` about +Y (a model set at an angle in its file) as a Y-up OBJ: its up is still
    +Y, and any override of the up axis is false."""
    a = np.radians(degrees)
    rot = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
    o = framing.orient(case.mesh.vertices @ rot.T, case.mesh.faces, ".obj", front=False)
    return {"mesh": case.name, "group": case.group, "yaw": degrees, "up_ok": o.up == "y", "up": o.up,
            "rule": o.rule}


NOISE = 0.005  # the noisy copies: vertices moved by this share of the diagonal (root mean square)
VARIANTS = ("plain", "noisy", "scaled", "mirrored")
YAWS = {"+z": 0, "+x": 90, "-z": 180, "-x": 270}  # where the true front points, by the turn about +Y


def variant(case: Case, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, faces) of `case.mesh` (Y-up, in its own frame) as a plain, noisy, scaled or mirrored copy, the
    front where it was: noisy, every vertex moved by NOISE of the diagonal (fixed seed); scaled, a thousandth
    the size and moved five diagonals off the origin; mirrored, reflected left to right (faces turned back)."""
    v, f = case.mesh.vertices.astype(np.float64), case.mesh.faces
    if kind == "noisy":
        rng = np.random.default_rng(7)
        v = v + rng.normal(0.0, NOISE * case.mesh.diagonal() / np.sqrt(3.0), v.shape)
    elif kind == "scaled":
        v = v * 1e-3 + 5e-3 * case.mesh.diagonal()
    elif kind == "mirrored":
        side = np.cross([0.0, 1.0, 0.0], case.front)
        v = v - 2.0 * np.outer(v @ side, side)
        f = f[:, ::-1]
    return v, f


def judge_front(case: Case, toward: str, kind: str) -> dict[str, Any]:
    """The `kind` copy of `case.mesh` turned about +Y so that its front points `toward` (+z, +x, -z, -x), given
    as a Y-up OBJ (the up axis given: only the front is judged)."""
    assert case.front is not None
    a = np.radians(YAWS[toward])
    rot = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
    v, f = variant(case, kind)
    truth = rot @ case.front
    o = framing.orient(v @ rot.T, f, ".obj", up="y")
    return {"mesh": case.name, "group": case.group, "toward": framing.axis_name(truth), "variant": kind,
            "front_ok": bool(np.allclose(o.front, truth)), "found": framing.axis_name(o.front),
            "overrode": bool(o.notes), "ratio": o.evidence.get("detail", {}).get("ratio")}


def run_front(all_cases: list[Case], variants: tuple[str, ...] = VARIANTS) -> tuple[list[dict[str, Any]],
                                                                                    dict[str, Any]]:
    """The front table: every case with a known front, its front toward +Z (the convention right), -Z (the file
    faces away) and +-X, in each variant."""
    rows = [judge_front(c, toward, kind) for c in all_cases if c.front is not None for toward in YAWS
            for kind in variants]
    summary: dict[str, Any] = {}
    for group in GROUPS:
        for label, towards in (("front +z", ("z",)), ("front -z", ("-z",)), ("front +-x", ("x", "-x"))):
            sel = [r for r in rows if r["group"] == group and r["toward"] in towards]
            if not sel:
                continue
            summary[f"{group}: {label}"] = {
                "presentations": len(sel), "front found": round(sum(r["front_ok"] for r in sel) / len(sel), 3),
                ("false overrides" if label == "front +z" else "overrides said"):
                    round(sum(r["overrode"] for r in sel) / len(sel), 3)}
    return rows, summary


WITHOUT = {"legs": "the legs' rules of up and front (`framing.stance` finds no feet)",
           "head": "the front's legs rule alone (`framing.head_ends` never decides)"}


@contextlib.contextmanager
def without(rules: tuple[str, ...]) -> Iterator[None]:
    """The framing rules named (WITHOUT) switched off inside the block, to measure what each adds."""
    unknown = set(rules) - set(WITHOUT)
    if unknown:
        raise ValueError(f"without: unknown rule {sorted(unknown)[0]!r}; known: {', '.join(WITHOUT)}")
    with contextlib.ExitStack() as stack:
        if "legs" in rules:
            stack.enter_context(mock.patch.object(framing, "stance", lambda *a, **k: framing.Stance(0, -1.0, False)))
        if "head" in rules:
            stack.enter_context(mock.patch.object(framing, "head_ends", lambda v, f, axes, d: [None] * len(axes)))
        yield


def run(meshes_dir: Path | None = SHARED_MESHES, only: tuple[str, ...] = (), n_rotations: int = 24,
        variants: tuple[str, ...] = VARIANTS, wild_dir: Path | None = None,
        rules_off: tuple[str, ...] = ()) -> dict[str, Any]:
    """The figures of the module docstring (`rules_off`: framing rules switched off, `without`)."""
    with without(tuple(rules_off)):
        out = _run(meshes_dir, only, n_rotations, variants, wild_dir)
    out["without"] = sorted(rules_off)
    return out


def _run(meshes_dir: Path | None, only: tuple[str, ...], n_rotations: int, variants: tuple[str, ...],
         wild_dir: Path | None) -> dict[str, Any]:
    t0 = time.perf_counter()
    rows = []
    to_z_up = np.linalg.inv(framing.up_rotation("z")[:3, :3])  # +Y -> +Z, the front +Z -> -Y: as an STL has it
    all_cases = cases(meshes_dir, only)
    wild = wild_cases(wild_dir, only) if wild_dir is not None else []
    distributed = [dict(judge(c, c.as_distributed(), c.suffix), file=c.name + c.suffix) for c in wild]
    all_cases += wild
    front_rows, front_summary = run_front(all_cases, variants)
    yawed = [judge_yawed(c, a) for c in all_cases for a in OFF_AXIS_YAWS]
    for case in all_cases:
        for rot in rotations()[:n_rotations]:
            rows.append(judge(case, rot))
        rows.append(judge(case, to_z_up, ".stl"))
    summary: dict[str, Any] = {}
    for group in GROUPS:
        for kind in ("convention", "front turned", "up turned"):
            sel = [r for r in rows if r["group"] == group and r["kind"] == kind]
            if not sel:
                continue
            fronts = [r["front_ok"] for r in sel if r["front_ok"] is not None]
            summary[f"{group}: {kind}"] = {
                "presentations": len(sel),
                "up found": round(sum(r["up_ok"] for r in sel) / len(sel), 3),
                "front found (of up found)": round(sum(fronts) / len(fronts), 3) if fronts else None,
                ("false overrides" if kind == "convention" else "overrides said"):
                    round(sum(r["overrode"] for r in sel) / len(sel), 3),
            }
    for group in GROUPS:
        sel = [r for r in yawed if r["group"] == group]
        if sel:
            summary[f"{group}: turned off the axes"] = {
                "presentations": len(sel), "up found": round(sum(r["up_ok"] for r in sel) / len(sel), 3)}
    if distributed:
        fronts = [r["front_ok"] for r in distributed if r["front_ok"] is not None]
        summary["wild: as distributed"] = {
            "files": len(distributed), "up found": round(sum(r["up_ok"] for r in distributed) / len(distributed), 3),
            "front found (of up found)": round(sum(fronts) / len(fronts), 3) if fronts else None,
            "overrides said": round(sum(r["overrode"] for r in distributed) / len(distributed), 3)}
    meshes = {g: sorted({r["mesh"] for r in rows if r["group"] == g}) for g in GROUPS}
    return {"benchmark": "orientation", "meshes": {g: m for g, m in meshes.items() if m}, "summary": summary,
            "front": front_summary, "rows": rows, "front_rows": front_rows, "as_distributed": distributed,
            "turned_off_axes": yawed,
            "seconds": round(time.perf_counter() - t0, 2)}


@click.command(help="Up and front found by the framing of a mesh file, on meshes with a known up and front, "
                    "in the 24 axis-aligned rotations and as a Z-up STL; tune, report and fresh sets apart.")
@click.option("--meshes", "meshes_dir", type=click.Path(path_type=Path), default=None,
              help="Folder of the shared test meshes (default: ../shared/meshes beside the checkout; the generated "
                   "shapes alone where it is absent).")
@click.option("--only", multiple=True, help="Only these meshes (by name; repeat).")
@click.option("--wild", "wild_dir", type=click.Path(path_type=Path, file_okay=False, exists=True), default=None,
              help="Folder with files of github.com/alecjacobson/common-3d-test-models (data/; horse.ply unzipped "
                   "from horse.zip): judged as distributed and turned, as a third set (WILD_KNOWN).")
@click.option("--without", "rules_off", multiple=True, type=click.Choice(tuple(WITHOUT)),
              help="Switch a rule off, to measure what it adds: legs (both legs' rules, up and front) or head (the "
                   "front's alone); repeat for both.")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def command(meshes_dir: Path | None, only: tuple[str, ...], wild_dir: Path | None, rules_off: tuple[str, ...],
            json_path: Path | None) -> None:
    result = run(meshes_dir or SHARED_MESHES, tuple(only), wild_dir=wild_dir, rules_off=tuple(rules_off))
    if rules_off:
        click.echo("without " + "; ".join(WITHOUT[r] for r in sorted(set(rules_off))))
    for group, names in result["meshes"].items():
        click.echo(f"{group} set: {', '.join(names)}")
    if wild_dir is not None and "wild" not in result["meshes"]:
        click.echo(f"wild set: none of {', '.join(WILD_KNOWN)} in {wild_dir}")
    for r in result["as_distributed"]:
        click.echo(f"  as distributed: {r['file']:16s} up {r['up']:>2s} ({'right' if r['up_ok'] else 'wrong'}), "
                   f"front {'-' if r['front_ok'] is None else ('right' if r['front_ok'] else 'wrong')}"
                   + (" (an override said)" if r["overrode"] else ""))
    for key, figures in result["summary"].items():
        click.echo(f"{key}: " + ", ".join(f"{k} {v}" for k, v in figures.items()))
    click.echo(f"front sign (up given; {', '.join(VARIANTS)} copies, front toward +z, -z, +-x):")
    click.echo(f"  {'set: front toward':24s} {'shown':>6s} {'found':>6s} {'overrides':>10s}")
    for key, figures in result["front"].items():
        said = figures.get("false overrides", figures.get("overrides said"))
        click.echo(f"  {key:24s} {figures['presentations']:6d} {figures['front found']:6.3f} {said:10.3f}"
                   + ("  (false)" if "false overrides" in figures else ""))
    misses: dict[str, int] = {}
    for r in result["front_rows"]:
        misses[r["mesh"]] = misses.get(r["mesh"], 0) + (not r["front_ok"])
    click.echo(f"front missed per mesh (of {4 * len(VARIANTS)}): " + ", ".join(f"{m} {k}" for m, k in misses.items()))
    per_mesh: dict[str, list[bool]] = {}
    for r in result["rows"]:
        per_mesh.setdefault(r["mesh"], []).append(r["up_ok"])
    click.echo("up found per mesh (25 presentations): " + ", ".join(f"{m} {sum(v)}" for m, v in per_mesh.items()))
    wrong = [f"{r['mesh']} {r['yaw']}\N{DEGREE SIGN} ({r['up']}, {r['rule']})" for r in result["turned_off_axes"]
             if not r["up_ok"]]
    click.echo(f"turned off the axes about +Y ({', '.join(map(str, OFF_AXIS_YAWS))} degrees), up not found: "
               + (", ".join(wrong) or "none"))
    click.echo(f"{result['seconds']} s")
    text = json.dumps(result, indent=1)
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json_path, text + "\n")
        click.echo(f"wrote {json_path}")
    else:
        click.echo(json.dumps({"summary": result["summary"], "front": result["front"]}))
