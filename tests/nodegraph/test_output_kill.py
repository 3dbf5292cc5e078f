"""A killed run never truncates an earlier good output: SIGKILL at seeded random moments while `sketchgraph
run` renders and writes over an existing image; afterwards the file is always a whole image, byte for byte
either the earlier one or the new one."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # 27 s: a render killed KILLS times as a process

KILLS = 8


def _run(args: list[str], env: dict[str, str]) -> subprocess.Popen:
    code = "import sys; sys.argv = ['sketchgraph', *sys.argv[1:]]; from nodegraph.cli import main; main()"
    return subprocess.Popen([sys.executable, "-c", code, *args], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs SIGKILL")
def test_sigkill_while_overwriting_an_output_leaves_old_or_new_never_a_fragment(tmp_path: Path) -> None:
    env = {**os.environ, "SKETCHGRAPH_CACHE_DIR": str(tmp_path / "cache")}
    out = tmp_path / "image.png"
    base = ["run", "nienhaus_sketchy", "--scene", "builtin:torus", "--size", "160x160", "-q"]
    old = _run([*base, "-o", str(out), "--no-cache"], env)
    assert old.wait(120) == 0, old.stderr.read().decode()
    new_ref = tmp_path / "new.png"
    changed = ["--set", "noise.scale=0.02"]
    p = _run([*base, *changed, "-o", str(new_ref), "--no-cache"], env)
    t0 = time.perf_counter()
    assert p.wait(120) == 0, p.stderr.read().decode()
    full = time.perf_counter() - t0
    old_bytes, new_bytes = out.read_bytes(), new_ref.read_bytes()
    assert old_bytes != new_bytes

    rng = random.Random(1201)
    outcomes = {"old": 0, "new": 0}
    for _ in range(KILLS):
        out.write_bytes(old_bytes)
        p = _run([*base, *changed, "-o", str(out), "--no-cache"], env)
        time.sleep(rng.uniform(0.3, 1.2) * full)
        p.send_signal(signal.SIGKILL)
        p.wait(60)
        got = out.read_bytes()
        assert got in (old_bytes, new_bytes), f"a killed run left {len(got)} bytes that are neither image"
        outcomes["old" if got == old_bytes else "new"] += 1
    # temporary files of killed writers are hidden beside the output, never the output itself
    assert all(f.name.startswith(".image.png.tmp-") for f in tmp_path.glob(".*tmp*"))
    print(f"kill outcomes over {KILLS} kills (cold run {full:.2f} s): {outcomes}")


LONG_SCENE = """\
objects:
  - primitive: {type: box}
    animate:
      translate:
        - {time: 0, value: [0, 0, 0]}
        - {time: 20, value: [1, 0, 0]}
camera: {eye: [0, 1, 6], target: [0, 0, 0]}
"""


def _wait_for(p: subprocess.Popen, found, bound: float = 120.0) -> bool:
    """Poll until `found()` or the process ends (`bound` seconds at most: a hang bound, not a timing check)."""
    end = time.monotonic() + bound
    while time.monotonic() < end:
        if found():
            return True
        if p.poll() is not None:
            return bool(found())
        time.sleep(0.01)
    return False


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs SIGKILL")
def test_a_killed_film_leaves_a_hidden_partial_file_the_next_run_removes(tmp_path: Path) -> None:
    from nodegraph import fsio

    env = {**os.environ, "SKETCHGRAPH_CACHE_DIR": str(tmp_path / "cache")}
    scene = tmp_path / "long.yaml"
    scene.write_text(LONG_SCENE)
    out = tmp_path / "film.mp4"
    base = ["run", "nienhaus_sketchy", "--scene", str(scene), "--size", "64x64", "-q", "--no-cache", "-o", str(out)]
    p = _run(base, env)  # the whole animation: 481 frames

    def partial() -> list[Path]:
        return [f for f in tmp_path.glob(".film.mp4.partial-*") if f.stat().st_size > 0]

    try:
        assert _wait_for(p, partial), "the film's partial file never appeared"
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait(60)
    left = partial()
    assert left and not out.exists()  # the killed run could not remove it
    assert fsio.temp_target(left[0].name) == ("film.mp4", p.pid)
    again = _run([*base, "--frames", "0:3"], env)
    assert again.wait(120) == 0, again.stderr.read().decode()
    assert out.exists() and list(tmp_path.glob(".*partial*")) == []


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs SIGKILL")
def test_resume_after_a_killed_sequence_reports_exactly_and_leaves_no_temporary_files(tmp_path: Path) -> None:
    """A sequence killed after a few frames: `--resume` removes the killed run's temporary files (one is planted
    under the killed pid, as a kill during a frame's write leaves it), skips exactly the frames the manifest
    recorded with intact files, renders the rest, and says so; a second `--resume` writes none."""
    from nodegraph.output.frames_manifest import FramesManifest, file_sha256

    env = {**os.environ, "SKETCHGRAPH_CACHE_DIR": str(tmp_path / "cache")}
    scene = tmp_path / "long.yaml"
    scene.write_text(LONG_SCENE)
    seq = tmp_path / "seq"
    pattern = str(seq / "f_####.png")
    base = ["run", "nienhaus_sketchy", "--scene", str(scene), "--size", "32x32", "--no-cache", "--frames", "0:120",
            "-o", pattern, "--resume"]
    p = _run([*base, "-q"], env)
    try:
        assert _wait_for(p, lambda: len(list(seq.glob("f_*.png"))) >= 3), "no frames were written"
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait(60)
    if p.returncode == 0:
        pytest.skip("the run finished before it could be killed")
    planted = seq / f".f_0100.png.tmp-{p.pid}-7.png"
    planted.write_bytes(b"half a frame")
    manifest = FramesManifest.load(pattern)
    intact = sum(1 for f, rec in manifest.frames.items() if (seq / f"f_{f:04d}.png").is_file()
                 and file_sha256(seq / f"f_{f:04d}.png") == rec["sha256"])
    assert intact >= 1

    def resume() -> tuple[int, int]:
        proc = subprocess.run([sys.executable, "-c", "import sys; sys.argv = ['sketchgraph', *sys.argv[1:]]; "
                               "from nodegraph.cli import main; main()", *base], env=env, capture_output=True,
                              text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        import re

        m = re.search(r"wrote (\d+) frames(?: \((\d+) already written\))?", proc.stdout)
        assert m, proc.stdout
        return int(m.group(1)), int(m.group(2) or 0)

    assert resume() == (120 - intact, intact)
    assert sorted(f.name for f in seq.iterdir() if f.name.startswith(".")) == [".f_####.png.frames.json"]
    assert len(list(seq.glob("f_*.png"))) == 120
    assert resume() == (0, 120)
