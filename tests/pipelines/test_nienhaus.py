"""The Nienhaus & Döllner pipeline as a whole: caching across runs, ancestors only, seeds, pass-through."""

from __future__ import annotations

import numpy as np
from nodegraph_nodes.depth_sprite import DepthSprite

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from tests.helpers import ROOT, run_node


# -- whole pipeline, cache --------------------------------------------------------------------
def test_pipeline_second_run_computes_nothing_and_param_change_recomputes_downstream(gl, tmp_path):
    from nodegraph.cache import Cache

    path = ROOT / "pipelines" / "nienhaus_sketchy.yaml"
    cache = Cache(tmp_path / "c")
    first = Executor(pl.load(path, size=(96, 96)), cache, gl=gl)
    r1 = first.run()
    assert sorted(r1.computed()) == ["edges", "gbuf", "noise", "sketch"]  # the sprite passes the sketch on
    r2 = Executor(pl.load(path, size=(96, 96)), cache, gl=gl).run()
    assert r2.computed() == []
    assert np.array_equal(r1.values[("sprite", "color")].read(), r2.values[("sprite", "color")].read())
    r3 = Executor(pl.load(path, size=(96, 96), overrides=["edges.normal_threshold=0.6"]), cache, gl=gl).run()
    assert sorted(r3.computed()) == ["edges", "sketch"]


def test_requesting_one_intermediate_runs_only_its_ancestors(gl):
    pipe = pl.load(ROOT / "pipelines" / "nienhaus_sketchy.yaml", size=(64, 64))
    ex = Executor(pipe, None, requested=[("edges", "out")], gl=gl)
    res = ex.run()
    assert sorted(res.computed()) == ["edges", "gbuf"]
    assert ex.plan.needed["gbuf"] == frozenset({"normal_depth"})


def test_same_seed_same_bytes_and_frames_differ_only_where_the_camera_moves(gl):
    pipe = pl.load(ROOT / "pipelines" / "nienhaus_sketchy.yaml", size=(64, 64))
    a = Executor(pipe, None, gl=gl).run(3).values[("sprite", "color")].read()
    b = Executor(pipe, None, gl=gl).run(3).values[("sprite", "color")].read()
    assert np.array_equal(a, b)


def test_sprite_over_paper_is_the_sketch_unchanged(gl):
    """With the sketch's depth connected and nothing under it, the sprite is a pass-through; the real
    depth-tested pass over paper at the far plane gives the same pixels, colour and depth."""
    pipe = pl.load(ROOT / "pipelines" / "nienhaus_sketchy.yaml", size=(160, 120))
    refs = [("sketch", "color"), ("sketch", "depth"), ("sprite", "color"), ("sprite", "depth")]
    ex = Executor(pipe, None, requested=refs, gl=gl)
    res = ex.run()
    v = res.values
    assert v[("sprite", "color")] is v[("sketch", "color")] and v[("sprite", "depth")] is v[("sketch", "depth")]
    assert res.stats["sprite"].status == "pass-through" and ex.compute_counts.get("sprite") is None
    paper = np.zeros((120, 160, 4), np.float32)
    paper[..., :3] = (0.98, 0.97, 0.94)
    paper[..., 3] = 1
    full = run_node(gl, DepthSprite("d"), {"color": v[("sketch", "color")], "sketch_depth": v[("sketch", "depth")],
                                           "under_color": gl.upload(paper, "RGBA8"),
                                           "under_depth": gl.upload(np.ones((120, 160, 1), np.float32), "R32F")},
                    (160, 120))
    sk_z = v[("sketch", "depth")].read()
    assert np.array_equal(full["depth"].read(), sk_z)
    sk = v[("sketch", "color")].read()
    assert np.abs(full["color"].read()[..., :3] - sk[..., :3]).max() <= 1 / 255
    far = sk_z[..., 0] >= 1
    assert far.any() and (~far).any()
    assert np.abs(sk[far][:, :3] - paper[0, 0, :3]).max() <= 1 / 255  # paper where nothing lands
