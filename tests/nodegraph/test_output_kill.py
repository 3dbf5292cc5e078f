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
