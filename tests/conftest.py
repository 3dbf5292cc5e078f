"""Shared fixtures: the one test GL context, the shared meshes, an isolated cache folder."""

from __future__ import annotations

import os
from pathlib import Path

# isort: off
import nodegraph  # noqa: F401  (before NumPy: it pins OpenBLAS's kernels, nodegraph/blas.py)
# isort: on
import numpy as np
import pytest

from tests.helpers import FAILURES, GOLDEN, ROOT, SHARED_MESHES, run_node, shared_mesh

__all__ = ["FAILURES", "GOLDEN", "ROOT", "SHARED_MESHES", "run_node", "shared_mesh"]  # re-exported for old imports


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--regen-golden", action="store_true", help="Rewrite golden EXRs instead of comparing.")


@pytest.fixture(scope="session")
def gl():
    """The process's headless GL context; tests that need GL skip with the reason when there is none."""
    from nodegraph.errors import GLUnavailableError
    from nodegraph.gpu import gl as glmod

    try:
        ctx = glmod.get()
    except GLUnavailableError as exc:
        pytest.skip(f"no OpenGL: {exc}")
    return ctx


@pytest.fixture(autouse=True)
def _gl_errors(request: pytest.FixtureRequest):
    """GL errors are checked around each test that used the context."""
    yield
    if "gl" in request.fixturenames:
        ctx = request.getfixturevalue("gl")
        err = ctx.ctx.error
        assert err == "GL_NO_ERROR", f"OpenGL error left by the test: {err}"


@pytest.fixture(autouse=True)
def _mesh_store_reset():
    """A command or API call in a test points the mesh store at its cache (nodegraph/scene/meshstore.py); the next
    test starts without one, so a mesh it loads is parsed as the test expects."""
    yield
    from nodegraph.scene import meshstore

    meshstore.configure(None)


@pytest.fixture
def cache_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    d = tmp_path / "cache"
    monkeypatch.setenv("SKETCHGRAPH_CACHE_DIR", str(d))
    return d


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1234)


def pytest_configure(config: pytest.Config) -> None:
    os.environ.setdefault("SKETCHGRAPH_CACHE_DIR", str(ROOT / ".sketchgraph-cache" / "tests"))
