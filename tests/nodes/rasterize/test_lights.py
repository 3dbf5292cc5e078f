"""Punctual lights (KHR_lights_punctual, scene YAML `lights:`): rasterize's lit colour of a quad facing +Z against
the Lambert irradiance written out by hand in float64 (E = I cos / d^2, the range window, the spot cone)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from nodegraph.errors import PipelineError
from nodegraph.scene import lights as lights_mod
from nodegraph.scene.meshes import MeshWarning
from nodegraph.scene.scene import load_scene
from tests import gltf_files
from tests.helpers import run_minimal

W, H = 64, 48
CAMERA = "camera: {eye: [0, 0, 4], target: [0, 0, 0], fov: 40, near: 1, far: 10}\n"
QUAD = ("objects:\n  - primitive: {type: plane, size: 2, subdiv: 2}\n    transform: {rotate: [90, 0, 0]}\n"
        "    color: [1, 1, 1]\n")


def quad_points(scene) -> tuple[np.ndarray, np.ndarray]:
    """float64 per pixel centre (row 0 = bottom): the point where the eye ray meets the plane z = 0, and
    whether it lies inside the quad's [-1, 1]^2 by more than a pixel (no edge pixels)."""
    cam = scene.camera_at(0)
    inv = np.linalg.inv(cam.projection_matrix(W / H) @ cam.view_matrix())
    xs, ys = np.meshgrid((np.arange(W) + 0.5) / W * 2 - 1, (np.arange(H) + 0.5) / H * 2 - 1)
    ndc = np.stack([xs, ys, -np.ones_like(xs), np.ones_like(xs)], axis=-1)
    near, far = ndc @ inv.T, (ndc * [1, 1, -1, 1]) @ inv.T
    p0 = near[..., :3] / near[..., 3:]
    d = far[..., :3] / far[..., 3:] - p0
    p = p0 - (p0[..., 2:3] / d[..., 2:3]) * d
    inside = (np.abs(p[..., 0]) < 0.93) & (np.abs(p[..., 1]) < 0.93)
    return p, inside


def render(gl, tmp_path, text: str, ambient: float = 0.0) -> tuple[np.ndarray, object]:
    path = tmp_path / "lit.yaml"
    path.write_text(text)
    _, res = run_minimal(gl, f"  g: {{type: rasterize, params: {{lit: true, ambient: {ambient}}}}}\n",
                         {"image": "g.color"}, size=(W, H), scene=str(path))
    return res.values[("g", "color")].read()[..., :3], load_scene(str(path))


def point_e(p: np.ndarray, pos, intensity: float, rng: float | None = None) -> np.ndarray:
    """Lambert irradiance of a point light at `pos` on the plane z = 0, normal +Z, by hand."""
    delta = np.asarray(pos, float) - p
    d = np.linalg.norm(delta, axis=-1)
    e = intensity * (delta[..., 2] / d) / d**2
    if rng is not None:
        e = e * np.clip(1.0 - (d / rng) ** 4, 0.0, 1.0)
    return e


TOL = 2.5 / 255  # RGBA8 rounding and float32 shading


def test_point_light_matches_hand_lambert(gl, tmp_path):
    img, scene = render(gl, tmp_path, QUAD + CAMERA + "exposure: 1\nlights:\n"
                        "  - {type: point, position: [0.4, 0.3, 1.0], intensity: 0.8}\n")
    p, inside = quad_points(scene)
    ref = point_e(p, (0.4, 0.3, 1.0), 0.8)
    assert inside.sum() > 600 and ref[inside].max() > 0.75 and ref[inside].min() < 0.25
    for c in range(3):
        np.testing.assert_allclose(img[..., c][inside], ref[inside], atol=TOL)
    assert np.all(img[~inside & (np.abs(p[..., 0]) > 1.07)] == 0.0)  # background untouched


def test_point_light_range_window_and_colour_with_ambient(gl, tmp_path):
    img, scene = render(gl, tmp_path, QUAD + CAMERA + "exposure: 1\nlights:\n"
                        "  - {type: point, position: [0, 0, 0.8], intensity: 0.6, range: 1.25, "
                        "color: [1, 0.5, 0.25]}\n",
                        ambient=0.2)
    p, inside = quad_points(scene)
    e = point_e(p, (0, 0, 0.8), 0.6, 1.25)
    assert (e[inside] == 0.0).sum() > 20  # the range window cuts the corners off
    for c, k in enumerate((1.0, 0.5, 0.25)):
        np.testing.assert_allclose(img[..., c][inside], 0.2 + 0.8 * np.minimum(k * e[inside], 1.0), atol=TOL)


def test_spot_light_cone_matches_hand_value(gl, tmp_path):
    img, scene = render(gl, tmp_path, QUAD + CAMERA + "exposure: 1\nlights:\n"
                        "  - {type: spot, position: [0.2, 0, 2], direction: [0, 0, -1], intensity: 3, "
                        "inner_cone: 10, outer_cone: 25}\n")
    p, inside = quad_points(scene)
    delta = np.array([0.2, 0.0, 2.0]) - p
    d = np.linalg.norm(delta, axis=-1)
    cos_axis = delta[..., 2] / d  # the angle from the spot's axis (0, 0, -1)
    lo, hi = math.cos(math.radians(25)), math.cos(math.radians(10))
    spot = np.clip((cos_axis - lo) / (hi - lo), 0.0, 1.0) ** 2
    ref = 3.0 * spot * (delta[..., 2] / d) / d**2
    assert (ref[inside] == 0.0).sum() > 100 and (ref[inside] > 0.7).sum() > 20  # outside the cone, inside it
    np.testing.assert_allclose(img[..., 0][inside], ref[inside], atol=TOL)


def test_directional_and_point_lights_add(gl, tmp_path):
    img, scene = render(gl, tmp_path, QUAD + CAMERA + "exposure: 1\nlights:\n"
                        "  - {type: directional, direction: [0.3, -0.2, -1], intensity: 0.4, color: [1, 0.5, 0.25]}\n"
                        "  - {type: point, position: [-0.5, 0, 1.2], intensity: 0.5}\n")
    p, inside = quad_points(scene)
    cos = 1.0 / math.sqrt(0.3**2 + 0.2**2 + 1.0)
    e = point_e(p, (-0.5, 0, 1.2), 0.5)
    for c, k in enumerate((1.0, 0.5, 0.25)):
        np.testing.assert_allclose(img[..., c][inside], np.minimum(0.4 * cos * k + e[inside], 1.0), atol=TOL)


def test_auto_exposure_makes_the_brightest_point_one(gl, tmp_path):
    """A point light over the quad's centre (a vertex): exposure = 1 / E(centre) = h^2 / I, so the colour is
    (h / d)^3 whatever the intensity."""
    img, scene = render(gl, tmp_path, QUAD + CAMERA + "lights:\n  - {type: point, position: [0, 0, 0.7], "
                        "intensity: 25}\n")
    assert scene.exposure == pytest.approx(0.7**2 / 25, rel=1e-12)
    p, inside = quad_points(scene)
    ref = (0.7 / np.linalg.norm(np.array([0, 0, 0.7]) - p, axis=-1)) ** 3
    np.testing.assert_allclose(img[..., 1][inside], ref[inside], atol=TOL)
    assert img[..., 1][inside].max() > 0.97


def test_gltf_point_light_shades_and_is_no_longer_left_out(gl, tmp_path):
    path = gltf_files.lit_quad(tmp_path / "lit.gltf", [{"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 3.0,
                                                        "name": "bulb"}],
                               [{"light": 0, "translation": [0.0, 0.0, 1.0], "name": "lamp"}])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_scene(str(path))
    assert not [w for w in caught if issubclass(w.category, MeshWarning) and "light" in str(w.message)]
    (light,) = scene.lights
    assert light.kind == "point" and light.name == "bulb" and light.intensity == 3.0
    np.testing.assert_allclose(light.position, [0.0, 0.0, 1.0])
    assert scene.exposure == pytest.approx(1.0 / 3.0, rel=1e-12)  # E(centre) = 3 cd / 1 m^2, red channel
    yaml = tmp_path / "s.yaml"
    yaml.write_text(f"objects:\n  - gltf: {path.name}\n" + CAMERA)
    _, res = run_minimal(gl, "  g: {type: rasterize, params: {lit: true, ambient: 0}}\n", {"image": "g.color"},
                         size=(W, H), scene=str(yaml))
    img = res.values[("g", "color")].read()[..., :3]
    p, inside = quad_points(load_scene(str(yaml)))
    base = (1.0 / np.linalg.norm(np.array([0, 0, 1.0]) - p, axis=-1)) ** 3
    for c, k in enumerate((1.0, 0.5, 0.25)):
        np.testing.assert_allclose(img[..., c][inside], k * base[inside], atol=TOL)


def test_gltf_spot_and_directional_lights_follow_their_nodes(tmp_path):
    """A light shines down its node's -Z: turned 90 degrees about X, along +Y; about Y, along -X."""
    s = math.sqrt(0.5)
    path = gltf_files.lit_quad(
        tmp_path / "two.gltf",
        [{"type": "spot", "intensity": 2.0, "range": 5.0, "spot": {"innerConeAngle": 0.1, "outerConeAngle": 0.5}},
         {"type": "directional", "intensity": 0.5, "range": 3.0}],
        [{"light": 0, "translation": [0.0, 0.0, 2.0], "rotation": [s, 0.0, 0.0, s]},
         {"light": 1, "rotation": [0.0, s, 0.0, s]}])
    scene = load_scene(str(path))
    spot, sun = scene.lights
    np.testing.assert_allclose(spot.position, [0.0, 0.0, 2.0], atol=1e-12)
    np.testing.assert_allclose(spot.direction, [0.0, 1.0, 0.0], atol=1e-12)  # R_x(90) (0, 0, -1) = (0, 1, 0)
    assert (spot.inner_cone, spot.outer_cone, spot.range) == (0.1, 0.5, 5.0)
    np.testing.assert_allclose(sun.direction, [-1.0, 0.0, 0.0], atol=1e-12)  # R_y(90) (0, 0, -1) = (-1, 0, 0)
    assert sun.range is None  # a directional light has no range


def test_animated_light_moves_with_its_node(tmp_path):
    path = gltf_files.lit_quad(tmp_path / "moving.gltf", [{"type": "point", "intensity": 1.0}],
                               [{"light": 0, "translation": [0.0, 0.0, 1.0]}],
                               animate_light=([0.0, 1.0], np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]])))
    scene = load_scene(str(path))
    assert scene.animation is not None and scene.animation.lights is not None
    fps = scene.animation.fps
    half = scene.at(int(fps / 2))
    np.testing.assert_allclose(half.lights[0].position, [int(fps / 2) / fps, 0.0, 1.0], atol=1e-6)
    assert half.content_hash() != scene.at(0).content_hash()
    assert scene.at(0).exposure == scene.exposure == half.exposure  # one exposure for the whole film


def test_more_lights_than_the_shader_takes_are_dropped_with_one_note(tmp_path):
    n = lights_mod.MAX_LIGHTS + 2
    path = gltf_files.lit_quad(tmp_path / "many.gltf", [{"type": "point", "intensity": 1.0}] * n,
                               [{"light": i, "translation": [0.1 * i, 0.0, 1.0]} for i in range(n)])
    with pytest.warns(lights_mod.LightWarning, match=f"{n} lights: the first {lights_mod.MAX_LIGHTS} are drawn"):
        scene = load_scene(str(path))
    assert len(scene.lights) == lights_mod.MAX_LIGHTS


def test_scenes_without_lights_keep_their_hash_and_lights_change_it(tmp_path):
    plain = tmp_path / "plain.yaml"
    plain.write_text(QUAD + CAMERA)
    lit = tmp_path / "lit.yaml"
    lit.write_text(QUAD + CAMERA + "lights:\n  - {type: point, position: [0, 0, 1]}\n")
    a, b = load_scene(str(plain)), load_scene(str(lit))
    assert a.lights == () and a.exposure == 1.0
    assert a.content_hash() != b.content_hash()


@pytest.mark.parametrize(("light", "message"), [
    ({"type": "spot", "spot": {"innerConeAngle": 0.6, "outerConeAngle": 0.5}}, "innerConeAngle 0.6"),
    ({"type": "area"}, "expected directional, point or spot"),
    ({"type": "point", "range": -1.0}, "range: -1.0: must be > 0"),
])
def test_bad_gltf_lights_are_one_line_errors(tmp_path, light, message):
    from nodegraph.errors import PipelineError

    path = gltf_files.lit_quad(tmp_path / "bad.gltf", [light], [{"light": 0}])
    with pytest.raises(PipelineError, match=message) as info:
        load_scene(str(path))
    assert "\n" not in str(info.value)


def test_tone_bands_follow_the_lights_brightness(gl, tmp_path):
    from nodes.rasterize import TONE_BANDS

    path = tmp_path / "bands.yaml"
    path.write_text(QUAD + CAMERA + "exposure: 1\nlights:\n"
                    "  - {type: point, position: [0.4, 0.3, 1.0], intensity: 0.8}\n")
    _, res = run_minimal(gl, "  g: {type: rasterize, params: {tone_bands: 3}}\n", {"image": "g.color"},
                         size=(W, H), scene=str(path))
    img = res.values[("g", "color")].read()[..., 0]
    p, inside = quad_points(load_scene(str(path)))
    e = point_e(p, (0.4, 0.3, 1.0), 0.8)
    (lo, hi), (dark, middle, light) = TONE_BANDS[3]
    ref = np.where(e < lo, dark, np.where(e < hi, middle, light))
    clear = inside & (np.abs(e - lo) > 0.02) & (np.abs(e - hi) > 0.02)  # off the band borders
    assert len(np.unique(ref[clear])) == 3
    np.testing.assert_allclose(img[clear], ref[clear], atol=1.0 / 255)


def test_exposure_without_lights_says_it_has_no_effect(tmp_path) -> None:
    from nodegraph.scene import lights
    from nodegraph.scene import scene as sc

    path = tmp_path / "s.yaml"
    path.write_text("objects:\n  - primitive: {type: sphere}\nexposure: 2.0\n")
    with pytest.warns(lights.LightWarning, match="exposure: the scene has no punctual lights"):
        s = sc.load_scene(str(path))
    assert not s.lights


def _pointer_channel(path: Path, pointer: str, times: list[float], values: np.ndarray) -> None:
    """Add to the .gltf at `path` a clip animating `pointer` (KHR_animation_pointer), LINEAR, values as given."""
    import base64
    import json

    doc = json.loads(path.read_text())
    uri = doc["buffers"][0]["uri"]
    blob = bytearray(base64.b64decode(uri.split(",", 1)[1]) if uri.startswith("data:") else
                     (path.parent / uri).read_bytes())
    accs = []
    for arr, kind in ((np.asarray(times, np.float32), "SCALAR"),
                      (np.asarray(values, np.float32), "VEC3" if np.asarray(values).ndim == 2 else "SCALAR")):
        while len(blob) % 4:
            blob += b"\0"
        doc["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": arr.nbytes})
        blob += arr.tobytes()
        acc = {"bufferView": len(doc["bufferViews"]) - 1, "componentType": 5126, "count": len(arr), "type": kind}
        if kind == "SCALAR" and not accs:
            acc.update(min=[float(arr.min())], max=[float(arr.max())])
        doc["accessors"].append(acc)
        accs.append(len(doc["accessors"]) - 1)
    doc["buffers"][0] = {"byteLength": len(blob),
                         "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}
    doc.setdefault("animations", []).append({"samplers": [{"input": accs[0], "output": accs[1]}], "channels": [
        {"sampler": 0, "target": {"path": "pointer", "extensions": {"KHR_animation_pointer": {"pointer": pointer}}}}]})
    doc["extensionsUsed"] = [*doc.get("extensionsUsed", []), "KHR_animation_pointer"]
    path.write_text(json.dumps(doc))


def test_a_light_animated_through_pointers_changes_over_the_film(tmp_path):
    """KHR_animation_pointer on a light's intensity and colour: sampled at each frame (LINEAR, by hand), the
    light counts as moving, and each frame's scene says so in its key."""
    path = gltf_files.lit_quad(tmp_path / "dimmer.gltf", [{"type": "point", "intensity": 1.0}],
                               [{"light": 0, "translation": [0.0, 0.0, 1.0]}])
    _pointer_channel(path, "/extensions/KHR_lights_punctual/lights/0/intensity", [0.0, 1.0], np.array([1.0, 3.0]))
    scene = load_scene(str(path))
    assert scene.animation is not None and scene.animation.lights is not None
    fps = scene.animation.fps
    quarter = scene.at(int(fps / 4))
    assert quarter.lights[0].intensity == pytest.approx(1.0 + 2.0 * int(fps / 4) / fps, abs=1e-6)
    assert scene.at(int(fps)).lights[0].intensity == pytest.approx(3.0)
    assert quarter.content_hash() != scene.at(0).content_hash()


def test_a_camera_zoom_through_a_pointer(tmp_path):
    """/cameras/N/perspective/yfov animated: the film's camera takes the yfov of each frame (by hand)."""
    import json

    from nodegraph.scene import gltf as gltf_mod

    path = gltf_files.lit_quad(tmp_path / "zoom.gltf", [{"type": "point", "intensity": 1.0}],
                               [{"light": 0, "translation": [0.0, 0.0, 1.0]}])
    doc = json.loads(path.read_text())
    doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1, "zfar": 20.0}}]
    doc["nodes"].append({"camera": 0, "translation": [0.0, 0.0, 4.0]})
    doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
    path.write_text(json.dumps(doc))
    _pointer_channel(path, "/cameras/0/perspective/yfov", [0.0, 1.0], np.array([0.5, 1.0]))
    scene = load_scene(str(path))
    fps = scene.animation.fps
    half = scene.at(int(fps / 2))
    assert math.radians(half.camera.fov_y_deg) == pytest.approx(0.5 + 0.5 * int(fps / 2) / fps, abs=1e-6)
    assert math.radians(scene.at(0).camera.fov_y_deg) == pytest.approx(0.5, abs=1e-6)
    gltf_mod._ASSETS.clear()
    doc = json.loads(path.read_text())
    doc["animations"][0]["channels"][0]["target"]["extensions"]["KHR_animation_pointer"]["pointer"] = \
        "/cameras/0/orthographic/ymag"
    path.write_text(json.dumps(doc))
    with pytest.raises(PipelineError, match="camera 0 is 'perspective', not 'orthographic'"):
        load_scene(str(path))
