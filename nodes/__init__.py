"""Built-in node types: one folder per node, the folder name is the YAML `type:`."""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path


def register(registry) -> None:  # noqa: ANN001 - nodegraph.registry.Registry
    """Entry point for the `nodegraph.nodes` group: register every `nodes/<name>/` that defines `NODE`.

    Folders whose name starts with `_` (`_shared`: helpers nodes share) are never nodes and are not imported."""
    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if not info.ispkg or info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        cls = getattr(module, "NODE", None)
        if cls is not None:
            registry.add(cls, info.name)
