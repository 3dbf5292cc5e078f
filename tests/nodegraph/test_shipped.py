"""Shipped pipelines: pipelines/ installs as the data package nodegraph_pipelines and resolves by name."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from nodegraph import pipeline as pl
from nodegraph import shipped
from nodegraph.cli import main
from nodegraph.errors import PipelineError, SketchgraphError
from nodegraph.output import imageio

ROOT = Path(__file__).resolve().parents[2]
REPO_PIPELINES = sorted(p.stem for p in (ROOT / "pipelines").glob("*.yaml"))


def test_every_repository_pipeline_ships():
    assert shipped.names() == REPO_PIPELINES
    for name, path in shipped.paths().items():
        assert path.read_bytes() == (ROOT / "pipelines" / f"{name}.yaml").read_bytes()


@pytest.mark.parametrize("spec", ["nienhaus_sketchy", "nienhaus_sketchy.yaml"])
def test_a_name_resolves_to_the_shipped_file(spec, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert shipped.resolve(spec) == shipped.paths()["nienhaus_sketchy"]


def test_an_existing_path_wins_over_a_shipped_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    mine = tmp_path / "chalk.yaml"
    mine.write_text((ROOT / "pipelines" / "nienhaus_sketchy.yaml").read_text())
    assert shipped.resolve("chalk.yaml") == Path("chalk.yaml")
    assert pl.load("chalk.yaml", load_scene=False).name == "nienhaus-sketchy"
    assert pl.load("chalk", load_scene=False).name == "chalk"  # no such file: the shipped one


def test_unknown_name_is_one_line_with_the_names_and_a_suggestion(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(PipelineError) as exc:
        pl.load("nienhaus_sketchi")
    msg = str(exc.value)
    assert "\n" not in msg
    assert "did you mean 'nienhaus_sketchy'?" in msg
    assert all(n in msg for n in REPO_PIPELINES)


def test_missing_path_says_the_shipped_name_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(PipelineError, match=r"pipeline file not found: pipelines/chalk.yaml \(the shipped "
                                            r"pipeline 'chalk' runs by name"):
        pl.load("pipelines/chalk.yaml")


def test_messages_name_the_file_as_given(tmp_path, monkeypatch):
    text = (ROOT / "pipelines" / "nienhaus_sketchy.yaml").read_text().replace("type: edge_detect", "type: edge_detekt")
    (tmp_path / "broken.yaml").write_text(text)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(PipelineError, match=r"^\./broken.yaml:\d+:\d+: .*edge_detekt"):
        pl.load("./broken.yaml")


def test_scene_paths_stay_relative_to_the_shipped_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    pipe = pl.load("sketchy_composite", size=(16, 16))
    assert pipe.spec.scene == "scenes/composite.yaml"
    assert Path(pipe.scene.source) == shipped.folder() / "scenes" / "composite.yaml"


def test_every_shipped_pipeline_has_a_description():
    for name, path in shipped.paths().items():
        line = shipped.describe(path)
        assert line and "\n" not in line and len(line) < 120, name


def test_first_clause_keeps_abbreviations():
    assert shipped.first_clause("Contours (Lee et al. 2006, §4): the edge map") == "Contours (Lee et al. 2006, §4)"
    assert shipped.first_clause('After "A. B" (2004), Fig. 8. Then more') == 'After "A. B" (2004), Fig. 8'


def test_doc_field_wins_over_the_comment(tmp_path):
    p = tmp_path / "p.yaml"
    p.write_text("# a comment: more\npipeline: p\ndoc: What it does\nnodes: {}\noutputs: {}\n")
    assert shipped.describe(p) == "What it does"


def test_cli_lists_and_runs_by_name(gl, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    env = {"SKETCHGRAPH_CACHE_DIR": str(tmp_path / "cache")}
    r = runner.invoke(main, ["pipelines"], env=env)
    assert r.exit_code == 0, r.output
    lines = r.output.splitlines()
    assert [ln.split()[0] for ln in lines] == REPO_PIPELINES
    assert "Sketchy drawing after Nienhaus" in next(ln for ln in lines if ln.startswith("nienhaus_sketchy "))
    r = runner.invoke(main, ["run", "nienhaus_sketchy", "-o", "a.png", "--size", "48x32"], env=env)
    assert r.exit_code == 0, r.output
    assert imageio.read(tmp_path / "a.png").shape == (32, 48, 3)
    r = runner.invoke(main, ["run", "nienhaus", "-o", "a.png"], env=env)
    assert r.exit_code == 2 and r.output.count("\n") == 1 and "did you mean 'nienhaus_sketchy'" in r.output


def test_a_gallery_entry_may_name_a_shipped_pipeline(tmp_path):
    from nodegraph.tools import gallery as gal

    f = tmp_path / "gallery.yaml"
    f.write_text("entries:\n  - {name: mine, pipeline: chalk, size: [16, 16]}\n")
    entry = gal.load(f).entries[0]
    assert entry.pipeline == shipped.paths()["chalk"].absolute() and entry.pipeline_rel == "chalk"
    f.write_text("entries:\n  - {name: mine, pipeline: chalky}\n")
    with pytest.raises(SketchgraphError, match=r"entries\[0\] \(mine\): pipeline: .*did you mean 'chalk'"):
        gal.load(f)


def test_gallery_outside_a_checkout_names_the_option(tmp_path):
    from nodegraph.tools import gallery as gal

    with pytest.raises(SketchgraphError, match="pass --gallery FILE"):
        gal.load(tmp_path / "gallery" / "gallery.yaml")
