"""Node registry, filled from the entry-point group `nodegraph.nodes`.

An entry point names a callable taking the `Registry`; the built-in `nodes` package registers through
the same group a third-party plugin uses, so the engine never imports `nodes` by name.
"""

from __future__ import annotations

from importlib.metadata import entry_points

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
