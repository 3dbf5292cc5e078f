"""`sketchgraph diff`: why keys differ, and how much the pixels do."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from nodegraph import pipeline as pl
from nodegraph.cli import main
from nodegraph.tools.diff import compare_keys, compare_values

ROOT = Path(__file__).resolve().parents[3]
NIENHAUS = ROOT / "pipelines" / "nienhaus_sketchy.yaml"


def load(*overrides: str, size=(40, 32), **kw) -> pl.Pipeline:
    return pl.load(NIENHAUS, overrides=list(overrides), size=size, **kw)


def by_node(diffs):
    return {d.node: d for d in diffs}


def test_param_change_explains_downstream():
    d = by_node(compare_keys(load(), load("edges.normal_threshold=0.2")))
    assert d["gbuf"].status == d["noise"].status == "same"
    assert d["edges"].status == "changed" and d["edges"].reasons == ["param normal_threshold: 0.4 → 0.2"]
    assert d["sketch"].reasons == ["input edges ← edges.out changed"]
    assert "input color ← sketch.color changed" in d["sprite"].reasons
    assert not any("gbuf" in r for r in d["sprite"].reasons)


def test_context_changes_are_named():
    d = by_node(compare_keys(load(), load(size=(48, 32))))
    assert all(n.status == "changed" for n in d.values())
    assert any(r == "size: [40, 32] → [48, 32]" for r in d["gbuf"].reasons)
    d = by_node(compare_keys(load(), load(scene="builtin:torus")))
    assert any(r.startswith("scene changed") for r in d["gbuf"].reasons)
    assert d["noise"].status == "same"  # noise does not read the scene


def test_seed_and_rewiring():
    text = NIENHAUS.read_text()
    a = pl.loads(text, "a.yaml", size=(40, 32))
    d = by_node(compare_keys(a, pl.loads(text.replace("seed: 7", "seed: 8"), "b.yaml", size=(40, 32))))
    assert d["noise"].reasons == ["seed changed (pipeline seed 7 → 8)"]
    assert d["gbuf"].status == "same"  # the rasterizer reads no seed
    rewired = text.replace("offset: noise.out", "offset: noise2.out").replace(
        "  sketch:\n", "  noise2:\n    type: perlin_noise\n  sketch:\n")
    d = by_node(compare_keys(a, pl.loads(rewired, "b.yaml", size=(40, 32))))
    assert d["sketch"].reasons == ["input offset: noise.out → noise2.out"]
    assert d["noise2"].status == "only_b"
    assert d["noise"].status == "only_a" and "not needed" in d["noise"].reasons[0]


def test_compare_values_numbers():
    a = np.zeros((4, 5, 1), np.float32)
    b = a.copy()
    b[0, 0, 0] = 0.5
    b[1, 1, 0] = -0.25
    p = compare_values("n", "out", a, b)
    assert p.max_abs == 0.5 and np.isclose(p.mean_abs, 0.75 / 20) and np.isclose(p.differing, 2 / 20)
    assert p.panels is not None and p.panels[2].shape == (4, 5, 3)
    b[2, 2, 0] = np.nan
    assert compare_values("n", "out", a, b).nan_mismatch == 1
    assert "shapes differ" in compare_values("n", "out", a, np.zeros((5, 5, 1), np.float32)).note


def test_cli_diff_pixels(gl, tmp_path, cache_dir):
    out = tmp_path / "d"
    r = CliRunner().invoke(main, ["diff", str(NIENHAUS), "--size", "40x32", "--set-b", "edges.normal_threshold=0.1",
                                  "-o", str(out)])
    assert r.exit_code == 1, r.output  # like diff(1): 1 when something differs
    assert "edges   param normal_threshold: 0.4 → 0.1" in r.output
    report = json.loads((out / "diff.json").read_text())
    outs = {f"{o['node']}.{o['port']}": o for o in report["outputs"]}
    assert outs["edges.out"]["max_abs"] > 0 and outs["edges.out"]["mean_abs"] > 0
    assert outs["sprite.color"]["max_abs"] > 0
    assert (out / "edges.out.diff.png").exists() and (out / "diff_sheet.png").exists()
    assert "gbuf.color" not in outs  # unchanged keys are not rendered twice


def test_cli_diff_identical(gl, tmp_path):
    r = CliRunner().invoke(main, ["diff", str(NIENHAUS), str(NIENHAUS), "--size", "40x32", "--keys-only"])
    assert r.exit_code == 0, r.output
    assert "keys: 0 of 5 nodes differ" in r.output
