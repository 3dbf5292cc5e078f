"""Which glTF animations play (all together by default, one by name or index), how clips of different lengths
end (hold or loop), the note that lists them, the frame range, and the framing of camera-less animated files;
on files built in code (tests/gltf_files.py), against hand-computed positions."""

from __future__ import annotations

import math
import warnings

import click
import numpy as np
import pytest
from click.testing import CliRunner

from nodegraph.errors import PipelineError
from nodegraph.scene import framing, views
from nodegraph.scene import scene as sc
from nodegraph.scene.animation import AnimationNote, default_frames, loop_time
from tests import gltf_files as gf

FPS = 24


def positions(scene, frame: int) -> dict[str, np.ndarray]:
    """World position of each object's origin at `frame`."""
    return {o.name: o.transform[:3, 3].copy() for o in scene.at(frame).objects}


def quiet_scene(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AnimationNote)
        return sc.scene_from_gltf(path, **kw)


# 'slide': a from x = 0 to 2 over 1 s; 'lift': b (z = -3) from y = 0 to 4 over 2 s; both LINEAR
def slide_x(t: float) -> float:
    return 2.0 * min(max(t, 0.0), 1.0)


def lift_y(t: float) -> float:
    return 4.0 * min(max(t, 0.0), 2.0) / 2.0


def test_every_clip_plays_together_by_default(tmp_path):
    scene = quiet_scene(gf.two_clips(tmp_path / "two.glb"))
    for frame in (0, 6, 12, 24, 30, 48):
        t = frame / FPS
        pos = positions(scene, frame)
        assert pos["a"] == pytest.approx([slide_x(t), 0, 0], abs=1e-6)
        assert pos["b"] == pytest.approx([0, lift_y(t), -3], abs=1e-6)
    assert default_frames(scene) == list(range(49))  # the longest clip: 2 s at 24 fps


@pytest.mark.parametrize("which", [1, "1", "lift"])
def test_one_clip_by_index_or_name(tmp_path, which):
    scene = quiet_scene(gf.two_clips(tmp_path / "two.glb"), animation=which)
    for frame in (0, 12, 36, 48):
        pos = positions(scene, frame)
        assert pos["a"] == pytest.approx([0, 0, 0], abs=1e-9)  # the first clip does not play
        assert pos["b"] == pytest.approx([0, lift_y(frame / FPS), -3], abs=1e-6)
    assert default_frames(scene) == list(range(49))


def test_the_frame_range_follows_the_clips_played(tmp_path):
    path = gf.two_clips(tmp_path / "two.glb")
    slide = quiet_scene(path, animation="slide")
    assert default_frames(slide) == list(range(25))  # 1 s
    assert positions(slide, 24)["b"] == pytest.approx([0, 0, -3])
    assert default_frames(quiet_scene(path, animation="all")) == list(range(49))


def test_hold_and_loop_against_hand_computed_positions(tmp_path):
    path = gf.two_clips(tmp_path / "two.glb")
    hold = quiet_scene(path)
    loop = quiet_scene(path, animation_end="loop")
    # 'slide' lasts 1 s: held at x = 2 after it; looped, each later second (k, k + 1] replays (0, 1]
    expected_loop = {0: 0.0, 12: 1.0, 24: 2.0, 30: 0.5, 36: 1.0, 42: 1.5, 48: 2.0}
    for frame, x in expected_loop.items():
        assert positions(loop, frame)["a"][0] == pytest.approx(x, abs=1e-6)
        assert positions(hold, frame)["a"][0] == pytest.approx(min(frame / FPS, 1.0) * 2.0, abs=1e-6)
        # the longest clip is the same either way
        assert positions(loop, frame)["b"][1] == pytest.approx(lift_y(frame / FPS), abs=1e-6)
    assert default_frames(loop) == list(range(49))
    assert loop_time(2.5, 1.0) == pytest.approx(0.5) and loop_time(3.0, 1.0) == pytest.approx(1.0)
    assert loop_time(0.25, 1.0) == 0.25 and loop_time(-1.0, 1.0) == -1.0


def test_the_note_lists_the_clips_once(tmp_path):
    path = gf.two_clips(tmp_path / "two.glb")
    with pytest.warns(AnimationNote) as caught:
        sc.scene_from_gltf(path)
    notes = [str(w.message) for w in caught if issubclass(w.category, AnimationNote)]
    assert len(notes) == 1
    assert notes[0] == ("two.glb: 2 animations: 0 'slide' 1 s, 1 'lift' 2 s; all play together, the shorter "
                        "holding their last pose (--animation NAME|INDEX|all)")
    assert "\n" not in notes[0]
    with pytest.warns(AnimationNote, match="playing 0 'slide'"):
        sc.scene_from_gltf(path, animation=0)


def test_one_clip_files_say_nothing_and_keep_their_keys(tmp_path):
    path = gf.animated_box(tmp_path / "box.glb")
    with warnings.catch_warnings():
        warnings.simplefilter("error", AnimationNote)
        scene = sc.scene_from_gltf(path)
    # the only clip plays as the file has it: the scene's key is the one --animation 0 gives
    assert scene.animation.digest() == sc.scene_from_gltf(path, animation=0).animation.digest()
    assert positions(scene, 12)["mover"] == pytest.approx([1, 0, 0])


@pytest.mark.parametrize("which, found", [("walk", "'walk': no such animation"),
                                          (2, "animation 2: no such animation"), ("-1", "animation -1")])
def test_bad_choices_are_one_line_listing_the_clips(tmp_path, which, found):
    with pytest.raises(PipelineError) as err:
        quiet_scene(gf.two_clips(tmp_path / "two.glb"), animation=which)
    text = str(err.value)
    assert found in text and "0 'slide' 1 s, 1 'lift' 2 s (or all)" in text and "\n" not in text


def test_indices_are_the_files_even_when_a_clip_is_left_out(tmp_path):
    b = gf.Builder()
    box = b.node(mesh=b.mesh(gf.BOX_V, gf.BOX_F), name="box")
    b.animate(box, "translation", [0.0, 1.0], np.array([[0, 0, 0], [0, 0, 0]]), name="ext", clip=0)
    b.doc.animations[0].channels[0].target = gf.g.AnimationChannelTarget(path="pointer")  # an extension's
    b.animate(box, "translation", [0.0, 1.0], np.array([[0, 0, 0], [0, 3, 0]]), name="up", clip=1)
    path = b.save(tmp_path / "ext.gltf")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = sc.scene_from_gltf(path, animation=1)
        assert positions(scene, 12)["box"] == pytest.approx([0, 1.5, 0])
        with pytest.raises(PipelineError, match=r"animation 0: no such animation; the file's animations: 1 'up' 1 s"):
            sc.scene_from_gltf(path, animation=0)


def test_no_animations_refuses_a_choice_but_not_all(tmp_path):
    path = gf.two_cameras(tmp_path / "cams.glb")
    assert quiet_scene(path, animation="all").animation is None
    with pytest.raises(PipelineError, match="has no animations"):
        quiet_scene(path, animation=0)
    with pytest.raises(PipelineError, match="expected one of hold, loop"):
        quiet_scene(path, animation_end="bounce")


def test_a_shared_channel_goes_to_the_later_clip_with_a_note(tmp_path):
    path = gf.two_clips(tmp_path / "shared.glb", shared=True)
    with pytest.warns(AnimationNote, match=r"the later clip in the file wins: translation of node 0 'a': clip 1 "
                                           r"over clip 0"):
        scene = sc.scene_from_gltf(path)
    assert positions(scene, 12)["a"] == pytest.approx([10.5, 0, 0], abs=1e-6)  # 'lift': 10 -> 12 over 2 s
    assert positions(quiet_scene(path, animation="slide"), 12)["a"] == pytest.approx([1, 0, 0], abs=1e-6)


def test_a_clip_that_moves_only_the_camera_plays(tmp_path):
    b = gf.Builder()
    b.node(mesh=b.mesh(gf.BOX_V, gf.BOX_F), name="box")
    b.doc.cameras.append(gf.g.Camera(type="perspective", name="cam",
                                     perspective=gf.g.Perspective(yfov=0.8, znear=0.1, zfar=50.0)))
    cam = b.node(camera=0, name="cam_node", translation=[0.0, 0.0, 5.0])
    box2 = b.node(mesh=b.mesh(gf.BOX_V, gf.BOX_F), name="box2", translation=[3.0, 0.0, 0.0])
    b.animate(box2, "scale", [0.0, 0.5], np.array([[1, 1, 1], [2, 2, 2]]), name="grow", clip=0)
    b.animate(cam, "translation", [0.0, 1.0], np.array([[0, 0, 5], [0, 0, 9]]), name="dolly", clip=1)
    scene = quiet_scene(b.save(tmp_path / "dolly.glb"))  # the camera's clip is the second: it plays too
    assert scene.at(24).camera.eye == pytest.approx([0, 0, 9])
    assert scene.at(12).camera.eye == pytest.approx([0, 0, 7])
    only = quiet_scene(tmp_path / "dolly.glb", animation="dolly")
    assert default_frames(only) == list(range(25))
    assert only.at(12).camera.eye == pytest.approx([0, 0, 7])


def test_scene_yaml_animation_and_animation_end(tmp_path):
    gf.two_clips(tmp_path / "two.glb")
    text = "objects:\n  - gltf: two.glb\n    animation: {a}\n    animation_end: loop\n"
    (tmp_path / "s.yaml").write_text(text.format(a="slide"))
    scene = sc.scene_from_yaml(tmp_path / "s.yaml")
    assert positions(scene, 12)["two/b"] == pytest.approx([0, 0, -3])
    assert default_frames(scene) == list(range(25))
    (tmp_path / "all.yaml").write_text(text.format(a="all"))
    with pytest.warns(AnimationNote, match="all play together, the shorter looping"):
        scene = sc.scene_from_yaml(tmp_path / "all.yaml")
    assert positions(scene, 30)["two/a"] == pytest.approx([0.5, 0, 0], abs=1e-6)  # looped
    (tmp_path / "bad.yaml").write_text(text.format(a="walk"))
    with pytest.raises(PipelineError, match=r"bad.yaml:2:\d+: .*'walk': no such animation"):
        quiet_scene_yaml(tmp_path / "bad.yaml")
    (tmp_path / "mesh.yaml").write_text("objects:\n  - primitive: {type: box}\n    animation: 0\n")
    with pytest.raises(PipelineError, match="'animation' and 'animation_end' are for a 'gltf' file"):
        sc.scene_from_yaml(tmp_path / "mesh.yaml")


def quiet_scene_yaml(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AnimationNote)
        return sc.scene_from_yaml(path, **kw)


def test_command_line_options_reach_every_scene_and_never_leak(tmp_path):
    """--animation and --animation-end (views.click_options) win over a scene YAML's; a later command
    without them plays the defaults again."""
    gf.two_clips(tmp_path / "two.glb")
    (tmp_path / "s.yaml").write_text("objects:\n  - gltf: two.glb\n    animation: slide\n")

    @click.command()
    @click.argument("scene")
    @views.click_options
    def show(scene: str, view: str | None, up: str | None, fill: float | None) -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AnimationNote)
            s = sc.load_scene(scene)
        pos = positions(s, 36)
        click.echo(f"{pos['two/a' if 'two/a' in pos else 'a'][0]:.3f} {pos['two/b' if 'two/b' in pos else 'b'][1]:.3f}"
                   f" {len(default_frames(s))}")

    runner = CliRunner()
    glb, yaml_path = str(tmp_path / "two.glb"), str(tmp_path / "s.yaml")
    bad = runner.invoke(show, [glb, "--animation-end", "bounce"])
    assert bad.exit_code == 2 and "hold" in bad.output and "loop" in bad.output
    assert runner.invoke(show, [glb, "--animation", "1"]).output.split() == ["0.000", "3.000", "49"]
    assert runner.invoke(show, [glb, "--animation-end", "loop"]).output.split() == ["1.000", "3.000", "49"]
    assert runner.invoke(show, [glb]).output.split() == ["2.000", "3.000", "49"]  # nothing left over
    assert runner.invoke(show, [yaml_path]).output.split() == ["2.000", "0.000", "25"]
    assert runner.invoke(show, [yaml_path, "--animation", "all"]).output.split() == ["2.000", "3.000", "49"]
    assert views.ANIMATION.get() is None and views.ANIMATION_END.get() is None  # back as they were


def test_the_python_api_passes_animation_choices(tmp_path):
    import nodegraph as ng

    path = gf.two_clips(tmp_path / "two.glb")
    with views.playing("lift", "hold"):
        scene = quiet_scene(path)
    assert positions(scene, 12)["a"] == pytest.approx([0, 0, 0])
    assert views.ANIMATION.get() is None and views.ANIMATION_END.get() is None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AnimationNote)
        pipe = ng.load("nienhaus_sketchy", scene=str(path), animation=1)
        assert positions(pipe.pipeline.scene, 12)["a"] == pytest.approx([0, 0, 0])
        assert positions(pipe.pipeline.scene, 12)["b"] == pytest.approx([0, 1, -3])
        looped = ng.load("nienhaus_sketchy", scene=str(path), animation_end="loop")
        assert positions(looped.pipeline.scene, 36)["a"] == pytest.approx([1, 0, 0])
        # a pipe made from it by set() plays the same
        assert positions(looped.set({"edges.normal_threshold": 0.5}).pipeline.scene, 36)["a"] == pytest.approx(
            [1, 0, 0])
    assert views.ANIMATION.get() is None and views.ANIMATION_END.get() is None
    with pytest.raises(ValueError, match="animation_end='bounce'"):
        ng.load("nienhaus_sketchy", scene=str(path), animation_end="bounce")
    with pytest.raises(TypeError, match="animation=True"):
        ng.load("nienhaus_sketchy", scene=str(path), animation=True)
    with pytest.raises(PipelineError, match="'walk': no such animation"):
        ng.load("nienhaus_sketchy", scene=str(path), animation="walk")


# --- framing of camera-less animated files (framing.motion_view) ----------------------------------------


def spans(scene, frame: int) -> tuple[np.ndarray, np.ndarray]:
    """NDC bounding box (lo, hi) of every object's vertices at `frame`, through the scene's camera (square)."""
    posed = scene.at(frame)
    ndc = np.vstack([scene.camera.project(o.world_vertices())[:, :2] for o in posed.objects])
    return ndc.min(axis=0), ndc.max(axis=0)


def half(lo: np.ndarray, hi: np.ndarray) -> float:
    return float(max(hi - lo)) / 2.0


FILL = framing.DEFAULT_FILL
SHARE = framing.MOTION_MIN_SHARE


def test_a_short_walk_is_framed_readable_at_frame_0_and_kept_in_view(tmp_path):
    scene = quiet_scene(gf.walking_figure(tmp_path / "walk.glb", distance=3.0))
    lo0, hi0 = spans(scene, 0)
    # frame 0 is framed as a still would be at half size: the subject spans SHARE of FILL
    assert half(lo0, hi0) == pytest.approx(SHARE * FILL, rel=0.03)
    # and the whole walk stays inside the picture (sampled every 4 frames)
    for frame in range(0, 49, 4):
        lo, hi = spans(scene, frame)
        assert np.all(lo >= -1.0) and np.all(hi <= 1.0), frame


def test_a_long_walk_is_capped_at_half_its_still_size_and_starts_inside(tmp_path):
    scene = quiet_scene(gf.walking_figure(tmp_path / "walk.glb", distance=12.0))
    lo, hi = spans(scene, 0)
    assert half(lo, hi) == pytest.approx(SHARE * FILL, rel=0.03)
    assert np.all(lo >= -FILL - 1e-6) and np.all(hi <= FILL + 1e-6)  # the subject at frame 0 is in the picture
    # slid toward the walk (+x, to the right of the picture) as far as allowed: it starts at the left edge
    assert lo[0] == pytest.approx(-FILL, abs=0.05)
    lo6, hi6 = spans(scene, 6)  # a quarter second later it is still in the picture
    assert np.all(lo6 >= -1.0) and np.all(hi6 <= 1.0)
    # framing the bounding sphere of the whole walk (the rule this replaces) shows it at a third of that size
    every = np.vstack([o.world_vertices() for f in range(0, 49, 4) for o in scene.at(f).objects])
    old = sc.frame_camera(every.min(axis=0), every.max(axis=0), direction=framing.THREE_QUARTER)
    ndc = old.project(scene.at(0).objects[0].world_vertices())[:, :2]
    assert half(lo, hi) > 2.5 * half(ndc.min(axis=0), ndc.max(axis=0))


@pytest.mark.parametrize("grow, capped", [(1.5, False), (4.0, True)])
def test_a_morphing_sphere_is_readable_at_frame_0(tmp_path, grow, capped):
    scene = quiet_scene(gf.morphing_sphere(tmp_path / "ball.glb", grow=grow))
    lo, hi = spans(scene, 0)
    first = half(lo, hi)
    assert first >= SHARE * FILL * 0.98  # never a dot: at least half of what a still would span
    assert (lo + hi) / 2.0 == pytest.approx([0, 0], abs=0.02)  # it grows about its centre: centred
    lo_end, hi_end = spans(scene, 24)
    if capped:
        assert first == pytest.approx(SHARE * FILL, rel=0.03)
    else:  # the whole growth fits: the largest sphere spans FILL, the first about FILL / grow
        assert half(lo_end, hi_end) == pytest.approx(FILL, rel=0.02)
        # a sphere of radius r at distance D spans r / sqrt(D^2 - r^2) in tangent units (its silhouette cone)
        t = math.tan(math.radians(scene.camera.fov_y_deg) / 2.0)
        dist = float(np.linalg.norm(scene.camera.eye))
        assert first == pytest.approx(1.0 / math.sqrt(dist ** 2 - 1.0) / t, rel=0.03)
        assert half(lo_end, hi_end) == pytest.approx(grow / math.sqrt(dist ** 2 - grow ** 2) / t, rel=0.03)


def test_still_files_keep_their_framing(tmp_path):
    """A file without animations is framed as before (fit_view of its vertices from its widest side)."""
    b = gf.Builder()
    b.node(mesh=b.mesh(gf.BOX_V, gf.BOX_F), name="box")
    path = b.save(tmp_path / "still.glb")
    scene = sc.scene_from_gltf(path)
    mesh = sc.merge_meshes([o.mesh.transformed(o.transform) for o in scene.objects], "still")
    ref = sc.fit_camera(mesh.vertices, sc.best_view_direction(mesh))
    assert scene.camera.eye == pytest.approx(ref.eye) and scene.orbit is not None


def test_a_distributed_spec_carries_the_choice_to_its_workers(tmp_path):
    from nodegraph import distributed as dist

    path = gf.two_clips(tmp_path / "two.glb")
    with views.playing("slide", "loop"):
        spec = dist.PipeSpec.make("nienhaus_sketchy", scene=str(path), size="32x32")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AnimationNote)
        scene = spec.open().scene  # opened where --animation was never given, as a worker does
    assert positions(scene, 30)["a"] == pytest.approx([0.5, 0, 0], abs=1e-6)  # 'slide' looped
    assert positions(scene, 24)["b"] == pytest.approx([0, 0, -3])  # 'lift' does not play
    assert default_frames(scene) == list(range(25))
