"""Wedges: sweep one or two node params over listed values and lay the results out as a labelled
contact sheet (columns: the first param's values, rows: the second's).

Every cell is an ordinary run with `--set` overrides; one executor hands its in-memory values to the
next, so nodes upstream of the swept params run once for the whole wedge.
"""

from __future__ import annotations

import itertools
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import yamlio
from ..errors import PipelineError, SketchgraphError
from ..executor import Executor
from ..pipeline import Pipeline
from . import viz


@dataclass(frozen=True)
class Axis:
    param: str  # NODE.PARAM
    values: tuple[Any, ...]

    def override(self, value: Any) -> str:
        return f"{self.param}={json.dumps(value)}"


def parse_axis(text: str) -> Axis:
    """`NODE.PARAM=V1,V2,...` or `NODE.PARAM=[V1, V2, ...]` (values are YAML)."""
    param, eq, values = text.partition("=")
    node, dot, name = param.strip().partition(".")
    if not eq or not dot or not node or not name:
        raise SketchgraphError(f"wedge '{text}': expected NODE.PARAM=V1,V2,... such as edges.normal_threshold=0.2,0.4")
    body = values.strip()
    shown = text if len(text) <= 80 else text[:77] + "..."
    try:
        parsed = yamlio.loads(body if body.startswith("[") else f"[{body}]", f"wedge '{shown}'")
    except PipelineError as exc:
        raise SketchgraphError(f"wedge '{shown}': values are not YAML ({exc.message})") from None
    if not isinstance(parsed, list) or not parsed:
        raise SketchgraphError(f"wedge '{text}': expected a non-empty list of values")
    return Axis(param.strip(), tuple(parsed))


def axes_from(spec: Any) -> list[Axis]:
    """A gallery entry's `wedge:` mapping ({NODE.PARAM: [values]}) or a list of `NODE.PARAM=...` strings."""
    if isinstance(spec, dict):
        axes = []
        for k, v in spec.items():
            if not isinstance(v, list) or not v:
                raise SketchgraphError(f"wedge {k}: expected a non-empty list of values, found {v!r}")
            axes.append(Axis(str(k), tuple(v)))
    elif isinstance(spec, (list, tuple)):
        axes = [parse_axis(s) if isinstance(s, str) else s for s in spec]
    else:
        raise SketchgraphError(f"wedge: expected {{NODE.PARAM: [values]}}, found {spec!r}")
    if not 1 <= len(axes) <= 2:
        raise SketchgraphError(f"wedge: sweep one or two params, found {len(axes)}")
    return axes


def label(value: Any) -> str:
    text = json.dumps(value) if not isinstance(value, str) else value
    return text.replace(" ", "")


@dataclass
class Cell:
    row: int
    col: int
    overrides: list[str]
    label: str
    image: np.ndarray  # display order
    computed: list[str]
    ms: float


def combinations(axes: list[Axis]) -> list[tuple[int, int, list[str], str]]:
    """(row, col, overrides, label) for every cell, row-major."""
    cols = axes[0]
    rows = axes[1] if len(axes) > 1 else None
    out = []
    for (r, rv), (c, cv) in itertools.product(enumerate(rows.values if rows else [None]), enumerate(cols.values)):
        overrides = [cols.override(cv)] + ([rows.override(rv)] if rows else [])
        text = f"{cols.param}={label(cv)}" + (f" {rows.param}={label(rv)}" if rows else "")
        out.append((r, c, overrides, text))
    return out


def run(load: Callable[[list[str]], Pipeline], axes: list[Axis], output: str | None = None, frame: int = 0,
        cache: Any = None, progress: Callable[[Any], Any] = lambda it: it) -> list[Cell]:
    """Render every cell; `load(overrides)` opens the pipeline with the cell's overrides added."""
    from .watch import adopt_memory

    cells: list[Cell] = []
    prev: Executor | None = None
    try:
        for r, c, overrides, text in progress(combinations(axes)):
            t0 = time.perf_counter()
            pipe = load(overrides)
            name = output or next(iter(pipe.outputs))
            if name not in pipe.outputs:
                raise SketchgraphError(f"pipeline has no output '{name}'; outputs: {', '.join(pipe.outputs)}")
            ref = pipe.outputs[name]
            ex = Executor(pipe, cache, requested=[ref])
            adopt_memory(ex, prev, frame)
            if prev is not None:
                prev.close()
            prev = ex
            result = ex.run(frame)
            panel = viz.visualize(result.values[ref], ref[1], pipe.nodes[ref[0]].outputs[ref[1]].doc)
            if panel.image is None:
                raise SketchgraphError(f"output '{name}' ({ref[0]}.{ref[1]}) is not an image; pick one with --output")
            cells.append(Cell(r, c, overrides, text, panel.image, result.computed(),
                              (time.perf_counter() - t0) * 1000))
    finally:
        if prev is not None:
            prev.close()
    return cells


def sheet(cells: list[Cell], axes: list[Axis], title: str = "", cell: int = 256) -> np.ndarray:
    """The labelled sheet: column headers are the first param's values, row headers the second's."""
    return viz.contact_sheet(**sheet_args(cells, axes, title, cell))


def sheet_args(cells: list[Cell], axes: list[Axis], title: str = "", cell: int = 256) -> dict[str, Any]:
    """The `viz.contact_sheet` arguments of `sheet` (the gallery names its sheet record by them)."""
    cols = axes[0]
    rows = axes[1] if len(axes) > 1 else None
    head = f"{title}  " if title else ""
    head += f"columns: {cols.param}" + (f"  rows: {rows.param}" if rows else "")
    return {"cells": [viz.Cell(c.image, []) for c in cells], "cell": cell, "columns": len(cols.values),
            "title": head, "column_labels": [f"{cols.param.split('.')[-1]}={label(v)}" for v in cols.values],
            "row_labels": [f"{rows.param.split('.')[-1]}={label(v)}" for v in rows.values] if rows else None}


# -- on a Dask cluster (`--scheduler`) -------------------------------------------------------------------
def cell_task(spec: Any, cells: list[tuple[list[str], str]], frame: int,
              cache_root: str | None | bool = None) -> dict[str, Any]:
    """Render wedge cells on a worker; each cell's display image goes to its .npy path (beside the sheet,
    atomically); only metadata comes back. A SketchgraphError comes back as a value."""
    from dataclasses import replace

    from .. import distributed as dist
    from ..fsio import atomic_output

    out = []
    try:
        state = dist.worker_state()
        for overrides, path in cells:
            t0 = time.perf_counter()
            cspec = replace(spec, overrides=spec.overrides + tuple(overrides))
            pipe = state.pipeline(cspec, cache_root)
            name = spec.output or next(iter(pipe.outputs))
            if name not in pipe.outputs:
                raise SketchgraphError(f"pipeline has no output '{name}'; outputs: {', '.join(pipe.outputs)}")
            ref = pipe.outputs[name]
            ex = state.executor(pipe, [ref], "single", frame, cache=state.cache_for(cache_root))
            result = ex.run(frame)
            panel = viz.visualize(result.values[ref], ref[1], pipe.nodes[ref[0]].outputs[ref[1]].doc)
            if panel.image is None:
                raise SketchgraphError(f"output '{name}' ({ref[0]}.{ref[1]}) is not an image; pick one with --output")
            with atomic_output(path) as tmp:
                np.save(tmp, np.ascontiguousarray(panel.image))
            out.append({"path": path, "computed": result.computed(), "ms": (time.perf_counter() - t0) * 1000})
        if ex.cache is not None:
            ex.cache.flush()
    except SketchgraphError as exc:
        return {"error": dist.TaskFailure.of(exc)}
    return {"cells": out, "worker": state.address, "renderer": state.renderer}


def run_distributed(client: Any, spec: Any, axes: list[Axis], frame: int = 0, cache_root: Any = None,
                    chunk: int | None = None, progress: Callable[[Any], Any] | None = None) -> list[Cell]:
    """`run` on the cluster behind `client`: one task per `chunk` cells (default 1); nodes whose key is the
    same in every cell are computed once, first, and reach the cells through the shared cache."""
    import shutil
    from dataclasses import replace

    from .. import distributed as dist

    combos = combinations(axes)
    if chunk is not None and chunk < 1:
        raise SketchgraphError(f"--chunk: expected at least 1 cell, found {chunk}")
    pipes = [replace(spec, overrides=spec.overrides + tuple(ov)).open() for _, _, ov, _ in combos]
    name = spec.output or next(iter(pipes[0].outputs))
    if name not in pipes[0].outputs:
        raise SketchgraphError(f"pipeline has no output '{name}'; outputs: {', '.join(pipes[0].outputs)}")
    ref = pipes[0].outputs[name]
    keysets = [Executor(p, None, requested=[ref]).keys(frame) for p in pipes]
    dist.ensure_plugin(client, cache_root)
    renderers: set[str] = set()
    refs = dist.shared_frontier(pipes[0], ref, keysets)
    if refs:
        first = replace(spec, overrides=spec.overrides + tuple(combos[0][2]))
        res = dist.result(client, client.submit(dist.prepare_task, first, refs, frame, cache_root, pure=False,
                                                retries=dist.RETRIES))
        dist._raise_failure(res)
        renderers.add(res["renderer"])
    scratch = dist.scratch_dir(cache_root, "wedge-")
    try:
        items = [(ov, str(scratch / f"cell_r{r}c{c}.npy")) for r, c, ov, _ in combos]
        size = chunk or 1
        futures = [client.submit(cell_task, spec, items[i:i + size], frame, cache_root, pure=False,
                                 retries=dist.RETRIES) for i in range(0, len(items), size)]
        by_path: dict[str, dict[str, Any]] = {}
        finished = dist.completed(client, futures)  # fails with one line when the cluster has no live worker
        done = progress(finished) if progress else finished
        for fut in done:
            try:
                res = fut.result()
            except SketchgraphError:
                raise
            except Exception as exc:  # noqa: BLE001
                raise dist.remote_error(exc) from None
            dist._raise_failure(res)
            renderers.add(res["renderer"])
            for rec in res["cells"]:
                by_path[rec["path"]] = rec
        cells = []
        for (r, c, ov, text), (_, path) in zip(combos, items, strict=True):
            rec = by_path[path]
            cells.append(Cell(r, c, ov, text, np.load(path), rec["computed"], rec["ms"]))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
        dist.prune_shared(cache_root, renderers)
    return cells
