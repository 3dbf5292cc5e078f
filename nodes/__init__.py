"""Built-in node types: one folder per node, the folder name is the YAML `type:`; `_shared/` holds helpers."""

from __future__ import annotations

import pkgutil
from pathlib import Path


def register(registry) -> None:  # noqa: ANN001 - nodegraph.registry.Registry
    """Entry point for the `nodegraph.nodes` group: every `nodes/<name>/` package as node type `name`, whose
    class is its module's `NODE`. Registered lazily: a package is imported when a pipeline uses its type."""
    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if info.ispkg and not info.name.startswith("_"):
            registry.add_lazy(info.name, f"{__name__}.{info.name}:NODE")
