"""draw_strokes against hand computation: a straight stroke's coverage across it, its round end caps, tone
scaling, hidden strokes, an empty Strokes."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.draw_strokes import DrawStrokes, quads

from nodegraph.values import Strokes
from tests.helpers import run_node

W, H = 96, 64


def draw(gl, strokes: Strokes, **params) -> np.ndarray:
    """The darkness (alpha of the transparent output), (H, W) row 0 at the bottom."""
    out = run_node(gl, DrawStrokes("d", DrawStrokes.Params(**params)), {"strokes": strokes}, (W, H))["color"]
    return out.read()[..., 3].astype(np.float64)


@pytest.mark.parametrize("width", [2.0, 5.0, 8.0])
def test_straight_stroke_covers_the_hand_computed_rows(gl, width):
    y = 30.5  # a pixel centre: the stroke spans [y - w/2, y + w/2]
    s = Strokes([np.array([[20.0, y], [76.0, y]])], size=(W, H), width=width)
    d = draw(gl, s, brush="ink")
    col = d[:, 48]
    # the linear edge ramp is centred on the edge: a pixel's coverage is its overlap with the band (box filter)
    centres = np.arange(H) + 0.5
    expected = np.clip(np.minimum(centres + 0.5, y + width / 2) - np.maximum(centres - 0.5, y - width / 2), 0, 1)
    np.testing.assert_allclose(col, expected, atol=2.0 / 255 + 1e-3)
    assert abs(col.sum() - width) < 1.0


def test_round_end_caps_reach_half_the_width_past_the_ends(gl):
    y, x0, x1, width = 30.5, 20.0, 76.0, 8.0
    s = Strokes([np.array([[x0, y], [x1, y]])], size=(W, H), width=width)
    d = draw(gl, s, brush="ink")
    row = d[30]
    centres = np.arange(W) + 0.5
    inside = (centres > x0 - width / 2 + 0.5) & (centres < x1 + width / 2 - 0.5)
    outside = (centres < x0 - width / 2 - 0.5) | (centres > x1 + width / 2 + 0.5)
    assert (row[inside] > 0.99).all() and (row[outside] == 0).all()
    # round: at the end x1 the cap's extent across shrinks as sqrt(r^2 - dx^2), hand-computed at dx = 3
    cap_col = int(x1 + 3.0)  # pixel centre x1 + 3.5: half-extent sqrt(16 - 3.5^2) = 1.94
    half = np.sqrt(16 - 3.5**2)
    covered = d[:, cap_col]
    assert abs((covered > 0.5).sum() - 2 * half) <= 1.0
    assert covered.sum() < 0.7 * width  # narrower than the stroke: not a square cap


def test_tone_scales_the_darkness(gl):
    polys = [np.array([[10.0, 20.5], [80.0, 20.5]]), np.array([[10.0, 44.5], [80.0, 44.5]])]
    tone = np.r_[np.full(2, 1.0), np.full(2, 0.4)].astype(np.float32)
    s = Strokes(polys, size=(W, H), width=4.0, attrs={"tone": tone})
    d = draw(gl, s, brush="ink")
    assert abs(d[20, 45] - 1.0) < 1e-3 and abs(d[44, 45] - 0.4) < 2e-3
    d2 = draw(gl, s, brush="ink", opacity=0.5)
    assert abs(d2[20, 45] - 0.5) < 2e-3 and abs(d2[44, 45] - 0.2) < 2e-3


def test_empty_and_hidden_draw_nothing(gl):
    assert draw(gl, Strokes([], size=(W, H))).max() == 0.0
    s = Strokes([np.array([[10.0, 20.5], [80.0, 20.5]])], size=(W, H), width=4.0,
                attrs={"visible": np.zeros(2, bool)})
    assert draw(gl, s).max() == 0.0
    assert draw(gl, s, hidden=True, brush="ink").max() > 0.99


def test_quads_are_mitred_and_arc_length_runs_along():
    xy = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    verts, tris = quads.expand(xy, np.array([0, 3]), np.full(3, 2.0), np.ones(3), 1.0)
    # the corner's outer vertex lies at distance 3 from both legs: (10 + 3, -3) or its mirror (7, 3)
    corner = verts[2:4, :2]
    assert {tuple(np.round(c, 5)) for c in corner} == {(13.0, -3.0), (7.0, 3.0)}
    np.testing.assert_allclose(verts[0:6:2, 3], [0.0, 10.0, 20.0])
    assert len(tris) == 2 * 2 + 2 * 2  # two segments, two caps
    assert quads.expand(np.zeros((0, 2)), np.array([0]), np.zeros(0), np.zeros(0), 1.0)[0].shape == (0, 9)


@pytest.mark.parametrize("brush", ["pencil", "chalk"])
def test_brush_textures_are_grainy_and_periodic(brush):
    t = quads.brush_texture(brush)
    assert t.shape == (quads.BRUSH_SIZE[1], quads.BRUSH_SIZE[0]) and t.min() >= 0 and t.max() <= 1
    assert t.std() > 0.05
    # periodic along u: the first and last columns differ no more than neighbouring columns do
    assert np.abs(t[:, 0] - t[:, -1]).mean() < 2.5 * np.abs(np.diff(t, axis=1)).mean()
