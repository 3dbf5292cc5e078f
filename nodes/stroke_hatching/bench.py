"""What stroke_hatching's streamlines cost, for `sketchgraph bench strokes`: `recording()` keeps the arguments of
every `hatch` call the node makes while it is on (the real inputs of a frame: field, tone, ids, seeds),
`compare()` runs those calls again with the compiled loop and with the Python loop (the reference) and checks
that they give the same streamlines, and `compile_seconds()` times the compiled loop's first call in fresh
processes: with an empty Numba cache (the compilation) and again with that cache filled (what a later process
pays)."""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

_FIRST_CALL = """
import time
t0 = time.perf_counter()
from nodegraph_nodes.stroke_hatching.bench import first_call
first_call()
print(time.perf_counter() - t0)
"""


def first_call() -> None:
    """A small compiled hatch call: compiles the loop, or loads it from Numba's cache."""
    node = sys.modules[__package__]
    t = np.zeros((8, 8, 3))
    t[..., 0] = 1.0
    node.hatch(t, np.zeros((32, 32)), np.ones((32, 32), np.int64), (32, 32), 3.0, 9.0, 0.9, 0.5, 1.0, 0.0, 4.0,
               engine="jit")


@contextmanager
def recording() -> Iterator[list[tuple[tuple[Any, ...], dict[str, Any]]]]:
    """While on, the node's `hatch` calls are recorded (args, kwargs) into the list it gives."""
    node = sys.modules[__package__]
    calls: list[tuple[tuple[Any, ...], dict[str, Any]]] = []
    real = node.hatch

    def hatch(*args: Any, **kwargs: Any) -> Any:
        calls.append((args, kwargs))
        return real(*args, **kwargs)

    node.hatch = hatch
    try:
        yield calls
    finally:
        node.hatch = real


def compare(calls: list[tuple[tuple[Any, ...], dict[str, Any]]], repeats: int = 3,
            python: bool = True) -> dict[str, Any]:
    """ms of all `calls` (one frame's families): the compiled loop (median of `repeats`, after one untimed run) and
    the Python loop (one run); whether both gave the same streamlines."""
    node = sys.modules[__package__]

    def run(engine: str) -> tuple[float, list[np.ndarray]]:
        t0 = time.perf_counter()
        lines = [q for a, k in calls for q in node.hatch(*a, **{**k, "engine": engine})]
        return (time.perf_counter() - t0) * 1e3, lines

    _, jit_lines = run("jit")
    jit_ms = statistics.median(run("jit")[0] for _ in range(max(repeats, 1)))
    out: dict[str, Any] = {"streamlines": len(jit_lines), "samples": int(sum(len(q) for q in jit_lines)),
                           "jit_ms": round(jit_ms, 1)}
    if python:
        py_ms, py_lines = run("python")
        out["python_ms"] = round(py_ms, 1)
        out["speedup"] = round(py_ms / max(jit_ms, 1e-9), 1)
        out["identical"] = len(py_lines) == len(jit_lines) and all(
            np.array_equal(a, b) for a, b in zip(py_lines, jit_lines, strict=True))
    return out


def compile_seconds() -> dict[str, float]:
    """Seconds of a fresh process's first compiled `hatch` call (imports included): with an empty Numba cache
    (NUMBA_CACHE_DIR a new folder: compilation) and again with the cache it filled."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": tmp}
        for label in ("cold_cache_s", "warm_cache_s"):
            res = subprocess.run([sys.executable, "-c", _FIRST_CALL], env=env, capture_output=True, text=True,
                                 check=True)
            out[label] = round(float(res.stdout.strip().splitlines()[-1]), 2)
    return out
