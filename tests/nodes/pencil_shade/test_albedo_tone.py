"""pencil takes tone from the lit albedo (rasterize.color into pencil_shade's `albedo`): a red box hatches darker
than a white one, by the hand-computed factor on its tone index; a box of the default mesh colour hatches as N.L
alone (the tone without the albedo)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from tests import gltf_files as gf

ROOT = Path(__file__).resolve().parents[3]


def _tone(gl, path: Path, overrides: list[str] | None = None) -> np.ndarray:
    """Tone index (blend.a, darkness x max tone; -1 off the objects) of pipelines/pencil.yaml over the file."""
    pipe = pl.load(ROOT / "pipelines" / "pencil.yaml", size=(96, 96), scene=str(path), overrides=overrides or [])
    res = Executor(pipe, None, gl=gl, requested=[("shade", "blend"), ("shade", "color")]).run(0)
    return res.values[("shade", "blend")].read()[..., 3]


def test_a_red_box_hatches_darker_than_a_white_one(gl, tmp_path: Path) -> None:
    from nodegraph_nodes.pencil_shade import ALBEDO_REF

    red = _tone(gl, gf.colored_box(tmp_path / "red.gltf", (1.0, 0.0, 0.0)))
    white = _tone(gl, gf.colored_box(tmp_path / "white.gltf", (1.0, 1.0, 1.0)))
    plain = _tone(gl, gf.colored_box(tmp_path / "plain.gltf", (1.0, 0.0, 0.0)), ["shade.albedo_weight=0"])
    on = (red >= 0) & (white >= 0) & (plain >= 0)
    assert on.mean() > 0.2
    assert red[on].mean() > white[on].mean() + 1.0  # tone indices: darker by more than one tone of 31
    # hand-computed: brightness b = (1 - d)^2 from the tone without albedo; red's luminance 0.2126 (Rec. 709 of
    # linear (1, 0, 0)), lightness L* = 116 * 0.2126^(1/3) - 16 = 53.24, against the default colour's (its sRGB
    # (0.91, 0.78, 0.55) -> linear -> Y 0.5990 -> L* 81.78): d' = 1 - (1 - d) sqrt(53.24 / 81.78), clamped at 1
    assert abs(ALBEDO_REF - 81.78) < 0.01
    red_lstar = 116.0 * 0.2126 ** (1.0 / 3.0) - 16.0
    max_tone = 0.6 * 31  # max_darkness x (tones - 1)
    d = plain[on] / max_tone
    want = (1.0 - np.minimum((1.0 - d) * np.sqrt(red_lstar / ALBEDO_REF), 1.0)) * max_tone
    assert np.median(np.abs(red[on] - want)) < 0.02 * max_tone


def test_the_default_mesh_colour_hatches_as_without_albedo(gl, tmp_path: Path) -> None:
    path = tmp_path / "default.gltf"
    b = gf.Builder()
    b.node(mesh=b.mesh(gf.BOX_V, gf.BOX_F), name="box", rotation=gf.quat_axis((0, 1, 0), 30))
    b.save(path)
    scene_yaml = tmp_path / "s.yaml"  # the file's object painted the default mesh colour by a scene
    scene_yaml.write_text(f"objects:\n  - gltf: {path.name}\n    color: [0.91, 0.78, 0.55]\n")
    with_albedo = _tone(gl, scene_yaml)
    without = _tone(gl, scene_yaml, ["shade.albedo_weight=0"])
    assert (with_albedo >= 0).mean() > 0.2
    assert np.array_equal(with_albedo, without)
