"""The README's set-up commands: exactly two, and the test command is the one `.ci/run` runs."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _setup_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    section = text.split("## Set up on a fresh machine", 1)[1].split("\n## ", 1)[0]
    return [b.strip() for b in re.findall(r"^```\n(.*?)^```", section, re.MULTILINE | re.DOTALL)]


def test_readme_has_two_setup_commands_render_and_test():
    render, test = _setup_commands()
    assert "sketchgraph run nienhaus_sketchy" in render
    assert "pytest" in test


def test_ci_runs_the_readme_test_command():
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    commands = [ln for ln in ci if ln.startswith("python3 -m venv .venv")]
    assert commands == [_setup_commands()[1]]
    # an && list that fails before its last command does not stop a `set -e` script: its status must be
    # checked on the next lines, or a failing pytest would let CI pass
    at = ci.index(commands[0])
    assert ci[at - 1] == "set +e" and ci[at + 1] == "status=$?" and 'exit "$status"' in ci[at + 3]


def test_ci_installs_from_the_lock():
    lock = (ROOT / "requirements.lock").read_text()
    test = _setup_commands()[1]
    assert "-r requirements.lock" in test and "--no-deps" in test
    for dist in ("numpy", "moderngl", "pydantic", "pyyaml", "jsonschema", "pytest", "setuptools"):
        assert re.search(rf"^{dist}==\S+ \\$", lock, re.MULTILINE | re.IGNORECASE), f"{dist} is not pinned"
