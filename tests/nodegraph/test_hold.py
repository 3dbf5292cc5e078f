"""The `hold` convention of stochastic nodes (nodegraph.node.held_frame): the frame a node's seed and noise
see is frame // hold * hold (0 when hold is 0), its key covers that frame only, so held frames share one
cache (or memory) entry; the defaults keep every node as it was (test_keys_stable.py checks the keys)."""

from __future__ import annotations

import numpy as np
import pytest

import nodegraph as ng
from nodegraph import pipeline as pl
from nodegraph import registry
from nodegraph.node import HashContext, held_frame

# (pipeline, stochastic node) for every shipped node type with a hold
HELD = [("nienhaus_sketchy", "noise"), ("object_space_uncertainty", "noise"), ("pencil_contours", "distortion"),
        ("pencil_contours", "contour"), ("loose_and_sketchy", "particles")]


def test_held_frame():
    assert [held_frame(f, 3) for f in range(7)] == [0, 0, 0, 3, 3, 3, 6]
    assert [held_frame(f, 0) for f in range(4)] == [0, 0, 0, 0]
    assert [held_frame(f, 1) for f in range(4)] == [0, 1, 2, 3]
    assert held_frame(5, None) == 5  # a node without a hold sees its frame


@pytest.mark.parametrize(("name", "nid"), [("nienhaus_sketchy", "noise"), ("pencil_contours", "distortion")])
def test_hold_3_computes_twice_over_6_frames(name, nid):
    """Nodes with no per-frame input (the G-buffer is per frame: downstream nodes recompute anyway)."""
    with ng.Session(cache=False) as session:
        pipe = session.load(name, size=(48, 48), set={f"{nid}.hold": 3})
        list(pipe.frames(range(6)))
        assert session.compute_counts[nid] == 2
        assert session.compute_counts["gbuf"] == 6


@pytest.mark.parametrize(("name", "nid"), HELD)
def test_keys_change_only_at_hold_boundaries(name, nid):
    """The node's own key (inputs fixed) on a still scene: one per hold; hold 0: one for all frames."""
    for hold, expect in ((3, [0, 0, 0, 3, 3, 3]), (0, [0] * 6), (1, list(range(6)))):
        pipe = pl.load(name, size=(48, 48), scene="builtin:box", overrides=[f"{nid}.hold={hold}"])
        scene = _still(pipe.scene)
        node = pipe.nodes[nid]
        keys = [node.key(HashContext(pipe.size, f, pipe.seed, scene), {"in": "fixed"}) for f in range(6)]
        assert [keys.index(k) for k in keys] == expect, hold


def _still(scene):
    from dataclasses import replace

    return replace(scene, orbit=None)


@pytest.mark.parametrize("type_name", ["perlin_noise", "distortion_map"])
def test_animate_is_hold_1_and_keys_agree(type_name):
    cls = registry.default().get(type_name)
    a = cls("n", cls.Params(animate=True))
    b = cls("n", cls.Params(hold=1))
    assert a.hold == b.hold == 1 and cls("n").hold == 0
    assert a.context_keys == b.context_keys and "frame" in a.context_keys and "frame" not in cls("n").context_keys


def test_held_frames_are_the_same_pixels(gl):
    """perlin_noise with hold 2: frames 0 and 1 are one image, frame 2 another."""
    with ng.Session(cache=False) as session:
        pipe = session.load("nienhaus_sketchy", size=(48, 48), scene="builtin:box", set={"noise.hold": 2})
        pipe.pipeline.scene = _still(pipe.pipeline.scene)
        imgs = dict(pipe.frames(range(3)))
    assert np.array_equal(imgs[0], imgs[1]) and not np.array_equal(imgs[1], imgs[2])


def test_records_show_hold_only_when_set():
    """Gallery records made before the nodes had a hold still match (gallery verify stays byte-identical)."""
    cls = registry.default().get("object_noise")
    assert "hold" not in cls("n").recorded_params()
    assert cls("n", cls.Params(hold=2)).recorded_params()["hold"] == 2
    assert "hold" in registry.default().get("particle_sketch")("p").recorded_params()  # hashed as ever
