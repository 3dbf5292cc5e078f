"""sketch draws only near its inputs' footprints (Sketch._rect): a single covered texel, with the offset at
its bound everywhere, is reached from exactly the pixel one largest shift away; that pixel must lie inside
the rectangle the pass draws, and the image must be the whole pass's (checked with footprints off)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from nodegraph_nodes.sketch import Sketch

from nodegraph.gpu import footprint
from nodegraph.values import Footprint
from tests.helpers import run_node

W, H = 160, 120
TEXEL = (70, 50)  # x, y (rows from the bottom)


def _inputs(gl, which: str, off: tuple[float, float]) -> dict:
    shade = np.zeros((H, W, 4), np.float32)
    edges = np.zeros((H, W, 1), np.float32)
    x, y = TEXEL
    if which == "shade":
        shade[y, x] = (0.2, 0.4, 0.6, 1.0)
    else:
        edges[y, x] = 1.0
    t_shade, t_edges = gl.upload(shade, "RGBA8"), gl.upload(edges, "R16F")
    t_shade.footprint = Footprint((x, y, 1, 1), (0.0, 0.0, 0.0, 0.0))
    t_edges.footprint = Footprint((x, y, 1, 1), (0.0,))
    t_off = gl.upload(np.broadcast_to(np.asarray(off, np.float32), (H, W, 2)).copy(), "RG16F", filter="nearest")
    t_off.absmax = (abs(off[0]), abs(off[1]))
    return {"edges": t_edges, "shade": t_shade, "offset": t_off}


@pytest.mark.parametrize("which", ["shade", "edges"])
@pytest.mark.parametrize("signs", list(itertools.product((1.0, -1.0), repeat=2)))
def test_the_farthest_pixel_a_texel_reaches_is_drawn(gl, which, signs):
    # matrices with cross terms: the shift along x takes both offset channels
    params = Sketch.Params(edge_matrix=((0.05, 0.02), (-0.01, 0.04)), shade_matrix=((-0.04, 0.03), (0.02, -0.05)),
                           edge_color=(0.0, 0.0, 0.0), edge_strength=1.0)
    off = (0.75 * signs[0], 0.5 * signs[1])
    node = Sketch("s", params)
    m = np.asarray(params.shade_matrix if which == "shade" else params.edge_matrix, np.float64)
    shift = m @ np.asarray(off) * np.array([W, H])  # pixel p reads p + shift
    reached = (int(round(TEXEL[0] - shift[0])), int(round(TEXEL[1] - shift[1])))
    got = {}
    for on in (True, False):
        footprint.ENABLED = on
        try:
            out = run_node(gl, node, _inputs(gl, which, off), (W, H), needed=frozenset({"color"}))["color"]
        finally:
            footprint.ENABLED = True
        got[on] = (out.read(), out.footprint)
    (drawn, fp), (whole, _) = got[True], got[False]
    np.testing.assert_array_equal(drawn, whole)
    assert fp is not None and fp.blank == (*params.paper, 0.0)
    x, y, w, h = fp.rect
    assert x <= reached[0] < x + w and y <= reached[1] < y + h, (fp.rect, reached)
    assert w * h < W * H / 4  # drawn near the texel, not over the image
    assert whole[reached[1], reached[0], 3] > 0.25, "the reached pixel is drawn on (bilinear: part of the texel)"
    paper = np.ones((H, W), bool)
    paper[y:y + h, x:x + w] = False
    assert (whole[paper, 3] == 0).all()


def test_without_a_bound_or_a_footprint_the_whole_image_is_drawn(gl):
    node = Sketch("s", Sketch.Params())
    ins = _inputs(gl, "shade", (0.5, 0.5))
    ins["offset"].absmax = None
    assert run_node(gl, node, ins, (W, H), needed=frozenset({"color"}))["color"].footprint is None
    ins = _inputs(gl, "shade", (0.5, 0.5))
    ins["edges"].footprint = None
    assert run_node(gl, node, ins, (W, H), needed=frozenset({"color"}))["color"].footprint is None
    ins = _inputs(gl, "shade", (0.5, 0.5))  # the offsets output differs everywhere
    assert run_node(gl, node, ins, (W, H), needed=frozenset({"color", "offsets"}))["color"].footprint is None
    ins = _inputs(gl, "shade", (0.5, 0.5))  # a shade whose blank is covered cannot be left out
    ins["shade"].footprint = Footprint((70, 50, 1, 1), (0.0, 0.0, 0.0, 1.0))
    assert run_node(gl, node, ins, (W, H), needed=frozenset({"color"}))["color"].footprint is None
