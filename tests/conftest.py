"""Shared fixtures: the one test GL context, the shared meshes, an isolated cache folder."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED_MESHES = ROOT.parent / "shared" / "meshes"
GOLDEN = Path(__file__).parent / "golden"
FAILURES = Path(__file__).parent / "_failures"


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--regen-golden", action="store_true", help="Rewrite golden EXRs instead of comparing.")


@pytest.fixture(scope="session")
def gl():
    """The process's headless GL context; tests that need GL skip with the reason when there is none."""
    from nodegraph import gl as glmod
    from nodegraph.errors import GLUnavailableError

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


@pytest.fixture
def cache_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    d = tmp_path / "cache"
    monkeypatch.setenv("SKETCHGRAPH_CACHE_DIR", str(d))
    return d


def shared_mesh(name: str) -> Path:
    """A mesh from ../shared/meshes, or a skip saying where it was looked for."""
    p = SHARED_MESHES / name
    if not p.exists():
        pytest.skip(f"shared test mesh {name} not found at {p} (the shared/ folder sits beside the repository)")
    return p


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1234)


def pytest_configure(config: pytest.Config) -> None:
    os.environ.setdefault("SKETCHGRAPH_CACHE_DIR", str(ROOT / ".sketchgraph-cache" / "tests"))


def run_node(gl, node, inputs: dict, size: tuple[int, int], frame: int = 0, scene: object = None, seed: int = 0,
             needed: frozenset[str] | None = None) -> dict:
    """Compute one node outside a pipeline (declared output formats)."""
    from nodegraph.node import RunContext

    ctx = RunContext(node, gl=gl, size=size, frame=frame, pipeline_seed=seed, scene=scene)
    return node.compute(ctx, inputs, frozenset(node.outputs) if needed is None else needed)
