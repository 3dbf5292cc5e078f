"""The Nienhaus & Döllner nodes against independent references: analytic geometry and float64 NumPy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from nodegraph_nodes.depth_sprite import DepthSprite
from nodegraph_nodes.depth_sprite.reference import depth_sprite as depth_sprite_ref
from nodegraph_nodes.edge_detect import EdgeDetect
from nodegraph_nodes.edge_detect.reference import edge_detect as edge_detect_ref
from nodegraph_nodes.perlin_noise import PerlinNoise
from nodegraph_nodes.rasterize import Rasterize
from nodegraph_nodes.sketch import Sketch
from nodegraph_nodes.sketch.reference import sketch as sketch_ref

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.sampling import nearest
from nodegraph.scene import load_scene
from tests.helpers import run_node

ROOT = Path(__file__).resolve().parents[2]


# -- edge detection on a box: edges where faces meet, none inside faces ------------------------
def _box_edges_px(scene, size):
    """Visible edges of the (convex) box, projected to pixel coordinates (x right, y up)."""
    obj = scene.objects[0]
    lo, hi = obj.world_bounds()
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    cam = scene.camera_at(0)
    faces = []  # (normal, corner indices of the face)
    for axis in range(3):
        for side, val in ((-1, lo[axis]), (1, hi[axis])):
            idx = [i for i, c in enumerate(corners) if np.isclose(c[axis], val)]
            n = np.zeros(3)
            n[axis] = side
            faces.append((n, idx))
    front = [np.dot(n, cam.eye - corners[idx].mean(axis=0)) > 0 for n, idx in faces]
    edges = set()
    for i in range(8):
        for j in range(i + 1, 8):
            if np.count_nonzero(~np.isclose(corners[i], corners[j])) != 1:
                continue
            adjacent = [k for k, (_, idx) in enumerate(faces) if i in idx and j in idx]
            if any(front[k] for k in adjacent):
                edges.add((i, j))
    w, h = size
    ndc = cam.project(corners, w / h)
    px = np.c_[(ndc[:, 0] * 0.5 + 0.5) * w, (ndc[:, 1] * 0.5 + 0.5) * h]
    return [(px[i], px[j]) for i, j in edges]


def _distance_to_segments(points, segments):
    d = np.full(len(points), np.inf)
    for a, b in segments:
        ab = b - a
        t = np.clip(((points - a) @ ab) / (ab @ ab), 0, 1)
        d = np.minimum(d, np.linalg.norm(points - (a + t[:, None] * ab), axis=1))
    return d


@pytest.mark.parametrize("operator", ["four_neighbour", "sobel"])
def test_box_edges_where_faces_meet_and_none_inside(gl, operator):
    size = (256, 256)
    scene = load_scene("builtin:box")
    g = run_node(gl, Rasterize("g"), {}, size, scene=scene, needed=frozenset({"normal_depth"}))
    node = EdgeDetect("e", EdgeDetect.Params(operator=operator))
    e = run_node(gl, node, {"normal_depth": g["normal_depth"]}, size)["out"].read()[..., 0]
    segments = _box_edges_px(scene, size)
    assert len(segments) == 9  # a box seen from a general direction shows 3 faces bounded by 9 edges
    ys, xs = np.mgrid[0:size[1], 0:size[0]]
    centres = np.c_[xs.ravel() + 0.5, ys.ravel() + 0.5]
    dist = _distance_to_segments(centres, segments).reshape(size[1], size[0])
    on = e > 0.5
    tol = 2.5 if operator == "sobel" else 1.5
    assert on.sum() > 0
    assert dist[on].max() <= tol, f"edge pixels {dist[on].max():.2f} px away from any box edge"
    assert e[dist > tol + 1].max() == 0.0, "no edges inside faces or in the background"
    # recall: points along every visible edge have an edge pixel within 1.5 px
    for a, b in segments:
        ts = np.linspace(0.05, 0.95, 40)
        pts = a + ts[:, None] * (b - a)
        hit = [on[max(0, int(y) - 1):int(y) + 2, max(0, int(x) - 1):int(x) + 2].any() for x, y in pts]
        assert np.mean(hit) >= 0.95


def test_edge_detect_matches_float64_reference(gl, rng):
    size = (96, 80)
    scene = load_scene("builtin:cloister")
    g = run_node(gl, Rasterize("g"), {}, size, scene=scene, needed=frozenset({"normal_depth"}))
    nd = g["normal_depth"]
    arr = nd.read()
    for operator in ("four_neighbour", "sobel"):
        for mode in ("normal_depth", "normal", "depth"):
            params = dict(operator=operator, mode=mode, normal_threshold=0.3, depth_threshold=0.02, width=1)
            out = run_node(gl, EdgeDetect("e", EdgeDetect.Params(**params)), {"normal_depth": nd}, size)
            ref = edge_detect_ref(arr, **params)
            for port in ("out", "profile", "inner"):
                got = out[port].read()[..., 0]
                # R16F output; smoothstep ramps make a few pixels sensitive to float32 vs float64 rounding
                bad = np.abs(got - ref[port]) > 2e-3
                assert bad.mean() < 0.002, (operator, mode, port, bad.sum())


# -- noise ----------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["perlin", "white"])
def test_noise_node_matches_float64_cpu(gl, kind):
    size = (120, 72)
    node = PerlinNoise("noise", PerlinNoise.Params(kind=kind, scale=0.013, octaves=4))
    got = run_node(gl, node, {}, size, seed=99)["out"].read()
    from nodegraph.node import derive_seed

    ref = node.reference(size[0], size[1], derive_seed(99, "noise", 0))
    assert np.abs(got - ref).max() < (1e-5 if kind == "perlin" else 1e-6)


# -- sketch and depth sprite against float64 NumPy on small images ---------------------------
def _smooth(rng, shape, scale=6):
    base = rng.random((shape[0] // scale + 2, shape[1] // scale + 2) + shape[2:])
    return np.kron(base, np.ones((scale, scale) + (1,) * (len(shape) - 2)))[: shape[0], : shape[1]]


def test_sketch_matches_float64_reference(gl, rng):
    h, w = 64, 96
    edges = gl.upload(_smooth(rng, (h, w)).astype(np.float32)[..., None], "R16F")
    shade_arr = _smooth(rng, (h, w, 4)).astype(np.float32)
    shade_arr[..., 3] = (shade_arr[..., 3] > 0.4).astype(np.float32)
    shade = gl.upload(shade_arr, "RGBA8")
    offset = gl.upload(rng.random((h, w, 2)).astype(np.float32), "RG16F")
    layers = ({"matrix": ((0.05, 0.01), (-0.02, 0.04)), "color": (0.1, 0.2, 0.3)},
              {"matrix": ((-0.03, 0.0), (0.0, 0.06)), "color": (0.6, 0.1, 0.1)})
    params = Sketch.Params(shade_matrix=((-0.04, 0.02), (0.01, -0.05)), edge_layers=layers, edge_strength=1.3)
    node = Sketch("s", params)
    got = run_node(gl, node, {"edges": edges, "shade": shade, "offset": offset}, (w, h),
                   needed=frozenset({"color", "offsets"}))
    # the reference reads exactly what the GPU holds (after 8-bit / half quantisation)
    ref = sketch_ref(edges.read()[..., 0], shade.read(), offset.read(), np.asarray(params.shade_matrix),
                     [(np.asarray(lay.matrix), lay.color) for lay in node.layers()], params.edge_strength,
                     params.use_shade, params.paper)
    for port in ("color", "offsets"):
        err = np.abs(got[port].read() - ref[port])
        # bilinear weights are quantised to 8 bits in llvmpipe's sampler; outputs are half floats
        assert np.percentile(err, 99) < 1e-2 and err.max() < 5e-2, (port, err.max())


@pytest.mark.parametrize("with_under", [False, True])
def test_depth_sprite_matches_float64_reference(gl, with_under):
    h, w = 48, 64
    ys, xs = np.mgrid[0:h, 0:w]
    depth = np.where((xs - 30) ** 2 + (ys - 24) ** 2 < 14**2, 0.4 + 0.002 * xs, 1.0).astype(np.float32)
    color = np.zeros((h, w, 4), np.float32)
    color[..., 0] = xs / w
    color[..., 1] = ys / h
    color[..., 3] = 1
    # whole-pixel shifts: edge +5 px in x, shade -3 px in y (in texture units)
    offsets = np.zeros((h, w, 4), np.float32)
    offsets[..., 0] = 5 / w
    offsets[..., 3] = -3 / h
    inputs = {"color": gl.upload(color, "RGBA16F"), "offsets": gl.upload(offsets, "RGBA16F"),
              "depth": gl.upload(depth[..., None], "R32F")}
    under_c = under_d = None
    if with_under:
        under_d = np.where(xs > 34, 0.42, 1.0).astype(np.float32)
        under_c = np.zeros((h, w, 4), np.float32)
        under_c[xs > 34] = (0.2, 0.5, 0.3, 1.0)
        inputs.update(under_color=gl.upload(under_c, "RGBA8"), under_depth=gl.upload(under_d[..., None], "R32F"))
        under_c = inputs["under_color"].read()
    got = run_node(gl, DepthSprite("d"), inputs, (w, h), needed=frozenset({"color", "depth"}))
    ref = depth_sprite_ref(inputs["color"].read(), inputs["offsets"].read(), depth, under_c, under_d)
    gz, rz = got["depth"].read()[..., 0], ref["depth"]
    # the depth test runs at depth-buffer precision: allow 1e-6 in the values, no pixel decided differently
    assert np.abs(gz - rz).max() < 1e-5
    assert np.abs(got["color"].read() - ref["color"]).max() < 2e-3
    # the sprite reaches beyond the disc (shifted lookups) and background stays paper at the far plane
    drawn = rz < 1.0
    assert drawn.sum() > (depth < 1).sum()
    assert np.all(gz[~drawn] == 1.0)


# -- the composite: occlusion both ways ---------------------------------------------------------
def test_composite_occlusion_both_ways(gl):
    pipe = pl.load(ROOT / "pipelines" / "sketchy_composite.yaml", size=(200, 200))
    refs = [("sprite", "depth"), ("sketchy", "depth"), ("plain", "depth"), ("sketch", "offsets"),
            ("sprite", "color"), ("plain", "color"), ("sketch", "color")]
    res = Executor(pipe, None, requested=refs, gl=gl).run()
    v = {ref: res.values[ref].read() for ref in refs}
    out_z = v[("sprite", "depth")][..., 0]
    sk_z, pl_z = v[("sketchy", "depth")][..., 0], v[("plain", "depth")][..., 0]
    off = v[("sketch", "offsets")]
    h, w = out_z.shape
    u, vv = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    sprite_z = np.minimum(nearest(sk_z, u + off[..., 0], vv + off[..., 1]),
                          nearest(sk_z, u + off[..., 2], vv + off[..., 3]))
    expected = np.minimum(pl_z, sprite_z)
    mismatch = np.abs(out_z - expected) > 1e-5
    assert mismatch.mean() < 0.002
    sketch_in_front = (sprite_z < pl_z) & (pl_z < 1)   # the sketch hides ordinary geometry here
    plain_in_front = (pl_z < sprite_z) & (sprite_z < 1)  # ordinary geometry hides the sketch here
    assert sketch_in_front.sum() > 200 and plain_in_front.sum() > 200, "the scene exercises both directions"
    color = v[("sprite", "color")][..., :3]
    plain = v[("plain", "color")][..., :3]
    sketch = v[("sketch", "color")][..., :3]
    assert np.abs(color[plain_in_front] - plain[plain_in_front]).max() < 1e-2
    assert np.abs(color[sketch_in_front] - sketch[sketch_in_front]).max() < 2e-3


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
