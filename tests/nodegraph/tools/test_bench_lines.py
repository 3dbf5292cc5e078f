"""bench_lines: the charts draw from the JSON the commands write (synthetic figures here; the commands
themselves are benchmarks, run by hand), and the uncertainty settings name parameters the pipelines have."""

from __future__ import annotations

import pytest

from nodegraph import pipeline as pl
from nodegraph.tools.bench import lines as B


def _summary(x: float) -> dict[str, float]:
    return {"median": x, "min": 0.8 * x, "max": 1.3 * x}


@pytest.mark.slow  # 3.1 s
def test_charts_are_written(tmp_path) -> None:
    pytest.importorskip("matplotlib")
    u = {"size": [40, 40], "entries": [
        {"mesh": m, "method": meth, "setting": f"s{k}", "shower_door": 0.05 * k + (0.1 if meth[0] == "s" else 0),
         "ms": _summary(10.0 + k)} for m in ("a.obj", "b.obj") for meth in ("screen-space", "object-space")
        for k in range(3)]}
    f = {"size": [40, 40], "entries": [
        {"mesh": m, "triangles": n, **{k: _summary(v) for k, v in (
            ("edges_only", 10.0), ("with_lines", 14.0), ("lines_node", 3.0), ("first_frame", 200.0),
            ("first_curvature", 90.0), ("first_lines", 60.0), ("later_frame", 15.0))}}
        for m, n in (("a.obj", 100), ("b.obj", 5000))]}
    paths = B.chart_uncertainty(u, tmp_path) + B.chart_feature_lines(f, tmp_path)
    assert sorted(p.name for p in paths) == ["feature_lines_cost.png", "feature_lines_cost.svg",
                                             "uncertainty_cost.png", "uncertainty_cost.svg"]
    assert all(p.stat().st_size > 1000 for p in paths)


@pytest.mark.parametrize("pipeline, settings", [(B.SCREEN, B.SCREEN_SETTINGS), (B.OBJECT, B.OBJECT_SETTINGS)])
def test_settings_apply_to_the_pipelines(pipeline: str, settings: list) -> None:
    base = pl.load(pipeline, load_scene=False)
    for _, overrides in settings:
        pipe = pl.load(pipeline, overrides=overrides, load_scene=False)
        changed = {nid for nid in pipe.nodes if pipe.nodes[nid].params != base.nodes[nid].params}
        assert bool(changed) == bool(overrides), (pipeline, overrides)
