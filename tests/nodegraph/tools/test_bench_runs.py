"""`sketchgraph bench startup` and `bench cold-cache` run whole commands in new processes and write their JSON
(smoke tests of the bookkeeping: no timing is asserted)."""

from __future__ import annotations

import json
import statistics
from pathlib import Path

import pytest
from click.testing import CliRunner

from nodegraph.cli import main


@pytest.mark.slow  # benchmark: runs the CLI as processes
def test_cold_cache_benchmark_pairs_its_runs_and_reports_their_ratios(gl, tmp_path: Path):
    out = tmp_path / "cold.json"
    res = CliRunner().invoke(main, ["bench", "cold-cache", "--scene", "builtin:torus", "--size", "96x64",
                                    "--pairs", "2", "--json", str(out)])
    assert res.exit_code == 0, res.output
    b = json.loads(out.read_text())
    walls = b["seconds"]
    assert len(walls["cold"]) == len(walls["no_cache"]) == 2 == len(b["cpu_seconds"]["cold"])
    assert b["ratio_per_pair"] == [c / n for c, n in zip(walls["cold"], walls["no_cache"], strict=True)]
    assert b["ratio_paired_median"] == statistics.median(b["ratio_per_pair"])
    assert b["met"] == (b["ratio_paired_median"] <= b["target"] == 1.25)
    assert all(t > 0 for t in b["cpu_seconds"]["no_cache"])
    # the empty cache got entries (at this size the cache keeps every node's output), the other run none
    assert b["cache_written"]["entries"] >= 1 and b["cache_written"]["bytes"] > 0


@pytest.mark.slow  # benchmark: runs the CLI as processes
def test_startup_benchmark_counts_each_run_and_writes_bytecode_where_asked(gl, tmp_path: Path):
    out = tmp_path / "startup.json"
    res = CliRunner().invoke(main, ["bench", "startup", "--scene", "builtin:torus", "--size", "96x64", "--runs", "2",
                                    "--bytecode", "written", "--json", str(out)])
    assert res.exit_code == 0, res.output
    b = json.loads(out.read_text())
    assert b["project_bytecode"] is True  # the first run wrote it where the later ones read it
    s = b["seconds"]
    assert len(s["help_cpu"]) == len(s["first_image_cpu"]) == 2
    assert b["first_image_cpu_s"]["max"] == max(s["first_image_cpu"]) > 0
    assert b["help_cpu_s"]["median"] == statistics.median(s["help_cpu"]) > 0
    assert b["met"]["help_cpu_s"] == (max(s["help_cpu"]) <= 0.3)


def test_a_failing_command_is_reported_in_one_line(tmp_path: Path):
    res = CliRunner().invoke(main, ["bench", "cold-cache", "--pipeline", str(tmp_path / "missing.yaml"),
                                    "--pairs", "1"])
    assert res.exit_code == 2
    line, = res.output.splitlines()
    assert line.startswith("error: `sketchgraph run ") and "` failed: pipeline file not found: " in line
