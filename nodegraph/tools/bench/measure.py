"""What the measuring tools share (accuracy, stability, the benchmarks): logging, timing, running one node
outside a pipeline, a G-buffer of a scene, and node classes and node-side modules found through the registry.

Nothing here names a node package: node classes come from `registry.default()`, a node's own measurement
modules (`nodes/<name>/accuracy.py`, `stability.py`, `bench.py`, `reference.py`) from `registry.node_module`.
"""

from __future__ import annotations

import math
import statistics
import sys
import time
import warnings
from collections.abc import Callable
from types import ModuleType
from typing import Any

import numpy as np


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def median_ms(fn: Callable[[], Any], repeats: int, finish: Callable[[], None] | None = None) -> float:
    """Median wall time of `fn` in ms over `repeats` runs (`finish`, e.g. gl.finish, waited for each time)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        if finish is not None:
            finish()
        times.append((time.perf_counter() - t0) * 1000.0)
    return statistics.median(times)


def node_class(type_name: str) -> Any:
    """The registered class of node type `type_name`."""
    from ...registry import default

    cls = default().get(type_name)
    if cls is None:
        raise KeyError(f"node type {type_name!r} is not registered")
    return cls


def node_module(type_name: str, sub: str) -> ModuleType:
    """The module `sub` beside node type `type_name` (its package found through the registry)."""
    from ...registry import node_module as _node_module

    return _node_module(type_name, sub)


class NodeRunner:
    """Runs one node's `compute()` outside a pipeline, with declared (or given) output formats."""

    def __init__(self, gl: Any, size: tuple[int, int], scene: Any = None, seed: int = 0,
                 formats: dict | None = None) -> None:
        self.gl, self.size, self.scene, self.seed = gl, size, scene, seed
        self.formats = formats or {}  # (node id, port) -> format

    def run(self, node: Any, inputs: dict[str, Any], needed: frozenset[str] | None = None, frame: int = 0) -> dict:
        from ...node import RunContext

        ctx = RunContext(node, gl=self.gl, size=self.size, frame=frame, pipeline_seed=self.seed, scene=self.scene,
                         formats={p: f for (n, p), f in self.formats.items() if n == node.id})
        return node.compute(ctx, inputs, frozenset(node.outputs) if needed is None else needed)


def gbuffer(gl: Any, scene: Any, size: tuple[int, int], ports: tuple[str, ...] = ("normal_depth",),
            frame: int = 0, **params: Any) -> dict[str, Any]:
    """Rasterize `scene` into the requested G-buffer outputs (textures) at `size`."""
    rasterize = node_class("rasterize")
    node = rasterize("gbuf", rasterize.Params(**params))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return NodeRunner(gl, size, scene).run(node, {}, frozenset(ports), frame)


def release(gl: Any, values: dict[str, Any]) -> None:
    for v in values.values():
        gl.release(v)


def scene_for(spec: str) -> Any:
    from ...scene.scene import load_scene

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(spec)


def particle_depth(meshes_dir: Any, size: int) -> tuple[np.ndarray, Any, np.ndarray]:
    """Window depth (1 = background) of cow.obj (or the built-in torus) at size^2, the scene, and its
    ground-truth line drawing."""
    from ...gpu import gl as glmod
    from .groundtruth import line_drawing

    gl = glmod.get()
    spec = str(meshes_dir / "cow.obj") if (meshes_dir / "cow.obj").exists() else "builtin:torus"
    scene = scene_for(spec)
    g = gbuffer(gl, scene, (size, size), ("depth", "linear_depth"))
    depth = g["depth"].read()[..., 0].astype(np.float64)
    lin = g["linear_depth"].read()[..., 0]
    release(gl, g)
    return depth, spec, line_drawing(scene, (size, size), lin).lines


def jsonable(v: Any) -> Any:
    """`v` with NumPy scalars and arrays as plain Python, non-finite floats as strings."""
    if isinstance(v, dict):
        return {str(k): jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [jsonable(x) for x in v]
    if isinstance(v, (np.floating, float)):
        f = float(v)
        return f if math.isfinite(f) else str(f)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.ndarray):
        return jsonable(v.tolist())
    return v
