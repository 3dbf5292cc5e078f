"""Variations in style (Nienhaus & Döllner §3.4) as whole pipelines: chalk roughens, the variation pipelines render."""

from __future__ import annotations

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from tests.helpers import ROOT


def _roughness(img: np.ndarray) -> tuple[float, int]:
    """(changes of the dark-ink mask along rows and columns per dark pixel, colour changes > 0.05 between
    neighbours): both grow when edges and colour borders fray."""
    rgb = img[..., :3]
    dark = rgb.mean(axis=-1) < 0.4
    changes = np.count_nonzero(dark[:, 1:] != dark[:, :-1]) + np.count_nonzero(dark[1:] != dark[:-1])
    borders = (np.count_nonzero(np.abs(np.diff(rgb, axis=1)).max(axis=-1) > 0.05)
               + np.count_nonzero(np.abs(np.diff(rgb, axis=0)).max(axis=-1) > 0.05))
    return changes / max(int(dark.sum()), 1), borders


def test_chalk_roughens_profiles_and_colour_borders(gl):
    """Same scene and matrices (a few pixels of spread at the pipeline's own size): white noise frays the
    edges and colour borders that Perlin noise keeps smooth."""
    path = ROOT / "pipelines" / "chalk.yaml"
    chalk = Executor(pl.load(path), None, gl=gl).run().values[("sprite", "color")].read()
    smooth = Executor(pl.load(path, overrides=["noise.kind=perlin"]), None, gl=gl).run()
    rough_edges, rough_borders = _roughness(chalk)
    smooth_edges, smooth_borders = _roughness(smooth.values[("sprite", "color")].read())
    assert rough_edges > 1.8 * smooth_edges  # measured 1.36 vs 0.63 transitions per dark pixel
    assert rough_borders > 1.4 * smooth_borders  # measured 116k vs 65k


@pytest.mark.parametrize("name", ["repeated_edges", "chalk", "object_space_uncertainty"])
def test_variation_pipelines_render(gl, name):
    pipe = pl.load(ROOT / "pipelines" / f"{name}.yaml", size=(96, 96))
    img = Executor(pipe, None, gl=gl).run().values[pipe.outputs["image"]].read()
    assert img.shape == (96, 96, 4) and np.isfinite(img).all()
    paper = np.asarray((0.98, 0.97, 0.94), np.float32)
    drawn = np.abs(img[..., :3] - paper).max(axis=-1) > 0.05
    assert 0.02 < drawn.mean() < 0.98
