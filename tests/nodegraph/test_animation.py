"""Scene YAML keyframes, glTF objects in scene files, and what recomputes per frame."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import numpy as np
import pytest
import yaml

import nodegraph as ng
from nodegraph.errors import PipelineError
from nodegraph.node import HashContext
from nodegraph.scene import scene as sc
from tests import gltf_files as gf

SLIDE = """
fps: 10
objects:
  - name: mover
    primitive: {type: box, size: 0.5}
    transform: {rotate: [0, 30, 0]}
    animate:
      translate:
        - {frame: 0, value: [0, 0, 0]}
        - {frame: 10, value: [2, 0, 0], interpolation: step}
        - {time: 2, value: [2, 2, 0]}
  - name: still
    primitive: {type: sphere, radius: 0.4, subdiv: 2}
    transform: {translate: [0, 0, -2]}
camera:
  eye: [0, 1, 6]
  target: [0, 0, 0]
  animate:
    fov:
      - {time: 0, value: 30, interpolation: smooth}
      - {time: 1, value: 50}
"""


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "scene.yaml"
    p.write_text(text)
    return p


def test_keyframes_interpolate_per_segment(tmp_path):
    scene = sc.load_scene(str(_write(tmp_path, SLIDE)))
    assert scene.animation is not None and list(scene.animation.frame_range()) == list(range(21))
    t = [scene.at(f).objects[0].transform[:3, 3].tolist() for f in (5, 10, 15, 25)]
    assert t == [pytest.approx([1, 0, 0]), pytest.approx([2, 0, 0]), pytest.approx([2, 0, 0]),
                 pytest.approx([2, 2, 0])]  # linear, then a step held to t = 2, the last key held after
    rot = scene.at(5).objects[0].transform[:3, :3]
    assert rot == pytest.approx(sc.euler_xyz([0, 30, 0])[:3, :3])  # the static part of `transform` stays
    assert scene.camera_at(5).fov_y_deg == pytest.approx(40.0)  # smoothstep at the midpoint
    assert scene.camera_at(2).fov_y_deg == pytest.approx(30 + 20 * (0.04 * 3 - 2 * 0.008))
    assert scene.at(3).objects[1] is not None and scene.at(3).objects[1].mesh is scene.objects[1].mesh


def test_keyframe_errors_are_located(tmp_path):
    bad = SLIDE.replace("{time: 2, value: [2, 2, 0]}", "{time: 0.5, value: [2, 2, 0]}")
    with pytest.raises(PipelineError, match=r"scene.yaml:8:\d+: animate: translate: key times must increase"):
        sc.load_scene(str(_write(tmp_path, bad)))
    with pytest.raises(PipelineError, match="exactly one of 'time'"):
        sc.load_scene(str(_write(tmp_path, SLIDE.replace("{frame: 0, value", "{frame: 0, time: 0, value"))))


def test_schema_accepts_animation_and_gltf():
    data = yaml.safe_load(SLIDE)
    jsonschema.validate(data, sc.json_schema())
    jsonschema.validate({"objects": [{"gltf": "walk.glb", "animation": 0}], "camera": "cam"}, sc.json_schema())
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"objects": [{"gltf": "a.glb", "mesh": "b.obj"}]}, sc.json_schema())


def test_gltf_object_in_a_scene_with_its_camera(tmp_path):
    gf.skinned_bar(tmp_path / "bar.glb")
    gf.two_cameras(tmp_path / "cams.glb")
    text = """
objects:
  - gltf: bar.glb
    name: hero
    transform: {translate: [0, 1, 0]}
  - gltf: cams.glb
    color: [0.2, 0.3, 0.4]
    sketchy: false
  - primitive: {type: plane, size: 4}
camera: side
"""
    scene = sc.load_scene(str(_write(tmp_path, text)))
    assert [o.name for o in scene.objects] == ["hero/bar", "cams/box", "plane2"]
    assert scene.objects[1].color == (0.2, 0.3, 0.4) and not scene.objects[1].sketchy
    assert scene.camera.eye == pytest.approx([5, 0, 0])
    tip = scene.at(24).objects[0].world_vertices()[16]  # joint 1 at 90 degrees, lifted by the placement
    assert tip == pytest.approx([0.9, 2.0, 0.1], abs=1e-6)
    assert sc.select_camera(scene, "front").camera.eye == pytest.approx([0, 0, 5])


def test_posed_frames_are_kept_a_few_at_a_time_and_frame_0_for_good(tmp_path, monkeypatch):
    """Scene.at keeps the last few poses and frame 0 (rasterize's spin pass turns every frame against it):
    a film's frames do not pose frame 0 again."""
    scene = sc.load_scene(str(_write(tmp_path, SLIDE)))
    posed: list[int] = []
    pose = type(scene.animation).pose

    def counted(self, s, frame):
        posed.append(frame)
        return pose(self, s, frame)

    monkeypatch.setattr(type(scene.animation), "pose", counted)
    first = scene.at(0)
    for f in range(1, 12):
        assert scene.at(f) is scene.at(f)  # one pose per frame however often it is asked for
        assert scene.at(0) is first
    assert posed == list(range(12))
    assert scene.at(1) is not None and posed[-1] == 1  # frame 1 was let go; frame 0 never was
    kept = [k for k in scene._cache if isinstance(k, tuple) and k[0] == "pose"]
    assert len(kept) <= 5 and ("pose", 0) in kept


def test_static_scene_keys_do_not_change_with_posing():
    scene = sc.load_scene("builtin:torus")
    assert scene.animation is None and scene.at(7) is scene
    h = HashContext((64, 64), 7, 1, scene)
    assert h.scene is scene


@pytest.mark.slow  # 2.9 s
def test_a_moving_object_recomputes_per_frame_a_still_ones_curvature_once(tmp_path):
    """pencil: curvature (per mesh) is computed once over four frames where one of two objects moves rigidly;
    the G-buffer every frame."""
    scene = _write(tmp_path, SLIDE)
    with ng.Session(cache=False) as session:
        pipe = session.load("pencil", scene=scene, size=(96, 96))
        frames = [f for f, _ in pipe.frames(range(4))]
        assert frames == [0, 1, 2, 3]
        counts = session.compute_counts
        assert counts["curv"] == 1
        assert counts["gbuf"] == 4
        assert counts["tam"] == 1
    with ng.Session(cache=False) as session:
        still = _write(tmp_path, "objects:\n  - primitive: {type: box}\n  - primitive: {type: sphere, subdiv: 1}\n"
                       "    transform: {translate: [2, 0, 0]}\n")
        pipe = session.load("pencil", scene=still, size=(96, 96))
        list(pipe.frames(range(3)))
        assert session.compute_counts["curv"] == 1  # (rasterize reads the frame: its G-buffer is per frame)


def test_frames_differ_only_where_the_scene_moves(tmp_path):
    gf.animated_box(tmp_path / "box.glb")
    with ng.Session(cache=False) as session:
        pipe = session.load("nienhaus_sketchy", scene=tmp_path / "box.glb", size=(96, 96))
        imgs = dict(pipe.frames([0, 12, 24]))
    assert not np.array_equal(imgs[0], imgs[12]) and not np.array_equal(imgs[12], imgs[24])
    assert json.dumps(sorted(imgs)) == "[0, 12, 24]"
