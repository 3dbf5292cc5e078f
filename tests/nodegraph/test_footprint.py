"""Footprints (nodegraph/gpu/footprint.py): the pixel rectangles hold every projected point, passes drawn inside one
give the pixels of the whole pass, and the G-buffer's footprint holds every covered pixel (built-in scene, the
shared meshes, enlarged geometry, a skinned glTF along its animation)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.gpu import footprint
from nodegraph.gpu.glsl import ENGINE_GLSL
from nodegraph.values import Footprint
from tests import gltf_files as gf
from tests.helpers import shared_mesh

SIZE = (160, 120)


def _assert_same_bits(a, b, what: str = "") -> None:
    """Byte for byte, not by value: -0.0 and 0.0 are equal numbers, but not the same pixels."""
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype, what
    np.testing.assert_array_equal(a.view(np.uint8), b.view(np.uint8), err_msg=what)


def _perspective(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A random projection x view and points in front of its eye."""
    rng = np.random.default_rng(seed)
    f, n, far = 1.0 / np.tan(np.radians(rng.uniform(20, 80)) / 2), 0.1, 100.0
    proj = np.array([[f * 0.75, 0, 0, 0], [0, f, 0, 0], [0, 0, (far + n) / (n - far), 2 * far * n / (n - far)],
                     [0, 0, -1, 0]])
    rot, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    view = np.eye(4)
    view[:3, :3] = rot
    pts_view = np.stack([rng.uniform(-3, 3, 50), rng.uniform(-3, 3, 50), rng.uniform(-20, -1, 50)])
    pts = rot.T @ pts_view  # world points whose view-space z lies in [-20, -1]
    return proj @ view, pts


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(0, 3))
def test_projected_points_lie_inside_the_rect(seed, margin):
    mvp, pts = _perspective(seed)
    rect = footprint.project_points(mvp, pts, SIZE, margin)
    assert rect is not None
    clip = mvp @ np.vstack([pts, np.ones(pts.shape[1])])
    px = (clip[:2] / clip[3] + 1.0) * 0.5 * np.array(SIZE)[:, None]
    inside = (px[0] >= rect[0] - 1e-9) & (px[0] <= rect[0] + rect[2] + 1e-9)
    inside &= (px[1] >= rect[1] - 1e-9) & (px[1] <= rect[1] + rect[3] + 1e-9)
    on_image = (px[0] >= 0) & (px[0] <= SIZE[0]) & (px[1] >= 0) & (px[1] <= SIZE[1])
    assert inside[on_image].all()
    # tight: the rectangle's sides lie within margin + 1 pixel of the extreme projected points (clipped)
    lo = np.clip(px.min(axis=1), 0, SIZE)
    assert rect[0] >= lo[0] - margin - 1 and rect[1] >= lo[1] - margin - 1


def test_points_on_or_behind_the_eye_plane_give_no_rect():
    proj = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, -1.002, -0.2002], [0, 0, -1, 0]])  # w = -z
    front = np.array([[0.5, -1.0], [0.2, 0.3], [-2.0, -5.0]])
    assert footprint.project_points(proj, front, SIZE, 0) is not None
    for z in (0.0, 1.0):  # on the eye's plane, behind the eye
        assert footprint.project_points(proj, np.hstack([front, [[0.0], [0.0], [z]]]), SIZE, 0) is None
    assert footprint.project_points(proj, np.zeros((3, 0)), SIZE, 0) == (0, 0, 0, 0)


def test_union_and_grow():
    assert footprint.union([(10, 20, 5, 5), (0, 0, 0, 0), (12, 10, 10, 4)]) == (10, 10, 12, 15)
    assert footprint.union([(1, 1, 2, 2), None]) is None
    assert footprint.union([]) == (0, 0, 0, 0)
    assert footprint.grow((10, 10, 5, 5), 3, 20, SIZE) == (7, 0, 11, 35)
    assert footprint.grow((150, 100, 10, 20), 5, 5, SIZE) == (145, 95, 15, 25)
    assert footprint.grow((3, 3, 0, 0), 5, 5, SIZE) == (3, 3, 0, 0)
    assert footprint.covers_image((0, 0) + SIZE, SIZE) and not footprint.covers_image((1, 0) + SIZE, SIZE)


def test_a_scissored_pass_clears_to_the_blank_value_outside(gl, rng):
    src = gl.upload(rng.random((SIZE[1], SIZE[0], 4)).astype(np.float32), "RGBA32F")
    prog = gl.program(ENGINE_GLSL / "copy.glsl", node="test")
    whole, part = gl.texture(SIZE, "RGBA32F"), gl.texture(SIZE, "RGBA32F")
    gl.fullscreen(prog, [whole], {"t_in": src})
    rect = (30, 20, 50, 40)
    gl.fullscreen(prog, [part], {"t_in": src}, rect=rect, blanks=[(0.25, 0.5, 0.75, 1.0)])
    a, b = whole.read(), part.read()
    x, y, w, h = rect
    np.testing.assert_array_equal(b[y:y + h, x:x + w], a[y:y + h, x:x + w])
    outside = np.ones(SIZE[::-1], bool)
    outside[y:y + h, x:x + w] = False
    assert (b[outside] == [0.25, 0.5, 0.75, 1.0]).all()
    assert part.footprint.rect == rect and part.footprint.blank == (0.25, 0.5, 0.75, 1.0)
    assert whole.footprint is None
    # the whole image as the rect, or footprints switched off: the plain pass, no footprint
    full = gl.texture(SIZE, "RGBA32F")
    gl.fullscreen(prog, [full], {"t_in": src}, rect=(0, 0) + SIZE, blanks=[(0.0,) * 4])
    assert full.footprint is None
    for t in (src, whole, part, full):
        gl.release(t)


def _run(gl, text: str, refs: list[tuple[str, str]], frames=(0, 5, 11)) -> list[dict]:
    """Each frame's values read back before the next frame runs (a frame loop hands the last frame's textures
    to the next), as {ref: (pixels as float32 and as stored, footprint, absmax)}."""
    ex = Executor(pl.loads(text, "t.yaml"), None, mode="loop", requested=refs, gl=gl)
    out = []
    for f in frames:
        values = ex.run(f).values
        out.append({r: Read(values[r].read(), values[r].read_native(), values[r].footprint, values[r].absmax)
                    for r in refs})
    return out


class Read:
    def __init__(self, pixels, native, fp, absmax):
        self.pixels, self.native, self.footprint, self.absmax = pixels, native, fp, absmax


def _scene(name: str) -> str:
    return name if name.startswith("builtin:") else str(shared_mesh(name))


GBUF = ("pipeline: t\nsize: [{w}, {h}]\nscene: {scene}\nnodes:\n  g: {{type: rasterize, params: {params}}}\n"
        "outputs:\n  nd: g.normal_depth\n  c: g.color\n  d: g.depth\n")


def _assert_covered_inside(values: dict) -> None:
    nd, c, d = values[("g", "normal_depth")], values[("g", "color")], values[("g", "depth")]
    for tex, covered in ((nd, nd.pixels[..., 3] > 0), (c, c.pixels[..., 3] > 0), (d, d.pixels[..., 0] < 1)):
        fp = tex.footprint
        assert fp is not None
        x, y, w, h = fp.rect
        mask = np.zeros(covered.shape, bool)
        mask[y:y + h, x:x + w] = True
        assert covered.any() and not (covered & ~mask).any(), "a covered pixel lies outside the footprint"
        assert mask.mean() < 1.0, "the objects should leave part of the image uncovered"
    assert nd.footprint.blank == (0.0, 0.0, 0.0, 0.0) and d.footprint.blank == (1.0,)


@pytest.mark.slow  # 8 cases, ogre 2.5 s
@pytest.mark.parametrize("name", ["spot.obj", "ogre.obj", "teapot.obj", "fandisk.obj"])
@pytest.mark.parametrize("params", ["{}", "{enlarge: 0.05}"])
def test_the_gbuffer_footprint_holds_every_covered_pixel(gl, name, params):
    text = GBUF.format(w=SIZE[0], h=SIZE[1], scene=_scene(name), params=params)
    for values in _run(gl, text, [("g", "normal_depth"), ("g", "color"), ("g", "depth")]):
        _assert_covered_inside(values)


def test_the_footprint_follows_a_skinned_mesh(gl, tmp_path):
    path = gf.skinned_tube(tmp_path / "tube.glb")
    text = GBUF.format(w=SIZE[0], h=SIZE[1], scene=path, params="{}")
    for values in _run(gl, text, [("g", "normal_depth"), ("g", "color"), ("g", "depth")], frames=(0, 6, 12, 18)):
        _assert_covered_inside(values)


SKETCHY = """pipeline: t
size: [{w}, {h}]
scene: {scene}
nodes:
  g: {{type: rasterize}}
  e: {{type: edge_detect, in: {{normal_depth: g.normal_depth}}, params: {{width: 2}}}}
  n: {{type: perlin_noise, params: {noise}}}
  s:
    type: sketch
    in: {{edges: e.out, shade: g.color, offset: n.out, depth: g.depth}}
    params: {{edge_matrix: {em}, shade_matrix: {sm}}}
outputs:
  image: s.color
"""


SHIPPED = ("[[0.01, 0.0], [0.0, 0.01]]", "[[-0.016, 0.004], [-0.004, -0.016]]")  # nienhaus_sketchy's matrices
WIDE = ("[[0.06, 0.02], [0.0, 0.06]]", "[[-0.06, 0.0], [0.03, -0.06]]")  # shifts of 6-13 pixels at 160 x 120


@pytest.mark.slow  # 20 cases, about 0.5 s each
@pytest.mark.parametrize("name", ["builtin:cloister", "spot.obj", "teapot.obj", "cow.obj"])
@pytest.mark.parametrize(("noise", "matrices"), [("{scale: 0.01, octaves: 4}", SHIPPED), ("{kind: white}", SHIPPED),
                                                 ("{hold: 1, octaves: 3}", SHIPPED), ("{kind: white}", WIDE),
                                                 ("{scale: 0.05, octaves: 2}", WIDE)])
def test_sketch_and_edges_drawn_inside_their_footprint_give_the_whole_pass(gl, name, noise, matrices):
    # the colour (shade alpha standing in for the depth) and, asked for too, the depth read from the map; white
    # noise with wide matrices puts near-largest shifts next to every side of the objects
    text = SKETCHY.format(w=SIZE[0], h=SIZE[1], scene=_scene(name), noise=noise, em=matrices[0], sm=matrices[1])
    for refs in ([("s", "color"), ("e", "out")], [("s", "color"), ("s", "depth"), ("e", "out")]):
        with_fp = _run(gl, text, refs)
        footprint.ENABLED = False
        try:
            whole = _run(gl, text, refs)
        finally:
            footprint.ENABLED = True
        for a, b in zip(with_fp, whole, strict=True):
            for ref in refs:
                _assert_same_bits(a[ref].native, b[ref].native, str(ref))
                assert b[ref].footprint is None
        # the cloister's ground fills the view, and the cow, framed to fill 85% of the shorter side, is wider
        # than tall, so its sketch shifted by the largest offsets reaches every side: nothing to leave out
        if name not in ("builtin:cloister", "cow.obj"):
            assert all(v[("s", "color")].footprint is not None for v in with_fp)
            assert all(v[("e", "out")].footprint is not None for v in with_fp)


def test_noise_held_for_the_sequence_is_measured_and_changing_noise_bounded(gl):
    text = ("pipeline: t\nsize: [96, 64]\nscene: builtin:box\nnodes:\n  n: {type: perlin_noise, params: {hold: %d}}\n"
            "outputs:\n  o: n.out\n")
    held = _run(gl, text % 0, [("n", "out")], frames=(0,))[0][("n", "out")]
    a = np.abs(held.pixels).max(axis=(0, 1))
    assert held.absmax == (float(a[0]), float(a[1]))
    for values in _run(gl, text % 1, [("n", "out")], frames=(0, 1, 2, 3)):
        tex = values[("n", "out")]
        assert (np.abs(tex.pixels).max(axis=(0, 1)) <= np.asarray(tex.absmax)).all()
        assert tex.absmax == (3.75, 3.75)  # 2 x (1 + 1/2 + 1/4 + 1/8): the analytic bound of 4 octaves


def _both_ways(gl, pipeline: str, scene: str | None, refs, compared, frames, check) -> None:
    """A shipped pipeline's frames with footprints on and off: `compared` refs byte-identical both ways, and
    `check(values)` run on each frame's values with footprints on (before the next frame reuses them)."""
    from tests.helpers import ROOT

    out = {}
    for on in (True, False):
        footprint.ENABLED = on
        try:
            ex = Executor(pl.load(str(ROOT / "pipelines" / f"{pipeline}.yaml"), size=SIZE, scene=scene), None,
                          mode="loop", requested=refs, gl=gl)
            out[on] = []
            for f in frames:
                values = ex.run(f).values
                out[on].append([values[r].read_native() for r in compared])
                if on:
                    check(values)
        finally:
            footprint.ENABLED = True
    for a, b in zip(out[True], out[False], strict=True):
        for x, y in zip(a, b, strict=True):
            _assert_same_bits(x, y)


def _assert_drawn_inside(tex, pixels) -> None:
    x, y, w, h = tex.footprint.rect
    drawn = pixels[..., 0] != 0
    inside = np.zeros(drawn.shape, bool)
    inside[y:y + h, x:x + w] = True
    assert drawn.any() and not (drawn & ~inside).any()


def test_the_depth_sprite_over_geometry_draws_the_sprite_inside_its_footprint(gl):
    # sketchy_composite: ordinary geometry laid down over the whole image, the sprite where its depth is below
    # the far plane, which is inside the sketch depth's footprint
    refs = [("sprite", "color"), ("sprite", "depth")]

    def check(values):  # the sprite pass was scissored: the sketch depth has a footprint smaller than the image
        fp = values[("sketch", "depth")].footprint
        assert fp is not None and fp.blank == (1.0,) and not footprint.covers_image(fp.rect, SIZE)

    _both_ways(gl, "sketchy_composite", None, [*refs, ("sketch", "depth")], refs, (0, 9), check)


@pytest.mark.parametrize("pipeline", ["sketchy_lines", "repeated_edges"])
def test_feature_lines_are_drawn_inside_their_footprint(gl, pipeline):
    # the lines' footprint (their projected points grown by the quads' reach, and the edges copied in) holds
    # every line pixel, and the sketch over it gives the whole pass's pixels
    refs = [("lines", "out"), ("sketch", "color")]

    def check(values):
        lines = values[("lines", "out")]
        fp = lines.footprint
        assert fp is not None and fp.blank == (0.0,) and not footprint.covers_image(fp.rect, SIZE)
        _assert_drawn_inside(lines, lines.read())
        assert values[("sketch", "color")].footprint is not None

    _both_ways(gl, pipeline, str(shared_mesh("spot.obj")), refs, refs, (0, 13), check)


@pytest.mark.parametrize("name", ["spot.obj", "cow.obj", "builtin:torus"])
def test_lines_alone_lie_inside_their_footprint(gl, name):
    # without edges copied in, the footprint is the segments' own: every line pixel (quads 4 pixels wide)
    text = (f"pipeline: t\nsize: [160, 120]\nscene: {_scene(name)}\nnodes:\n  g: {{type: rasterize}}\n"
            "  c: {type: curvature, params: {smoothing: 0}}\n"
            "  l: {type: feature_lines, in: {curvature: c.out, normal_depth: g.normal_depth},"
            " params: {width: 4, ridge_intensity: 1.0, valley_intensity: 1.0}}\noutputs:\n  o: l.out\n")
    for values in _run(gl, text, [("l", "out")], frames=(0, 7, 21)):
        lines = values[("l", "out")]
        assert lines.footprint is not None and lines.footprint.blank == (0.0,)
        _assert_drawn_inside(lines, lines.pixels)


def test_object_space_noise_is_bounded_and_its_sketch_drawn_inside_the_footprint(gl):
    refs = [("noise", "out"), ("sketch", "color")]

    def check(values):
        noise = values[("noise", "out")]
        assert (np.abs(noise.read()).max(axis=(0, 1)) <= np.asarray(noise.absmax)).all()
        assert noise.footprint is not None and not footprint.covers_image(noise.footprint.rect, SIZE)
        fp = values[("sketch", "color")].footprint
        assert fp is not None and not footprint.covers_image(fp.rect, SIZE)

    _both_ways(gl, "object_space_uncertainty", str(shared_mesh("spot.obj")), refs, refs, (0, 8, 16), check)


def _both_ways_text(gl, text: str, refs, frames) -> list:
    """`_both_ways` for a pipeline given as text: the frames' values with footprints on (returned, read back
    as they were made), and the same frames byte-identical with footprints off."""
    out = {}
    for on in (True, False):
        footprint.ENABLED = on
        try:
            ex = Executor(pl.loads(text, "t.yaml"), None, mode="loop", requested=refs, gl=gl)
            out[on] = []
            for f in frames:
                values = ex.run(f).values
                out[on].append({r: Read(values[r].read(), values[r].read_native(), values[r].footprint, None)
                                for r in refs})
        finally:
            footprint.ENABLED = True
    for a, b in zip(out[True], out[False], strict=True):
        for r in refs:
            _assert_same_bits(a[r].native, b[r].native, str(r))
    return out[True]


CURTIS = ("pipeline: t\nsize: [{w}, {h}]\nreference_size: {ref}\nscene: {scene}\nnodes:\n"
          "  g: {{type: rasterize}}\n"
          "  e: {{type: depth_edges, in: {{depth: g.{depth}}}, params: {params}}}\n"
          "  f: {{type: force_field, in: {{gradient: e.gradient}}, params: {{restoring: {restoring}}}}}\n"
          "outputs:\n  edges: e.edges\n  gradient: e.gradient\n  magnitude: e.magnitude\n  field: f.out\n")


@pytest.mark.slow  # up to 2.6 s a case
@pytest.mark.parametrize(("size", "ref", "depth", "params", "restoring"), [
    ((160, 120), 800, "linear_depth", "{}", "rotated"),  # px_scale 0.15: weights that are not small integers
    ((200, 200), 200, "linear_depth", "{threshold: 0.01}", "gradient"),  # px_scale 1: the seed's filters
    ((150, 100), 64, "depth", "{mode: window, reference_height: 100}", "rotated"),  # px_scale > 1, window depth
    ((256, 192), 72, "linear_depth", "{}", "rotated"),  # px_scale 2.67: both nodes in their split passes
])
@pytest.mark.parametrize("name", ["spot.obj", "builtin:torus"])
def test_depth_edges_and_the_force_field_drawn_inside_their_footprints_give_the_whole_passes(
        gl, name, size, ref, depth, params, restoring):
    # outside the depth's footprint grown by the filter windows the passes give what they give on a constant,
    # asked of the shaders on 1x1 textures (footprint.blank_results): the same bytes as the whole passes
    # (a Sobel difference of a constant is -0.0 or 0.0 by its sum's order; the test would see a wrong sign)
    text = CURTIS.format(w=size[0], h=size[1], ref=ref, scene=_scene(name), depth=depth, params=params,
                         restoring=restoring)
    refs = [("e", "edges"), ("e", "gradient"), ("e", "magnitude"), ("f", "out")]
    for values in _both_ways_text(gl, text, refs, (0, 6)):
        for r in refs:
            fp = values[r].footprint
            assert fp is not None and not footprint.covers_image(fp.rect, size), r
            x, y, w, h = fp.rect
            outside = np.ones(size[::-1], bool)
            outside[y:y + h, x:x + w] = False
            px = values[r].native.reshape(size[1], size[0], -1)
            assert (px[outside] == px[outside][:1]).all(), f"{r}: not one value outside the footprint"
        edges = values[("e", "edges")]
        assert edges.pixels.any() and edges.footprint.blank == (0.0,)


@pytest.mark.slow  # 16 s
def test_loose_and_sketchy_draws_its_filters_inside_their_footprints(gl):
    refs = [("edges", "edges"), ("field", "out"), ("particles", "image")]

    def check(values):
        for r in refs[:2]:
            fp = values[r].footprint
            assert fp is not None and not footprint.covers_image(fp.rect, SIZE)

    _both_ways(gl, "loose_and_sketchy", str(shared_mesh("cow.obj")), refs, refs, (0, 5), check)


def _tight(gl, rng, size, rect, fmt, blank, values):
    """A texture holding `values(n)` (random, none of them the blank) on every pixel of `rect` and `blank`
    elsewhere, with exactly that footprint: content right up to the rectangle's sides, so a window grown too
    little shows."""
    w, h = size
    comps = len(blank)
    a = np.empty((h, w, comps), np.float32)
    a[:] = blank
    x, y, rw, rh = rect
    a[y:y + rh, x:x + rw] = values((rh, rw, comps))
    tex = gl.upload(a, fmt, filter="nearest")
    tex.footprint = Footprint(rect, tuple(float(b) for b in blank))
    return tex


@pytest.mark.slow  # 6 cases, 4.7 s the largest
@pytest.mark.parametrize("reference", [None, 37, 200])  # px_scale 1 (the seed's), > 1, < 1
@pytest.mark.parametrize("mode", ["window", "linear"])
def test_curtis_filters_on_a_tight_footprint_give_the_whole_passes(gl, rng, reference, mode):
    from nodegraph_nodes.depth_edges import DepthEdges
    from nodegraph_nodes.force_field import ForceField

    from tests.helpers import run_node

    size, rect = (90, 70), (31, 17, 23, 29)
    blank = (1.0,) if mode == "window" else (0.0,)
    lo, hi = (0.2, 0.9) if mode == "window" else (2.0, 9.0)
    depth = _tight(gl, rng, size, rect, "R32F", blank, lambda s: rng.uniform(lo, hi, s))
    edges = DepthEdges("de", DepthEdges.Params(mode=mode, range=None if mode == "window" else (1.0, 10.0),
                                               threshold=0.02))
    field = ForceField("ff", ForceField.Params())
    grads = []
    outs = {}
    for on in (True, False):
        footprint.ENABLED = on
        try:
            e = run_node(gl, edges, {"depth": depth}, size, reference_size=reference)
            grads.append(e["gradient"])
            f = run_node(gl, field, {"gradient": e["gradient"]}, size, reference_size=reference)
            outs[on] = {**{p: t.read_native() for p, t in e.items()}, "field": f["out"].read_native()}
            if on:
                assert all(t.footprint is not None for t in (*e.values(), f["out"]))
                assert not footprint.covers_image(f["out"].footprint.rect, size)
        finally:
            footprint.ENABLED = True
    for port in outs[True]:
        _assert_same_bits(outs[True][port], outs[False][port], port)
    # the field on a gradient of its own tight footprint (not depth_edges' margin)
    g = _tight(gl, rng, size, rect, "RG32F", (0.0, 0.0), lambda s: rng.uniform(-0.3, 0.3, s))
    got = {}
    for on in (True, False):
        footprint.ENABLED = on
        try:
            got[on] = run_node(gl, field, {"gradient": g}, size, reference_size=reference)["out"].read_native()
        finally:
            footprint.ENABLED = True
    _assert_same_bits(got[True], got[False])


@pytest.mark.parametrize("background", [(0.0, 0.0), (0.3, -0.0), (-1.5, 2.0)])
def test_object_noise_on_a_tight_footprint_gives_the_whole_pass(gl, rng, background):
    from nodegraph_nodes.object_noise import ObjectNoise

    from tests.helpers import run_node

    size, rect = (90, 70), (12, 30, 41, 33)

    def positions(shape):  # covered texels (alpha 1) at points of a unit box
        return np.concatenate([rng.uniform(-1, 1, shape[:2] + (3,)), np.ones(shape[:2] + (1,))], axis=2)

    pos = _tight(gl, rng, size, rect, "RGBA32F", (0.0, 0.0, 0.0, 0.0), positions)
    node = ObjectNoise("n", ObjectNoise.Params(background=background, scale=3.0))
    got = {}
    for on in (True, False):
        footprint.ENABLED = on
        try:
            out = run_node(gl, node, {"position": pos}, size)["out"]
            got[on] = out.read_native()
            if on:
                assert out.footprint is not None and out.footprint.rect == rect
        finally:
            footprint.ENABLED = True
    _assert_same_bits(got[True], got[False])
    assert (np.signbit(got[True][0, 0]) == np.signbit(np.float32(background))).all()


def test_textures_from_the_disk_cache_keep_their_footprints(gl, tmp_path):
    # an edit downstream (the sketch's matrices) in a new process-like executor: the G-buffer, edges and noise
    # come from the disk cache with the footprints and bound their nodes gave them, and the sketch drawn inside
    # them gives the whole pass's pixels
    from nodegraph.cache import Cache

    def cache():
        c = Cache(tmp_path / "c")
        c.ms_per_mb = 0.0  # every entry is worth writing
        return c

    upstream = [("g", "color"), ("g", "normal_depth"), ("g", "depth"), ("e", "out"), ("n", "out")]
    refs = [*upstream, ("s", "color")]
    texts = [SKETCHY.format(w=SIZE[0], h=SIZE[1], scene=_scene("spot.obj"), noise="{scale: 0.01, octaves: 4}",
                            em=em, sm=sm) for em, sm in (SHIPPED, WIDE)]
    ex = Executor(pl.loads(texts[0], "t.yaml"), cache(), requested=refs, gl=gl)
    made = ex.run(0).values
    facts = {r: (made[r].footprint, made[r].absmax) for r in upstream}
    ex.close()
    # the G-buffer and the edges have footprints, the noise (everywhere) a bound on its values
    assert all(facts[r][0] is not None for r in upstream[:4]) and facts[("n", "out")][1] is not None
    ex = Executor(pl.loads(texts[1], "t.yaml"), cache(), requested=refs, gl=gl)
    res = ex.run(0)
    assert {res.stats[n].status for n in ("g", "e", "n")} == {"disk"} and res.stats["s"].status == "computed"
    for r in upstream:
        fp, absmax = facts[r]
        got = res.values[r]
        assert got.absmax == absmax
        if fp is None:
            assert got.footprint is None
            continue
        assert got.footprint is not None and got.footprint.rect == fp.rect, r
        _assert_same_bits(np.float32(got.footprint.blank), np.float32(fp.blank), str(r))
    sketch = res.values[("s", "color")]
    assert sketch.footprint is not None and not footprint.covers_image(sketch.footprint.rect, SIZE)
    drawn = sketch.read_native()
    ex.close()
    footprint.ENABLED = False
    try:
        whole = Executor(pl.loads(texts[1], "t.yaml"), None, requested=refs, gl=gl).run(0).values
        _assert_same_bits(drawn, whole[("s", "color")].read_native())
    finally:
        footprint.ENABLED = True


@pytest.mark.slow  # 1.5 s a case
@pytest.mark.parametrize("pipeline", ["pencil_contours", "pencil"])
def test_contours_drawn_inside_the_edges_footprint_give_the_whole_pass(gl, pipeline):
    # pencil_contours asks for the colour (the paper everywhere, the attempts inside the edges' footprint grown
    # by the largest shift), pencil for the value alone (1 outside: a footprint of its own)
    refs = [("contour", "color")] if pipeline == "pencil_contours" else [("contour", "out"), ("shade", "color")]

    def check(values):
        if pipeline == "pencil":
            fp = values[("contour", "out")].footprint
            assert fp is not None and fp.blank == (1.0,) and not footprint.covers_image(fp.rect, SIZE)

    _both_ways(gl, pipeline, str(shared_mesh("spot.obj")), refs, refs, (0, 7), check)


@pytest.mark.parametrize("ports", [("out", "color"), ("out",)])
def test_contours_on_a_tight_footprint_give_the_whole_pass(gl, rng, ports):
    # edges right up to their rectangle's sides, the largest shifts the distortion allows, and surface pixels
    # with a degenerate normal outside the footprint: no edge there, so bare paper either way (llvmpipe's clamp
    # already turns the NaN of normalize(0) into a number; the shader's guard, a factor of exactly 1 where no
    # edge is read, keeps it so on drivers whose clamp passes a NaN on)
    from nodegraph_nodes._shared.pencil import MAX_AMPLITUDE
    from nodegraph_nodes.contour import Contour

    from nodegraph.node import RunContext

    size, rect = (96, 80), (30, 25, 27, 22)
    w, h = size
    edges = _tight(gl, rng, size, rect, "R16F", (0.0,), lambda s: rng.uniform(0.05, 1.0, s))
    a = MAX_AMPLITUDE * h
    dist = rng.choice([-a, a], (3, h, w, 2)).astype(np.float32)
    nd = np.concatenate([rng.normal(size=(h, w, 3)), rng.uniform(1, 5, (h, w, 1))], axis=2).astype(np.float32)
    nd[:5, :5, :3] = 0.0  # normalize(0) is NaN
    inputs = {"edges": edges, "normal_depth": gl.upload(nd, "RGBA16F"),
              "distortion": gl.texture_array(size, 3, "RG16F", dist, repeat=False, mipmaps=False),
              "paper": gl.upload(rng.uniform(-1, 1, (32, 32, 4)).astype(np.float32), "RGBA16F")}
    node = Contour("c", Contour.Params())
    got = {}
    for on in (True, False):
        footprint.ENABLED = on
        try:
            out = node.compute(RunContext(node, gl=gl, size=size, pipeline_seed=3), inputs, frozenset(ports))
            got[on] = {p: t.read_native() for p, t in out.items()}
            if on and ports == ("out",):
                assert out["out"].footprint is not None and out["out"].footprint.blank == (1.0,)
        finally:
            footprint.ENABLED = True
    for p in ports:
        _assert_same_bits(got[True][p], got[False][p], p)
    assert (got[False]["out"][:5, :5] == 1.0).all()  # the degenerate normals far from any edge: bare paper


@pytest.mark.slow  # 3.1 s
def test_particle_ink_and_its_composite_are_drawn_inside_their_footprints(gl):
    # the ink's footprint is its strokes' bounding rectangle; the drawing and the shaded pipeline's composite
    # (the sketch under the ink) are drawn inside the union of their inputs' footprints
    refs = [("particles", "ink"), ("ink", "color"), ("shade", "color")]

    def check(values):
        ink = values[("particles", "ink")]
        assert ink.footprint is not None and ink.footprint.blank == (0.0,)
        _assert_drawn_inside(ink, ink.read())
        x, y, w, h = ink.footprint.rect  # tight: ink on each side of the rectangle
        px = ink.read()[..., 0]
        assert px[y, x:x + w].any() and px[y + h - 1, x:x + w].any()
        assert px[y:y + h, x].any() and px[y:y + h, x + w - 1].any()
        fp = values[("ink", "color")].footprint
        assert fp is not None and not footprint.covers_image(fp.rect, SIZE)

    _both_ways(gl, "loose_and_sketchy_shaded", str(shared_mesh("spot.obj")), refs, refs, (0, 4), check)


@pytest.mark.parametrize(("mode", "opacity", "top"), [("over", 1.0, False), ("multiply", 0.7, False),
                                                      ("over", 0.5, True)])
def test_a_composite_on_tight_footprints_gives_the_whole_pass(gl, rng, mode, opacity, top):
    from nodegraph_nodes.composite import Composite

    from tests.helpers import run_node

    size = (90, 70)
    inputs = {
        "base": _tight(gl, rng, size, (10, 12, 30, 25), "RGBA8", (0.98, 0.97, 0.94, 0.0),
                       lambda s: rng.uniform(0, 1, s)),
        "mask": _tight(gl, rng, size, (35, 30, 40, 28), "R8", (0.0,), lambda s: rng.uniform(0.1, 1, s)),
    }
    if top:
        inputs["top"] = _tight(gl, rng, size, (50, 5, 20, 20), "RGBA8", (0.2, 0.4, 0.6, 0.5),
                               lambda s: rng.uniform(0, 1, s))
    node = Composite("c", Composite.Params(mode=mode, opacity=opacity))
    got = {}
    for on in (True, False):
        footprint.ENABLED = on
        try:
            out = run_node(gl, node, inputs, size)["color"]
            got[on] = out.read_native()
            if on:
                want = footprint.union(t.footprint.rect for t in inputs.values())
                assert out.footprint is not None and out.footprint.rect == want
        finally:
            footprint.ENABLED = True
    _assert_same_bits(got[True], got[False])
