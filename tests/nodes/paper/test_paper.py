"""paper: seeded, tileable grain normals."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.paper import paper_height, paper_normals

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor
from nodegraph.node import HashContext
from tests.helpers import assert_outputs_as_planned, run_minimal

TEXT = """\
pipeline: t
size: [40, 30]
reference_size: 30  # px_scale 1: the tile as its params say
scene: builtin:box
seed: 8
nodes:
  paper: {type: paper, params: {size: 64}}
outputs:
  out: paper.out
"""


def load(overrides: list[str] = (), seed: int = 8) -> pl.Pipeline:
    return pl.loads(TEXT.replace("seed: 8", f"seed: {seed}"), "t.yaml", overrides=list(overrides), load_scene=False)


def test_unit_normals_height_and_size(gl):
    out = Executor(load(), None, gl=gl).run().values[("paper", "out")]
    assert out.fmt == "RGBA16F" and out.size == (64, 64)  # its own tile size, not the image's
    a = out.read()
    np.testing.assert_allclose(np.linalg.norm(a[..., :3], axis=-1), 1.0, atol=2e-3)
    assert a[..., 2].min() > 0.2  # facing up out of the paper
    assert a[..., 3].min() >= 0.0 and a[..., 3].max() <= 1.0
    assert a[..., :2].std() > 0.05  # there is relief


def test_same_seed_same_bytes(gl):
    a = Executor(load(), None, gl=gl).run().values[("paper", "out")].read()
    b = Executor(load(), None, gl=gl).run().values[("paper", "out")].read()
    c = Executor(load(seed=9), None, gl=gl).run().values[("paper", "out")].read()
    assert a.tobytes() == b.tobytes() and a.tobytes() != c.tobytes()


def test_tileable_and_normals_match_the_height_field():
    h = paper_height(64, 3, 1.5, 0.4, 6.0)
    inner = np.abs(np.diff(h, axis=1)).mean()
    assert np.abs(h[:, 0] - h[:, -1]).mean() < 1.5 * inner and np.abs(h[0] - h[-1]).mean() < 1.5 * inner
    n = paper_normals(h, 6.0)
    # normal from periodic central differences, written out
    y, x = 10, 63
    gx = (h[y, 0] - h[y, 62]) * 0.5 * 6.0
    gy = (h[11, x] - h[9, x]) * 0.5 * 6.0
    expected = np.array([-gx, -gy, 1.0]) / np.linalg.norm([-gx, -gy, 1.0])
    np.testing.assert_allclose(n[y, x, :3], expected, atol=1e-6)


def test_key_reads_the_seed_not_the_size():
    node = load().nodes["paper"]
    k = node.key(HashContext((40, 30), 0, 8, None), {})
    assert k == node.key(HashContext((800, 600), 5, 8, None), {})
    assert k != node.key(HashContext((40, 30), 0, 9, None), {})


def test_bad_params():
    with pytest.raises(PipelineError, match="fibres"):
        load(["paper.fibres=2"])


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  p: {type: paper, params: {size: 32}}
"""
    ex, res = run_minimal(gl, nodes, {"out": "p.out"})
    assert assert_outputs_as_planned(ex, res, "p") == ["out"]


def test_gpu_tile_range_and_seam(gl):
    """The node's texture: heights span [0, 1]; across the wrap-around seam (last column to first, last row
    to first) the height steps no more than between interior neighbours; the normals are the unit normals
    of the stored heights by periodic central differences (float64, from the GPU's own heights)."""
    out = Executor(load(), None, gl=gl).run().values[("paper", "out")].read().astype(np.float64)
    h = out[..., 3]
    assert abs(h.min()) < 1e-3 and abs(h.max() - 1.0) < 1e-3  # half floats
    inner_x = np.abs(np.diff(h, axis=1)).mean()
    inner_y = np.abs(np.diff(h, axis=0)).mean()
    assert np.abs(h[:, 0] - h[:, -1]).mean() < 1.5 * inner_x
    assert np.abs(h[0] - h[-1]).mean() < 1.5 * inner_y
    relief = load().nodes["paper"].params.relief
    gx = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / 2 * relief
    gy = (np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0)) / 2 * relief
    n = np.stack([-gx, -gy, np.ones_like(h)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    np.testing.assert_allclose(out[..., :3], n, atol=1.5e-2)  # heights and normals both in half floats


def test_grain_follows_the_reference_size():
    """At px_scale 2 the tooth is twice as many texels and the relief twice as high (same lean of the
    normals); at 1 the tile is exactly the params'."""
    from nodegraph_nodes.paper import paper_height, paper_normals

    node = load().nodes["paper"]
    p = node.params
    assert np.array_equal(node.normals(3, 1.0), paper_normals(paper_height(p.size, 3, p.grain, p.fibres,
                                                                            p.fibre_length), p.relief))
    assert np.array_equal(node.normals(3, 2.0), paper_normals(paper_height(p.size, 3, 2 * p.grain, p.fibres,
                                                                            p.fibre_length), 2 * p.relief))
