"""load_mesh: a mesh file as a value, framed like a mesh scene; missing files are load errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from tests.helpers import RASTER, assert_outputs_as_planned, render_normal_depth, run_minimal, shared_mesh


def test_a_loaded_mesh_is_framed_like_a_mesh_scene(gl):
    mesh = shared_mesh("spot.obj")
    direct = render_normal_depth(gl, RASTER.format(scene=str(mesh), extra="", g_in=""))
    extra = f"  m: {{type: load_mesh, params: {{path: '{mesh}'}}}}\n  s: {{type: scene, in: {{mesh: m.out}}}}"
    via_nodes = render_normal_depth(gl, RASTER.format(scene="builtin:box", extra=extra, g_in=", in: {scene: s.out}"))
    assert np.array_equal(direct, via_nodes)


def test_missing_files_are_load_errors(tmp_path: Path):
    text = RASTER.format(scene="builtin:box", extra=f"  m: {{type: load_mesh, params: {{path: {tmp_path}/no.obj}}}}",
                         g_in="")
    with pytest.raises(PipelineError, match=r"t.yaml:5:39: node 'm' \(load_mesh\) field 'path': .*no.obj"):
        pl.loads(text, "t.yaml")


# -- roster -----------------------------------------------------------------------------------------
# a unit square split into two triangles plus a tetrahedron apex: 5 vertices, 4 faces, no repairs needed
VERTS = np.array([[0, 0, 0], [1.5, 0, 0], [1.5, 1, 0], [0, 1, 0], [0.75, 0.5, 0.8]], np.float64)
FACES = np.array([[0, 2, 1], [0, 3, 2], [0, 1, 4], [1, 2, 4]], np.int64)  # wound consistently (base facing down)


def write_mesh(path: Path) -> Path:
    if path.suffix == ".obj":
        text = "".join(f"v {x} {y} {z}\n" for x, y, z in VERTS) + "".join(f"f {a + 1} {b + 1} {c + 1}\n"
                                                                          for a, b, c in FACES)
    else:  # .off
        text = f"OFF\n{len(VERTS)} {len(FACES)} 0\n" + "".join(f"{x} {y} {z}\n" for x, y, z in VERTS) + \
            "".join(f"3 {a} {b} {c}\n" for a, b, c in FACES)
    path.write_text(text)
    return path


def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl, tmp_path: Path):
    f = write_mesh(tmp_path / "m.obj")
    ex, res = run_minimal(gl, f"  m: {{type: load_mesh, params: {{path: '{f}'}}}}\n", {"mesh": "m.out"},
                          load_scene=False)
    assert assert_outputs_as_planned(ex, res, "m") == ["out"]


@pytest.mark.parametrize("ext", ["obj", "off"])
def test_vertices_and_faces_equal_the_mesh_written(gl, tmp_path: Path, ext: str):
    f = write_mesh(tmp_path / f"m.{ext}")
    ex, res = run_minimal(gl, f"  m: {{type: load_mesh, params: {{path: '{f}'}}}}\n", {"mesh": "m.out"},
                          load_scene=False)
    mesh = res.values[("m", "out")]
    assert mesh.vertices.dtype == np.float64 and mesh.faces.shape == (4, 3)
    assert np.array_equal(mesh.vertices, VERTS)
    assert np.array_equal(mesh.faces, FACES)
