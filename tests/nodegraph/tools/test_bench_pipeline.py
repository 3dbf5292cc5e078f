"""`sketchgraph bench PIPELINE` runs and writes its JSON (a smoke test: no timing is asserted)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from nodegraph.cli import main


def test_pipeline_benchmark_reports_both_frame_rates_and_the_draws(gl, tmp_path: Path):
    out = tmp_path / "b.json"
    res = CliRunner().invoke(main, ["bench", "nienhaus_sketchy", "--scene", "builtin:torus", "--frames", "3",
                                    "--size", "96x80", "--json", str(out)])
    assert res.exit_code == 0, res.output
    b = json.loads(out.read_text())
    assert b["size"] == [96, 80] and b["frames"] == 3
    assert b["fps"] > 0 and b["fps_back_to_back"] > 0 and b["copy_pass_ms"] > 0 < b["copy_pass_in_a_row_ms"]
    assert abs(b["fps"] - 1000.0 / b["ms_per_frame"]) < 1e-6 * b["fps"]
    # the G-buffer, the edges, the sketch pass (the depth sprite passes it through); noise is made once
    assert b["draws"] == {"fullscreen": 2.0, "geometry": 1.0, "total": 3.0}
    assert b["floor_ratio"] == b["ms_per_frame"] / (3.0 * b["copy_pass_ms"])
    assert abs(b["floor_ratio_back_to_back"] * b["fps_back_to_back"] * 3.0 * b["copy_pass_ms"] - 1000.0) < 1e-6
    assert set(b["nodes"]) == {"gbuf", "edges", "sketch"}


@pytest.mark.slow  # benchmark rounds, 2.6 s
def test_footprint_benchmark_compares_both_ways(gl, tmp_path: Path):
    out = tmp_path / "f.json"
    res = CliRunner().invoke(main, ["bench", "footprint", "--scene", "builtin:torus", "--frames", "2",
                                    "--json", str(out)])
    assert res.exit_code == 0, res.output
    b = json.loads(out.read_text())
    assert b["frames"] == 2 and b["draws"] == 3.0 and b["A_ms"] > 0 and b["B_ms"] > 0
    assert b["B_over_A"] == b["B_ms"] / b["A_ms"]
    assert 0.0 < b["output_footprint_share"] < 1.0  # the torus leaves part of the view to the paper


@pytest.mark.slow  # benchmark rounds
def test_film_benchmark_reports_best_and_paired_ratios_of_its_rounds(gl, tmp_path: Path):
    out = tmp_path / "film.json"
    res = CliRunner().invoke(main, ["bench", "film", "--scene", "builtin:torus", "--frames", "3", "--size", "96x80",
                                    "--repeat", "3", "--json", str(out)])
    assert res.exit_code == 0, res.output
    b = json.loads(out.read_text())
    t = b["seconds"]
    assert b["frames"] == 3 and all(len(t[k]) == 3 for k in ("frames", "png", "mp4"))
    for way in ("png", "mp4"):
        assert abs(b["ratio"][way] - min(t["frames"]) / min(t[way])) < 1e-12
        rounds = sorted(f / w for f, w in zip(t["frames"], t[way], strict=True))
        assert b["ratio_paired_median"][way] == rounds[1]
        assert b["met"][way] == (rounds[1] >= b["targets"][way])  # the paired median decides
        assert b["met_best_rounds"][way] == (b["ratio"][way] >= b["targets"][way])
    assert b["png_bytes_per_frame"] > 0 and b["mp4_bytes"] > 0
