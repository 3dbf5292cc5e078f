"""`bench accuracy`: the edge-detection target on the shared meshes, the analytic references, the command."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from nodegraph_nodes.curvature.accuracy import (
    curvature_errors,
    ellipsoid_mesh,
    ellipsoid_truth,
    torus_mesh,
    torus_truth,
)
from nodegraph_nodes.edge_detect import EdgeDetect

from nodegraph.tools.bench.accuracy import TARGET_F1
from nodegraph.tools.bench.accuracy_charts import pareto
from nodegraph.tools.bench.groundtruth import line_drawing, precision_recall
from nodegraph.tools.bench.measure import NodeRunner, gbuffer, release, scene_for
from tests.conftest import shared_mesh


@pytest.mark.slow  # 800 px renders, up to 2.4 s a mesh
@pytest.mark.parametrize("name", ["fandisk.obj", "spot.obj", "stanford-bunny.obj"])
def test_edge_detection_reaches_the_target_f1_at_800(gl, name):
    """The issue's target: best setting F1 >= 0.85 at 800x800 with 1-px tolerance (the default setting)."""
    scene = scene_for(str(shared_mesh(name)))
    size = (800, 800)
    nd = gbuffer(gl, scene, size)["normal_depth"]
    truth = line_drawing(scene, size, nd.read()[..., 3])
    out = NodeRunner(gl, size, scene).run(EdgeDetect("edges"), {"normal_depth": nd}, frozenset({"out"}))
    pr = precision_recall(out["out"].read()[..., 0] > 0.5, truth.lines, 1)
    release(gl, out)
    gl.release(nd)
    assert pr["f1"] >= TARGET_F1, pr


def test_ellipsoid_truth_at_the_axes_by_hand():
    # at (a, 0, 0) the normal sections are ellipses with curvature a/b^2 and a/c^2 (a, b, c = 1, 0.75, 0.5)
    kmin, kmax, dmin, n = ellipsoid_truth(np.array([[1.0, 0, 0], [0, 0, 0.5]]))
    assert kmin[0] == pytest.approx(1 / 0.75**2) and kmax[0] == pytest.approx(4.0)
    assert abs(dmin[0] @ [0, 1, 0]) == pytest.approx(1.0) and n[0] @ [1, 0, 0] == pytest.approx(1.0)
    assert kmin[1] == pytest.approx(0.5) and kmax[1] == pytest.approx(0.5 / 0.75**2)
    # a sphere: every principal curvature 1/r
    k1, k2, _, _ = ellipsoid_truth(np.random.default_rng(0).normal(size=(20, 3)), (2.0, 2.0, 2.0))
    assert np.allclose(k1, 0.5) and np.allclose(k2, 0.5)


def test_torus_truth_and_the_curvature_errors_of_a_fine_torus():
    V, F = torus_mesh(200, 50)
    kmin, kmax, dmin, normal = torus_truth(V)
    assert np.allclose(kmax, 2.0)  # 1 / tube radius
    assert kmin.max() == pytest.approx(1 / 2.5) and kmin.min() == pytest.approx(-1 / 1.5)  # cos v / (R + r cos v)
    assert np.allclose(np.einsum("ij,ij->i", dmin, normal), 0.0)
    from nodegraph_nodes.curvature.principal import compute_curvature

    err = curvature_errors(compute_curvature(V, F, 3), kmin, kmax, dmin)
    assert err["finite"] and err["direction_p95_deg"] < 2.0 and err["value_p95"] < 0.1
    V2, F2 = ellipsoid_mesh(4)
    e2 = curvature_errors(compute_curvature(V2, F2, 3), *ellipsoid_truth(V2)[:3])
    assert e2["direction_median_deg"] < 2.0 and e2["value_median"] < 0.05


def test_pareto_front():
    xs = [1.0, 2.0, 3.0, 4.0, 2.5]
    ys = [0.5, 0.4, 0.9, 0.95, 0.9]
    assert pareto(xs, ys) == [0, 4, 3]
    assert pareto(xs, [1 - y for y in ys], maximize_y=False) == [0, 4, 3]


@pytest.mark.slow  # the quick accuracy sitting
def test_bench_accuracy_quick_writes_json_and_charts(gl, tmp_path):
    pytest.importorskip("matplotlib")
    for name in ("fandisk.obj", "spot.obj", "stanford-bunny.obj"):
        shared_mesh(name)  # the quick edge run measures these
    from nodegraph.cli import main

    out = tmp_path / "acc.json"
    charts = tmp_path / "charts"
    res = CliRunner().invoke(main, ["bench", "accuracy", "--quick", "--families", "edges,noise,hatching",
                                    "--json", str(out), "--charts", str(charts)])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert data["edges"], "edge entries"
    for e in data["edges"]:
        assert {"mesh", "method", "size", "ms", "precision", "recall", "f1"} <= set(e)
        assert 0.0 <= e["f1"] <= 1.0 and e["ms"] > 0
    assert data["edges_info"]["summary"]["target_met"]
    assert {e["method"] for e in data["noise"]} >= {"perlin x4", "white x1"}
    assert all(e["max_error"] < 1e-4 for e in data["noise"])
    assert all(e["tone_error_max"] < 0.01 for e in data["hatching"])
    for name in ("edges_800", "edges_by_mesh_800", "noise", "hatching"):
        assert (charts / f"{name}.png").stat().st_size > 1000 and (charts / f"{name}.svg").exists()


def test_bench_accuracy_rejects_unknown_families():
    from nodegraph.cli import main

    res = CliRunner().invoke(main, ["bench", "accuracy", "--families", "edges,colour"])
    assert res.exit_code == 2 and "unknown families" in res.output


def test_a_chart_is_drawn_again_from_a_json_of_figures(tmp_path, monkeypatch):
    """`python -m nodegraph.tools.bench.accuracy_charts pipelines FIGURES OUT`: the chart from merged figures, one
    line per pipeline in a colour of its own (twelve pipelines are more than the default cycle's ten)."""
    pytest.importorskip("matplotlib")
    from nodegraph.tools.bench import accuracy_charts

    names = [f"p{i:02d}" for i in range(12)]
    figures = {"pipelines": [{"pipeline": n, "size": s, "ms": (i + 1) * s / 100} for i, n in enumerate(names)
                             for s in (400, 800)]}
    (tmp_path / "f.json").write_text(json.dumps(figures))
    assert accuracy_charts.main(["pipelines", str(tmp_path / "f.json"), str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "pipelines.png").stat().st_size > 1000
    drawn = []
    monkeypatch.setattr(accuracy_charts, "_save", lambda fig, out, name: drawn.append(fig) or [])
    accuracy_charts.chart_pipelines(figures, tmp_path)
    lines = drawn[0].axes[0].get_lines()
    assert len(lines) == 12 and len({str(ln.get_color()) for ln in lines}) == 12
