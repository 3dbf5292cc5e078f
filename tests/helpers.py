"""Test helpers shared by test modules: paths, the shared meshes, running one node, the seed 004 kernels."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED_MESHES = ROOT.parent / "shared" / "meshes"
GOLDEN = Path(__file__).parent / "golden"
FAILURES = Path(__file__).parent / "_failures"


def shared_mesh(name: str) -> Path:
    """A mesh from ../shared/meshes, or a skip saying where it was looked for."""
    p = SHARED_MESHES / name
    if not p.exists():
        pytest.skip(f"shared test mesh {name} not found at {p} (the shared/ folder sits beside the repository)")
    return p


def run_node(gl, node, inputs: dict, size: tuple[int, int], frame: int = 0, scene: object = None, seed: int = 0,
             needed: frozenset[str] | None = None) -> dict:
    """Compute one node outside a pipeline (declared output formats)."""
    from nodegraph.node import RunContext

    ctx = RunContext(node, gl=gl, size=size, frame=frame, pipeline_seed=seed, scene=scene)
    return node.compute(ctx, inputs, frozenset(node.outputs) if needed is None else needed)


# The kernels of seed 004 (Curtis' loose and sketchy method) exactly as printed.
SEED_TENT = np.array([[1, 2, 1], [2, 4, 2], [1, 2, 1]], float)
SEED_GX = np.array([[-1, -2, -1], [0, 0, 0], [1, 2, 1]], float)
SEED_GY = np.array([[1, 0, -1], [2, 0, -2], [1, 0, -1]], float)


def seed_weights(k: np.ndarray) -> np.ndarray:
    """The seed's k[x][y] (y down the image) as a weight array over our [row (y up), col (x)]."""
    return np.flipud(k.T)


# A one-rasterize pipeline around extra nodes: `extra` adds node lines, `g_in` connects the rasterizer's inputs.
RASTER = """\
pipeline: t
size: [96, 80]
scene: {scene}
nodes:
{extra}
  g: {{type: rasterize{g_in}}}
outputs:
  image: g.normal_depth
"""


def render_normal_depth(gl, text: str) -> np.ndarray:
    """Run a pipeline given as YAML text (named t.yaml) without a cache; rasterize `g`'s normal_depth."""
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor

    pipe = pl.loads(text, "t.yaml")
    return Executor(pipe, None, gl=gl).run().values[("g", "normal_depth")].read()
