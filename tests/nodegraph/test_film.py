"""Films and frame sequences from the command line, decoded again with PyAV."""

from __future__ import annotations

import json

import av
import numpy as np
import pytest
from click.testing import CliRunner

from nodegraph.cli import main
from nodegraph.output import film
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


def _moving_frames(gl, w: int, h: int, n: int):
    """Smooth test frames (gradients and a moving soft disc) as RGBA16F textures, row 0 at the bottom."""
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    out = []
    for i in range(n):
        cx, cy = w * (0.3 + 0.1 * i), h * 0.5
        disc = np.clip(1.0 - np.hypot(xx - cx, yy - cy) / (0.3 * min(w, h)), 0.0, 1.0)
        a = np.stack([xx / w, yy / h, disc, np.ones_like(xx)], axis=2)
        out.append(gl.upload(a, "RGBA16F"))
    return out


@pytest.mark.parametrize("ext,min_psnr", [(".mp4", 38.0), (".webm", 36.0)])
@pytest.mark.parametrize("size", [(96, 64), (97, 63)])
def test_film_from_gpu_planes_decodes_to_the_frames(gl, tmp_path, ext, min_psnr, size):
    """Frames converted on the GPU (`GL.read_yuv420`) and encoded: the decoded film is the rendered frames'
    8-bit RGB (`read_uint8`) within a PSNR over all frames (mp4 CRF 18 >= 38 dB, webm CRF 32 >= 36 dB; the
    4:2:0 round trip alone costs some), padded to even sizes by repeating the last column/row, and tagged
    BT.601 limited range."""
    w, h = size
    texs = _moving_frames(gl, w, h, 5)
    try:
        want = [gl.read_uint8(t)[:, :, :3] for t in texs]
        writer = film.FilmWriter(tmp_path / f"f{ext}", 12, (w, h))
        for t in texs:
            writer.write(gl.read_yuv420(t))
        path = writer.close()
    finally:
        for t in texs:
            gl.release(t)
    with av.open(str(path)) as c:
        decoded = [f for f in c.decode(video=0)]
        assert (decoded[0].colorspace, decoded[0].color_range) == (6, 1)  # SMPTE170M (BT.601), MPEG ("tv")
        rgb = [f.to_ndarray(format="rgb24") for f in decoded]
    assert len(rgb) == 5 and rgb[0].shape == (h + h % 2, w + w % 2, 3)
    got = np.stack([f[:h, :w] for f in rgb]).astype(np.float64)
    mse = np.mean((got - np.stack(want).astype(np.float64)) ** 2)
    psnr = 10 * np.log10(255.0**2 / mse)
    assert psnr >= min_psnr, psnr
    if w % 2:  # the repeated column decodes close to the last one
        assert np.abs(rgb[0][:h, w].astype(int) - rgb[0][:h, w - 1].astype(int)).mean() < 3.0


def _animated(tmp_path, size=(48, 40)):
    from nodegraph import pipeline as pl

    box = gf.animated_box(tmp_path / "box.glb")
    pipe = pl.load("nienhaus_sketchy", size=size, scene=str(box))
    return pipe, pipe.outputs[next(iter(pipe.outputs))]


def test_sequence_read_back_during_the_next_run_has_the_bytes_of_frames_written_one_by_one(gl, tmp_path,
                                                                                        monkeypatch):
    from nodegraph.executor import Executor
    from nodegraph.output.write import write_frame

    pipe, ref = _animated(tmp_path)
    frames = [0, 1, 2, 3, 4]
    runs: list[bool] = []
    real_run = Executor.run

    def run(self, frame=0, before_wait=None):
        runs.append(before_wait is not None)
        return real_run(self, frame, before_wait)

    ex = Executor(pipe, None, mode="loop", requested=[ref], gl=gl)
    monkeypatch.setattr(Executor, "run", run)
    done = film.render_frames(ex, ref, frames, str(tmp_path / "seq" / "f_####.png"))
    monkeypatch.undo()
    assert done["frames"] == 5 and runs == [True] * 5  # every frame handed over by the next run (or the end)
    for f in frames:
        one = Executor(pipe, None, requested=[ref], gl=gl).run(f).values[ref]
        write_frame(one, tmp_path / "one" / f"f_{f:04d}.png", gl)
        assert (tmp_path / "seq" / f"f_{f:04d}.png").read_bytes() == (tmp_path / "one" / f"f_{f:04d}.png").read_bytes()
    assert len({(tmp_path / "seq" / f"f_{f:04d}.png").read_bytes() for f in frames}) == 5  # the box moves


def test_film_frames_read_back_a_run_later_are_the_planes_of_frames_converted_one_by_one(gl, tmp_path,
                                                                                        monkeypatch):
    # render_frames converts each frame during the next run and reads it during the run after (GL.pack_yuv420,
    # two target sets alternating); every frame, in order, has the planes of the frame converted alone
    from nodegraph.executor import Executor

    pipe, ref = _animated(tmp_path, size=(64, 40))
    got = []
    real = film.FilmWriter.write

    def write(self, planes):
        got.append(planes)
        real(self, planes)

    monkeypatch.setattr(film.FilmWriter, "write", write)
    ex = Executor(pipe, None, mode="loop", requested=[ref], gl=gl)
    film.render_frames(ex, ref, range(5), str(tmp_path / "f.mp4"))
    monkeypatch.undo()
    assert len(got) == 5
    for f, planes in enumerate(got):
        want = gl.read_yuv420(Executor(pipe, None, requested=[ref], gl=gl).run(f).values[ref])
        for plane in ("y_even", "y_odd", "u", "v"):
            np.testing.assert_array_equal(getattr(planes, plane), getattr(want, plane), err_msg=f"{f} {plane}")
    assert len({got[f].y_even.tobytes() for f in range(5)}) == 5  # the box moves


@pytest.mark.parametrize("failing", ["gbuf", "sketch"])  # before the hand-over point of the run, and after it
def test_a_failing_frame_still_writes_the_frame_before_it(gl, tmp_path, failing):
    from nodegraph.errors import NodeError
    from nodegraph.executor import Executor

    pipe, ref = _animated(tmp_path)
    node = pipe.nodes[failing]
    real = node.compute

    def compute(ctx, inputs, needed):
        if ctx.frame == 3:
            raise NodeError("broken on purpose", failing, node.type_name)
        return real(ctx, inputs, needed)

    node.compute = compute
    ex = Executor(pipe, None, mode="loop", requested=[ref], gl=gl)
    with pytest.raises(NodeError, match="broken on purpose"):
        film.render_frames(ex, ref, range(6), str(tmp_path / "f_####.png"))
    assert sorted(p.name for p in tmp_path.glob("f_*.png")) == ["f_0000.png", "f_0001.png", "f_0002.png"]


def test_sequence_frames_are_synced_together_once_all_are_written(gl, tmp_path, monkeypatch):
    # PNG frames are renamed into place unsynced (no fsync per frame on the writer threads) and synced together
    # when the sequence closes, after the last one is written
    import os

    from nodegraph import fsio
    from nodegraph.executor import Executor

    pipe, ref = _animated(tmp_path)
    fsyncs: list[int] = []
    real_fsync = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: (fsyncs.append(fd), real_fsync(fd))[1])
    calls: list[list[str]] = []
    real_sync = fsio.sync_written

    def sync_written(paths):
        paths = list(paths)
        assert sorted(p.name for p in tmp_path.glob("f_*.png")) == [f"f_{f:04d}.png" for f in range(4)]
        assert fsyncs == []  # nothing synced while the frames were written
        calls.append(sorted(p.name for p in paths))
        real_sync(paths)

    monkeypatch.setattr(fsio, "sync_written", sync_written)
    ex = Executor(pipe, None, mode="loop", requested=[ref], gl=gl)
    film.render_frames(ex, ref, range(4), str(tmp_path / "f_####.png"))
    assert calls == [[f"f_{f:04d}.png" for f in range(4)]]


def test_a_failed_sequence_reports_its_own_error_not_a_failed_sync(tmp_path, monkeypatch):
    # SequenceWriter.close syncs the frames written so far even after a writer failed, without hiding that failure;
    # with no failure before it, a sync that fails is the error
    from nodegraph import fsio
    from nodegraph.errors import SketchgraphError

    def refuse(paths):
        raise fsio.OutputError("out: cannot sync: Input/output error")

    monkeypatch.setattr(fsio, "sync_written", refuse)
    seq = film.SequenceWriter(str(tmp_path / "f_####.png"), resume=False)
    seq._worker.error = RuntimeError("disk on fire")
    with pytest.raises(SketchgraphError, match="writing frames failed: disk on fire"):
        seq.close()
    seq = film.SequenceWriter(str(tmp_path / "f_####.png"), resume=False)
    with pytest.raises(fsio.OutputError, match="cannot sync"):
        seq.close()


@pytest.mark.parametrize("name", ["film.mov", "film.mkv", "f_####.bmp", "noext"])
def test_an_output_no_writer_takes_is_refused_before_anything_renders(name: str, tmp_path) -> None:
    res = CliRunner().invoke(main, ["run", "nienhaus_sketchy", "--size", "16x16", "--frames", "0:2",
                                    "-o", str(tmp_path / name)])
    assert res.exit_code != 0 and "cannot write" in res.output and "use one of .png" in res.output
    assert len(res.output.strip().splitlines()) == 1 and not list(tmp_path.iterdir())
