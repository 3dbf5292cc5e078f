"""Helpers for the bad-input and fault tests: run the CLI (in process or as a subprocess with a timeout)
and assert the one-line error contract; build small pipelines and broken files in a folder."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from click.testing import CliRunner

ROOT = Path(__file__).resolve().parents[2]

TINY_PIPELINE = """\
pipeline: tiny
size: [24, 24]
scene: {scene}
nodes:
  gbuf: {{type: rasterize}}
outputs:
  image: gbuf.color
"""


@dataclass
class Outcome:
    code: int | None
    stdout: str
    stderr: str
    exception: BaseException | None = None


def cli(*args: str, env: dict[str, str] | None = None) -> Outcome:
    """`sketchgraph ARGS` in process (click's CliRunner on nodegraph.cli.main)."""
    from nodegraph.cli import main

    result = CliRunner().invoke(main, [str(a) for a in args], env=env, catch_exceptions=True)
    exc = result.exception if not isinstance(result.exception, SystemExit) else None
    return Outcome(result.exit_code, result.stdout, result.stderr, exc)


def cli_subprocess(*args: str, timeout: float = 60, env: dict[str, str] | None = None,
                   preexec: object = None) -> Outcome:
    """`sketchgraph ARGS` as a real process; a hang fails the test instead of stalling the suite."""
    full_env = {**os.environ, **(env or {})}
    full_env.pop("SKETCHGRAPH_DEBUG", None)
    proc = subprocess.run([sys.executable, "-m", "nodegraph.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, cwd=ROOT, env=full_env, preexec_fn=preexec)  # noqa: PLW1509
    return Outcome(proc.returncode, proc.stdout, proc.stderr)


def assert_one_line_error(out: Outcome, *needles: str) -> str:
    """Exit status 2, exactly one line on stderr starting 'error:', no traceback; returns the line."""
    assert out.exception is None, f"uncaught {type(out.exception).__name__}: {out.exception}"
    lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert out.code == 2, f"exit status {out.code}, stderr: {out.stderr[-2000:]!r}"
    assert len(lines) == 1, f"expected one line on stderr, found {len(lines)}: {out.stderr[-2000:]!r}"
    line = lines[0]
    assert line.startswith("error: "), line
    assert "Traceback" not in out.stderr + out.stdout
    for needle in needles:
        assert needle in line, f"{needle!r} not in {line!r}"
    return line


def tiny_pipeline(folder: Path, scene: str = "builtin:box", name: str = "p.yaml") -> Path:
    p = folder / name
    p.write_text(TINY_PIPELINE.format(scene=scene))
    return p
