"""Films and frame sequences from the command line, decoded again with PyAV."""

from __future__ import annotations

import json

import av
import numpy as np
import pytest
from click.testing import CliRunner

from nodegraph import film
from nodegraph.cli import main
from tests import gltf_files as gf


def _run(*args: str):
    return CliRunner().invoke(main, ["run", "nienhaus_sketchy", "--no-cache", "-q", *args], catch_exceptions=False)


def _decode(path):
    with av.open(str(path)) as c:
        return [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]


@pytest.mark.parametrize("ext", [".mp4", ".webm", ".gif"])
def test_film_of_the_whole_animation(tmp_path, ext):
    box = gf.animated_box(tmp_path / "box.glb")
    out = tmp_path / f"film{ext}"
    res = _run("--scene", str(box), "--size", "97x64", "--fps", "6", "-o", str(out))
    assert res.exit_code == 0, res.output
    frames = _decode(out)
    assert len(frames) == 7  # t = 0 .. 1 s at 6 fps, both ends
    if ext != ".gif":
        assert frames[0].shape == (64, 98, 3)  # H.264/VP9 need even sizes: one column repeated
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).mean() > 1.0  # the box moved
    assert not list(tmp_path.glob(".*partial*"))


def test_interrupted_film_leaves_nothing(tmp_path, monkeypatch):
    box = gf.animated_box(tmp_path / "box.glb")
    out = tmp_path / "cut.mp4"
    calls = {"n": 0}
    real = film.FilmWriter.write

    def write(self, rgb):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        real(self, rgb)

    monkeypatch.setattr(film.FilmWriter, "write", write)
    res = CliRunner().invoke(main, ["run", "nienhaus_sketchy", "--no-cache", "-q", "--scene", str(box), "--size",
                                    "64x64", "-o", str(out)])
    assert res.exit_code != 0
    assert not out.exists() and not list(tmp_path.glob(".*partial*"))


def test_sequence_resume_skips_frames_with_the_same_keys(tmp_path):
    box = gf.animated_box(tmp_path / "box.glb")
    pattern = str(tmp_path / "seq" / "f_####.png")
    assert _run("--scene", str(box), "--size", "48x48", "--frames", "0:4", "-o", pattern, "--resume").exit_code == 0
    manifest = json.loads((tmp_path / "seq" / ".f_####.png.frames.json").read_text())
    assert sorted(manifest["frames"], key=int) == ["0", "1", "2", "3"]
    (tmp_path / "seq" / "f_0002.png").unlink()
    res = CliRunner().invoke(main, ["run", "nienhaus_sketchy", "--no-cache", "--scene", str(box), "--size", "48x48",
                                    "--frames", "0:4", "-o", pattern, "--resume"], catch_exceptions=False)
    assert "3 already written" in res.output and (tmp_path / "seq" / "f_0002.png").exists()


def test_still_scene_film_needs_frames(tmp_path):
    res = CliRunner().invoke(main, ["run", "nienhaus_sketchy", "--no-cache", "-q", "--scene", "builtin:box", "-o",
                                    str(tmp_path / "x.mp4")])
    assert res.exit_code == 2 and "--frames" in res.output
