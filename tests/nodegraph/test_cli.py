"""The command line: each command once, and errors as one line with exit status 2."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from nodegraph.cli import main
from nodegraph.output import imageio
from tests.conftest import shared_mesh

ROOT = Path(__file__).resolve().parents[2]
PIPE = str(ROOT / "pipelines" / "nienhaus_sketchy.yaml")


@pytest.fixture
def cli(tmp_path: Path):
    runner = CliRunner()

    def call(*args: str) -> object:
        return runner.invoke(main, [*args], catch_exceptions=False,
                             env={"SKETCHGRAPH_CACHE_DIR": str(tmp_path / "cache")})
    return call


def test_run_writes_an_image_and_a_second_run_computes_nothing(gl, cli, tmp_path: Path):
    out = tmp_path / "sketchy.png"
    r = cli("run", PIPE, "-o", str(out), "--size", "160x120")
    assert r.exit_code == 0, r.output
    img = imageio.read(out)
    assert img.shape == (120, 160, 3)
    assert img.std() > 0.05  # a drawing, not a blank page
    assert "4 of 5 nodes computed: gbuf, edges, noise, sketch; 1 pass-through" in r.output
    r = cli("run", PIPE, "-o", str(out), "--size", "160x120")
    assert "0 of 5 nodes computed: none; 1 from disk; 1 pass-through" in r.output


def test_run_with_a_mesh_scene_and_overrides(gl, cli, tmp_path: Path):
    mesh = shared_mesh("spot.obj")
    out = tmp_path / "spot.png"
    r = cli("run", PIPE, "--scene", str(mesh), "--set", "edges.normal_threshold=0.6", "--size", "96x64",
            "-o", str(out), "--no-cache")
    assert r.exit_code == 0, r.output
    assert imageio.read(out).shape == (64, 96, 3)


def test_frames_are_written_with_numbers(gl, cli, tmp_path: Path):
    r = cli("run", PIPE, "--frames", "0:3", "--size", "48x48", "-o", str(tmp_path / "f_####.png"), "-q")
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in tmp_path.glob("f_*.png")) == ["f_0000.png", "f_0001.png", "f_0002.png"]


def test_inspect_any_port_runs_only_its_ancestors(gl, cli, tmp_path: Path):
    out = tmp_path / "edges.exr"
    r = cli("inspect", PIPE, "edges.out", "-o", str(out), "--size", "64x64")
    assert r.exit_code == 0, r.output
    arr = imageio.read(out)
    assert arr.shape == (64, 64, 1)
    # width 2 px at the reference size 800 is 0.16 px at 64: one-pixel lines at 0.16 intensity, not a fill
    assert arr.min() == 0.0 and arr.max() == pytest.approx(2 * 64 / 800, abs=2e-3) and 0.01 < (arr > 0).mean() < 0.5
    assert "R16F 64x64" in r.output


def test_explain_prints_the_plan(gl, cli, tmp_path: Path):
    r = cli("run", PIPE, "--explain", "--size", "64x64", "-o", str(tmp_path / "x.png"), "--no-cache")
    assert r.exit_code == 0
    assert "gbuf (rasterize): compute; needed by image" in r.output
    assert "normal_depth: RGBA32F" in r.output


def test_nodes_graph_schema(cli):
    r = cli("nodes")
    assert r.exit_code == 0 and "edge_detect" in r.output and "normal_threshold = 0.4" in r.output
    info = json.loads(cli("nodes", "--json").output)
    assert info["sketch"]["inputs"]["edges"]["type"] == "Texture[R16F]"
    dot = cli("graph", PIPE).output
    assert dot.startswith('digraph "nienhaus-sketchy"') and '"gbuf":o_normal_depth -> "edges":i_normal_depth' in dot
    schema = json.loads(cli("schema").output)
    variants = schema["properties"]["nodes"]["additionalProperties"]["oneOf"]
    assert any(v["properties"]["type"]["const"] == "edge_detect" for v in variants)


def test_errors_are_one_line_with_status_2(cli, tmp_path: Path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(Path(PIPE).read_text().replace("type: edge_detect", "type: edge_detekt"))
    r = cli("run", str(bad))
    assert r.exit_code == 2
    lines = [line for line in r.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {bad}:") and "did you mean 'edge_detect'" in lines[0]
    r = cli("run", PIPE, "--size", "12")
    assert r.exit_code == 2 and "--size: expected WIDTHxHEIGHT" in r.output
    r = cli("inspect", PIPE, "edges.nope")
    assert r.exit_code == 2 and "has no output 'nope'" in r.output


def test_cache_info_and_prune(gl, cli, tmp_path: Path):
    cli("run", PIPE, "--size", "32x32", "-o", str(tmp_path / "x.png"))
    info = json.loads(cli("cache", "info", "--json").output)
    assert info["entries"] >= 5 and info["bytes"] > 0
    r = cli("cache", "prune", "--max-size", "0")
    assert r.exit_code == 0 and "removed" in r.output
    assert json.loads(cli("cache", "info", "--json").output)["entries"] == 0


def test_bench_help_reaches_the_named_benchmark(cli):
    r = cli("bench", "accuracy", "--help")
    assert r.exit_code == 0 and "sketchgraph bench accuracy" in r.output and "--families" in r.output
    r = cli("bench", "--help")
    assert r.exit_code == 0 and "film, startup, cold-cache, pencil-shade" in " ".join(r.output.split())
    r = cli("bench", "nope")
    assert r.exit_code == 2 and "neither a pipeline file, a shipped pipeline" in r.output
    assert "nienhaus_sketchy" in r.output and "a named benchmark" in r.output


def test_bench_takes_a_shipped_pipeline_by_name(cli):
    # `sketchgraph bench pencil --scene M` as `sketchgraph run pencil` takes it
    r = cli("bench", "pencil", "--help")
    assert r.exit_code == 0 and "sketchgraph bench pencil" in r.output and "--scene" in r.output


def test_run_film_renders_the_pipelines_film_setting(gl, cli, tmp_path: Path):
    """`--film`: a shipped pipeline's film setting (nodegraph/films.py: holds at 0, then its measured overrides or
    its variant file), the same image as those settings given by hand; --set applies on top; a pipeline that is
    not shipped gets its holds at 0."""
    from nodegraph import films

    by_hand = ["--set", "distortion.hold=0", "--set", "contour.hold=0"] + [
        a for k, v in films.FILM["pencil"].items() for a in ("--set", f"{k}={v}")]
    for name, args in (("film", ["--film"]), ("hand", by_hand)):
        r = cli("run", "pencil", *args, "--size", "48x48", "-o", str(tmp_path / f"{name}.png"))
        assert r.exit_code == 0, r.output
    assert (tmp_path / "film.png").read_bytes() == (tmp_path / "hand.png").read_bytes()
    r = cli("run", "pencil", "--film", "--size", "48x48", "-o", str(tmp_path / "film.png"))
    assert "film setting: pencil --set distortion.hold=0 --set contour.hold=0 --set shade.anchor=surface " \
           "--set distortion.layers=1" in r.output
    # a variant file: nienhaus_sketchy's film setting is pipelines/film/nienhaus_sketchy.yaml
    r = cli("run", "nienhaus_sketchy", "--film", "--size", "48x48", "-o", str(tmp_path / "n.png"))
    assert r.exit_code == 0 and "film setting: " + str(Path(films.film_pipeline("nienhaus_sketchy"))) in r.output
    r = cli("run", PIPE, "--film", "--size", "48x48", "-o", str(tmp_path / "n2.png"), "-q")  # by path, as by name
    assert (tmp_path / "n2.png").read_bytes() == (tmp_path / "n.png").read_bytes()
    # --set wins over the film setting
    r = cli("run", "pencil", "--film", "--set", "distortion.layers=3", "--size", "48x48", "-o",
            str(tmp_path / "three.png"), "-q")
    assert r.exit_code == 0 and (tmp_path / "three.png").read_bytes() != (tmp_path / "film.png").read_bytes()
    # not shipped: its holds at 0 and nothing else
    own = tmp_path / "own.yaml"
    own.write_text((ROOT / "pipelines" / "nienhaus_sketchy.yaml").read_text())
    source, overrides = films.film_setting(str(own))
    assert source == str(own) and overrides == ["noise.hold=0"]
