"""Deforming meshes keep their drawing on the surface: posed (skinned, morphed) meshes carry their rest pose,
rasterize writes rest-pose positions (object-space noise reads them), curvature is measured once on the rest
pose and pencil_shade carries its directions with the skin (docs/animation.md)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from nodegraph_nodes.pencil_shade import skinned_directions

import nodegraph as ng
from nodegraph.scene import scene as sc
from nodegraph.tools.bench.showerdoor import compare_rest_pose, surface_pair_metric
from tests import gltf_files as gf


@pytest.fixture(scope="module")
def tube(tmp_path_factory):
    return gf.skinned_tube(tmp_path_factory.mktemp("tube") / "tube.glb")


def test_posed_meshes_carry_their_rest_pose(tube, tmp_path):
    scene = sc.load_scene(str(tube))
    posed = scene.at(24).objects[0].mesh
    rest = posed.rest
    assert rest is not None and rest.n_vertices == posed.n_vertices and np.array_equal(rest.faces, posed.faces)
    assert posed.skin_linear.shape == (posed.n_vertices, 3, 3)
    assert scene.at(0).objects[0].mesh.rest is rest  # one rest mesh for the whole animation
    # the tip (x = 2) turned 90 degrees about z at x = 1: its direction +x became +y
    tip = rest.n_vertices - 1  # the centre of the cap at x = 2
    np.testing.assert_allclose(posed.skin_linear[tip] @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(posed.vertices[tip], [1.0, 1.0, 0.0], atol=1e-6)
    # the scale scene-relative sizes measure does not move with the pose
    np.testing.assert_array_equal(scene.at(3).scale_bounds()[1], scene.at(20).scale_bounds()[1])
    gf.morphing_quad(tmp_path / "quad.glb")
    quad = sc.load_scene(str(tmp_path / "quad.glb")).at(24).objects[0].mesh
    assert quad.rest is not None and quad.skin_linear is None and quad.rest.vertices[2, 2] == 0.0


def test_rasterize_position_is_the_rest_pose(gl, tube):
    def positions(rest_pose: bool) -> np.ndarray:
        with ng.Session(cache=False) as session:
            pipe = session.load("object_space_uncertainty", scene=tube, size=(96, 96))
            pipe.pipeline.scene = replace(pipe.pipeline.scene,
                                          animation=replace(pipe.pipeline.scene.animation, rest_pose=rest_pose))
            return pipe.inspect("gbuf.position", frame=24)

    rest, posed = positions(True), positions(False)
    cov = rest[..., 3] > 0
    assert cov.sum() > 500 and np.array_equal(cov, posed[..., 3] > 0)  # the same geometry drawn
    assert np.abs(rest[cov][:, 1]).max() <= 0.25 + 1e-4  # rest pose: a straight tube of radius 0.25 along x
    assert np.abs(posed[cov][:, 1]).max() > 0.8  # posed: the bent half rises to y = 1


def test_curvature_is_computed_once_for_a_skinned_mesh(gl, tube):
    with ng.Session(cache=False) as session:
        pipe = session.load("pencil", scene=tube, size=(64, 64))
        list(pipe.frames(range(0, 24, 8)))
        assert session.compute_counts["curv"] == 1
        assert session.compute_counts["gbuf"] == 3


def test_directions_are_carried_by_the_skin():
    class Posed:
        skin_linear = np.stack([np.eye(3), [[0.0, -2.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]]])

    d = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]], np.float32)
    out = skinned_directions(Posed(), d, np.array([0, 1]))
    np.testing.assert_allclose(out, [[1, 0, 0], [0, 1, 0]], atol=1e-7)

    class Still:
        skin_linear = None

    assert skinned_directions(Still(), d, np.array([1])) is not None


def test_surface_metric_is_zero_for_the_same_frame():
    rng = np.random.default_rng(1)
    pos = np.zeros((8, 8, 4))
    pos[..., 0], pos[..., 1] = np.meshgrid(np.arange(8.0), np.arange(8.0))
    pos[..., 3] = 1.0
    off = rng.random((8, 8, 4))
    assert surface_pair_metric(pos, off, pos, off)[:2] == (0.0, 0.0)
    assert surface_pair_metric(pos, off, pos, rng.random((8, 8, 4)))[0] > 0.3


@pytest.mark.slow  # 3.4 s
def test_rest_pose_noise_sticks_to_a_bending_tube(gl, tube):
    """The shower-door metric over the bend (24 frames): noise at rest-pose positions moves far less with
    the surface than noise at posed positions (docs/animation.md has the figures)."""
    r = compare_rest_pose(str(tube), size=(200, 200), gl=gl)
    assert r["frames"] == 25 and min(r["pixels_compared"]) > 1000
    assert r["rest"] < 0.4 * r["posed"], r
