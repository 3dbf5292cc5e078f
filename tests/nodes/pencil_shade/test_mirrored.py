"""A mirrored object (a glTF node with scale (-1, 1, 1)) is shaded from its outside: a box mirrored in x is the
same box, so its tone index (blend.a, from N.L) matches the unmirrored box's pixel for pixel up to rounding.
Before, gl_FrontFacing turned its (already correct) normals inside out and the lit faces went dark."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from tests import gltf_files as gf

ROOT = Path(__file__).resolve().parents[3]


def _tone(gl, path: Path, implementation: str | None = None) -> np.ndarray:
    pipe = pl.load(ROOT / "pipelines" / "pencil.yaml", size=(120, 120), scene=str(path))
    res = Executor(pipe, None, gl=gl, requested=[("shade", "blend")]).run(0)
    return res.values[("shade", "blend")].read()[..., 3]


def _box(tmp_path: Path, name: str, scale: list[float]) -> Path:
    b = gf.Builder()
    b.node(mesh=b.mesh(gf.BOX_V, gf.BOX_F), name="box", scale=scale, rotation=gf.quat_axis((0, 1, 0), 30))
    return b.save(tmp_path / f"{name}.gltf")


def test_a_mirrored_box_is_toned_as_the_box(gl, tmp_path: Path) -> None:
    plain = _tone(gl, _box(tmp_path, "plain", [1.0, 1.0, 1.0]))
    mirrored = _tone(gl, _box(tmp_path, "mirror", [-1.0, 1.0, 1.0]))
    on = (plain >= 0) & (mirrored >= 0)
    assert on.mean() > 0.2 and ((plain >= 0) != (mirrored >= 0)).mean() < 0.01  # the same pixels covered
    spread = plain[on].max() - plain[on].min()
    assert spread > 1.0  # a lit and a dark face: the check can tell them apart
    assert np.abs(plain[on] - mirrored[on]).mean() < 0.02 * spread


def test_the_kept_geometry_shader_agrees_on_the_mirrored_box(gl, tmp_path: Path) -> None:
    from nodegraph_nodes.pencil_shade import geometry_shader

    from tests.nodes.pencil_shade.test_pencil_shade import _both_implementations

    path = _box(tmp_path, "mirror", [-1.0, 1.0, 1.0])
    pipe = pl.load(ROOT / "pipelines" / "pencil.yaml", size=(120, 120), scene=str(path),
                   overrides=["shade.grazing_floor=0"])
    ours = _both_implementations(gl, pipe, pipe.scene, 0, frozenset({"blend"}))["blend"][..., 3]
    kept = _both_implementations(gl, pipe, pipe.scene, 0, frozenset({"blend"}), only=geometry_shader.compute)
    on = (ours >= 0) & (kept["blend"][..., 3] >= 0)
    assert on.mean() > 0.2
    assert np.abs(ours[on] - kept["blend"][..., 3][on]).mean() < 0.05
