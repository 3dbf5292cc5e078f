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
