"""Outputs are written atomically (a failed write leaves the previous file, byte for byte); sizes, frame
ranges and cache limits are bounded; DOT output escapes every name."""

from __future__ import annotations

import os
import re
import resource
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from nodegraph import fsio
from nodegraph.errors import SketchgraphError
from nodegraph.output import imageio
from nodegraph.output.write import MAX_FRAMES, parse_frames
from tests.nodegraph.faultkit import ROOT, assert_one_line_error, cli, cli_subprocess, tiny_pipeline


def _mount(target: Path, options: str) -> bool:
    target.mkdir(parents=True, exist_ok=True)
    try:
        proc = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(target)], capture_output=True,
                              timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return proc.returncode == 0


def _umount(target: Path) -> None:
    subprocess.run(["umount", "-l", str(target)], capture_output=True, timeout=10)


@pytest.fixture
def small_fs(tmp_path: Path) -> Iterator[Path]:
    """A 1 MiB tmpfs (root only); skips where mounting is not allowed (the RLIMIT_FSIZE test covers those)."""
    target = tmp_path / "small"
    if not _mount(target, "size=1m"):
        pytest.skip("cannot mount a tmpfs here (not root, or no mount namespace)")
    try:
        yield target
    finally:
        _umount(target)


def _fill(folder: Path) -> None:
    """Use up every free byte of the filesystem holding `folder`."""
    fd = os.open(folder / "filler", os.O_WRONLY | os.O_CREAT, 0o644)
    try:
        for chunk in (65536, 1):
            try:
                while True:
                    os.write(fd, b"\0" * chunk)
            except OSError:
                pass
    finally:
        os.close(fd)


def _noise(n: int) -> np.ndarray:
    return np.random.default_rng(1).random((n, n, 3)).astype(np.float32)


def test_atomic_write_bytes_and_text(tmp_path: Path) -> None:
    p = tmp_path / "sub" / "a.json"
    fsio.atomic_write_text(p, '{"a": 1}')
    assert p.read_text() == '{"a": 1}'
    fsio.atomic_write_bytes(p, b"")
    assert p.read_bytes() == b""
    assert sorted(x.name for x in p.parent.iterdir()) == ["a.json"]


def test_atomic_writes_give_new_files_the_umask_mode_and_keep_a_rewritten_files_mode(tmp_path: Path) -> None:
    umask = os.umask(0o027)
    try:
        new = fsio.atomic_write_bytes(tmp_path / "new.bin", b"abc")
        with fsio.atomic_output(tmp_path / "new.txt") as tmp:
            tmp.write_text("x")
        kept = tmp_path / "kept.bin"
        kept.write_bytes(b"old")
        kept.chmod(0o604)
        fsio.atomic_write_bytes(kept, b"new")
        with fsio.atomic_output(kept) as tmp:
            tmp.write_text("newer")
    finally:
        os.umask(umask)
    assert new.stat().st_mode & 0o777 == 0o640 and (tmp_path / "new.txt").stat().st_mode & 0o777 == 0o640
    assert kept.stat().st_mode & 0o777 == 0o604 and kept.read_text() == "newer"
    assert sorted(x.name for x in tmp_path.iterdir()) == ["kept.bin", "new.bin", "new.txt"]


def test_atomic_write_skips_a_temporary_name_left_by_an_earlier_process(tmp_path: Path) -> None:
    # the next name this process would take already exists (a crashed process that had this pid): it is left
    # alone, and the write takes another name
    import itertools

    number = next(fsio._temp_numbers)
    fsio._temp_numbers = itertools.count(number)
    stale = tmp_path / f".a.bin.tmp-{os.getpid()}-{number}.bin"
    stale.write_bytes(b"stale")
    fsio.atomic_write_bytes(tmp_path / "a.bin", b"fresh")
    assert (tmp_path / "a.bin").read_bytes() == b"fresh" and stale.read_bytes() == b"stale"
    assert sorted(x.name for x in tmp_path.iterdir()) == sorted(["a.bin", stale.name])


@pytest.mark.parametrize("syncfs", [True, False])
def test_unsynced_writes_are_synced_together_with_their_folders(tmp_path: Path, monkeypatch, syncfs) -> None:
    # a frame sequence renames each frame into place unsynced and syncs them all at its end: with syncfs, each file
    # system once; without, every file once, then each folder once; a failure is one line naming what failed
    import os

    synced: list[str] = []
    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        synced.append(os.readlink(f"/proc/self/fd/{fd}"))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    real_syncfs = fsio._syncfs()
    if syncfs and real_syncfs is None:
        pytest.skip("no syncfs in this C library")
    calls: list[str] = []

    def counted(fd: int) -> int:
        calls.append(os.readlink(f"/proc/self/fd/{fd}"))
        return real_syncfs(fd)

    monkeypatch.setattr(fsio, "_syncfs", lambda: counted if syncfs else None)
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    paths = [fsio.atomic_write_bytes(tmp_path / d / f"f_{i}.png", b"x" * i, sync=False) for d in "ab" for i in range(3)]
    assert synced == [] and [p.read_bytes() for p in paths] == [b"", b"x", b"xx"] * 2
    assert not [p for p in tmp_path.rglob("*") if ".tmp" in p.name]
    fsio.sync_written(paths)
    if syncfs:
        assert synced == [] and calls == [str(tmp_path / "a")]  # both folders lie on one file system
        with pytest.raises(fsio.OutputError, match=r"gone: cannot sync: No such file"):
            fsio.sync_written([tmp_path / "gone" / "f.png"])
    else:
        assert sorted(synced) == sorted([str(p) for p in paths] + [str(tmp_path / "a"), str(tmp_path / "b")])
        with pytest.raises(fsio.OutputError, match=r"gone\.png: cannot sync: No such file"):
            fsio.sync_written([tmp_path / "gone.png"])
    synced.clear()
    fsio.atomic_write_bytes(tmp_path / "c.bin", b"abc")  # the default syncs the file itself
    assert len(synced) == 1 and synced[0].startswith(str(tmp_path / ".c.bin")) and ".tmp" in synced[0]


def test_atomic_output_failure_keeps_previous_and_cleans_up(tmp_path: Path) -> None:
    p = tmp_path / "a.txt"
    p.write_text("good")
    with pytest.raises(RuntimeError), fsio.atomic_output(p) as tmp:
        assert tmp.parent == p.parent and tmp.name.startswith(".a.txt.tmp-") and tmp.suffix == ".txt"
        tmp.write_text("half")
        raise RuntimeError("writer crashed")
    assert p.read_text() == "good" and [x.name for x in tmp_path.iterdir()] == ["a.txt"]
    with pytest.raises(fsio.OutputError, match="empty file"), fsio.atomic_output(p):
        pass  # the writer wrote nothing
    assert p.read_text() == "good"


def test_full_filesystem_keeps_previous_image(small_fs: Path) -> None:
    p = small_fs / "out.png"
    imageio.write(p, _noise(16), half=False)
    before = p.read_bytes()
    _fill(small_fs)
    with pytest.raises(fsio.OutputError) as info:
        imageio.write(p, _noise(300), half=False)
    assert str(info.value) == f"{p}: cannot write: No space left on device"
    assert p.read_bytes() == before
    assert sorted(x.name for x in small_fs.iterdir()) == ["filler", "out.png"]


def test_full_filesystem_through_the_cli(small_fs: Path, tmp_path: Path) -> None:
    pipe = tiny_pipeline(tmp_path)
    out_png = small_fs / "out.png"
    ok = cli("run", pipe, "-o", out_png, "--no-cache")
    assert ok.code == 0 and out_png.stat().st_size > 0
    before = out_png.read_bytes()
    _fill(small_fs)
    for target in (out_png, small_fs / "out.exr", small_fs / "new" / "x.png"):
        out = cli("run", pipe, "-o", target, "--no-cache", "--size", "200x200")
        assert_one_line_error(out, "No space left on device")
    assert out_png.read_bytes() == before
    files = sorted(str(x.relative_to(small_fs)) for x in small_fs.rglob("*") if not x.is_dir())
    assert files == ["filler", "out.png"]  # no temporary file left (the empty folder 'new' may stay)


def _file_size_limit(limit: int):
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # the write then fails with EFBIG instead of killing us
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


@pytest.mark.slow  # 2.5 s: CLI processes
def test_file_size_limit_keeps_previous_image(tmp_path: Path) -> None:
    pipe = tiny_pipeline(tmp_path)
    out_png = tmp_path / "out.png"
    ok = cli_subprocess("run", pipe, "-o", out_png, "--no-cache", timeout=120)
    assert ok.code == 0, ok.stderr
    before = out_png.read_bytes()
    limit = _file_size_limit(len(before) + 64)
    code = ("import numpy as np, sys; from nodegraph.output import imageio\n"
            "imageio.write(sys.argv[1], np.random.default_rng(0).random((256, 256, 3)).astype(np.float32))\n")
    proc = subprocess.run([sys.executable, "-c", code, str(out_png)], capture_output=True, text=True, cwd=ROOT,
                          timeout=120, preexec_fn=limit)  # noqa: PLW1509
    assert proc.returncode != 0 and "File too large" in proc.stderr
    out = cli_subprocess("run", pipe, "-o", out_png, "--no-cache", "--size", "256x256", timeout=120,
                         preexec=limit)
    assert_one_line_error(out, f"{out_png}: cannot write: File too large")
    assert out_png.read_bytes() == before
    assert sorted(x.name for x in tmp_path.iterdir()) == ["out.png", "p.yaml"]


def test_svg_write_is_atomic(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from nodegraph.output import strokes
    from nodegraph.output.write import write_value
    from nodegraph.values import Strokes

    p = tmp_path / "s.svg"
    p.write_text("previous")
    monkeypatch.setattr(strokes, "to_svg", lambda value: "x" * 10)
    value = Strokes([np.array([[1.0, 1.0], [4.0, 5.0]])], (8, 8))  # particle strokes: the plain writer
    real_replace = os.replace

    def failing_replace(src: str, dst: str) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(SketchgraphError, match="s.svg: cannot write: No space left on device"):
        write_value(value, p)
    monkeypatch.setattr(os, "replace", real_replace)
    assert p.read_text() == "previous" and [x.name for x in tmp_path.iterdir()] == ["s.svg"]


def test_output_in_new_folder_on_read_only_filesystem(tmp_path: Path) -> None:
    ro = tmp_path / "ro"
    if not _mount(ro, "ro,size=64k"):
        pytest.skip("cannot mount a read-only tmpfs here")
    try:
        out = cli("run", tiny_pipeline(tmp_path), "-o", ro / "new" / "deeper" / "x.png", "--no-cache")
        assert_one_line_error(out, "x.png: cannot write in", "Read-only file system")  # found before rendering
    finally:
        _umount(ro)


def test_output_path_that_is_a_folder(tmp_path: Path) -> None:
    (tmp_path / "o.png").mkdir()
    out = cli("run", tiny_pipeline(tmp_path), "-o", tmp_path / "o.png", "--no-cache")
    assert_one_line_error(out, "o.png: cannot write: it is a folder")  # found before rendering


# -- sizes, frames, cache limit ---------------------------------------------------------------------------


@pytest.mark.parametrize("size,needle", [
    ("100000x100000", "between 1 and 16384, found 100000x100000"),
    ("16385x16", "found 16385x16"),
    ("0x10", "found 0x10"),
    ("9" * 5000 + "x3", "expected WIDTHxHEIGHT"),
    ("12", "expected WIDTHxHEIGHT"),
])
def test_size_bounds(tmp_path: Path, size: str, needle: str) -> None:
    line = assert_one_line_error(cli("run", tiny_pipeline(tmp_path), "-o", tmp_path / "o.png", "--size", size),
                                 needle)
    assert len(line) < 200


def test_size_checked_against_the_contexts_max_texture_size(tmp_path: Path, gl,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    from nodegraph.gpu.gl import GL

    monkeypatch.setattr(GL, "max_texture_size", property(lambda self: 32))
    out = cli("run", tiny_pipeline(tmp_path), "-o", tmp_path / "o.png", "--no-cache", "--size", "40x20")
    assert_one_line_error(out, "size 40x20: expected width and height at most 32", "GL_MAX_TEXTURE_SIZE")
    assert not (tmp_path / "o.png").exists()


def test_max_texture_size_is_reported(gl) -> None:
    assert gl.max_texture_size >= 1024


@pytest.mark.parametrize("frames,needle", [
    ("0:1000000000000", "frame numbers between"),
    (f"0:{MAX_FRAMES + 1}", f"expected at most {MAX_FRAMES} frames, found {MAX_FRAMES + 1}"),
    ("9" * 5000, "expected N or START:END"),
    ("3:1", "empty range"),
    ("0:10:0", "empty range"),
])
def test_frame_range_bounds(tmp_path: Path, frames: str, needle: str) -> None:
    out = cli("run", tiny_pipeline(tmp_path), "-o", tmp_path / "o_####.png", "--frames", frames)
    assert len(assert_one_line_error(out, needle)) < 200


def test_largest_frame_range_is_accepted() -> None:
    assert len(parse_frames(f"0:{MAX_FRAMES}")) == MAX_FRAMES
    assert parse_frames("-5:5:4") == [-5, -1, 3]


@pytest.mark.parametrize("value", ["lots", "nan", "1e999G", "-5M", "\x01\x02" * 100])
def test_bad_cache_limit_env(tmp_path: Path, value: str) -> None:
    env = {"SKETCHGRAPH_CACHE_LIMIT": value, "SKETCHGRAPH_CACHE_DIR": str(tmp_path / "c")}
    for args in (["run", tiny_pipeline(tmp_path), "-o", tmp_path / "o.png"], ["cache", "info"]):
        line = assert_one_line_error(cli(*args, env=env), "SKETCHGRAPH_CACHE_LIMIT: expected a size")
        assert len(line) < 200


@pytest.mark.parametrize("value", ["nan", "inf", "-1", "x"])
def test_bad_max_size(tmp_path: Path, value: str) -> None:
    assert_one_line_error(cli("cache", "prune", "--cache-dir", tmp_path, "--max-size", value), "--max-size")


# -- DOT ----------------------------------------------------------------------------------------------------


def _dot_strings_balanced(text: str) -> list[str]:
    """Quoted strings of DOT text by Graphviz's lexer rules (backslash-quote and backslash-backslash are
    escapes); fails when a string never ends. Returns the raw contents."""
    out, i = [], 0
    while i < len(text):
        if text[i] == '"':
            j, buf = i + 1, []
            while True:
                assert j < len(text), "unterminated string"
                if text[j] == "\\" and j + 1 < len(text) and text[j + 1] in '"\\':
                    buf.append(text[j:j + 2])
                    j += 2
                elif text[j] == '"':
                    break
                else:
                    assert text[j] != "\n", "raw line break inside a string"
                    buf.append(text[j])
                    j += 1
            out.append("".join(buf))
            i = j + 1
        else:
            i += 1
    return out


@pytest.mark.parametrize("name", ["ends in backslash \\", 'has "quotes"', "two\nlines", "a{b}|c<d>", "\\\"x\\"])
def test_dot_escapes_names(tmp_path: Path, name: str) -> None:
    import json

    p = tmp_path / "p.yaml"
    p.write_text(f"pipeline: {json.dumps(name)}\nscene: builtin:box\nnodes:\n  g: {{type: rasterize}}\n"
                 f"outputs:\n  {json.dumps(name)}: g.color\n")
    out = cli("graph", p)
    assert out.code == 0, out.stderr
    text = out.stdout
    strings = _dot_strings_balanced(text)
    first = strings[0]
    assert first.replace("\\\\", "\x00").replace('\\"', '"').replace("\\n", "\n").replace("\x00", "\\") == name
    assert text.count("{") - sum(s.count("{") for s in strings) == text.count("}") - sum(s.count("}") for s in strings)
    for s in strings:  # record labels: every structure character in a name is escaped
        if s.startswith("{"):
            assert not re.search(r"(?<!\\)[<>](?![io]_)", s.replace("<i_", "").replace("<o_", "").replace("> ", " "))


def test_dot_output_unchanged_for_plain_pipelines() -> None:
    out = cli("graph", ROOT / "pipelines" / "pencil.yaml")
    assert out.code == 0
    assert '"gbuf" [label="{{<i_scene> scene}|gbuf\\n(rasterize)|{<o_color> color|' in out.stdout
    assert '"out:image" [shape=oval, label="image"];' in out.stdout
