"""Generated scene files (Hypothesis): whatever a scene YAML holds, loading it gives a scene whose transforms,
camera and light are finite and posable at a few frames, or one SketchgraphError line naming the file. No
other exception, no traceback, never a silently non-finite scene."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nodegraph.errors import SketchgraphError
from nodegraph.scene.scene import load_scene

GOOD = st.floats(0.05, 5.0)  # most values sensible, so that deeper checks (posing, framing) are reached too
BAD = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.sampled_from([0, -1, 1e-300, 1e12, 1e13, 1e300, -1e300, 2**31, 2**63]),
    st.integers(-10**30, 10**30),
)
NUMBER = st.one_of(GOOD, GOOD, GOOD, BAD)
VALUE = st.one_of(NUMBER, st.booleans(), st.none(), st.text(max_size=6), st.lists(NUMBER, max_size=4))
VEC = st.one_of(st.lists(GOOD, min_size=3, max_size=3), st.lists(GOOD, min_size=3, max_size=3),
                st.lists(NUMBER, min_size=3, max_size=3), VALUE)
PRIMITIVES = ["plane", "box", "sphere", "uv_sphere", "cylinder", "cone", "torus", "ellipsoid", "arch", "nope"]
PRIMITIVE_PARAMS = {"plane": ["size"], "box": ["size"], "sphere": ["radius"], "uv_sphere": ["radius"],
                    "cylinder": ["radius", "height"], "cone": ["radius", "height"], "torus": ["R", "r"],
                    "ellipsoid": ["a", "b", "c"], "arch": ["span", "thickness", "depth"], "nope": ["size"]}
PARAMS = ["size", "radius", "height", "R", "r", "a", "b", "c", "span", "thickness", "depth", "subdiv", "segments"]


@st.composite
def keys(draw: st.DrawFn) -> list[dict]:
    out = []
    for _ in range(draw(st.integers(1, 3))):
        key = {draw(st.sampled_from(["frame", "time"])): draw(NUMBER), "value": draw(VEC)}
        if draw(st.booleans()):
            key["interpolation"] = draw(st.sampled_from(["linear", "step", "smooth", "cubic", 3]))
        out.append(key)
    return out


@st.composite
def scene_doc(draw: st.DrawFn) -> dict:
    objects = []
    for _ in range(draw(st.integers(1, 3))):
        prim = {"type": draw(st.sampled_from(PRIMITIVES))}
        names = PRIMITIVE_PARAMS[prim["type"]] if draw(st.integers(0, 3)) else PARAMS  # now and then a wrong one
        for name in draw(st.lists(st.sampled_from(names), max_size=3, unique=True)):
            prim[name] = draw(st.one_of(NUMBER, VEC))
        obj: dict = {"primitive": prim}
        if draw(st.booleans()):
            obj["transform"] = {k: draw(VEC) for k in draw(st.lists(st.sampled_from(["translate", "rotate", "scale"]),
                                                                      max_size=3, unique=True))}
        if draw(st.booleans()):
            obj["animate"] = {k: draw(keys()) for k in draw(st.lists(st.sampled_from(["translate", "rotate", "scale"]),
                                                                       min_size=1, max_size=2, unique=True))}
        objects.append(obj)
    doc: dict = {"objects": objects}
    if draw(st.booleans()):
        doc["camera"] = {k: draw(VEC if k in ("eye", "target", "up") else NUMBER)
                         for k in draw(st.lists(st.sampled_from(["eye", "target", "up", "fov", "near", "far"]),
                                                max_size=4, unique=True))}
    if draw(st.booleans()):
        doc["light"] = {"direction": draw(VEC)}
    if draw(st.booleans()):
        doc["orbit"] = {"axis": draw(VEC), "degrees_per_frame": draw(NUMBER)}
    if draw(st.booleans()):
        doc["fps"] = draw(NUMBER)
    return doc


def _finite(scene) -> bool:
    cam = scene.camera
    parts = [np.asarray(o.transform, float) for o in scene.objects]
    parts += [np.asarray(o.mesh.vertices, float) for o in scene.objects]
    parts += [np.asarray(cam.view_projection(1.0), float), np.asarray(scene.light_direction, float)]
    return all(np.isfinite(p).all() for p in parts)


@settings(max_examples=200, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(doc=scene_doc())
def test_generated_scene_files_load_finite_or_fail_in_one_line(tmp_path_factory: pytest.TempPathFactory,
                                                               doc: dict) -> None:
    p = tmp_path_factory.mktemp("scene") / "s.yaml"
    p.write_text(yaml.safe_dump(doc, allow_unicode=True))
    try:
        scene = load_scene(p)
        posed = [scene.at(f) if getattr(scene, "animation", None) is not None else scene for f in (0, 1, 7)]
    except SketchgraphError as exc:
        msg = str(exc)
        assert "\n" not in msg and len(msg) < 600 and msg.startswith(str(p)), msg
        return
    for s in posed:
        assert _finite(s), doc
