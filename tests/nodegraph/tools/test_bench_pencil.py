"""The named pencil benchmarks run and write their JSON (a smoke test: no timing is asserted)."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from nodegraph.cli import main


def test_hatching_and_curvature_benchmarks_write_json(gl, tmp_path: Path):
    runner = CliRunner()
    out = tmp_path / "h.json"
    res = runner.invoke(main, ["bench", "hatching", "--size", "32", "--tones", "4", "--repeat", "1",
                               "--json", str(out)])
    assert res.exit_code == 0, res.output
    h = json.loads(out.read_text())
    assert h["benchmark"] == "hatching" and h["cached_from"] == "disk"
    assert all(h[k] >= 0 for k in ("cold_s", "cached_s", "compute_s", "memory_s"))
    out = tmp_path / "c.json"
    res = runner.invoke(main, ["bench", "curvature", "--scene", "builtin:torus", "--repeat", "1", "--json", str(out)])
    assert res.exit_code == 0, res.output
    c = json.loads(out.read_text())
    assert c["benchmark"] == "curvature" and c["vertices"] > 0 and c["cached_from"] == "disk"
    assert all(c[k] >= 0 for k in ("cold_s", "cached_s", "compute_s", "libigl_s"))


def test_pencil_shade_benchmark_compares_both_implementations(gl, tmp_path: Path):
    out = tmp_path / "s.json"
    res = CliRunner().invoke(main, ["bench", "pencil-shade", "--scene", "builtin:torus", "--frames", "2",
                                    "--size", "96x80", "--json", str(out)])
    assert res.exit_code == 0, res.output
    s = json.loads(out.read_text())
    assert s["benchmark"] == "pencil-shade" and s["size"] == [96, 80] and s["frames"] == 2
    assert s["deferred_ms"] > 0 and s["geometry_shader_ms"] > 0 and s["copy_pass_ms"] > 0
    assert s["speedup_min"] <= s["speedup"] <= s["speedup_max"]
    # the geometry pass, the paper pass and the hatching pass; before: the geometry pass and the composite
    assert s["deferred_draws"] == 3 and s["geometry_shader_draws"] == 2
