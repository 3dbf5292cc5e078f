"""Framing a bare mesh file: the up axis and the front (the format's convention unless the shape says otherwise),
the named views and the fill (`--view`, `--up`, `--fill`, scene files' `view:` / `up:`, `ng.load(view=, up=)`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from nodegraph.scene import framing, primitives
from nodegraph.scene.meshes import Mesh, MeshWarning, load_mesh, merge_meshes
from nodegraph.scene.scene import load_scene, scene_for_mesh, translation
from nodegraph.tools.bench import orientation
from nodegraph.tools.bench.orientation import quadruped

PIPE = """pipeline: t
size: [96, 96]
scene: {scene}
nodes:
  g: {{type: rasterize}}
outputs:
  image: g.normal_depth
"""


def _box(lo, hi) -> Mesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return primitives.box(hi - lo).transformed(translation((lo + hi) / 2))


def figure() -> Mesh:
    """A Y-up 'character' of boxes facing +Z: a flat base, feet and a nose pointing forward, arms, a head."""
    parts = [_box((-0.6, 0.0, -0.4), (0.6, 0.1, 0.4)),  # base
             _box((-0.3, 0.1, -0.12), (-0.08, 0.2, 0.35)), _box((0.08, 0.1, -0.12), (0.3, 0.2, 0.35)),  # feet
             _box((-0.3, 0.2, -0.15), (0.3, 1.1, 0.15)),  # body
             _box((-0.45, 0.55, -0.08), (-0.3, 1.05, 0.08)), _box((0.3, 0.55, -0.08), (0.45, 1.05, 0.08)),  # arms
             _box((-0.2, 1.1, -0.18), (0.2, 1.5, 0.18)),  # head
             _box((-0.05, 1.22, 0.18), (0.05, 1.34, 0.38))]  # nose
    return merge_meshes(parts, "figure")


def write_obj(path: Path, mesh: Mesh, matrix: np.ndarray | None = None) -> Path:
    v = mesh.vertices if matrix is None else mesh.transformed(matrix).vertices
    path.write_text("".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in v)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in mesh.faces))
    return path


def write_stl(path: Path, mesh: Mesh, matrix: np.ndarray) -> Path:
    m = mesh.transformed(matrix)
    lines = ["solid t"]
    for face in m.faces:
        corners = [f"vertex {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in m.vertices[face]]
        lines += ["facet normal 0 0 0", "outer loop", *corners]
        lines += ["endloop", "endfacet"]
    path.write_text("\n".join(lines + ["endsolid t"]) + "\n")
    return path


TO_Z_UP = np.linalg.inv(framing.up_rotation("z"))  # +Y -> +Z, +Z (the front) -> -Y, as Blender has it
TO_X_FRONT = np.array([[0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]], float)  # front +Z -> +X


def coverage(gl, scene: str, **kw) -> np.ndarray:
    pipe = pl.loads(PIPE.format(scene=scene), "t.yaml", **kw)
    return Executor(pipe, None, gl=gl).run().values[("g", "normal_depth")].read()[..., 3] > 0


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum()) / float((a | b).sum())


@pytest.fixture
def files(tmp_path: Path) -> dict[str, Path]:
    fig = figure()
    return {"y": write_obj(tmp_path / "fig_y.obj", fig), "z": write_obj(tmp_path / "fig_z.obj", fig, TO_Z_UP),
            "stl": write_stl(tmp_path / "fig_z.stl", fig, TO_Z_UP),
            "x_front": write_obj(tmp_path / "fig_xf.obj", fig, TO_X_FRONT)}


def test_up_keeps_the_file_convention_unless_the_shape_says_otherwise(files) -> None:
    fig = figure()
    assert framing.detect_up(fig.vertices, fig.faces, ".obj") == "y"
    z = fig.transformed(TO_Z_UP)
    assert framing.detect_up(z.vertices, z.faces, ".stl") == "z"  # STL's convention
    assert framing.detect_up(z.vertices, z.faces, ".obj") == "y"  # it lies on its back, as an OBJ says: --up z
    ball = primitives.sphere(1.0, 2)  # no evidence either way: the format decides
    assert framing.detect_up(ball.vertices, ball.faces, ".stl") == "z"
    assert framing.detect_up(ball.vertices, ball.faces, ".obj") == "y"
    for key in ("y", "stl"):
        s = load_scene(str(files[key]))
        lo, hi = s.bounds()
        assert hi[1] - lo[1] == pytest.approx(1.5), key  # standing: the figure's height along +Y


def test_a_vertical_mirror_plane_overrides_the_convention() -> None:
    """A head with a nose and ears (no legs) written with its left-right axis along Y (a Z-up scan read as Y-up
    lies on its side): Y cannot be up; it is stood up along another axis and the line says so."""
    head = orientation.GENERATED["head"][0]()
    lying = head.transformed(np.linalg.inv(framing.up_rotation("x")))  # +Y (up) -> +X, +X (left-right) -> -Y
    o = framing.orient(lying.vertices, lying.faces, ".obj")
    assert o.notes and "mirror-symmetric across y" in o.notes[0]
    assert o.up[-1] != "y"
    with pytest.warns(framing.FramingWarning, match="stood up along"):
        scene_for_mesh(lying, "lying.obj")


def test_legs_stand_a_lying_animal_up() -> None:
    """The four-legged animal lying on its side (its up along +X, its left-right along Y): it stands on four feet
    with +X up and on nothing else, so it is stood up along +X exactly, and the line says so."""
    lying = quadruped().transformed(np.linalg.inv(framing.up_rotation("x")))
    o = framing.orient(lying.vertices, lying.faces, ".obj")
    assert o.up == "x"
    assert o.notes and "stands on 4 feet" in o.notes[0] and "`--up y`" in o.notes[0]
    assert o.evidence["feet"] == {"x": 4}
    with pytest.warns(framing.FramingWarning, match=r"stood up along x: it stands on 4 feet"):
        scene = scene_for_mesh(lying, "lying.obj")
    lo, hi = scene.bounds()
    assert hi[1] - lo[1] == pytest.approx(1.95, abs=1e-6)  # standing: legs, body and head along +Y
    upright = framing.orient(quadruped().vertices, quadruped().faces, ".obj")  # the convention holds, silently
    assert upright.up == "y" and not any("stood up" in n for n in upright.notes)


@pytest.mark.slow
def test_legs_stand_an_insect_up_in_every_rotation() -> None:
    """The bench's insect (six splayed legs) in each of the 24 axis-aligned rotations, as an OBJ: up is found
    every time, by the legs where the file's Y is not up."""
    insect = orientation.GENERATED["insect"][0]()
    for rot in orientation.rotations():
        row = orientation.judge(orientation.Case("insect", insect, np.array([0.0, 0.0, 1.0]), "fresh"), rot)
        assert row["up_ok"], row


def test_a_flat_base_on_another_axis_leaves_legs_undecided() -> None:
    """A chair on its side stands on four legs one way, but rests as well on its flat back, a side of another
    axis: the legs alone do not override the convention. A table on its side rests on its flat top too, but
    that is the other end of its legs' own axis: it is stood on its legs."""
    chair = orientation.GENERATED["chair"][0]()
    side = chair.transformed(np.linalg.inv(framing.up_rotation("x")))
    o = framing.orient(side.vertices, side.faces, ".obj")
    assert not any("feet" in n for n in o.notes) and o.up != "x"
    table = orientation.GENERATED["table"][0]().transformed(np.linalg.inv(framing.up_rotation("x")))
    o = framing.orient(table.vertices, table.faces, ".obj")
    assert o.up == "x" and "stands on 4 feet" in o.notes[0]


def _stool(legs: bool = True) -> Mesh:
    """A seat 1 x 0.1 x 1 at height 1 on four 0.1 x 1 x 0.1 legs in its corners (or the seat alone)."""
    parts = [_box((-0.5, 1.0, -0.5), (0.5, 1.1, 0.5))]
    if legs:
        parts += [_box((x, 0.0, z), (x + 0.1, 1.0, z + 0.1)) for x in (-0.5, 0.4) for z in (-0.5, 0.4)]
    return merge_meshes(parts, "stool")


def test_stance_by_hand() -> None:
    """A stool stands on 4 feet up +Y, its centre of mass (0, ., 0) inside the square of its legs by 0.5 (its
    half width) over the diagonal; on its seat (up -Y) it has one contact; the seat alone has no feet either way;
    legs of one slab rising from the floor (bumps a flank lies on) are not legs."""
    stool = _stool()
    v, f = stool.vertices.astype(np.float64), stool.faces
    p = framing.surface_samples(v, f, framing.LEG_SAMPLES)
    com = framing.surface_centroid(v, f)
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    up = framing.stance(p, com, "y", diag)
    assert up.feet == 4 and up.legs and up.stands
    assert up.margin == pytest.approx(0.5 / diag, abs=0.01)  # samples stop a little inside the legs' corners
    assert framing.stance(p, com, "-y", diag).feet == 1 and not framing.stance(p, com, "-y", diag).stands
    seat = _stool(legs=False)
    ps = framing.surface_samples(seat.vertices, seat.faces, framing.LEG_SAMPLES)
    for axis in framing.SIGNED_AXES:
        assert not framing.stance(ps, framing.surface_centroid(seat.vertices, seat.faces), axis, diag).stands
    # bumps 2% high under a slab: apart at the floor, joined within LEG_HEIGHT of the height
    bumps = merge_meshes([_box((-0.5, 0.02, -0.5), (0.5, 0.3, 0.5))]
                         + [_box((x, 0.0, -0.1), (x + 0.1, 0.02, 0.1)) for x in (-0.45, 0.35)], "bumps")
    pb = framing.surface_samples(bumps.vertices, bumps.faces, framing.LEG_SAMPLES)
    st = framing.stance(pb, framing.surface_centroid(bumps.vertices, bumps.faces), "y", diag)
    assert st.feet == 2 and not st.legs and not st.stands


TURN_Z = TO_X_FRONT @ TO_X_FRONT  # half a turn about +Y: the front +Z -> -Z
SPOT = Path(__file__).resolve().parents[3] / "shared" / "meshes" / "spot.obj"


def _framed(mesh: Mesh, source: str = "m.obj") -> tuple[np.ndarray, list[str]]:
    """(the default camera's direction target -> eye, the FramingWarning lines) of a mesh file."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cam = scene_for_mesh(mesh, source).camera
    lines = [str(w.message) for w in caught if issubclass(w.category, framing.FramingWarning)]
    return cam.eye - cam.target, lines


def test_front_keeps_the_convention_unless_the_other_end_shows_more_detail() -> None:
    fig = figure()
    assert np.array_equal(framing.detect_front(fig.vertices, fig.faces), [0, 0, 1])
    back = fig.transformed(TURN_Z)  # facing -Z: its nose and feet show little more than its back (1.1x)
    assert np.array_equal(framing.detect_front(back.vertices, back.faces), [0, 0, 1])
    animal = quadruped()  # clearly mirror-symmetric across X only
    assert np.array_equal(framing.detect_front(animal.vertices, animal.faces), [0, 0, 1])
    turned = animal.transformed(TO_X_FRONT)  # Z now runs left to right: the front is +-X, +X unless -X shows more
    choice = framing.front_choice(turned.vertices, turned.faces)
    assert choice.across_z and np.array_equal(choice.front, [1, 0, 0])
    away = animal.transformed(np.linalg.inv(TO_X_FRONT))  # a box head shows no more than a box rump: a guess
    choice = framing.front_choice(away.vertices, away.faces)
    assert choice.across_z and abs(choice.front[0]) == 1.0
    assert "do not say which end" in choice.note()


def test_the_front_lies_in_the_upright_mirror_plane() -> None:
    """The boxes figure is mirror-symmetric left to right, and its nose and feet make it a little less so front to
    back: too little for a clean mirror plane (`mirror_axis`), enough for the finer `mirror_distance`; turned to
    face +-X its front axis is X."""
    fig = figure()
    p = framing.surface_samples(fig.vertices, fig.faces)
    scale = float(np.linalg.norm(np.ptp(p, axis=0)))
    assert framing.mirror_axis([framing.asymmetry(p, k, scale) for k in range(3)]) is None
    assert framing.mirror_distance(p, 2, scale) >= framing.MIRROR_RATIO * framing.mirror_distance(p, 0, scale)
    assert framing.upright_mirror(p, scale) == 0
    for turn in (TO_X_FRONT, np.linalg.inv(TO_X_FRONT)):
        turned = fig.transformed(turn)
        choice = framing.front_choice(turned.vertices, turned.faces)
        assert choice.across_z and abs(choice.front[0]) == 1.0
        d, lines = _framed(turned)
        assert abs(d[0]) > abs(d[2]) and len(lines) == 1 and "mirror-symmetric across z" in lines[0]


def test_a_figure_lying_with_its_left_right_axis_up_is_stood_up() -> None:
    """The boxes figure turned so that its left-right axis is Y, its up Z and its front X, as an OBJ: its mirror
    plane lies across Y by `mirror_plane` (not clean by `asymmetry`'s 4 % count), so Y is not up; it stands along Z."""
    turn = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # x -> y, y -> z, z -> x
    fig = figure()
    v = fig.vertices @ turn.T
    p = framing.surface_samples(v, fig.faces)
    scale = float(np.linalg.norm(np.ptp(p, axis=0)))
    assert framing.mirror_axis([framing.asymmetry(p, k, scale) for k in range(3)]) is None
    assert framing.mirror_plane(p, scale) == 1
    o = framing.orient(v, fig.faces, ".obj")
    assert o.up == "z" and o.evidence["mirror"] == "y"
    assert o.notes[0].startswith("stood up along z: the mesh is mirror-symmetric across y")
    assert np.allclose(framing.up_rotation(o.up)[:3, :3].T @ o.front, turn @ [0.0, 0.0, 1.0])  # its front: +X


def _yawed(v: np.ndarray, degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    return v @ np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]]).T


def test_a_mesh_turned_about_its_up_off_the_axes_keeps_its_up() -> None:
    """A Y-up van, sedan or box robot (the orientation bench's) turned 20-65 degrees about Y has no axis mid-plane
    for a mirror plane; its top and bottom halves mirror each other less badly than its turned sides do across the
    X and Z mid-planes, which stood it up along Z ("mirror-symmetric across y") before the principal planes were
    weighed. Its mirror plane is a principal plane (`off_axis_mirror`), so Y stays up and nothing is said."""
    for make in (orientation.van, orientation.sedan, orientation.robot):
        mesh = make()
        for degrees in (20.0, 40.0, 65.0):
            v = _yawed(mesh.vertices, degrees)
            p = framing.surface_samples(v, mesh.faces)
            scale = float(np.linalg.norm(np.ptp(p, axis=0)))
            along = [framing.mirror_distance(p, k, scale) for k in range(3)]
            assert framing.MIRROR_RATIO * framing.off_axis_mirror(p, scale) <= min(along)
            assert framing.mirror_plane(p, scale) is None
            o = framing.orient(v, mesh.faces, ".obj")
            assert o.up == "y" and not any(n.startswith("stood up") for n in o.notes), (mesh.name, degrees, o.notes)


def test_the_legs_of_a_mesh_turned_off_the_axes_do_not_stand_it_across_its_mirror_plane() -> None:
    """The office chair turned 20 degrees about Y: no axis mid-plane is its mirror plane, so none was left out of
    the legs' rule, and it stood along X on two "feet" of its side. Its turned mirror plane's normal lies 20
    degrees from X: X runs left to right and is not tried (`turned_mirror`)."""
    mesh = orientation.office_chair()
    v = _yawed(mesh.vertices, 20.0)
    p = framing.surface_samples(v, mesh.faces)
    normal = framing.turned_mirror(p, float(np.linalg.norm(np.ptp(p, axis=0))))
    assert normal is not None and abs(normal[0]) > np.cos(np.radians(25.0))
    o = framing.orient(v, mesh.faces, ".obj")
    assert o.up == "y" and not o.notes, o.notes


def test_the_principal_plane_of_an_axis_mirror_is_that_plane() -> None:
    """Where an axis mid-plane is the mirror plane, the principal planes find nothing closer: the boxes figure keeps
    its upright mirror plane across X, and turned 90 degrees about Y, across Z."""
    fig = figure()
    for degrees, axis in ((0.0, 0), (90.0, 2)):
        v = _yawed(fig.vertices, degrees)
        p = framing.surface_samples(v, fig.faces)
        scale = float(np.linalg.norm(np.ptp(p, axis=0)))
        assert framing.off_axis_mirror(p, scale) >= framing.mirror_distance(p, axis, scale) / framing.MIRROR_RATIO
        assert framing.upright_mirror(p, scale) == axis


def test_a_flat_cut_out_has_no_upright_mirror() -> None:
    """A thin plate is its own mirror image across its thin axis, whichever way it faces: no front from that."""
    for size in ((1.0, 1.5, 0.02), (0.02, 1.5, 1.0)):
        plate = primitives.box(size)
        p = framing.surface_samples(plate.vertices, plate.faces)
        assert framing.upright_mirror(p, float(np.linalg.norm(np.ptp(p, axis=0)))) is None


def test_the_orientation_bench_judges_wild_files_as_distributed(tmp_path: Path) -> None:
    """A file named as one of WILD_KNOWN's (here the boxes figure written Z-up, its front -Y, as nefertiti.obj)
    is stood up by its known up and judged as the file has it: a Z-up OBJ is an up-turned presentation."""
    write_obj(tmp_path / "nefertiti.obj", figure(), TO_Z_UP)
    result = orientation.run(meshes_dir=None, only=("nefertiti",), n_rotations=1, variants=("plain",),
                             wild_dir=tmp_path)
    assert result["meshes"] == {"wild": ["nefertiti"]}
    (row,) = result["as_distributed"]
    assert row["file"] == "nefertiti.obj" and row["kind"] == "up turned" and row["true_up"] == "z"
    assert row["up_ok"] == (row["up"] == "z")
    assert result["summary"]["wild: as distributed"]["files"] == 1
    ident = [r for r in result["rows"] if r["kind"] == "convention"]
    assert len(ident) == 2 and all(r["up_ok"] for r in ident)  # stood up (Y-up) as an OBJ, and as the STL


def test_a_head_facing_away_is_seen_from_its_face_and_the_line_says_so() -> None:
    head = orientation.face()  # a nose, eyes under brows and a mouth toward +Z
    d, lines = _framed(head)
    assert d[2] > 0 and lines == []
    d, lines = _framed(head.transformed(TURN_Z))
    assert d[2] < 0
    assert len(lines) == 1 and lines[0].startswith("face: seen from -z: ")
    assert "the feature lines of the file's front (+z)" in lines[0] and "`--view back`" in lines[0]
    ratio = float(lines[0].split(": ")[2].split("x ")[0])
    assert ratio >= framing.DETAIL_MARGIN
    front = framing.front_choice(head.transformed(TURN_Z).vertices, head.faces)
    assert np.array_equal(front.front, [0, 0, -1])


def test_an_stl_facing_away_names_its_own_axes() -> None:
    head = orientation.face().transformed(TURN_Z)  # facing -Z; as an STL (Z-up), the file's front is -Y
    d, lines = _framed(head.transformed(TO_Z_UP), "away.stl")
    assert d[2] < 0  # stood up: seen from its face
    assert len(lines) == 1 and lines[0].startswith("face: seen from +y: ") and "file's front (-y)" in lines[0]


@pytest.mark.parametrize("name", ["sphere", "box", "cube"])
def test_a_featureless_shape_keeps_the_convention_without_a_word(name: str) -> None:
    mesh = {"sphere": lambda: primitives.sphere(1.0, 3), "box": lambda: primitives.box((1.0, 0.6, 1.4)),
            "cube": lambda: primitives.box(1.0)}[name]()
    for m in (mesh, mesh.transformed(TURN_Z)):
        choice = framing.front_choice(m.vertices, m.faces)
        assert np.array_equal(choice.front, [0, 0, 1]) and choice.note() is None
        d, lines = _framed(m)
        assert d[2] > 0 and lines == []


def test_visible_detail_is_deterministic_and_free_of_scale_position_and_mirror() -> None:
    head = orientation.face()
    plus, minus, width = framing.visible_detail(head.vertices, head.faces, 2)
    assert (plus, minus, width) == framing.visible_detail(head.vertices, head.faces, 2)
    assert plus > 2.0 * minus > 0.0  # the face shows the nose, the eyes, the brows and the mouth
    small = head.vertices * 1e-3 + 7.0  # pixel edges fall a rounding apart: a few samples change sides
    assert np.allclose(framing.visible_detail(small, head.faces, 2), (plus * 1e-3, minus * 1e-3, width * 1e-3),
                       rtol=0.02)
    mirrored = head.vertices * [-1.0, 1.0, 1.0]
    assert np.allclose(framing.visible_detail(mirrored, head.faces[:, ::-1], 2), (plus, minus, width), rtol=0.02)
    flipped = framing.visible_detail(head.vertices, head.faces[:, ::-1], 2)  # wound inside out: the same lines
    assert np.allclose(flipped, (plus, minus, width), rtol=1e-9)


@pytest.mark.skipif(not SPOT.exists(), reason=f"the shared meshes are absent ({SPOT.parent})")
def test_spot_is_seen_from_its_face() -> None:
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)
        spot = load_mesh(SPOT)
    d, lines = _framed(spot, str(SPOT))
    assert d[2] < 0  # spot's file faces -Z: its head and neck reach past its forelegs, its rump hardly past its hind
    assert len(lines) == 1 and lines[0].startswith("spot: seen from -z: it stands on 4 feet and ")
    assert "(a head)" in lines[0] and "`--view back` looks at the file's front" in lines[0]


def test_axis_facing_by_hand() -> None:
    # a sphere: the caps within 10 degrees of the six axis directions, 6 x (1 - cos 10deg) / 2 of its area
    ball = primitives.sphere(1.0, 5)
    expected = 3.0 * (1.0 - np.cos(np.radians(framing.HEAD_BUILT_DEG)))
    assert framing.axis_facing(ball.vertices, ball.faces) == pytest.approx(expected, abs=0.01)
    cube = primitives.box(1.0)
    assert framing.axis_facing(cube.vertices, cube.faces) == 1.0
    turned = cube.transformed(np.array([[0.6, 0, 0.8, 0], [0, 1, 0, 0], [-0.8, 0, 0.6, 0], [0, 0, 0, 1]]))
    assert framing.axis_facing(turned.vertices, turned.faces) == pytest.approx(1.0 / 3.0)  # its top and bottom


def _long_animal() -> Mesh:
    """Four legs 0.1 x 0.8 x 0.1 at x +-0.3, z +-0.5 under a body 0.8 x 0.4 x 2.2 running from z = -0.6 to 1.6."""
    legs = [_box((x - 0.05, 0.0, z - 0.05), (x + 0.05, 0.8, z + 0.05)) for x in (-0.3, 0.3) for z in (-0.5, 0.5)]
    return merge_meshes([*legs, _box((-0.4, 0.8, -0.6), (0.4, 1.2, 1.6))], "long")


def test_head_ends_by_hand(monkeypatch) -> None:
    animal = _long_animal()
    assert framing.head_ends(animal.vertices, animal.faces, (2, 0), 1.0) == [None, None]  # boxes: built
    monkeypatch.setattr(framing, "HEAD_BUILT", 1.01)
    diag = float(np.linalg.norm([0.8, 1.2, 2.2]))
    # the feet reach z = +-0.55; past 0.55 + HEAD_GAP x diag lie the body's four sides (perimeter 2.4) over the
    # rest of its length and its end (0.8 x 0.4); nothing lies past -0.55 - gap; all of it over the total area
    # (the body 2 x (0.8 x 0.4 + 0.8 x 2.2 + 0.4 x 2.2) = 5.92, the legs 4 x (4 x 0.08 + 2 x 0.01) = 1.36)
    reach = 1.6 - (0.55 + framing.HEAD_GAP * diag)
    expected = (2.4 * reach + 0.32) / (5.92 + 1.36)
    (sign, feet, plus, minus), across = framing.head_ends(animal.vertices, animal.faces, (2, 0), diag)
    assert (sign, feet, minus) == (1.0, 4, 0.0)
    assert plus == pytest.approx(expected, abs=0.015)  # 20000 samples
    assert across is None  # the body (x +-0.4) stays within the feet (x +-0.35) and the gap (0.05) sideways
    away = animal.transformed(TURN_Z)
    [(sign, feet, plus_away, minus_away)] = framing.head_ends(away.vertices, away.faces, (2,), diag)
    assert (sign, feet, plus_away) == (-1.0, 4, 0.0) and minus_away == pytest.approx(expected, abs=0.015)
    even = merge_meshes([*(_box((x - 0.05, 0.0, z - 0.05), (x + 0.05, 0.8, z + 0.05)) for x in (-0.3, 0.3)
                           for z in (-0.5, 0.5)), _box((-0.4, 0.8, -1.1), (0.4, 1.2, 1.1))], "even")
    assert framing.head_ends(even.vertices, even.faces, (2,), diag) == [None]  # as much past the feet at each end


def test_the_legs_choose_the_axis_where_the_mirror_plane_is_wrong(monkeypatch) -> None:
    monkeypatch.setattr(framing, "HEAD_BUILT", 1.01)
    side = _long_animal().transformed(TO_X_FRONT)  # its head toward +X
    monkeypatch.setattr(framing, "upright_mirror", lambda *a: None)  # no mirror plane found: the axis would be Z
    choice = framing.front_choice(side.vertices, side.faces, mirror=None)
    assert np.array_equal(choice.front, [1, 0, 0]) and choice.legs_axis and choice.feet == 4
    assert (choice.axis, choice.detail_axis) == (0, 2)
    note = choice.note()
    assert note.startswith("seen from +x: it stands on 4 feet and ") and "neither end of z stands out so" in note
    assert note.endswith("`--front z` keeps the file's front")
    back = framing.FrontChoice.decode(choice.encode())
    assert back.legs_axis and np.array_equal(back.front, choice.front) and back.axis == 0
    assert not framing.FrontChoice.decode(choice.encode()[:10]).legs_axis  # a memo written before the axis rule
    monkeypatch.setattr(framing, "upright_mirror", lambda *a: 2)  # the mirror plane across Z: along X already
    choice = framing.front_choice(side.vertices, side.faces)
    assert np.array_equal(choice.front, [1, 0, 0]) and not choice.legs_axis


def test_an_animal_facing_away_is_seen_from_its_head() -> None:
    dog = orientation.dog()  # ellipsoids and rods: grown, not built; its head reaches past its forelegs at +Z
    choice = framing.front_choice(dog.vertices, dog.faces)
    assert np.array_equal(choice.front, [0, 0, 1]) and choice.feet == 4 and choice.note() is None
    d, lines = _framed(dog.transformed(TURN_Z))
    assert d[2] < 0 and len(lines) == 1 and lines[0].startswith("dog: seen from -z: it stands on 4 feet and ")
    d, lines = _framed(dog.transformed(TO_X_FRONT))  # Z runs left to right: along X, toward its head
    assert d[0] > 0 and "mirror-symmetric across z" in lines[0] and "(a head)" in lines[0]
    d, _ = _framed(dog.transformed(np.linalg.inv(TO_X_FRONT)))
    assert d[0] < 0
    back = framing.FrontChoice.decode(choice.encode())
    assert (back.feet, back.beyond_plus, back.beyond_minus) == (choice.feet, choice.beyond_plus, choice.beyond_minus)
    assert framing.FrontChoice.decode(choice.encode()[:7]).feet == 0  # a memo written before the rule


def test_orientation_bench_on_the_convention_presentations() -> None:
    result = orientation.run(meshes_dir=None, only=("head", "quadruped", "vase", "table", "van", "face"),
                             n_rotations=1, variants=("plain",))
    conv = result["summary"]["report: convention"]
    assert conv["up found"] == 1.0 and conv["false overrides"] == 0.0
    assert conv["front found (of up found)"] == 1.0
    front = result["front"]
    assert front["report: front +z"]["front found"] == 1.0 and front["report: front +z"]["false overrides"] == 0.0
    away = [r for r in result["front_rows"] if r["toward"] == "-z"]
    assert [r["mesh"] for r in away if r["front_ok"]] == ["face"]  # the one with a modelled face
    assert all(r["overrode"] == r["front_ok"] for r in away)


def test_a_z_up_copy_is_drawn_like_the_y_up_original(gl, files) -> None:
    ref = coverage(gl, str(files["y"]))
    assert iou(coverage(gl, str(files["z"]), up="z"), ref) >= 0.95
    assert iou(coverage(gl, str(files["stl"])), ref) >= 0.95  # auto, STL: Z-up by convention
    assert iou(coverage(gl, str(files["z"]), up="y"), ref) < 0.8  # taken as Y-up it lies on its back
    assert iou(coverage(gl, str(files["z"])), ref) < 0.8  # as an OBJ says (auto: no strong evidence against)


def _drawn_fill(mask: np.ndarray) -> float:
    rows, cols = np.nonzero(mask.any(axis=1))[0], np.nonzero(mask.any(axis=0))[0]
    return max(rows[-1] - rows[0] + 1, cols[-1] - cols[0] + 1) / min(mask.shape)


@pytest.mark.parametrize("name", ["sphere", "box", "figure", "sheet_flat", "sheet_standing"])
def test_the_subject_fills_80_to_90_percent_of_the_frame(gl, tmp_path: Path, name: str) -> None:
    standing = np.array([[0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)  # +Y normal -> -X
    mesh = {"sphere": lambda: primitives.sphere(1.0, 3), "box": lambda: primitives.box((1.0, 0.6, 1.4)),
            "figure": figure, "sheet_flat": lambda: primitives.plane(2.0, 8),
            "sheet_standing": lambda: primitives.plane(2.0, 8).transformed(standing)}[name]()
    path = write_obj(tmp_path / f"{name}.obj", mesh)
    for size in ((96, 96), (128, 80)):
        mask = coverage(gl, str(path), size=size)
        assert 0.80 <= _drawn_fill(mask) <= 0.90, (name, size, _drawn_fill(mask))
    if name.startswith("sheet"):  # seen face-on: along the sheet's normal
        cam = load_scene(str(path)).camera
        normal = framing.broad_side(mesh.vertices, mesh.faces)
        assert abs(abs(float(np.dot(cam.basis()[2], normal))) - 1.0) < 1e-9
    half = coverage(gl, str(path), size=(96, 96), fill=0.5)
    assert 0.45 <= _drawn_fill(half) <= 0.55


def test_an_unused_vertex_far_away_changes_nothing(tmp_path: Path) -> None:
    fig = figure()
    far = fig.vertices.max(axis=0) + 5 * fig.diagonal()
    with_far = Mesh("figure", np.vstack([fig.vertices, far]), fig.faces)
    a, b = scene_for_mesh(fig, "f.obj").camera, scene_for_mesh(with_far, "f.obj").camera
    assert np.allclose(a.eye, b.eye) and np.allclose(a.target, b.target) and np.allclose(a.up, b.up)
    path = write_obj(tmp_path / "far.obj", with_far)
    with pytest.warns(MeshWarning, match="dropped 1 vertex no face uses"):
        loaded = load_mesh(path)
    assert loaded.n_vertices == fig.n_vertices
    assert np.allclose(load_scene(str(path)).camera.eye, a.eye)


def test_views_give_the_expected_silhouettes(gl, files) -> None:
    y = str(files["y"])
    front, back = coverage(gl, y, view="front"), coverage(gl, y, view="back")
    left, right = coverage(gl, y, view="left"), coverage(gl, y, view="right")
    assert iou(front, back[:, ::-1]) >= 0.9  # mirror images of each other
    assert iou(left, right[:, ::-1]) >= 0.9
    assert iou(front, left) < 0.8  # the figure is wider than deep
    rows = np.nonzero(front.any(axis=1))[0]
    assert front.sum() > 0 and rows.max() - rows.min() > 40  # standing: tall in the picture
    assert iou(right, right[:, ::-1]) < 0.97  # the side shows the nose and the feet: not its own mirror
    s = load_scene(y, view="top")
    assert np.allclose(s.camera.basis()[2], [0, -1, 0])
    tq = load_scene(y).camera  # default: three-quarter front, from above and to the right
    d = tq.eye - tq.target
    assert d[2] > 0 and d[1] > 0 and d[0] > 0


def test_framing_options_are_errors_where_they_do_not_apply(tmp_path: Path, files) -> None:
    with pytest.raises(PipelineError, match="own camera"):
        load_scene("builtin:box", view="front")
    with pytest.raises(PipelineError, match="up"):
        load_scene(str(files["y"]), up="w")
    scene = tmp_path / "s.yaml"
    scene.write_text(f"objects:\n  - mesh: {files['z']}\n")
    with pytest.raises(PipelineError, match="per mesh object"):
        load_scene(str(scene), up="z")


def test_scene_files_take_view_and_up(tmp_path: Path, files) -> None:
    scene = tmp_path / "s.yaml"
    scene.write_text(f"objects:\n  - mesh: {files['z']}\n    up: z\ncamera: {{view: front, fov: 30}}\n")
    s = load_scene(str(scene))
    lo, hi = s.bounds()
    assert hi[1] - lo[1] == pytest.approx(1.5)
    assert np.allclose(s.camera.basis()[2], [0, 0, -1]) and s.camera.fov_y_deg == 30
    scene.write_text(f"objects:\n  - mesh: {files['z']}\n    up: auto\n")
    assert load_scene(str(scene), view="left").camera.eye[0] < 0
    scene.write_text("objects:\n  - primitive: {type: box}\ncamera: {view: front, eye: [0, 0, 5]}\n")
    with pytest.raises(PipelineError, match="not both"):
        load_scene(str(scene))
    scene.write_text("objects:\n  - primitive: {type: box}\n    up: z\n")
    with pytest.raises(PipelineError, match="stands a mesh file up"):
        load_scene(str(scene))


def test_api_and_cli_take_view_and_up(gl, files, tmp_path: Path) -> None:
    from click.testing import CliRunner

    import nodegraph as ng
    from nodegraph.cli import main

    def cli(*args: str):
        return CliRunner().invoke(main, list(args), catch_exceptions=False)

    sketchy = str(Path(__file__).parents[2] / "pipelines" / "nienhaus_sketchy.yaml")
    pipe = ng.load(sketchy, scene=files["z"],
                   view="front", up="z", size=(64, 48))
    cam = pipe.pipeline.scene.camera
    assert np.allclose(cam.basis()[2], [0, 0, -1])
    assert pipe.set({"edges.width": 2}).pipeline.scene.camera.params() == cam.params()
    out = tmp_path / "o.png"
    with pytest.raises(PipelineError, match="fill"):
        load_scene(str(files["y"]), fill=0)
    with pytest.raises(PipelineError, match="own camera"):
        load_scene("builtin:box", fill=0.8)
    r = cli("run", sketchy, "--scene", str(files["z"]), "--up", "z", "--view", "back", "--fill", "0.7",
            "--size", "64x48", "--no-cache", "-q", "-o", str(out))
    assert r.exit_code == 0, r.output
    assert out.exists()
    r = cli("run", sketchy, "--view", "front", "--no-cache", "-q", "-o", str(out))
    assert r.exit_code == 2 and "own camera" in r.output


def test_front_is_given_in_the_file_axes(gl, files, tmp_path: Path) -> None:
    from click.testing import CliRunner

    import nodegraph as ng
    from nodegraph.cli import main
    from nodegraph.scene import views

    dog = orientation.dog().transformed(TURN_Z)  # facing -Z: the legs' rule finds it, and says so
    path = write_obj(tmp_path / "dog.obj", dog)
    d, lines = _framed(dog, str(path))
    assert d[2] < 0 and len(lines) == 1
    with views.facing("z"):  # the file's +Z, its tail: no rule asked, nothing said
        d, lines = _framed(dog, str(path))
    assert d[2] > 0 and lines == []
    with views.facing("x"):
        assert _framed(dog, str(path))[0][0] > 0
    with views.facing({str(path.resolve()): "z"}):  # the benchmarks' form: by file
        assert _framed(dog, str(path))[0][2] > 0
        assert _framed(dog, str(tmp_path / "other.obj"))[0][2] < 0
    with views.facing("-y"):  # STL: Z-up, its front -Y as Blender has it; -y is then the front's file axis
        stl = write_stl(tmp_path / "dog.stl", orientation.dog(), TO_Z_UP)
        assert load_scene(str(stl)).camera.eye[2] > 0
    with views.facing("y"), pytest.raises(PipelineError, match="stands up along y, so its front faces across it"):
        load_scene(str(path))
    with views.facing("z"), pytest.raises(PipelineError, match="--front faces a mesh file"):
        load_scene("builtin:box")
    scene = tmp_path / "s.yaml"
    scene.write_text(f"objects:\n  - mesh: {path}\n")
    with views.facing("z"), pytest.raises(PipelineError, match="--front faces a mesh file"):
        load_scene(str(scene))
    sketchy = str(Path(__file__).parents[2] / "pipelines" / "nienhaus_sketchy.yaml")
    pipe = ng.load(sketchy, scene=str(path), front="z", size=(64, 48))
    assert pipe.pipeline.scene.camera.eye[2] > 0
    assert pipe.set({"edges.width": 2}).pipeline.scene.camera.params() == pipe.pipeline.scene.camera.params()
    assert ng.load(sketchy, scene=str(path), size=(64, 48)).pipeline.scene.camera.eye[2] < 0
    with pytest.raises(PipelineError, match="front"):
        ng.load(sketchy, scene=str(path), front="w")
    out = tmp_path / "o.png"
    r = CliRunner().invoke(main, ["run", sketchy, "--scene", str(path), "--front", "z", "--size", "64x48",
                                  "--no-cache", "-q", "-o", str(out)], catch_exceptions=False)
    assert r.exit_code == 0 and "seen from" not in r.output, r.output
    assert views.FRONT.get() is None  # the option does not outlive its command


def test_benchmarks_see_the_shared_meshes_from_fixed_sides() -> None:
    from nodegraph import distributed as dist
    from nodegraph.scene import views
    from nodegraph.tools.bench import sides

    fixed = sides.fixed()
    assert fixed[str((sides.SHARED_MESHES / "spot.obj").resolve())] == "z"
    with views.facing(fixed):
        spec = dist.PipeSpec.make("nienhaus_sketchy", scene=str(sides.SHARED_MESHES / "spot.obj"))
    hash(spec)  # the spec stays hashable: the sides travel as sorted pairs
    assert dict(spec.facing) == fixed
    if not SPOT.exists():
        pytest.skip(f"the shared meshes are absent ({SPOT.parent})")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)
        with views.facing(fixed):
            pinned = load_scene(str(SPOT)).camera
        found = load_scene(str(SPOT)).camera
    assert pinned.eye[2] > 0 > found.eye[2]  # spot's file +Z (its back) for the benchmarks; its face otherwise


def test_the_orientation_bench_switches_rules_off() -> None:
    def away(rules_off: tuple[str, ...]) -> float:
        result = orientation.run(meshes_dir=None, only=("dog",), n_rotations=1, variants=("plain",),
                                 rules_off=rules_off)
        assert result["without"] == sorted(rules_off)
        return result["front"]["fresh: front -z"]["front found"]

    assert away(()) == 1.0  # its head, past its forelegs
    assert away(("head",)) == 0.0 == away(("legs",))  # a plain head: the feature lines do not decide
    with pytest.raises(ValueError, match="unknown rule 'nose'"):
        orientation.run(meshes_dir=None, only=("dog",), rules_off=("nose",))
    assert framing.head_ends.__name__ == "head_ends" and framing.stance.__name__ == "stance"  # switched back on after
