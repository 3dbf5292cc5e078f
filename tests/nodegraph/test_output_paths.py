"""Output paths (`-o`) and frame counts: every fault is one line. Faults that can be known before rendering (a
part of the folder is a file, the target is a folder or a device, the folder takes no new files, a bad --fps, an
animation longer than a run renders) are reported before anything renders; the rest (a full disk, the file-size
limit mid-write) after, with no partial output and no hidden file left. `--resume` reports what it wrote and what
it skipped apart, and a later run removes the temporary files killed runs left (ours by name, their process gone).

Faults are injected without relying on permissions (the tests run as root): a path under a regular file, a FIFO,
`os.open` refusing with EACCES / ENOSPC / EFBIG, RLIMIT_FSIZE in a child process, a full tmpfs where one can be
mounted."""

from __future__ import annotations

import errno
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from nodegraph import fsio
from nodegraph.errors import SketchgraphError
from nodegraph.output.write import MAX_FRAMES
from tests.nodegraph.faultkit import assert_one_line_error, cli, cli_subprocess

ANIMATED = """\
objects:
  - primitive: {type: box}
    animate:
      translate:
        - {time: 0, value: [0, 0, 0]}
        - {time: %s, value: [1, 0, 0]}
camera: {eye: [0, 1, 6], target: [0, 0, 0]}
"""


def _scene(folder: Path, end: str = "1") -> Path:
    p = folder / "anim.yaml"
    p.write_text(ANIMATED % end)
    return p


def _run(folder: Path, *args: Any, scene: Path | None = None) -> Any:
    return cli("run", "nienhaus_sketchy", "--no-cache", "-q", "--size", "32x32", "--scene",
               scene or _scene(folder), *args)


def _hidden(folder: Path) -> list[str]:
    """Temporary files of ours anywhere under `folder`."""
    return sorted(p.name for p in folder.rglob(".*") if fsio.temp_target(p.name) or ".partial" in p.name)


@pytest.fixture
def no_render(monkeypatch: pytest.MonkeyPatch) -> None:
    """Any frame rendered fails the test: the fault must be found first."""
    from nodegraph.executor import Executor

    def refuse(self: Any, *args: Any, **kwargs: Any) -> None:
        raise AssertionError("a frame was rendered before the output path was checked")

    monkeypatch.setattr(Executor, "run", refuse)


# -- found before rendering -------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["under_file_png", "under_file_film", "under_file_sequence", "onto_folder_png",
                                  "onto_folder_film", "onto_folder_frame", "onto_fifo"])
def test_output_path_faults_are_one_line_before_rendering(tmp_path: Path, no_render: None, case: str) -> None:
    (tmp_path / "file.png").write_bytes(b"not a folder")
    args, needle = {
        "under_file_png": (["-o", tmp_path / "file.png" / "x.png", "--frames", "0"],
                           "file.png is a file, not a folder"),
        "under_file_film": (["-o", tmp_path / "file.png" / "x.mp4"], "file.png is a file, not a folder"),
        "under_file_sequence": (["-o", tmp_path / "file.png" / "s" / "f_####.png", "--frames", "0:3"],
                                "file.png is a file, not a folder"),
        "onto_folder_png": (["-o", tmp_path / "o.png", "--frames", "0"], "o.png: cannot write: it is a folder"),
        "onto_folder_film": (["-o", tmp_path / "o.mp4"], "o.mp4: cannot write: it is a folder"),
        "onto_folder_frame": (["-o", tmp_path / "s" / "f_####.png", "--frames", "0:4"],
                              "f_0002.png: cannot write: it is a folder"),
        "onto_fifo": (["-o", tmp_path / "p.png", "--frames", "0"], "expected a regular file, found a FIFO"),
    }[case]
    (tmp_path / "o.png").mkdir()
    (tmp_path / "o.mp4").mkdir()
    (tmp_path / "s" / "f_0002.png").mkdir(parents=True)
    os.mkfifo(tmp_path / "p.png")
    scene = _scene(tmp_path)
    before = sorted(p.name for p in tmp_path.rglob("*"))
    assert_one_line_error(_run(tmp_path, *args, scene=scene), needle)
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing written, no folder made


def test_a_folder_that_takes_no_new_files_is_found_before_rendering(tmp_path: Path, no_render: None,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """Root ignores permission bits, so the refusal is injected: os.open in the folder fails with EACCES."""
    locked = tmp_path / "locked"
    locked.mkdir()
    real_open = os.open

    def refusing_open(path: Any, flags: int, *args: Any, **kwargs: Any) -> int:
        if Path(path).parent == locked and flags & os.O_CREAT:
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", refusing_open)
    for out, first in [("x.png", "x_0000.png"), ("x.mp4", "x.mp4"), ("f_####.png", "f_0000.png")]:
        assert_one_line_error(_run(tmp_path, "-o", locked / out, "--frames", "0:2"),
                              f"{locked / first}: cannot write in {locked}: Permission denied")
    assert list(locked.iterdir()) == []


def test_inspect_outputs_are_checked_before_rendering(tmp_path: Path, no_render: None) -> None:
    (tmp_path / "file").write_bytes(b"x")
    base = ["nienhaus_sketchy", "--scene", "builtin:box", "--size", "32x32", "--no-cache"]
    assert_one_line_error(cli("inspect", *base, "--all", "-o", "/dev/null"),
                          "/dev/null: cannot write into it: expected a folder, found a character device")
    assert_one_line_error(cli("inspect", *base, "--all", "-o", tmp_path / "file" / "pages"),
                          "file is a file, not a folder")
    assert_one_line_error(cli("inspect", *base, "--all", "-o", tmp_path / "file"), "expected a folder, found a file")
    assert_one_line_error(cli("inspect", *base, "edges.out", "-o", tmp_path / "file" / "e.exr"),
                          "file is a file, not a folder")


@pytest.mark.parametrize("fps", ["0", "-1", "nan", "inf", "-inf", "1e9", "1e-9"])
def test_bad_fps_is_one_line_before_rendering(tmp_path: Path, no_render: None, fps: str) -> None:
    out = tmp_path / "f.mp4"
    assert_one_line_error(_run(tmp_path, "--fps", fps, "-o", out), "--fps: expected frames per second between")
    assert not out.exists() and _hidden(tmp_path) == []


def test_a_long_animation_is_capped_with_one_line_suggesting_frames(tmp_path: Path, no_render: None) -> None:
    """A key at t = 1e7 s is 2.4e8 frames at 24 fps: the default range (a film, a #### pattern) is refused in one
    line naming --frames before any list of frames is made (it took a MemoryError after 7.4 GB)."""
    scene = _scene(tmp_path, "1e7")
    for out in ["f.mp4", "s/f_####.png"]:
        line = assert_one_line_error(_run(tmp_path, "-o", tmp_path / out, scene=scene), "--frames")
        assert f"more than the {MAX_FRAMES}" in line and "240000001 frames" in line
    for fps in ["1000", "999.5"]:  # a short animation at a high rate: the same cap
        assert_one_line_error(_run(tmp_path, "-o", tmp_path / "f.mp4", "--fps", fps, scene=_scene(tmp_path, "1e4")),
                              "more than the", "--frames")


def test_default_range_cap_in_the_animation_module(tmp_path: Path) -> None:
    from nodegraph.errors import PipelineError
    from nodegraph.scene import scene as sc
    from nodegraph.scene.animation import default_frames

    assert default_frames(sc.load_scene(str(_scene(tmp_path)))) == list(range(25))
    with pytest.raises(SketchgraphError, match="give --frames"):
        default_frames(sc.load_scene(str(_scene(tmp_path, "1e7"))))
    with pytest.raises(SketchgraphError, match="frame numbers beyond"):
        default_frames(sc.load_scene(str(_scene(tmp_path, "2e9"))))
    frame_key = (tmp_path / "anim.yaml").read_text().replace("{time: 2e9,", "{frame: 1e10,")
    (tmp_path / "anim.yaml").write_text(frame_key)
    with pytest.raises(PipelineError, match="anim.yaml:6:.*frame"):  # a key no frame number can reach
        sc.load_scene(str(tmp_path / "anim.yaml"))


# -- found while writing ----------------------------------------------------------------------------------
def _file_size_limit(limit: int) -> Any:
    def apply() -> None:
        import resource
        import signal

        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # the write then fails with EFBIG instead of killing us
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


@pytest.mark.slow  # 1.3 s: a CLI process each
@pytest.mark.parametrize("ext", [".mp4", ".gif"])
def test_film_over_the_file_size_limit_is_one_line_and_leaves_nothing(tmp_path: Path, ext: str) -> None:
    scene = _scene(tmp_path)
    out = tmp_path / f"film{ext}"
    res = cli_subprocess("run", "nienhaus_sketchy", "--no-cache", "-q", "--size", "64x64", "--scene", scene,
                         "-o", out, timeout=180, preexec=_file_size_limit(2000))
    assert_one_line_error(res, f"{out}: cannot write: File too large")
    assert not out.exists() and _hidden(tmp_path) == []


@pytest.mark.parametrize("code,reason", [(errno.ENOSPC, "No space left on device"), (errno.EFBIG, "File too large")])
def test_a_sequence_frame_that_cannot_be_written_is_one_line_after_the_frames_before(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, code: int, reason: str) -> None:
    real_open = os.open

    def failing_open(path: Any, flags: int, *args: Any, **kwargs: Any) -> int:
        if ".f_0002.png.tmp-" in str(path) and flags & os.O_CREAT:
            raise OSError(code, os.strerror(code), str(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", failing_open)
    line = assert_one_line_error(_run(tmp_path, "-o", tmp_path / "s" / "f_####.png", "--frames", "0:5"),
                                 f"f_0002.png: cannot write: {reason}")
    assert line.startswith("error: writing frames failed: ")
    written = sorted(p.name for p in (tmp_path / "s").glob("f_*.png"))
    assert written[:2] == ["f_0000.png", "f_0001.png"] and "f_0002.png" not in written
    assert _hidden(tmp_path) == []


def test_a_film_on_a_full_disk_is_one_line_and_leaves_nothing(tmp_path: Path) -> None:
    from tests.nodegraph.test_render_io import _fill, _mount, _umount

    disk = tmp_path / "small"
    if not _mount(disk, "size=1m"):
        pytest.skip("cannot mount a tmpfs here (not root, or no mount namespace)")
    try:
        _fill(disk)
        out = disk / "film.mp4"
        assert_one_line_error(_run(tmp_path, "-o", out), f"{out}: cannot write: No space left on device")
        assert not out.exists() and _hidden(disk) == []
    finally:
        _umount(disk)


def test_the_api_checks_the_path_before_rendering(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import nodegraph as ng
    from nodegraph import api

    def refuse(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("rendered before the path was checked")

    pipe = ng.load("nienhaus_sketchy", scene="builtin:box", size=(16, 16), session=ng.Session(cache=False))
    monkeypatch.setattr(api.Session, "executor", refuse)
    (tmp_path / "d.png").mkdir()
    (tmp_path / "f").write_bytes(b"x")
    for path, needle in [(tmp_path / "d.png", "it is a folder"), (tmp_path / "f" / "x.png", "is a file, not a folder")]:
        with pytest.raises(fsio.OutputPathError, match=needle) as info:
            pipe.write(path)
        assert isinstance(info.value, ValueError) and "\n" not in str(info.value)


# -- --resume reports, stale temporary files ------------------------------------------------------------------
def _report(res: Any) -> tuple[int, int]:
    assert res.code == 0, res.stderr or res.stdout
    m = re.search(r"wrote (\d+) frames(?: \((\d+) already written\))?", res.stdout)
    assert m, res.stdout
    return int(m.group(1)), int(m.group(2) or 0)


def test_resume_reports_what_it_wrote_and_what_it_skipped(tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    pattern = tmp_path / "s" / "f_####.png"
    args = ["run", "nienhaus_sketchy", "--no-cache", "--size", "32x32", "--scene", scene, "--frames", "0:4",
            "-o", pattern, "--resume"]
    assert _report(cli(*args)) == (4, 0)
    stamps = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "s").glob("f_*.png")}
    assert _report(cli(*args)) == (0, 4)  # it wrote none (it said "wrote 4 frames (4 already written)")
    assert {p.name: p.stat().st_mtime_ns for p in (tmp_path / "s").glob("f_*.png")} == stamps
    (tmp_path / "s" / "f_0001.png").unlink()
    (tmp_path / "s" / "f_0003.png").write_bytes(b"cut short")
    assert _report(cli(*args)) == (2, 2)


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_a_later_run_removes_the_temporary_files_killed_runs_left(tmp_path: Path) -> None:
    """Files named as ours, for these outputs, whose process is gone, are removed by the next run (a sequence's
    frames and manifest, a film's partial file, the name films used before pids were in it); a live process's
    files, this process's own and other outputs' files stay."""
    dead = _dead_pid()
    s = tmp_path / "s"
    s.mkdir()
    stale = [s / f".f_0001.png.tmp-{dead}-0.png", s / f"..f_####.png.frames.json.tmp-{dead}-4.json",
             tmp_path / f".film.mp4.partial-{dead}-0.mp4", tmp_path / ".film.partial.mp4",
             tmp_path / f".one.png.tmp-{dead}-2.png"]
    live = os.getppid()
    kept = [s / f".f_0002.png.tmp-{live}-0.png", s / f".other.png.tmp-{dead}-0.png", s / f"f_0003.png.tmp-{dead}-0.png",
            tmp_path / f".film.mp4.partial-{live}-1.mp4"]
    for p in stale + kept:
        p.write_bytes(b"left by a killed run")
    old = s / f".f_0000.png.tmp-{live}-9.png"  # a live pid, but two days old: the pid was reused
    old.write_bytes(b"old")
    os.utime(old, (old.stat().st_atime - 2 * 86400, old.stat().st_mtime - 2 * 86400))
    stale.append(old)
    scene = _scene(tmp_path)
    assert _report(cli("run", "nienhaus_sketchy", "--no-cache", "--size", "32x32", "--scene", scene, "--frames", "0:3",
                       "-o", s / "f_####.png", "--resume")) == (3, 0)
    assert _run(tmp_path, "-o", tmp_path / "film.mp4", "--frames", "0:2").code == 0
    assert _run(tmp_path, "-o", tmp_path / "one.png", "--frames", "0").code == 0
    assert [p.name for p in stale if p.exists()] == []
    assert [p.name for p in kept if not p.exists()] == []
