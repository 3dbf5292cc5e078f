"""The library face's plumbing: open a pipeline with the command line's overrides, and the node cache. The
CLI, the tools and the Python API (`nodegraph.api`) all call these; frame ranges, frame file names and
writing values are `nodegraph.output.write`'s."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .pipeline import Pipeline


def open_pipeline(path: str, overrides: tuple[str, ...] = (), size: str | None = None, scene: str | None = None,
                  load_scene: bool = True, out_dir: str | Path | None = None, allow_outside: bool = False,
                  view: str | None = None, up: str | None = None, reference_size: int | None = None,
                  fill: float | None = None) -> Pipeline:
    """Load a pipeline; files its nodes write resolve against `out_dir` (default: the current directory);
    `view`, `up` and `fill` frame a mesh-file scene (`--view`, `--up`, `--fill`); `reference_size` replaces the
    pipeline's."""
    from . import pipeline as pl

    return pl.load(path, overrides=list(overrides), size=pl.parse_size(size) if size else None, scene=scene,
                   load_scene=load_scene, out_dir=out_dir, allow_outside=allow_outside, view=view, up=up,
                   reference_size=reference_size, fill=fill)


def open_cache(no_cache: bool, cache_dir: Path | None) -> Any:
    """The node cache (None with `no_cache`); mesh files parsed in this process are kept under its root, and
    read from there in later ones (`nodegraph/scene/meshstore.py`)."""
    from .cache import Cache
    from .scene import meshstore

    cache = None if no_cache else Cache(cache_dir)
    meshstore.use_cache(cache)
    return cache
