"""The plugin's test fixtures: the engine's headless GL context (skip where none exists), a private cache."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def gl():
    from nodegraph.errors import GLUnavailableError
    from nodegraph.gpu import gl as glmod

    try:
        return glmod.get()
    except GLUnavailableError as exc:
        pytest.skip(f"no OpenGL: {exc}")


@pytest.fixture(autouse=True)
def _cache_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    d = tmp_path / "cache"
    monkeypatch.setenv("SKETCHGRAPH_CACHE_DIR", str(d))
    return d
