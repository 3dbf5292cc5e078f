"""Every ```python block of README.md and docs/*.md runs, as a user would paste it, on a checkout without
../shared: from an empty folder that holds the repository's `pipelines/` and `examples/` (snippets name them
by relative path) and nothing else, with a cache of its own. docs/api.md's examples run in
tests/nodegraph/test_api.py, against the command line's files."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SKIP = {"api.md"}  # tests/nodegraph/test_api.py runs these


def _snippets() -> list[tuple[str, int, str]]:
    found = []
    for page in PAGES:
        if page.name in SKIP:
            continue
        text = page.read_text()
        for m in re.finditer(r"^```python\n(.*?)^```", text, flags=re.S | re.M):
            line = text.count("\n", 0, m.start()) + 2
            found.append((str(page.relative_to(ROOT)), line, m.group(1)))
    return found


SNIPPETS = _snippets()


def test_the_pages_hold_snippets():
    assert any(page == "README.md" for page, _, _ in SNIPPETS), "README's Python example is not a ```python block"


@pytest.mark.parametrize("page,line,code", SNIPPETS, ids=[f"{p}:{n}" for p, n, _ in SNIPPETS])
def test_snippet_runs(gl, page: str, line: int, code: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                      cache_dir: Path) -> None:
    for name in ("pipelines", "examples"):
        (tmp_path / name).symlink_to(ROOT / name)
    monkeypatch.chdir(tmp_path)
    exec(compile(code, f"{page}:{line}", "exec"), {"__name__": "__snippet__"})
