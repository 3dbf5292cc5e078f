"""rasterize tone_bands: the shade map in 2 or 3 colour patches by N.L; default 0 keeps the flat colour and
the keys it had."""

from __future__ import annotations

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from nodes.rasterize import TONE_BANDS

TEXT = """pipeline: t
size: [120, 100]
scene: builtin:sphere
nodes:
  g: {{type: rasterize, params: {{tone_bands: {bands}}}}}
outputs:
  image: g.color
"""


def _analytic_ndotl(scene, size):
    """float64 N.L per pixel of the unit sphere (ray cast through each pixel centre); NaN off the sphere."""
    w, h = size
    cam = scene.camera
    tx, ty = cam.tan_half(w / h)
    r, u, f = cam.basis()
    xs = ((np.arange(w) + 0.5) / w * 2 - 1) * tx
    ys = ((np.arange(h) + 0.5) / h * 2 - 1) * ty  # row 0 = bottom, as textures read back
    d = f[None, None, :] + xs[None, :, None] * r + ys[:, None, None] * u
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    o = cam.eye
    b = d @ o
    disc = b * b - (o @ o - 1.0)
    t = -b - np.sqrt(np.where(disc > 0, disc, np.nan))
    hit = o + t[..., None] * d
    view = cam.view_matrix()[:3, :3]
    n_view = hit @ view.T
    light = np.asarray(scene.light_direction, dtype=np.float64)
    return n_view @ (light / np.linalg.norm(light))


@pytest.mark.parametrize("bands", [2, 3])
def test_bands_follow_n_dot_l(gl, bands: int) -> None:
    pipe = pl.loads(TEXT.format(bands=bands), "t.yaml")
    color = Executor(pipe, None, gl=gl).run().values[("g", "color")].read()
    nl = _analytic_ndotl(pipe.scene, pipe.size)
    inside = (color[..., 3] > 0) & np.isfinite(nl)  # on both the icosphere and the analytic sphere
    rgb = np.round(color[inside][:, :3] * 255).astype(int)
    colours, index = np.unique(rgb, axis=0, return_inverse=True)
    assert len(colours) == bands
    base = np.asarray(pipe.scene.objects[0].color)
    (lo_t, hi_t), factors = TONE_BANDS[bands]
    wanted = sorted(set(factors))
    # each colour is the flat colour times its band's factor; order the bands by brightness
    order = np.argsort(colours.sum(axis=1))
    for rank, k in enumerate(order):
        assert np.allclose(colours[k] / 255.0, base * wanted[rank], atol=1.5 / 255)
    ranks = np.empty(len(order), int)
    ranks[order] = np.arange(len(order))
    band = ranks[index.ravel()]
    values = nl[inside]
    for k in range(bands - 1):  # ordered by N.L: band k lies below band k + 1 (tolerance: the icosphere)
        assert values[band == k].max() <= values[band == k + 1].min() + 0.03
    edges = [lo_t, hi_t] if bands == 3 else [lo_t]
    expected = np.searchsorted(edges, values, side="right")
    assert (expected == band).mean() > 0.99


def test_default_keeps_flat_colour_and_keys(gl) -> None:
    flat = pl.loads(TEXT.format(bands=0), "t.yaml")
    plain = pl.loads(TEXT.format(bands=0).replace(", params: {tone_bands: 0}", ""), "t.yaml")
    assert Executor(flat, None).keys(0) == Executor(plain, None).keys(0)
    banded = pl.loads(TEXT.format(bands=3), "t.yaml")
    assert Executor(banded, None).keys(0)["g"] != Executor(plain, None).keys(0)["g"]
    color = Executor(flat, None, gl=gl).run().values[("g", "color")].read()
    assert len(np.unique(np.round(color[color[..., 3] > 0][:, :3] * 255), axis=0)) == 1


def test_bands_with_normal_requested_match(gl) -> None:
    pipe = pl.loads(TEXT.format(bands=3), "t.yaml")
    only = Executor(pipe, None, gl=gl).run().values[("g", "color")].read()
    both = Executor(pipe, None, gl=gl, requested=[("g", "color"), ("g", "normal")]).run()
    assert np.array_equal(both.values[("g", "color")].read(), only)
    assert both.values[("g", "normal")].read()[..., 3].max() == 1.0


def test_bands_are_not_for_lit_colour() -> None:
    with pytest.raises(PipelineError, match="tone_bands"):
        pl.loads(TEXT.format(bands="3, lit: true"), "t.yaml")
