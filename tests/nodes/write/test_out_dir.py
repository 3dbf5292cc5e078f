"""write and strokes_svg paths resolve against the output directory and may not leave it (load-time errors)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.executor import Executor

PIPE = """pipeline: t
size: [16, 12]
scene: builtin:sphere
nodes:
  g: {{type: rasterize}}
  w: {{type: write, in: {{image: g.color}}, params: {{path: '{path}'}}}}
  e: {{type: depth_edges, in: {{depth: g.linear_depth}}}}
  f: {{type: force_field, in: {{gradient: e.gradient}}}}
  p: {{type: particle_sketch, in: {{edges: e.edges, force: f.out}}, params: {{strokes: 20}}}}
  s: {{type: strokes_svg, in: {{strokes: p.strokes}}, params: {{path: '{svg}'}}}}
outputs: {{file: w.file, svg: s.file}}
"""


def _load(tmp_path: Path, path: str = "a.png", svg: str = "d.svg", **kw):
    return pl.loads(PIPE.format(path=path, svg=svg), "t.yaml", load_scene=False, **kw)


@pytest.mark.parametrize("path", ["a.png", "sub/a_####.png", "sub/../a.png", "./x/y/z.exr"])
def test_relative_paths_resolve_inside_the_out_dir(tmp_path, path):
    pipe = _load(tmp_path, path, out_dir=tmp_path)
    assert pipe.nodes["w"].output_path("path") == (tmp_path / path).resolve()
    assert pipe.nodes["s"].output_path("path") == (tmp_path / "d.svg").resolve()


@pytest.mark.parametrize(("node", "bad"), [
    ("w", "../a.png"), ("w", "sub/../../a.png"), ("w", "/tmp/elsewhere.png"), ("w", "~/a.png"),
    ("s", "../d.svg"), ("s", "/tmp/d.svg"),
])
def test_paths_leaving_the_out_dir_are_located_load_errors(tmp_path, node, bad):
    kw = {"path": bad} if node == "w" else {"svg": bad}
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(PipelineError) as info:
        _load(tmp_path, out_dir=out, **kw)
    msg = str(info.value)
    line = 6 if node == "w" else 10
    assert msg.startswith(f"t.yaml:{line}:") and "\n" not in msg
    assert f"node '{node}' ({'write' if node == 'w' else 'strokes_svg'}) path '{bad}' resolves to" in msg
    assert f"outside the output directory {out.resolve()}" in msg and "--allow-outside-out-dir" in msg
    # the explicit flag lets it through, resolved
    pipe = _load(tmp_path, out_dir=out, allow_outside=True, **kw)
    assert pipe.nodes[node].output_path("path") == (out / Path(bad).expanduser()).resolve()


def test_tilde_expands_to_home(tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path))
    pipe = _load(tmp_path, "~/pics/a.png", out_dir=tmp_path)
    assert pipe.nodes["w"].output_path("path") == tmp_path.resolve() / "pics" / "a.png"


def test_symlink_out_of_the_out_dir_is_refused(tmp_path):
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    os.symlink(elsewhere, out / "link")
    with pytest.raises(PipelineError, match=r"path 'link/a.png' resolves to .*elsewhere/a.png, outside"):
        _load(tmp_path, "link/a.png", out_dir=out)


def test_override_leaving_the_out_dir_names_the_override(tmp_path):
    with pytest.raises(PipelineError, match=r"^--set w.path=../x.png: node 'w' \(write\) path '../x.png'"):
        _load(tmp_path, out_dir=tmp_path, overrides=["w.path=../x.png"])


def test_default_out_dir_is_the_current_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert _load(tmp_path).nodes["w"].output_path("path") == tmp_path.resolve() / "a.png"
    with pytest.raises(PipelineError, match="outside the output directory"):
        _load(tmp_path, "../a.png")


def test_keys_do_not_depend_on_the_out_dir(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    keys = [Executor(pl.loads(PIPE.format(path="x.png", svg="d.svg"), "t.yaml", out_dir=d), None).keys(0)
            for d in (a, b)]
    assert keys[0] == keys[1]


def test_write_goes_into_the_out_dir(gl, tmp_path, cache_dir):
    text = PIPE.format(path="sub/a.png", svg="d.svg").replace("outputs: {file: w.file, svg: s.file}",
                                                              "outputs: {file: w.file}")
    pipe = pl.loads(text, "t.yaml", out_dir=tmp_path)
    written = Executor(pipe, None).run(0).values[("w", "file")]
    assert written == (tmp_path / "sub" / "a.png").resolve() and written.exists()


def test_cli_out_dir_and_flag(tmp_path, cache_dir):
    from nodegraph.cli import main

    f = tmp_path / "p.yaml"
    f.write_text(PIPE.format(path="../up.png", svg="d.svg"))
    runner = CliRunner()
    res = runner.invoke(main, ["inspect", str(f), "g.color", "-o", str(tmp_path / "g.exr"), "--out-dir",
                               str(tmp_path / "o")])
    assert res.exit_code != 0 and "outside the output directory" in res.output and "node 'w' (write)" in res.output
    assert len(res.output.strip().splitlines()) == 1
    res = runner.invoke(main, ["inspect", str(f), "w.file", "-o", str(tmp_path / "w.txt"), "--out-dir",
                               str(tmp_path / "o"), "--allow-outside-out-dir", "--no-cache"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "up.png").exists()


def test_api_out_dir(tmp_path, cache_dir):
    import nodegraph as ng

    f = tmp_path / "p.yaml"
    f.write_text(PIPE.format(path="../up.png", svg="d.svg"))
    with pytest.raises(PipelineError, match="outside the output directory"):
        ng.load(str(f), out_dir=tmp_path / "o")
    pipe = ng.load(str(f), out_dir=tmp_path / "o", allow_outside=True)
    moved = pipe.set({"w.path": "../up2.png"})  # set() keeps the out dir and the flag
    assert moved.pipeline.nodes["w"].output_path("path") == (tmp_path / "up2.png").resolve()
    assert np.asarray(pipe.pipeline.size).tolist() == [16, 12]
