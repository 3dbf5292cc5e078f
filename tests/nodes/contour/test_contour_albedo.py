"""pencil_contours takes the surface colour (rasterize.color into contour's `albedo`): a line over a red box is
darker than over a white one, by the light term the L* rule predicts, and a box of the default mesh colour draws
exactly as with the albedo off."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from tests import gltf_files as gf

ROOT = Path(__file__).resolve().parents[3]


def _contour(gl, path: Path, overrides: list[str] | None = None) -> np.ndarray:
    pipe = pl.load(ROOT / "pipelines" / "pencil_contours.yaml", size=(128, 128), scene=str(path),
                   overrides=["contour.grain=0", *(overrides or [])])
    return Executor(pipe, None, gl=gl, requested=[("contour", "out")]).run(0).values[("contour", "out")].read()


def test_lines_over_a_red_box_are_darker_than_over_a_white_one(gl, tmp_path: Path) -> None:
    red = _contour(gl, gf.colored_box(tmp_path / "red.gltf", (1.0, 0.0, 0.0)))[..., 0]
    white = _contour(gl, gf.colored_box(tmp_path / "white.gltf", (1.0, 1.0, 1.0)))[..., 0]
    off = _contour(gl, gf.colored_box(tmp_path / "off.gltf", (1.0, 0.0, 0.0)), ["contour.albedo_weight=0"])[..., 0]
    lines = off < 0.9
    assert lines.sum() > 50
    # darkness 1 - value: red's lines darker than with the albedo off, white's lighter
    assert (1.0 - red[lines]).mean() > (1.0 - off[lines]).mean() * 1.05
    assert (1.0 - white[lines]).mean() < (1.0 - off[lines]).mean()
    # white's L* is 100 against the reference's 81.78: its light is sqrt(100 / 81.78) brighter, so (one attempt's
    # darkness being tone x (1 - light_weight x light)) no line gets darker; red's L* 53.24: none gets lighter
    assert np.all(white[lines] >= off[lines] - 1e-3) and np.all(red[lines] <= off[lines] + 1e-3)


def test_the_default_mesh_colour_draws_as_without_albedo(gl, tmp_path: Path) -> None:
    path = tmp_path / "default.gltf"
    b = gf.Builder()
    b.node(mesh=b.mesh(gf.BOX_V, gf.BOX_F), name="box", rotation=gf.quat_axis((0, 1, 0), 30))
    b.save(path)
    scene_yaml = tmp_path / "s.yaml"
    scene_yaml.write_text(f"objects:\n  - gltf: {path.name}\n    color: [0.91, 0.78, 0.55]\n")
    with_albedo = _contour(gl, scene_yaml)
    assert (with_albedo < 0.9).sum() > 50
    assert np.array_equal(with_albedo, _contour(gl, scene_yaml, ["contour.albedo_weight=0"]))
