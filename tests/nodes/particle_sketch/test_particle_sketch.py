"""particle_sketch as a node: determinism, boil control (hold), outputs, SVG, pipelines, cache.

The particle dynamics themselves (following an edge, RK4 vs Euler, valid starts, erasing, termination)
are tested on the core in test_particle_core.py.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from nodegraph_nodes.depth_edges import DepthEdges
from nodegraph_nodes.force_field import ForceField
from nodegraph_nodes.particle_sketch import ParticleSketch, core, synthetic
from nodegraph_nodes.strokes_svg import StrokesSvg
from pydantic import ValidationError

from nodegraph import pipeline as pl
from nodegraph.errors import NodeError, PipelineError
from nodegraph.executor import Executor
from nodegraph.node import HashContext, RunContext
from nodegraph.values import Strokes
from tests.helpers import assert_outputs_as_planned, run_minimal, run_node, shared_mesh

ROOT = Path(__file__).resolve().parents[3]
SIZE = (160, 160)


@pytest.fixture(scope="module")
def inputs(gl) -> dict:
    """edges and force of the synthetic cow at 160 px, through the GPU nodes."""
    depth = synthetic.cow_depth(SIZE[0])
    de = run_node(gl, DepthEdges("de", DepthEdges.Params(mode="window")), {"depth": gl.upload(depth, "R32F")}, SIZE,
                  needed=frozenset({"edges", "gradient"}))
    ff = run_node(gl, ForceField("ff"), {"gradient": de["gradient"]}, SIZE)
    return {"edges": de["edges"], "force": ff["out"]}


def _draw(gl, inputs, frame: int = 0, seed: int = 3, node_id: str = "p", **params) -> dict:
    node = ParticleSketch(node_id, ParticleSketch.Params(**params))
    return run_node(gl, node, inputs, SIZE, frame=frame, seed=seed)


def _same(a: dict, b: dict) -> bool:
    return (a["image"].read().tobytes() == b["image"].read().tobytes()
            and len(a["strokes"].polylines) == len(b["strokes"].polylines)
            and all(np.array_equal(p, q) for p, q in zip(a["strokes"].polylines, b["strokes"].polylines, strict=True)))


def test_outputs_and_the_core_they_wrap(gl, inputs):
    node = ParticleSketch("p", ParticleSketch.Params(strokes=300, color=(0.2, 0.1, 0.0), paper=(1.0, 0.9, 0.8)))
    out = run_node(gl, node, inputs, SIZE, seed=3)
    assert {k: v.fmt for k, v in out.items() if k != "strokes"} == {"image": "RGBA8", "ink": "R8", "remaining": "R8"}
    s = out["strokes"]
    assert isinstance(s, Strokes) and s.size == SIZE and s.width == 1.2 and s.color == (0.2, 0.1, 0.0)
    assert 20 < len(s.polylines) <= 300 and all(p.shape[1] == 2 and len(p) >= 2 for p in s.polylines)
    # exactly the core's drawing on the read-back inputs with the node's random stream
    ctx = RunContext(node, gl=gl, size=SIZE, pipeline_seed=3)
    edges = inputs["edges"].read()[..., 0] >= 0.5
    ref = core.simulate(edges, inputs["force"].read().astype(np.float64), node.core_params(), node.rng(ctx))
    assert len(ref.strokes) == len(s.polylines) and all(map(np.array_equal, ref.strokes, s.polylines))
    ink = out["ink"].read()[..., 0]
    np.testing.assert_allclose(ink, ref.sketch, atol=0.5 / 255 + 1e-6)
    np.testing.assert_array_equal(out["remaining"].read()[..., 0] > 0.5, ref.edges)
    img = out["image"].read()
    want = np.array([1.0, 0.9, 0.8]) + (np.array([0.2, 0.1, 0.0]) - np.array([1.0, 0.9, 0.8])) * ink[..., None]
    np.testing.assert_allclose(img[..., :3], want, atol=1.01 / 255)
    assert (img[..., 3] == 1.0).all()
    cov, prec = core.coverage_precision(ref.sketch, edges)
    assert cov > 0.9 and prec > 0.85


def test_same_seed_same_bytes_other_seed_other_drawing(gl, inputs):
    a, b = _draw(gl, inputs, strokes=200), _draw(gl, inputs, strokes=200)
    assert _same(a, b)
    assert not _same(a, _draw(gl, inputs, strokes=200, seed=4))  # pipeline seed
    assert not _same(a, _draw(gl, inputs, strokes=200, node_id="q"))  # node id


def test_seed_param_changes_the_drawing(gl, inputs):
    node = ParticleSketch("p", ParticleSketch.Params(strokes=200, seed=1))
    other = run_node(gl, node, inputs, SIZE, seed=3)
    assert not _same(_draw(gl, inputs, strokes=200), other)


@pytest.mark.parametrize("hold", [0, 1, 3])
def test_hold_keeps_the_strokes_for_k_frames(gl, inputs, hold):
    frames = range(0, 7)
    draws = [_draw(gl, inputs, frame=f, strokes=150, hold=hold) for f in frames]
    node = ParticleSketch("p", ParticleSketch.Params(strokes=150, hold=hold))
    keys = [node.key(HashContext(SIZE, f, 3, None), {"edges": "e", "force": "f"}) for f in frames]
    for f in frames[1:]:
        held = hold == 0 or f // hold == (f - 1) // hold
        assert _same(draws[f], draws[f - 1]) == held, f"frame {f} against {f - 1}, hold {hold}"
        assert (keys[f] == keys[f - 1]) == held  # held frames share the cache entry
    assert ("frame" in node.context_keys) is False


def test_strokes_svg_is_well_formed_with_one_path_per_stroke(gl, inputs, tmp_path):
    out = _draw(gl, inputs, strokes=120)
    strokes = out["strokes"]
    svg = StrokesSvg("svg", StrokesSvg.Params(path=str(tmp_path / "d_####.svg")))
    written = run_node(gl, svg, {"strokes": strokes}, SIZE, frame=7)["file"]
    assert written == tmp_path / "d_0007.svg"
    root = ET.parse(written).getroot()
    ns = {"s": "http://www.w3.org/2000/svg"}
    assert root.tag == "{http://www.w3.org/2000/svg}svg" and root.get("viewBox") == "0 0 160 160"
    paths = root.findall(".//s:path", ns)
    assert len(paths) == len(strokes.polylines) > 0
    for d, poly in zip((p.get("d") for p in paths), strokes.polylines, strict=True):
        pts = [tuple(map(float, c.split(","))) for c in d[1:].split(" L")]
        assert len(pts) == len(poly)
        np.testing.assert_allclose(pts, np.c_[poly[:, 0], SIZE[1] - poly[:, 1]], atol=0.006)  # y flipped
    with pytest.raises(ValueError, match="ending in .svg"):
        run_node(gl, StrokesSvg("svg", StrokesSvg.Params(path=str(tmp_path / "d.png"))), {"strokes": strokes}, SIZE)


def test_errors(gl, inputs):
    small = run_node(gl, ForceField("ff"), {"gradient": gl.upload(np.zeros((40, 50, 2), np.float32), "RG32F")},
                     (50, 40))["out"]
    with pytest.raises(NodeError, match="differ in size"):
        _draw(gl, {"edges": inputs["edges"], "force": small})
    for bad in ({"mass": 0.0}, {"step": float("inf")}, {"randomness": float("nan")}, {"hold": -1},
                {"integrator": "midpoint"}, {"colour": (0, 0, 0)}):
        with pytest.raises(ValidationError):
            ParticleSketch.Params(**bad)


# -- pipelines ------------------------------------------------------------------------------------
def _load(name: str, size: tuple[int, int], **kw) -> pl.Pipeline:
    return pl.load(ROOT / "pipelines" / f"{name}.yaml", size=size, **kw)


@pytest.mark.parametrize("name", ["loose_and_sketchy", "loose_and_sketchy_shaded"])
def test_pipelines_draw_the_depth_edges(gl, name):
    pipe = _load(name, (200, 200), reference_size=200)  # px_scale 1: spacing and widths as written
    res = Executor(pipe, None, requested=[("particles", "ink"), ("edges", "edges"), *pipe.outputs.values()],
                   gl=gl).run(0)
    ink = res.values[("particles", "ink")].read()[..., 0]
    edges = res.values[("edges", "edges")].read()[..., 0] > 0.5
    cov, prec = core.coverage_precision(ink, edges)
    assert edges.mean() > 0.01 and cov > 0.95 and prec > 0.85
    image = res.values[pipe.outputs["image"]].read()
    assert image.shape == (200, 200, 4) and np.isfinite(image).all()
    if name.endswith("shaded"):  # ink over the shade map: dark where there is ink, coloured elsewhere
        assert image[ink > 0.99][:, :3].max() < 0.13
        assert image[..., :3].std(axis=(0, 1)).max() > 0.05


def test_spot_draws_its_silhouette(gl):
    pipe = _load("loose_and_sketchy", (320, 320), scene=str(shared_mesh("spot.obj")))
    res = Executor(pipe, None, requested=[("particles", "ink"), ("edges", "edges"), ("gbuf", "linear_depth")],
                   gl=gl).run(0)
    ink = res.values[("particles", "ink")].read()[..., 0]
    edges = res.values[("edges", "edges")].read()[..., 0] > 0.5
    cov, prec = core.coverage_precision(ink, edges)
    assert cov > 0.95 and prec > 0.85
    # the outline of the cow (object against background) is inked all round
    obj = res.values[("gbuf", "linear_depth")].read()[..., 0] > 0
    rim = obj & ~np.pad(obj, 1)[2:, 1:-1] | obj & ~np.pad(obj, 1)[:-2, 1:-1]
    near_ink = core.dilate(ink > 0.1, 2.0)
    assert near_ink[rim].mean() > 0.95


def test_cache_second_run_computes_nothing_and_a_param_recomputes_only_the_particles(gl, tmp_path):
    from nodegraph.cache import Cache

    cache = Cache(tmp_path / "cache")
    pipe = _load("loose_and_sketchy", (120, 120))
    first = Executor(pipe, cache, gl=gl)
    assert set(first.run(0).computed()) == {"gbuf", "edges", "field", "particles"}
    first.close()
    assert Executor(_load("loose_and_sketchy", (120, 120)), cache, gl=gl).run(0).computed() == []
    changed = _load("loose_and_sketchy", (120, 120), overrides=["particles.randomness=0.5"])
    assert Executor(changed, cache, gl=gl).run(0).computed() == ["particles"]
    cache.close()


def test_composite_needs_a_layer():
    text = (ROOT / "pipelines" / "loose_and_sketchy_shaded.yaml").read_text().replace(
        "in: {base: shade.color, mask: particles.ink}", "in: {base: shade.color}")
    with pytest.raises(PipelineError, match="connect `top`"):
        pl.loads(text, "<t>", load_scene=False)


def test_bench_particles_reports_the_figures(gl, tmp_path):
    from nodegraph.tools.bench import pipeline as bench
    from nodegraph.tools.bench.particles import run

    assert bench.NAMED["particles"] == "nodegraph.tools.bench.particles:command"
    r = run("builtin:cloister", 300, (160, 160), repeat=1, python_repeat=1, overrides=("max_steps=10",),
            out=tmp_path)
    for key in ("strokes", "seconds", "coverage", "precision", "python_reference_seconds", "speedup_vs_python"):
        assert key in r and r[key] > 0
    assert r["requested_strokes"] == 300 and r["params"]["max_steps"] == 10
    assert r["equals_python"]  # batch 1 (the default) draws exactly what the pure-Python reference draws
    assert r["lockstep_batch"] == 256 and r["lockstep_strokes"] > 0
    assert (tmp_path / "particles.png").exists() and (tmp_path / "particles.svg").exists()


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  g: {type: rasterize}
  e: {type: depth_edges, in: {depth: g.linear_depth}}
  f: {type: force_field, in: {gradient: e.gradient}}
  p: {type: particle_sketch, in: {edges: e.edges, force: f.out}, params: {strokes: 40}}
"""
    outputs = {"image": "p.image", "ink": "p.ink", "strokes": "p.strokes", "remaining": "p.remaining"}
    ex, res = run_minimal(gl, nodes, outputs)
    assert assert_outputs_as_planned(ex, res, "p") == ["image", "ink", "remaining", "strokes"]


def test_distances_follow_the_reference_size():
    """At px_scale 2 the core gets twice the spacing, widths and random force (and the node doubles the
    field): the equation of motion is linear in them, so trajectories are the reference ones scaled."""
    from nodegraph_nodes.particle_sketch import ParticleSketch

    node = ParticleSketch("p", ParticleSketch.Params(n=2.0, m=1.5, line_width=1.2, randomness=0.35))
    one, two = node.core_params(1.0), node.core_params(2.0)
    assert (two.n, two.m, two.line_width, two.randomness) == (4.0, 3.0, 2.4, 0.7)
    assert two.erase_width is None and (two.step, two.max_steps, two.mass, two.drag) == (one.step, one.max_steps,
                                                                                       one.mass, one.drag)
    assert node.core_params(1.0) == node.core_params()


SURFACE_YAML = """pipeline: surface-starts
size: [200, 200]
reference_size: 200
scene: builtin:torus
nodes:
  gbuf: {{type: rasterize}}
  edges: {{type: depth_edges, in: {{depth: gbuf.linear_depth}}, params: {{threshold: 0.03}}}}
  field: {{type: force_field, in: {{gradient: edges.gradient}}, params: {{saturate: 0.03}}}}
  particles:
    type: particle_sketch
    in: {{edges: edges.edges, force: field.out, linear_depth: gbuf.linear_depth, object_id: gbuf.object_id}}
    params: {{strokes: 400, hold: 0, starts: {starts}}}
outputs:
  strokes: particles.strokes
  depth: gbuf.linear_depth
"""


def _turned_torus(deg: float):
    import dataclasses

    from nodegraph.scene.scene import load_scene

    base = load_scene("builtin:torus")
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    m = np.eye(4)
    m[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]  # about the vertical axis
    obj = base.objects[0]
    return dataclasses.replace(base, objects=(dataclasses.replace(obj, transform=m @ np.asarray(obj.transform)),))


def _starts_and_depth(starts: str, scene) -> tuple[np.ndarray, np.ndarray]:
    pipe = pl.loads(SURFACE_YAML.format(starts=starts), "surface.yaml")
    pipe.scene = scene
    ex = Executor(pipe, None)
    try:
        res = ex.run(0).values
        return (np.array([p[0] for p in res[("particles", "strokes")].polylines], np.float64),
                res[("gbuf", "linear_depth")].read()[..., 0].astype(np.float64))
    finally:
        ex.close()


def test_surface_starts_move_with_the_surface(gl):
    """The torus turned by 2 degrees about the vertical: each start of the first drawing on the object is lifted to
    its surface point through the depth buffer, turned with the object and projected again (float64); the share of
    the second drawing's starts within 0.1 px of one of those. Starts fixed on the surface (`starts: surface`)
    come back where the surface took them (measured 0.56: the rest changed with the strokes before them), random
    starts practically never (0.00); unturned, the surface starts give the same drawing again."""
    from scipy.spatial import cKDTree

    shares = {}
    for starts in ("random", "surface"):
        a, depth = _starts_and_depth(starts, _turned_torus(0.0))
        b, _ = _starts_and_depth(starts, _turned_torus(2.0))
        assert len(a) > 100 and len(b) > 100
        first, second = _turned_torus(0.0), _turned_torus(2.0)
        cam = first.camera_at(0)
        view, proj = cam.view_matrix(), cam.projection_matrix(1.0)
        d = depth[a[:, 1].astype(int), a[:, 0].astype(int)]  # linear depth at each start's pixel
        a, d = a[d > 0], d[d > 0]  # starts on the object (random ones also start on the background)
        ndc = a / 100.0 - 1.0
        eye = np.c_[ndc[:, 0] * d / proj[0, 0], ndc[:, 1] * d / proj[1, 1], -d, np.ones(len(d))]
        world = eye @ np.linalg.inv(view).T
        turn = np.asarray(second.objects[0].transform) @ np.linalg.inv(np.asarray(first.objects[0].transform))
        hom = world @ turn.T @ view.T @ proj.T
        carried = (hom[:, :2] / hom[:, 3:4] + 1.0) * 100.0
        near, _ = cKDTree(carried).query(b)
        shares[starts] = float((near < 0.1).mean())
    assert shares["surface"] > 0.35 and shares["random"] < 0.05, shares
    again, _ = _starts_and_depth("surface", _turned_torus(0.0))
    assert np.array_equal(again, _starts_and_depth("surface", _turned_torus(0.0))[0])


def test_surface_starts_need_depth_and_ids(gl, inputs):
    with pytest.raises(NodeError, match="linear_depth and object_id"):
        _draw(gl, inputs, strokes=10, starts="surface")
