"""scene: a scene from a path or a connected mesh, errors at load time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.scene import framing
from tests.helpers import RASTER, assert_outputs_as_planned, render_normal_depth, run_minimal


def test_scene_node_draws_what_the_pipeline_scene_draws(gl):
    direct = render_normal_depth(gl, RASTER.format(scene="builtin:box", extra="", g_in=""))
    extra = "  s: {type: scene, params: {path: builtin:box}}"
    via_node = render_normal_depth(gl, RASTER.format(scene="builtin:torus", extra=extra, g_in=", in: {scene: s.out}"))
    assert np.array_equal(direct, via_node)
    assert (direct[..., 3] > 0).sum() > 500


def test_scene_node_needs_exactly_one_source():
    text = RASTER.format(scene="builtin:box", extra="  s: {type: scene}", g_in=", in: {scene: s.out}")
    with pytest.raises(PipelineError, match=r"t.yaml:5:3: node 's' \(scene\): give either params.path"):
        pl.loads(text, "t.yaml")


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  s: {type: scene, params: {path: builtin:torus}}
  g: {type: rasterize, in: {scene: s.out}}
"""
    ex, res = run_minimal(gl, nodes, {"scene": "s.out", "image": "g.color"})
    assert assert_outputs_as_planned(ex, res, "s") == ["out"]


def test_a_mesh_file_becomes_one_framed_object(gl, tmp_path: Path):
    """Against the file written here: one object, its faces and vertices as written (an OBJ is Y-up, and a
    pyramid that can rest on its side gives no strong evidence against it: nodegraph/scene/framing.py),
    identity transform, and every vertex inside the camera's view (projected with the camera matrices in
    float64)."""
    verts = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0], [1, 0.5, 1.5]], np.float64)
    faces = np.array([[0, 2, 1], [0, 3, 2], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])  # wound consistently, outward
    f = tmp_path / "m.obj"
    f.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in verts)
                 + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces))
    ex, res = run_minimal(gl, f"  s: {{type: scene, params: {{path: '{f}'}}}}\n", {"scene": "s.out"},
                          size=(48, 40), load_scene=False)
    scene = res.values[("s", "out")]
    (obj,) = scene.objects
    stood = verts @ framing.up_rotation("y")[:3, :3].T
    assert np.array_equal(obj.mesh.vertices, stood) and np.array_equal(obj.mesh.faces, faces)
    assert np.array_equal(np.asarray(obj.transform), np.eye(4))
    cam = scene.camera_at(0)
    clip = np.c_[stood, np.ones(len(verts))] @ (cam.projection_matrix(48 / 40) @ cam.view_matrix()).T
    ndc = clip[:, :3] / clip[:, 3:]
    assert np.all(clip[:, 3] > 0) and np.all(np.abs(ndc) < 1.0)
