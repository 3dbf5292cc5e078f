"""Node registry, filled from the entry-point group `nodegraph.nodes`.

An entry point names a callable taking the `Registry`; the built-in `nodes` package registers through
the same group a third-party plugin uses, so the engine never imports `nodes` by name.
"""

from __future__ import annotations

import importlib
import sys
from importlib.metadata import entry_points
from types import ModuleType

from .node import Node

GROUP = "nodegraph.nodes"


class Registry:
    def __init__(self) -> None:
        self._types: dict[str, type[Node]] = {}

    def add(self, cls: type[Node], name: str | None = None) -> type[Node]:
        name = name or cls.type_name
        if not name:
            raise ValueError(f"{cls.__name__} has no type name")
        if name in self._types and self._types[name] is not cls:
            raise ValueError(f"node type {name!r} registered twice ({self._types[name].__module__}, {cls.__module__})")
        cls.type_name = name
        self._types[name] = cls
        return cls

    def get(self, name: str) -> type[Node] | None:
        return self._types.get(name)

    def module(self, name: str) -> str:
        """The package that holds node type `name`'s class (`nodegraph_nodes.edge_detect` for a built-in), so
        tools find a node's own measurement modules (`reference`, `accuracy`, `stability`, `bench`) beside it."""
        cls = self._types.get(name)
        if cls is None:
            raise KeyError(f"unknown node type {name!r}")
        mod = sys.modules.get(cls.__module__)
        return (getattr(mod, "__package__", None) or cls.__module__) if mod is not None else cls.__module__

    def submodule(self, name: str, sub: str) -> ModuleType:
        """Import the module `sub` beside node type `name` (e.g. `submodule("edge_detect", "reference")`)."""
        return importlib.import_module(f"{self.module(name)}.{sub}")

    def names(self) -> list[str]:
        return sorted(self._types)

    def __contains__(self, name: str) -> bool:
        return name in self._types

    def items(self) -> list[tuple[str, type[Node]]]:
        return sorted(self._types.items())


_DEFAULT: Registry | None = None


def default() -> Registry:
    """The registry filled from every installed `nodegraph.nodes` entry point (loaded once)."""
    global _DEFAULT
    if _DEFAULT is None:
        reg = Registry()
        eps = entry_points(group=GROUP)
        if not eps:
            raise RuntimeError("no node types registered: the package is not installed "
                               "(run `pip install -e .` in the repository)")
        for ep in eps:
            ep.load()(reg)
        _DEFAULT = reg
    return _DEFAULT


def module_of(type_name: str) -> str:
    """The package module of a registered node type (see `Registry.module`), from the default registry."""
    return default().module(type_name)


def node_module(type_name: str, sub: str) -> ModuleType:
    """`sub` imported from beside a registered node type, e.g. `node_module("curvature", "principal")`."""
    return default().submodule(type_name, sub)
