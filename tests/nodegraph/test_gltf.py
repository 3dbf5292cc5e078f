"""glTF import and animation, on small files built in code (tests/gltf_files.py), against hand-computed values."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pygltflib as g
import pytest

from nodegraph.errors import MeshError, PipelineError
from nodegraph.scene import animation as an
from nodegraph.scene import scene as sc
from nodegraph.scene.gltf import load_any_mesh, load_asset
from nodegraph.scene.meshes import MeshWarning
from tests import gltf_files as gf
from tests.workcount import peak_bytes, python_lines


def _rot_z(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


@pytest.mark.parametrize("name,external", [("box.glb", True), ("box.gltf", True), ("box.gltf", False)])
def test_box_in_every_container(tmp_path, name, external):
    scene = sc.load_scene(str(gf.animated_box(tmp_path / name, external)))
    assert [o.name for o in scene.objects] == ["mover", "still"]
    assert scene.objects[0].mesh.n_faces == 12
    # baseColorFactor is linear; the flat colour is its display (sRGB) value
    assert scene.objects[0].color == pytest.approx((0.7354, 0.4845, 0.3492), abs=1e-3)
    mid = scene.at(12)  # t = 0.5 s at 24 fps: halfway from x = 0 to x = 2
    assert mid.objects[0].transform[:3, 3] == pytest.approx([1.0, 0.0, 0.0])
    assert mid.objects[1].transform[:3, 3] == pytest.approx([0.0, 0.0, -3.0])
    assert mid.objects[1].mesh is scene.objects[1].mesh  # a still object keeps its mesh (and its keys)
    assert list(scene.animation.frame_range()) == list(range(25))
    assert an.with_fps(scene, 10).at(5).objects[0].transform[0, 3] == pytest.approx(1.0)


def test_skinned_bar_matches_the_blend_by_hand(tmp_path):
    scene = sc.load_scene(str(gf.skinned_bar(tmp_path / "bar.glb")))
    v, _, _, weights = gf.bar_vertices()
    posed = scene.at(12)  # t = 0.5: joint 1 turned 45 degrees about +Z
    got = posed.objects[0].world_vertices()
    # joint matrices: J0 = I, J1 = T(1,0,0) R(45) T(-1,0,0) (world of joint 1 times its inverse bind matrix)
    pivot = np.array([1.0, 0, 0])
    for i in range(len(v)):
        p = v[i].astype(np.float64)
        bent = pivot + _rot_z(45) @ (p - pivot)
        want = weights[i, 0] * p + weights[i, 1] * bent
        assert got[i] == pytest.approx(want, abs=1e-6), i
    tip = got[16]  # (2, 0.1, 0.1) fully on joint 1
    assert tip == pytest.approx([1 + math.cos(math.pi / 4) - 0.1 * math.sin(math.pi / 4),
                                 math.sin(math.pi / 4) + 0.1 * math.cos(math.pi / 4), 0.1], abs=1e-6)
    assert scene.at(0).objects[0].world_vertices() == pytest.approx(v.astype(np.float64), abs=1e-7)


def test_morphing_quad(tmp_path):
    scene = sc.load_scene(str(gf.morphing_quad(tmp_path / "quad.glb")))
    assert scene.at(12).objects[0].mesh.vertices[2] == pytest.approx([1, 1, 0.5])
    assert scene.at(24).objects[0].mesh.vertices[2] == pytest.approx([1, 1, 1.0])
    assert scene.at(0).content_hash() != scene.at(12).content_hash()
    assert scene.at(30).content_hash() == scene.at(24).content_hash()  # the last key holds


def test_cameras_by_default_name_and_index(tmp_path):
    path = gf.two_cameras(tmp_path / "cams.glb")
    scene = sc.load_scene(str(path))
    cam = scene.camera  # the first camera by default
    assert cam.eye == pytest.approx([0, 0, 5]) and cam.fov_y_deg == pytest.approx(math.degrees(0.8))
    assert (cam.near, cam.far) == (pytest.approx(0.1), pytest.approx(50.0))
    side = sc.select_camera(scene, "side").camera
    world = np.eye(4)
    world[:3, :3] = gf_quat_matrix(gf.quat_axis((0, 1, 0), 90))
    world[:3, 3] = [5, 0, 0]
    assert side.view_matrix() == pytest.approx(np.linalg.inv(world), abs=1e-9)
    assert sc.select_camera(scene, 1).camera.eye == pytest.approx([5, 0, 0])
    top = sc.select_camera(scene, "top").camera  # orthographic: ymag is half the height (test_camera_ortho.py)
    assert top.orthographic and top.ortho_half == 2.0
    with pytest.raises(PipelineError, match="no such camera.*front"):
        sc.select_camera(scene, "frnt")


def gf_quat_matrix(q: list[float]) -> np.ndarray:
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def test_no_camera_frames_the_whole_animation(tmp_path):
    scene = sc.load_scene(str(gf.animated_box(tmp_path / "box.glb")))
    last = scene.at(24)
    ndc = scene.camera.project(last.objects[0].world_vertices())
    assert np.all(np.abs(ndc[:, :2]) < 1.0)  # the mover's end position is in the picture
    assert scene.orbit is None


def test_strips_fans_and_left_out_parts_warn_once(tmp_path):
    b = gf.Builder()
    strip = b.mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], np.float32),
                   np.array([0, 1, 2, 3], np.uint32), mode=5)
    b.doc.meshes[strip].primitives.append(g.Primitive(attributes=g.Attributes(POSITION=0), mode=1))
    b.node(mesh=strip, name="s")
    b.doc.extensionsUsed = ["EXT_meshopt_compression"]
    path = b.save(tmp_path / "strip.glb")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        asset = load_asset(path)
    msgs = [str(w.message) for w in caught if issubclass(w.category, MeshWarning)]
    assert len(msgs) == 1 and "LINES" in msgs[0] and "EXT_meshopt_compression" in msgs[0]
    faces = asset.meshes[0][0].faces
    assert faces.tolist() == [[0, 1, 2], [2, 1, 3]]  # the strip's second triangle keeps the winding
    assert load_any_mesh(path).n_faces == 2


def test_points_only_is_one_line_error(tmp_path):
    b = gf.Builder()
    b.node(mesh=b.mesh(gf.BOX_V, np.arange(8, dtype=np.uint16), mode=0), name="p")
    path = b.save(tmp_path / "points.glb")
    with pytest.raises(PipelineError, match="no triangle meshes") as err, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc.load_scene(str(path))
    assert "\n" not in str(err.value)


def test_tracks_step_cubic_and_slerp():
    step = an.Track([0, 1], [[0.0], [1.0]], "STEP")
    assert step.sample(0.99)[0] == 0.0 and step.sample(1.0)[0] == 1.0
    # CUBICSPLINE: (in, value, out) per key; tangents scaled by the segment length
    cub = an.Track([0, 2], [[[0.0]], [[0.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]]], "CUBICSPLINE")
    s = 0.25
    want = (s**3 - 2 * s**2 + s) * 2 * 1.0 + (-2 * s**3 + 3 * s**2) * 1.0 + (s**3 - s**2) * 2 * 1.0
    assert cub.sample(0.5)[0] == pytest.approx(want)
    rot = an.Track([0, 1], [gf.quat_axis((0, 1, 0), 0), gf.quat_axis((0, 1, 0), 120)], "LINEAR", quaternion=True)
    assert rot.sample(0.25) == pytest.approx(gf.quat_axis((0, 1, 0), 30))
    q = an.Track([0, 1], np.array([[[0, 0, 0, 0]], [[0, 0, 0, 1]], [[0, 0, 0, 0]], [[0, 0, 0, 0]],
                                   [[0, 0, 0.5, 1]], [[0, 0, 0, 0]]], float).reshape(2, 3, 4), "CUBICSPLINE",
                 quaternion=True)
    assert np.linalg.norm(q.sample(0.5)) == pytest.approx(1.0)  # normalised
    smooth = an.Track([0, 1], [[0.0], [1.0]], segment=("SMOOTH", "LINEAR"))
    assert smooth.sample(0.25)[0] == pytest.approx(0.15625)


def test_skinning_100k_vertices_is_vectorised():
    rng = np.random.default_rng(1)
    n, j = 100_000, 40
    v = rng.normal(size=(n, 3))
    joints = rng.integers(0, j, size=(n, 4))
    w = rng.random((n, 4))
    w /= w.sum(axis=1, keepdims=True)
    mats = np.tile(np.eye(4), (j, 1, 1))
    mats[:, :3, 3] = rng.normal(size=(j, 3))
    out = an.skin_vertices(v, joints, w, mats)
    ref = sum(w[:, k, None] * (v + mats[joints[:, k], :3, 3]) for k in range(4))
    np.testing.assert_allclose(out, ref, rtol=1e-6, atol=1e-12)  # pytest.approx's tolerances, without its 3 s
    prebuilt = an.skin_weights(joints, w, j)  # once per mesh, as posing does
    small = an.skin_weights(joints[:1000], w[:1000], j)
    # what keeps a frame's skinning within its 5 ms target (docs/animation.md), bounded as work, not time: a
    # fixed number of array operations whatever the vertex count (the same lines of Python for 100k vertices
    # as for 1k, about 50 now; a Python loop over vertices or joints adds at least one a step) ...
    lines, _ = python_lines(lambda: an.skin_vertices(v, None, prebuilt, mats))
    small_lines, _ = python_lines(lambda: an.skin_vertices(v[:1000], None, small, mats))
    assert lines <= 2 * small_lines < 1000
    # ... on arrays of a few floats a vertex: the (n, 3, 4) blended matrices and the result, 120 bytes a
    # vertex at the peak now; a dense (n, J) weight matrix alone would take 320
    peak, _ = peak_bytes(lambda: an.skin_vertices(v, None, prebuilt, mats))
    assert peak <= 3 * 96 * n


def test_a_gltf_cameras_yfov_spans_the_height_of_a_portrait_image_too(tmp_path):
    """glTF's yfov is the vertical field of view: a tall image sees exactly yfov from top to bottom (the engine's
    own cameras span the shorter side with theirs, so a framed subject stays in a tall picture)."""
    import math

    from nodegraph.scene import scene as sc
    from tests import gltf_files as gf

    path = gf.two_cameras(tmp_path / "cams.gltf")
    cam = sc.load_scene(str(path)).camera  # 'front': yfov 0.8 rad at z = 5, looking down -z
    assert cam.fov_vertical and cam.fov_y_deg == pytest.approx(math.degrees(0.8))
    for w, h in ((80, 160), (160, 80), (100, 100)):
        aspect = w / h
        edge = np.array([[0.0, 5.0 * math.tan(0.4) * (1 - 1e-9), 0.0]])  # the top of the view at the origin's depth
        assert cam.project(edge, aspect)[0, 1] == pytest.approx(1.0, abs=1e-6)
        side = np.array([[5.0 * math.tan(0.4) * aspect, 0.0, 0.0]])
        assert cam.project(side, aspect)[0, 0] == pytest.approx(1.0, abs=1e-6)
    plain = sc.Camera(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=math.degrees(0.8))
    assert plain.tan_half(0.5) == pytest.approx((math.tan(0.4), math.tan(0.4) / 0.5))  # the shorter side
    assert "fov_vertical" not in plain.params()  # other cameras' keys are unchanged


@pytest.mark.parametrize("required", [False, True])
def test_a_files_lights_are_read_not_left_out(tmp_path, required: bool):
    """KHR_lights_punctual is read (the lights shade the drawing, tests/nodes/rasterize/test_lights.py): the file
    loads, even where it requires the extension, and no warning says the lights were left out."""
    import json
    import warnings

    from nodegraph.scene import scene as sc
    from nodegraph.scene.meshes import MeshWarning
    from tests import gltf_files as gf

    b = gf.Builder()
    b.node(mesh=b.mesh(gf.BOX_V, gf.BOX_F), name="box")
    path = b.save(tmp_path / "lit.gltf")
    doc = json.loads(path.read_text())
    doc["extensionsUsed"] = ["KHR_lights_punctual"]
    if required:
        doc["extensionsRequired"] = ["KHR_lights_punctual"]
    doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "directional"}]}}
    path.write_text(json.dumps(doc))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = sc.load_scene(str(path))
    notes = [str(w.message) for w in caught if issubclass(w.category, MeshWarning)]
    assert len(scene.objects) == 1
    assert not [n for n in notes if "light" in n], notes
    assert scene.lights == ()  # a light defined but placed on no node shines nowhere


def _instanced_boxes(path, rotation_ctype: int = gf.FLOAT, **extra: object):
    """A box on a node turned 90 degrees about +Y and moved to x = 10, instanced three times by
    EXT_mesh_gpu_instancing (`extra`: more keys for the extension's attributes)."""
    b = gf.Builder()
    box = b.mesh(gf.BOX_V, gf.BOX_F, color=(0.2, 0.4, 0.6))
    t = np.array([[0, 0, 0], [3, 0, 0], [0, 2, -1]], np.float32)
    q = np.array([gf.quat_axis((0, 0, 1), 0), gf.quat_axis((0, 0, 1), 90), gf.quat_axis((1, 0, 0), 45)])
    s = np.array([[1, 1, 1], [2, 2, 2], [1, 3, 1]], np.float32)
    if rotation_ctype == gf.FLOAT:
        rot = b.accessor(q.astype(np.float32), "VEC4")
    else:  # normalized signed shorts
        rot = b.accessor(np.round(q * 32767).astype(np.int16), "VEC4", 5122, normalized=True)
    attrs = {"TRANSLATION": b.accessor(t, "VEC3"), "ROTATION": rot, "SCALE": b.accessor(s, "VEC3"), **extra}
    b.node(mesh=box, name="boxes", translation=[10.0, 0.0, 0.0], rotation=gf.quat_axis((0, 1, 0), 90),
           extensions={"EXT_mesh_gpu_instancing": {"attributes": attrs}})
    b.doc.extensionsUsed = ["EXT_mesh_gpu_instancing"]
    return b.save(path), t.astype(np.float64), q, s.astype(np.float64)


@pytest.mark.parametrize("ctype", [gf.FLOAT, 5122])
def test_gpu_instancing_places_each_instance_by_its_trs_in_the_node(tmp_path, ctype):
    path, t, q, s = _instanced_boxes(tmp_path / "inst.glb", ctype)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the extension is read: nothing is noted as left out
        scene = sc.load_scene(str(path))
    assert [o.name for o in scene.objects] == ["boxes[0]", "boxes[1]", "boxes[2]"]
    assert scene.objects[0].mesh is scene.objects[2].mesh  # one mesh: what is derived from it is made once
    got = np.concatenate([o.world_vertices() for o in scene.objects])
    node = np.eye(4)
    node[:3, :3] = gf_quat_matrix(gf.quat_axis((0, 1, 0), 90))
    node[:3, 3] = [10, 0, 0]
    v = gf.BOX_V.astype(np.float64)
    want = []
    for k in range(3):  # node world x T x R x S, by hand
        inst = np.eye(4)
        inst[:3, :3] = gf_quat_matrix(list(q[k])) * s[k][None, :]
        inst[:3, 3] = t[k]
        want.append((node @ inst @ np.c_[v, np.ones(len(v))].T).T[:, :3])
    # the scene may turn and frame the file as a whole (its up axis, origin): compare shapes after that
    got_rel, want_rel = got - got.mean(0), np.concatenate(want) - np.concatenate(want).mean(0)
    tol = 1e-6 if ctype == gf.FLOAT else 1e-3
    assert got.shape == (24, 3) and np.abs(got_rel - want_rel).max() < tol


def test_gpu_instancing_faults_and_application_attributes(tmp_path):
    path, *_ = _instanced_boxes(tmp_path / "ids.glb", _ID=0)  # an application-specific attribute is not drawn
    assert len(load_asset(path).objects) == 3
    from nodegraph.scene import info

    described = info.info(path)
    assert described["meshes"][0]["instances"] == {"boxes": 3}
    assert "boxes x3" in info.format_info(described)
    b_path, *_ = _instanced_boxes(tmp_path / "bad.glb", FOO=0)
    with pytest.raises(PipelineError, match=r"nodes\[0\]\.extensions\.EXT_mesh_gpu_instancing\.attributes\.FOO: "
                                            "not an instancing attribute"):
        sc.load_scene(str(b_path))
    doc = g.GLTF2().load(str(path))
    doc.accessors[doc.nodes[0].extensions["EXT_mesh_gpu_instancing"]["attributes"]["SCALE"]].count = 2
    doc.save(str(tmp_path / "counts.glb"))
    with pytest.raises(PipelineError, match="its accessors have different counts .2, 3."):
        sc.load_scene(str(tmp_path / "counts.glb"))


def test_node_visibility_hides_a_node_and_everything_below_it(tmp_path):
    """KHR_node_visibility: `visible: false` on a parent hides its child's mesh too; `visible: true` and nodes
    without the extension are drawn; the extension is read, not noted as left out."""
    b = gf.Builder()
    box = b.mesh(gf.BOX_V, gf.BOX_F)
    hidden = {"KHR_node_visibility": {"visible": False}}
    b.node(name="shown", mesh=box, extensions={"KHR_node_visibility": {"visible": True}})
    b.node(name="off", mesh=box, translation=[2.0, 0, 0], extensions=hidden, children=[2])
    b.node(root=False, name="child_of_off", mesh=box, translation=[0, 2.0, 0])
    b.node(name="plain", mesh=box, translation=[-2.0, 0, 0])
    b.doc.extensionsUsed = ["KHR_node_visibility"]
    b.doc.extensionsRequired = ["KHR_node_visibility"]
    path = b.save(tmp_path / "vis.glb")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = sc.load_scene(str(path))
    assert [o.name for o in scene.objects] == ["shown", "plain"]
    from nodegraph.scene import info  # `sketchgraph scene info` says why the mesh is not drawn only where it is not

    b2 = gf.Builder()
    other = b2.mesh(gf.BOX_V, gf.BOX_F)
    b2.node(name="seen", mesh=b2.mesh(gf.BOX_V, gf.BOX_F))
    b2.node(name="unseen", mesh=other, extensions=hidden)
    b2.doc.extensionsUsed = ["KHR_node_visibility"]
    verdicts = [m["sketchgraph"]["does"] for m in info.info(b2.save(tmp_path / "two.glb"))["meshes"]]
    assert verdicts == ["ignored", "drawn"] and info.info(path)["meshes"][0]["sketchgraph"]["does"] == "drawn"


def test_animation_pointer_channels_move_nodes_as_plain_channels_do(tmp_path):
    """KHR_animation_pointer: a channel whose target is the pointer /nodes/N/translation (or rotation, scale,
    weights) moves the node as the plain channel does; a pointer to anything else (a material's colour) is named
    in the file's one warning, not read; a pointer to a node the file lacks is one line."""
    import json

    plain = gf.animated_box(tmp_path / "plain.gltf", external=False)
    doc = json.loads(plain.read_text())
    doc["extensionsUsed"] = ["KHR_animation_pointer"]
    for ch in doc["animations"][0]["channels"]:
        tgt = ch["target"]
        ch["target"] = {"path": "pointer", "extensions": {"KHR_animation_pointer": {
            "pointer": f"/nodes/{tgt['node']}/{tgt['path']}"}}}
    anim = doc["animations"][0]
    anim["channels"].append({"sampler": 0, "target": {"path": "pointer", "extensions": {"KHR_animation_pointer": {
        "pointer": "/materials/0/pbrMetallicRoughness/baseColorFactor"}}}})
    pointed = tmp_path / "pointer.gltf"
    pointed.write_text(json.dumps(doc))
    with pytest.warns(MeshWarning, match="1 channel whose target is not read .an extension's: channel 1 "
                                         "'/materials/0/pbrMetallicRoughness/baseColorFactor'"):
        got = sc.load_scene(str(pointed))
    want = sc.load_scene(str(plain))
    for frame in (0, 6, 12, 24):
        for a, b in zip(got.at(frame).objects, want.at(frame).objects, strict=True):
            assert a.transform == pytest.approx(b.transform)
    assert got.at(12).objects[0].transform[:3, 3] == pytest.approx([1.0, 0.0, 0.0])
    anim["channels"][0]["target"]["extensions"]["KHR_animation_pointer"]["pointer"] = "/nodes/9/translation"
    (tmp_path / "bad.gltf").write_text(json.dumps(doc))
    with pytest.raises(PipelineError, match=r"animations\[0\]\.channels\[0\]\.target\.extensions\."
                                            r"KHR_animation_pointer\.pointer: node 9 does not exist"):
        sc.load_scene(str(tmp_path / "bad.gltf"))


def test_the_warning_says_the_same_of_many_primitives_once(tmp_path):
    """Five primitives drawn opaque for alphaMode BLEND: one clause naming three and counting the rest; a note
    said of three or fewer keeps each; other notes stay as they are, in order."""
    b = gf.Builder()
    for k in range(5):
        colors = b.accessor(np.full((8, 3), 0.5, np.float32), "VEC3")  # coloured per vertex: the mode is read
        mesh = b.mesh(gf.BOX_V + np.float32(2 * k), gf.BOX_F, color=(0.5, 0.5, 0.5), COLOR_0=colors)
        b.doc.materials[-1].alphaMode = "BLEND"
        b.node(mesh=mesh, name=f"glass{k}")
    b.doc.extensionsUsed = ["VENDOR_thing"]
    with pytest.warns(MeshWarning) as caught:
        load_asset(b.save(tmp_path / "glass.glb"))
    text = str(caught[0].message)
    assert text.endswith("left out: extension VENDOR_thing; 5 primitives: alphaMode BLEND (drawn opaque) "
                         "(mesh 'mesh0' primitive 0, mesh 'mesh1' primitive 0, mesh 'mesh2' primitive 0 and 2 more)")
    from nodegraph.scene.gltf import left_out

    three = [f"mesh '{c}' primitive 0: alphaMode BLEND (drawn opaque)" for c in "abc"]
    assert left_out(three + ["extension Y"]) == "; ".join(three + ["extension Y"])


def test_an_instance_whose_world_matrix_overflows_is_one_line(tmp_path):
    """Node scale 1e300 (finite) times an instance's scale 1e38 (a float32 can hold it) overflows float64."""
    import json

    path, *_ = _instanced_boxes(tmp_path / "huge.gltf")
    doc = json.loads(path.read_text())
    doc["nodes"][0]["scale"] = [1e300, 1e300, 1e300]
    path.write_text(json.dumps(doc))
    blob = bytearray((tmp_path / "huge.bin").read_bytes())
    scale = doc["accessors"][doc["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["SCALE"]]
    at = doc["bufferViews"][scale["bufferView"]].get("byteOffset", 0) + 12  # the second instance's scale
    blob[at:at + 12] = np.array([1e38, 1e38, 1e38], np.float32).tobytes()
    (tmp_path / "huge.bin").write_bytes(bytes(blob))
    with pytest.raises(MeshError, match=r"nodes\[0\]\.extensions\.EXT_mesh_gpu_instancing: instance "
                                            r"'boxes\[1\]': its world matrix overflows") as err:
        load_asset(path)
    assert "\n" not in str(err.value)
