"""`sketchgraph bench targets`: the sitting's plan, the verdict per target, and one quick sitting end to end on
a small sphere standing in for spot and ogre (its figures mean nothing; every benchmark's JSON must reach its
target and the repository's gallery must stay untouched)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nodegraph.cli import main
from nodegraph.tools.bench import targets as bt

ROOT = Path(__file__).resolve().parents[3]


def test_evaluate_counts_the_runs_within_each_limit_in_its_direction():
    got = bt.evaluate({"png_sequence": [0.9, 0.85, 0.84], "default_floor_ogre": [3.5, 3.51], "ogre_fps": [30.0],
                       "help_cpu_s": []})
    png, floor, fps = got["png_sequence"], got["default_floor_ogre"], got["ogre_fps"]
    assert (png["met_runs"], png["runs"], png["met"]) == (2, 3, False)  # at least 0.85: 0.84 misses
    assert (floor["met_runs"], floor["runs"], floor["met"]) == (1, 2, False)  # at most 3.5: 3.51 misses
    assert (fps["met_runs"], fps["met"]) == (1, True)
    assert "help_cpu_s" not in got and "gallery_force" not in got  # no figures, no verdict


def test_table_gives_one_line_a_target_and_the_sitting_verdict():
    targets = bt.evaluate({"cold_cache_4k": [1.0, 1.3], "pencil_shade_speedup": [2.5]})
    lines = bt.table({"renderer": "R", "copy_pass_ms": {"min": 1.5, "max": 2.25}, "targets": targets,
                      "met": False})
    assert lines[:2] == ["renderer: R", "copy pass: 1.50-2.25 ms"]
    # in the order of TARGETS, whatever the order of the figures
    assert lines[2] == "pencil_shade_speedup: met (1 of 1 runs >= 2): 2.5"
    assert lines[3] == "cold_cache_4k: NOT met (1 of 2 runs <= 1.25): 1, 1.3"
    assert lines[-1] == "all targets met: no"


def test_jobs_run_film_and_the_default_pipeline_runs_times_the_rest_half_as_often(tmp_path: Path):
    todo = bt.jobs(tmp_path, runs=3)
    kinds = [j.args[1] for j in todo]
    assert kinds.count("film") == 3 and kinds.count("nienhaus_sketchy") == 6
    assert kinds.count("pencil") == kinds.count("pencil-shade") == kinds.count("cold-cache") == 2
    assert [j.args[-1] for j in todo if j.args[1] == "startup"] == ["as-is", "written"]
    film = next(j for j in todo if j.args[1] == "film")
    assert film.args[2:] == ("--scene", str(tmp_path / "spot.obj"), "--frames", "60", "--repeat", "5")
    ogre = [j for j in todo if j.args[1] == "nienhaus_sketchy" and str(tmp_path / "ogre.obj") in j.args]
    assert len(ogre) == 3
    assert ogre[0].read({"floor_ratio": 3.0, "fps": 31.0}) == {"default_floor_ogre": [3.0], "ogre_fps": [31.0]}


def test_missing_meshes_stop_the_sitting_in_one_line(tmp_path: Path):
    res = CliRunner().invoke(main, ["bench", "targets", "--meshes", str(tmp_path), "--quick"])
    assert res.exit_code != 0
    assert res.output.strip().splitlines() == [
        f"error: bench targets: spot.obj, ogre.obj not found in {tmp_path} (--meshes DIR: the folder of the "
        "project's test meshes, ../shared/meshes)"]


def _sphere_obj(path: Path, rings: int = 12, segments: int = 24) -> None:
    """A UV sphere of radius 1 as an OBJ file (poles, rings of vertices, triangles facing out)."""
    lines = ["v 0 1 0"]
    for i in range(1, rings):
        t = np.pi * i / rings
        for j in range(segments):
            p = 2 * np.pi * j / segments
            lines.append(f"v {np.sin(t) * np.cos(p):.6f} {np.cos(t):.6f} {np.sin(t) * np.sin(p):.6f}")
    lines.append("v 0 -1 0")
    bottom = 2 + (rings - 1) * segments  # 1-based index of the lower pole

    def ring(i: int, j: int) -> int:
        return 2 + (i - 1) * segments + j % segments

    for j in range(segments):
        lines.append(f"f 1 {ring(1, j + 1)} {ring(1, j)}")
        lines.append(f"f {bottom} {ring(rings - 1, j)} {ring(rings - 1, j + 1)}")
    for i in range(1, rings - 1):
        for j in range(segments):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1)
            lines += [f"f {a} {b} {d}", f"f {a} {d} {c}"]
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.slow
def test_a_quick_sitting_gives_every_target_its_figures_and_leaves_the_gallery_alone(gl, tmp_path: Path):
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    _sphere_obj(meshes / "spot.obj")
    shutil.copy(meshes / "spot.obj", meshes / "ogre.obj")
    gallery = ROOT / "gallery"
    before = {p: p.stat().st_mtime_ns for p in gallery.rglob("*")}
    out = tmp_path / "targets.json"
    res = CliRunner().invoke(main, ["bench", "targets", "--meshes", str(meshes), "--gallery",
                                    str(gallery / "gallery.yaml"), "--quick", "--runs", "1", "--json", str(out)])
    assert res.exit_code == 0, res.output
    r = json.loads(out.read_text())
    assert set(r["targets"]) == {t.key for t in bt.TARGETS}
    for key, t in r["targets"].items():
        want = 2 if key in ("help_cpu_s", "first_image_cpu_s") else 1  # startup: one process each way
        assert t["runs"] == want == len(t["values"]), key
        assert all(v > 0 for v in t["values"]), key
        assert t["met"] == all(bt.BY_KEY[key].met(v) for v in t["values"])
    assert r["met"] == all(t["met"] for t in r["targets"].values())
    assert r["renderer"] and r["copy_pass_ms"]["min"] > 0
    assert {p: p.stat().st_mtime_ns for p in gallery.rglob("*")} == before  # built from a copy
    assert res.output.splitlines()[-2].startswith("all targets met: ")
