"""The Python API (nodegraph.api): what it returns against the command line's files, the session's reuse
of in-memory values (compute counts), errors, and every example in docs/api.md."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import nodegraph as ng
from nodegraph.cli import main
from tests.conftest import ROOT, shared_mesh

PIPE = str(ROOT / "pipelines" / "nienhaus_sketchy.yaml")


def _read_png(path: Path) -> np.ndarray:
    """A PNG as uint8 (H, W, C), row 0 at the top, read with OpenImageIO directly (not the engine's reader)."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    pixels = inp.read_image(oiio.UINT8)
    inp.close()
    return np.asarray(pixels).reshape(spec.height, spec.width, spec.nchannels)


def _read_exr(path: Path) -> np.ndarray:
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    pixels = inp.read_image(oiio.FLOAT)
    inp.close()
    return np.asarray(pixels).reshape(spec.height, spec.width, spec.nchannels)


@pytest.mark.slow  # 3.6 s
def test_issue_example_equals_the_cli_png(gl, tmp_path: Path, cache_dir: Path) -> None:
    """The issue's example, run as written (a mesh from shared/, 1200x900, an override), against the PNG that
    `sketchgraph run` writes with the same arguments: the same pixels, row 0 at the top."""
    spot = shared_mesh("spot.obj")
    pipe = ng.load("nienhaus_sketchy", scene=str(spot), size=(1200, 900), set={"edges.width": 3})  # shipped name
    img = pipe.render()
    assert img.dtype == np.uint8 and img.shape == (900, 1200, 4)
    out = tmp_path / "a.png"
    res = CliRunner().invoke(main, ["run", "nienhaus_sketchy", "--scene", str(spot), "--size", "1200x900",
                                    "--set", "edges.width=3", "-o", str(out), "-q"])
    assert res.exit_code == 0, res.output
    png = _read_png(out)
    assert png.shape == (900, 1200, 3)
    assert np.array_equal(img[:, :, :3], png)
    assert img[:, :, :3].std() > 5  # a drawing, not a blank image

    hdr = pipe.render(dtype="float32")
    assert hdr.dtype == np.float32 and hdr.shape == (900, 1200, 4)
    assert np.array_equal(np.clip(np.rint(hdr * 255), 0, 255).astype(np.uint8), img)

    edges = pipe.inspect("edges.out")
    assert edges.dtype == np.float32 and edges.shape == (900, 1200, 1)
    exr = tmp_path / "edges.exr"
    res = CliRunner().invoke(main, ["inspect", PIPE, "edges.out", "--scene", str(spot), "--size", "1200x900",
                                    "--set", "edges.width=3", "-o", str(exr)])
    assert res.exit_code == 0, res.output
    assert np.array_equal(edges, _read_exr(exr))


def test_rows_are_top_down(gl, tmp_path: Path) -> None:
    """A scene with one sphere above the camera's target: its pixels are in the upper rows of the array, as in a
    picture (independent of the engine: a sphere at +y projects above the image centre)."""
    scene_yaml = tmp_path / "up_sphere.yaml"
    scene_yaml.write_text("objects:\n"
                          "  - {primitive: {type: sphere, radius: 0.4}, transform: {translate: [0, 1.2, 0]}}\n"
                          "camera: {eye: [0, 0, 6], target: [0, 0, 0], fov: 40}\n")
    with ng.Session(cache=False) as s:
        pipe = s.load(PIPE, scene=str(scene_yaml), size=(64, 64))
        depth = pipe.inspect("gbuf.depth")[:, :, 0]
    covered = depth < depth.max()
    rows = np.nonzero(covered.any(axis=1))[0]
    assert rows.size and rows.max() < 32, rows


def test_frames_yield_each_frame_like_render(gl) -> None:
    with ng.Session(cache=False) as s:
        pipe = s.load(PIPE, scene="builtin:torus", size=(96, 96))
        frames = list(pipe.frames(range(0, 3)))
        assert [f for f, _ in frames] == [0, 1, 2]
        assert np.array_equal(frames[2][1], pipe.render(frame=2))
        assert not np.array_equal(frames[0][1], frames[2][1])  # the orbit moves
        assert [f for f, _ in pipe.frames("0:4:2")] == [0, 2]


def test_session_recomputes_only_what_a_change_reaches(gl) -> None:
    """Compute counts: a second render computes nothing; a changed param recomputes that node and its
    descendants (from the graph), nothing else; an inspect of an unchanged node computes nothing."""
    import networkx as nx

    with ng.Session(cache=False) as s:
        pipe = s.load(PIPE, scene="builtin:torus", size=(128, 128))
        pipe.render()
        passthrough = {n for n, st in pipe.last_run.stats.items() if st.status == "pass-through"}
        assert passthrough == {"sprite"}  # over paper the depth sprite is the sketch itself (see sketchy.md)
        assert set(pipe.last_run.computed()) == set(pipe.nodes) - passthrough
        pipe.render()
        assert pipe.last_run.computed() == []
        changed = pipe.set({"noise.scale": 0.02})
        changed.render()
        expected = ({"noise"} | nx.descendants(changed.pipeline.graph(), "noise")) - passthrough
        assert set(changed.last_run.computed()) == expected
        assert s.compute_counts["gbuf"] == 1 and s.compute_counts["noise"] == 2
        changed.inspect("edges.out")
        assert changed.last_run.computed() == []
        kw = changed.set(edges__width=3)
        kw.render()
        assert "edges" in kw.last_run.computed() and "gbuf" not in kw.last_run.computed()


def test_errors_are_the_cli_errors(gl) -> None:
    with pytest.raises(ng.PipelineError, match="did you mean 'normal_threshold'"):
        ng.load(PIPE, set={"edges.normal_treshold": 0.6})
    pipe = ng.load(PIPE, scene="builtin:torus", size=(32, 32))
    with pytest.raises(ng.PipelineError, match="unknown node 'edgez'"):
        pipe.inspect("edgez.out")
    with pytest.raises(ng.SketchgraphError, match="dtype"):
        pipe.render(dtype="float16")
    with pytest.raises(ng.PipelineError, match="size"):
        ng.load(PIPE, size=(0, 10))


def test_repr_png_is_the_first_output(gl, tmp_path: Path) -> None:
    pipe = ng.load(PIPE, scene="builtin:torus", size=(48, 40))
    png = pipe._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    p = tmp_path / "r.png"
    p.write_bytes(png)
    assert np.array_equal(_read_png(p), pipe.render()[:, :, :3])
    assert "48x40" in repr(pipe)


def _doc_examples() -> list[str]:
    text = (ROOT / "docs" / "api.md").read_text()
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_docs_have_examples() -> None:
    assert len(_doc_examples()) >= 4


@pytest.mark.parametrize("index", range(len(_doc_examples())))
def test_docs_api_examples_run(gl, index: int, monkeypatch: pytest.MonkeyPatch, cache_dir: Path) -> None:
    monkeypatch.chdir(ROOT)
    exec(compile(_doc_examples()[index], f"docs/api.md example {index + 1}", "exec"), {})


def test_load_film_is_the_pipelines_film_setting(gl) -> None:
    """`film=True` (the CLI's --film): pencil with its holds at 0 and its measured setting, the same pixels as that
    setting given by hand; `set=` applies on top."""
    from nodegraph import films

    with ng.Session(cache=False) as session:
        film = session.load("pencil", size=(48, 48), film=True).render(dtype="float32")
        by_hand = {"distortion.hold": 0, "contour.hold": 0, **films.FILM["pencil"]}
        np.testing.assert_array_equal(film, session.load("pencil", size=(48, 48), set=by_hand).render(dtype="float32"))
        three = session.load("pencil", size=(48, 48), film=True, set={"distortion.layers": 3}).render(dtype="float32")
        assert not np.array_equal(three, film)
