"""No more than a scene needs: engine-chosen buffer formats give the float32 result; only the ancestors of a
requested output run; derived mesh data (normals, curvature) is computed only when a node needing it runs."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.edge_detect import EdgeDetect
from nodegraph_nodes.edge_detect.reference import edge_detect as edge_detect_ref

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.registry import default
from nodegraph.scene.meshes import Mesh
from nodegraph.scene.primitives import torus
from nodegraph.scene.scene import Scene, SceneObject, frame_camera, load_scene
from nodegraph.tools.bench.measure import NodeRunner
from nodegraph.tools.explain import explain

SIZE = (240, 180)


def _pipeline(scene, with_curvature: bool = False) -> pl.Pipeline:
    nodes = {
        "gbuf": {"type": "rasterize"},
        "edges": {"type": "edge_detect", "in": {"normal_depth": "gbuf.normal_depth"}},
        "noise": {"type": "perlin_noise"},
        "sketch": {"type": "sketch", "in": {"edges": "edges.out", "shade": "gbuf.color", "offset": "noise.out"}},
    }
    outputs = {"image": "sketch.color"}
    if with_curvature:
        nodes["curv"] = {"type": "curvature"}
        outputs["curvature"] = "curv.out"
    data = {"pipeline": "formats", "size": list(SIZE), "reference_size": min(SIZE),  # px_scale 1, as NodeRunner
            "scene": "builtin:box", "nodes": nodes, "outputs": outputs}
    pipe = pl.build(data, "<test_formats>", load_scene=False)
    pipe.scene = scene
    return pipe


def test_engine_formats_for_edges_equal_a_float32_computation(gl):
    scene = load_scene("builtin:cloister")
    pipe = _pipeline(scene)
    ex = Executor(pipe, None, requested=[("sketch", "color"), ("edges", "out"), ("gbuf", "normal_depth")])
    f = ex.plan.formats
    # chosen from the consumers' port types: full float where depth precision matters, half where it does not
    assert f[("gbuf", "normal_depth")] == "RGBA32F"
    assert f[("edges", "out")] == "R16F"
    assert f[("noise", "out")] == "RG16F"  # declared RG32F; sketch asks for no more
    assert f[("gbuf", "color")] == "RGBA8"
    res = ex.run(0)
    nd = res.values[("gbuf", "normal_depth")]
    got = res.values[("edges", "out")].read()[..., 0]
    # the same pass with every output in float32
    f32 = NodeRunner(gl, SIZE, scene, formats={("edges", p): "R32F" for p in ("out", "profile", "inner")})
    out = f32.run(EdgeDetect("edges", pipe.nodes["edges"].params), {"normal_depth": nd})
    full = out["out"].read()[..., 0]
    assert out["out"].fmt == "R32F"
    assert np.abs(got - full).max() <= 2.0**-11 * 1.01, "half keeps values in [0, 1] to its rounding step"
    undecided = np.abs(full - 0.5) < 1e-3
    assert np.array_equal((got > 0.5)[~undecided], (full > 0.5)[~undecided]), "the same edge pixels"
    # and the float32 pass agrees with the float64 NumPy reference of the same operator
    ref = edge_detect_ref(nd.read(), **pipe.nodes["edges"].params.model_dump())["out"]
    assert np.mean(np.abs(full - ref) > 2e-3) < 0.002
    for v in out.values():
        gl.release(v)


def test_requesting_only_edges_runs_only_its_ancestors(gl):
    pipe = _pipeline(load_scene("builtin:box"), with_curvature="curvature" in default().names())
    ex = Executor(pipe, None, requested=[("edges", "out")])
    assert ex.plan.order == ["gbuf", "edges"]
    assert ex.plan.needed["gbuf"] == frozenset({"normal_depth"}), "rasterize writes only what edges read"
    assert set(ex.plan.formats) == {("gbuf", "normal_depth"), ("edges", "out")}
    text = explain(ex)
    assert "not needed: " in text and "noise" in text.split("not needed: ")[1]
    res = ex.run(0)
    assert sorted(res.computed()) == ["edges", "gbuf"]
    assert ex.compute_counts == {"gbuf": 1, "edges": 1}


def _fresh_scene() -> tuple[Scene, Mesh]:
    """A torus with content no other test draws (GL vertex buffers are cached by mesh content)."""
    base = torus(1.0, 0.35, 40, 16)
    mesh = Mesh("fresh", base.vertices + np.array([0.0, 1e-3 * np.pi, 0.0]), base.faces)
    lo, hi = mesh.bounds()
    return Scene("fresh", (SceneObject(mesh, np.eye(4), name="fresh"),), frame_camera(lo, hi)), mesh


def _derived(mesh: Mesh) -> set[str]:
    keys = {k if isinstance(k, str) else k[0] for k in mesh._cache}
    return keys & {"vnormals", "render", "facegeo", "topology"}


def test_derived_mesh_data_only_when_a_node_needing_it_is_planned(gl, monkeypatch):
    if "curvature" not in default().names():
        pytest.skip("the curvature node is not registered")
    import nodegraph_nodes.curvature as curvature_node

    calls: list[int] = []
    real = curvature_node.compute_curvature

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(curvature_node, "compute_curvature", counting)
    scene, mesh = _fresh_scene()
    pipe = _pipeline(scene, with_curvature=True)

    Executor(pipe, None, requested=[("noise", "out")]).run(0)
    assert _derived(mesh) == set(), "noise alone touches no mesh data"
    assert calls == []

    ex = Executor(pipe, None, requested=[("edges", "out")])
    ex.run(0)
    assert "vnormals" in _derived(mesh) and "render" in _derived(mesh), "rasterize needs normals"
    assert calls == [], "no curvature for edges"

    ex = Executor(pipe, None, requested=[("curv", "out")])
    ex.run(0)
    ex.run(1)
    assert calls == [1], "curvature once per mesh content, reused in later frames"
    assert ex.plan.order == ["curv"]
