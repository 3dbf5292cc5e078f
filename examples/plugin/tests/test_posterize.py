"""posterize: registered through its entry point; on GL against a float64 NumPy reference; in a pipeline
of built-in nodes through the command line."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from sketchgraph_posterize import Posterize
from sketchgraph_posterize.reference import posterize

from nodegraph import pipeline as pl
from nodegraph import registry
from nodegraph.cli import main
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from nodegraph.output import imageio

TOON = Path(__file__).resolve().parents[1] / "pipelines" / "toon.yaml"


def pipeline_text(image: Path, levels: int, alpha: bool) -> str:
    return f"""\
pipeline: posterize-test
size: [8, 8]
nodes:
  src: {{type: load_image, params: {{path: "{image}"}}}}
  poster: {{type: posterize, in: {{color: src.out}}, params: {{levels: {levels}, alpha: {str(alpha).lower()}}}}}
outputs:
  image: poster.color
  source: src.out
"""


def test_registers_through_its_entry_point_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error", registry.PluginWarning)
        reg = registry.load()
    assert reg.get("posterize") is Posterize
    assert reg.origin("posterize").startswith("entry point 'posterize = sketchgraph_posterize:register'")
    assert (Posterize.source_dir() / "posterize.glsl").is_file()  # the GLSL was installed as package data


def test_reference_by_hand():
    px = np.array([[[0.0, 0.3, 0.74, 1.0], [-0.2, 0.25, 0.5, 1.3]]])
    assert np.allclose(posterize(px, 4, alpha=True), [[[0, 1 / 3, 2 / 3, 1], [0, 1 / 3, 2 / 3, 1]]])
    assert np.allclose(posterize(px, 2), [[[0, 0, 1, 1.0], [0, 0, 1, 1.3]]])  # alpha kept as it is


@pytest.mark.parametrize("levels, alpha", [(2, False), (3, True), (7, False), (16, True)])
def test_matches_the_float64_reference(gl, tmp_path: Path, levels: int, alpha: bool):
    rng = np.random.default_rng(levels)
    h, w = 37, 53
    img = rng.uniform(-0.1, 1.1, (h, w, 4)).astype(np.float32)
    image = imageio.write(tmp_path / "in.exr", img, half=False)
    pipe = pl.loads(pipeline_text(image, levels, alpha), str(tmp_path / "t.yaml"))
    res = Executor(pipe, None).run()
    out_tex = res.values[("poster", "color")]
    assert out_tex.fmt == "RGBA16F" and out_tex.size == (w, h)
    src = res.values[("src", "out")].read().astype(np.float64)
    got = out_tex.read().astype(np.float64)
    want = posterize(src, levels, alpha)
    # float32 products within a hair of a band edge may round either way on the GPU: leave those out
    scaled = src * levels
    edge = (np.abs(scaled - np.rint(scaled)) < 1e-5) & (src > 0) & (src < 1)  # clamped values are exact
    if not alpha:
        edge[..., 3] = False
    ok = ~edge.any(axis=2)
    assert ok.mean() > 0.99
    assert np.abs(got - want)[ok].max() <= 1e-3  # RGBA16F holds k / (levels - 1) within 2^-11
    values = np.unique(got[..., :3 if not alpha else 4])
    assert len(values) <= levels


def test_levels_below_two_fail_when_the_pipeline_loads(tmp_path: Path):
    image = imageio.write(tmp_path / "in.exr", np.zeros((2, 2, 4), np.float32))
    with pytest.raises(PipelineError, match=r"t\.yaml:\d+:\d+: .*levels"):
        pl.loads(pipeline_text(image, 1, False), str(tmp_path / "t.yaml"))


def test_the_example_pipeline_renders_through_the_cli(gl, tmp_path: Path):
    runner = CliRunner()
    out = tmp_path / "toon.png"
    r = runner.invoke(main, ["run", str(TOON), "--size", "96x72", "-o", str(out)], catch_exceptions=False)
    assert r.exit_code == 0, r.output
    assert "warning:" not in r.stderr
    img = imageio.read(out)
    assert img.shape[:2] == (72, 96) and img.std() > 0.05
    bands = tmp_path / "bands.exr"
    r = runner.invoke(main, ["inspect", str(TOON), "bands.color", "-o", str(bands), "--size", "96x72"],
                      catch_exceptions=False)
    assert r.exit_code == 0, r.output
    rgb = imageio.read(bands)[..., :3]
    steps = np.array([0, 1 / 3, 2 / 3, 1])
    assert np.abs(rgb[..., None] - steps).min(axis=-1).max() <= 1e-3  # every value is one of the 4 levels
    assert len(np.unique(np.round(rgb * 3))) > 1


def test_listed_by_sketchgraph_nodes():
    r = CliRunner().invoke(main, ["nodes", "posterize"], catch_exceptions=False)
    assert r.exit_code == 0, r.output
    assert "posterize  (version 1)" in r.stdout and "levels = 4" in r.stdout
