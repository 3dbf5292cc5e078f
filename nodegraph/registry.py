"""Node registry, filled from the entry-point group `nodegraph.nodes`.

An entry point names a callable taking the `Registry`; the built-in `nodegraph_nodes` package registers
through the same group a third-party plugin uses, so the engine never imports the built-in nodes by name.

Loading is robust to broken plugins: an entry point that fails to import, raises inside its register
function, or adds a class that is not a valid node (or whose type name is taken) costs only that plugin,
and each problem is one `PluginWarning` line naming the entry point and its distribution. A plugin's
types are committed only when its register function returns, so a failing plugin adds nothing. The
built-in entry point loads first, so no plugin can replace a built-in type; its failure is a
`PluginError` instead of a warning, because no pipeline can run without the built-in types.
"""

from __future__ import annotations

import contextlib
import importlib
import inspect
import re
import sys
import warnings
from importlib.metadata import EntryPoint, entry_points
from types import ModuleType
from typing import Any

from pydantic import BaseModel

from .errors import PluginError
from .node import CONTEXT_KEYS, Input, Node, NodeParams, Output
from .types import PortType

GROUP = "nodegraph.nodes"
BUILTIN_MODULE = "nodegraph_nodes"
BUILTIN_DIST = "sketchgraph"
PERSIST = ("always", "auto", "never")
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class PluginWarning(UserWarning):
    """A plugin (an entry point in `nodegraph.nodes`) or one of its node types was skipped."""


def node_problem(cls: Any, name: str | None = None) -> str | None:
    """Why `cls` cannot be registered as node type `name` (None when it can). Cheap, no GPU."""
    if not isinstance(cls, type) or not issubclass(cls, Node):
        return f"{cls!r} is not a subclass of nodegraph.node.Node"
    if cls is Node:
        return "nodegraph.node.Node itself cannot be registered; register a subclass"
    name = name or cls.type_name
    if not isinstance(name, str) or not _NAME.match(name):
        return f"{cls.__name__}: type name {name!r} must be letters, digits and '_', not starting with a digit"
    where = f"{cls.__module__}.{cls.__qualname__}"
    for kind, want in (("inputs", Input), ("outputs", Output)):
        ports = getattr(cls, kind)
        if not isinstance(ports, dict):
            return f"{where}.{kind} must be a dict of port name -> {want.__name__}, found {type(ports).__name__}"
        for port, spec in ports.items():
            if not isinstance(port, str) or not _NAME.match(port):
                return f"{where}.{kind}: port name {port!r} must be letters, digits and '_'"
            if not isinstance(spec, want):
                return f"{where}.{kind}['{port}'] must be a nodegraph.node.{want.__name__}, found {type(spec).__name__}"
            if not isinstance(spec.type, PortType):
                return (f"{where}.{kind}['{port}'].type must be a port type from nodegraph.types (e.g. "
                        f"Texture('RGBA16F')), found {spec.type!r}")
    if not cls.outputs:
        return f"{where} declares no outputs"
    params = cls.Params
    if not isinstance(params, type) or not issubclass(params, NodeParams):
        base = "a pydantic model" if isinstance(params, type) and issubclass(params, BaseModel) else repr(params)
        return f"{where}.Params must subclass nodegraph.node.NodeParams, found {base}"
    config = params.model_config
    if config.get("extra") != "forbid" or not config.get("frozen"):
        return f"{where}.Params must keep NodeParams' model_config (extra='forbid', frozen=True)"
    if cls.compute is Node.compute:
        return f"{where} does not define compute(ctx, inputs, needed)"
    if not isinstance(cls.version, str):
        return f"{where}.version must be a str, found {cls.version!r}"
    keys = inspect.getattr_static(cls, "context_keys")
    unknown = set() if isinstance(keys, property) else set(keys) - CONTEXT_KEYS  # a property: per params
    if unknown:
        return f"{where}.context_keys has unknown {sorted(unknown)}; known: {sorted(CONTEXT_KEYS)}"
    if cls.persist not in PERSIST:
        return f"{where}.persist must be one of {', '.join(PERSIST)}, found {cls.persist!r}"
    if isinstance(cls.shaders, str):
        return f"{where}.shaders must be a tuple of file names, found a str (write ({cls.shaders!r},))"
    if cls.shaders:
        try:
            folder = cls.source_dir()
        except (TypeError, OSError) as exc:
            return f"{where}: cannot find the module's folder for its shaders ({exc})"
        for s in cls.shaders:
            if not (folder / s).is_file():
                return (f"{where}: shader {s!r} not found in {folder} (GLSL files must sit beside the module "
                        "and be listed in the package's package-data)")
    return None


class Registry:
    def __init__(self) -> None:
        self._types: dict[str, type[Node]] = {}
        self._lazy: dict[str, str] = {}  # type name -> 'module:attribute', imported on first get()
        self._origins: dict[str, str] = {}  # type name -> who registered it (for duplicate messages)
        self.problems: list[str] = []  # one line per skipped plugin or node type (also warned)

    def add(self, cls: type[Node], name: str | None = None) -> type[Node]:
        """Register `cls` as node type `name` (default `cls.type_name`); PluginError if it cannot be."""
        name = self._check(cls, name)
        self._insert(cls, name, cls.__module__)
        return cls

    def add_lazy(self, name: str, target: str) -> None:
        """Register node type `name` as `'package.module:Class'`, imported the first time the type is used,
        so a pipeline imports only the node packages it uses. The class is checked when it is imported."""
        self._check_lazy(name, target)
        self._lazy[name] = target
        self._origins.setdefault(name, target)

    def _check_lazy(self, name: str, target: str) -> None:
        if not isinstance(name, str) or not _NAME.match(name):
            raise PluginError(f"type name {name!r} must be letters, digits and '_', not starting with a digit")
        module, colon, attr = str(target).partition(":")
        if not colon or not module or not attr:
            raise PluginError(f"node type '{name}': expected 'package.module:Class', found {target!r}")
        if name in self._types or name in self._lazy:
            raise PluginError(f"node type '{name}' is already registered by {self._origins.get(name)}")

    def _resolve(self, name: str) -> type[Node]:
        """Import a lazily registered type and check it against the node contract (PluginError if broken)."""
        target = self._lazy[name]
        module, _, attr = target.partition(":")
        try:
            cls = getattr(importlib.import_module(module), attr)
        except Exception as exc:  # noqa: BLE001 - a broken node package is one line, not a traceback
            raise PluginError(f"node type '{name}' ({target}) cannot be loaded: {_one_line(exc)}") from exc
        del self._lazy[name]
        try:
            problem = node_problem(cls, name)
        except Exception as exc:  # noqa: BLE001
            problem = f"{cls!r} cannot be checked as a node class: {_one_line(exc)}"
        if problem:
            raise PluginError(f"node type '{name}' ({target}): {problem}")
        self._insert(cls, name, self._origins.get(name, target))
        return cls

    def _check(self, cls: Any, name: str | None) -> str:
        try:
            problem = node_problem(cls, name)
        except Exception as exc:  # noqa: BLE001 - a class odd enough to break the checks is rejected too
            problem = f"{cls!r} cannot be checked as a node class: {_one_line(exc)}"
        if problem:
            raise PluginError(problem)
        name = name or cls.type_name
        if name in self._lazy:
            raise PluginError(f"node type '{name}' is already registered by {self._origins.get(name)}")
        held = self._types.get(name)
        if held is not None and held is not cls:
            raise PluginError(f"node type '{name}' is already registered by {self._origins[name]} "
                              f"({held.__module__}.{held.__qualname__})")
        other = next((n for n, c in self._types.items() if c is cls and n != name), None)
        if other is None:  # a lazily registered type whose module is already imported may be this class
            other = next((n for n, t in self._lazy.items() if n != name
                          and getattr(sys.modules.get(t.partition(":")[0]), t.partition(":")[2], None) is cls), None)
        if other is not None:
            raise PluginError(f"{cls.__qualname__} is already registered as '{other}'; subclass it to register "
                              f"it under a second name")
        return name

    def _insert(self, cls: type[Node], name: str, origin: str) -> None:
        cls.type_name = name
        self._types[name] = cls
        self._origins.setdefault(name, origin)

    def get(self, name: str) -> type[Node] | None:
        """The node class of a type (importing it if it was registered lazily), or None if unknown."""
        cls = self._types.get(name)
        if cls is None and name in self._lazy:
            cls = self._resolve(name)
        return cls

    def names(self) -> list[str]:
        return sorted({*self._types, *self._lazy})

    def __contains__(self, name: str) -> bool:
        return name in self._types or name in self._lazy

    def items(self) -> list[tuple[str, type[Node]]]:
        """Every type with its class: imports every lazily registered package."""
        return [(n, c) for n in self.names() if (c := self.get(n)) is not None]

    def module(self, name: str) -> str:
        """The package that holds node type `name`'s class (`nodegraph_nodes.edge_detect` for a built-in), so
        tools find a node's own measurement modules (`reference`, `accuracy`, `stability`, `bench`) beside it.
        A lazily registered type is not imported for this."""
        if name in self._lazy:
            return self._lazy[name].partition(":")[0]
        cls = self._types.get(name)
        if cls is None:
            raise KeyError(f"unknown node type {name!r}")
        mod = sys.modules.get(cls.__module__)
        return (getattr(mod, "__package__", None) or cls.__module__) if mod is not None else cls.__module__

    def submodule(self, name: str, sub: str) -> ModuleType:
        """Import the module `sub` beside node type `name` (e.g. `submodule("edge_detect", "reference")`)."""
        return importlib.import_module(f"{self.module(name)}.{sub}")

    def origin(self, name: str) -> str | None:
        """Who registered a type: the entry point and distribution, or the module for a direct add()."""
        return self._origins.get(name)

    # -- entry points ----------------------------------------------------------------------
    def load_entry_point(self, ep: EntryPoint, *, strict: bool = False) -> list[str]:
        """Run one entry point's register function; returns the types it added. A problem becomes one
        PluginWarning line (and an entry in `problems`), or a PluginError when `strict`."""
        label = describe(ep)

        def fail(message: str, exc: BaseException | None = None) -> None:
            line = f"{label}: {message}"
            if strict:
                raise PluginError(f"{line}; nothing can run without the built-in node types "
                                  f"(reinstall sketchgraph: pip install -e .)") from exc
            self.problems.append(line)
            warnings.warn(line, PluginWarning, stacklevel=3)

        try:
            register = ep.load()
        except Exception as exc:  # noqa: BLE001 - any import failure costs only this plugin
            fail(f"cannot be loaded: {_one_line(exc)}; its node types are not available", exc)
            return []
        if not callable(register):
            fail(f"names {type(register).__name__} {register!r}, not a function taking the registry")
            return []
        staging = _Staging(self)
        try:
            register(staging)
        except Exception as exc:  # noqa: BLE001
            fail(f"register() raised {_one_line(exc)}; none of its node types are available", exc)
            return []
        for problem in staging.rejected:
            fail(f"node type skipped: {problem}")
        for name, cls in staging.staged.items():
            self._insert(cls, name, label)
        for name, target in staging.staged_lazy.items():
            self._lazy[name] = target
            self._origins.setdefault(name, label)
        return [*staging.staged, *staging.staged_lazy]


class _Staging(Registry):
    """What a plugin's register function receives: `add` checks a class against the node contract and
    against every name already taken, and keeps it aside (a rejected class is recorded, not raised, so the
    plugin's other types still register); the target registry takes the kept ones when register returns."""

    def __init__(self, target: Registry) -> None:
        super().__init__()
        self._target = target
        self._types = dict(target._types)
        self._lazy = dict(target._lazy)
        self._origins = dict(target._origins)
        self.staged: dict[str, type[Node]] = {}
        self.staged_lazy: dict[str, str] = {}
        self.rejected: list[str] = []

    def add_lazy(self, name: str, target: str) -> None:
        try:
            self._check_lazy(name, target)
        except PluginError as exc:
            self.rejected.append(str(exc))
            return
        self._lazy[name] = target
        self._origins.setdefault(name, "this plugin")
        self.staged_lazy[name] = target

    def add(self, cls: type[Node], name: str | None = None) -> type[Node]:
        try:
            name = self._check(cls, name)
        except PluginError as exc:
            self.rejected.append(str(exc))
            return cls
        self._types[name] = cls
        self._origins.setdefault(name, "this plugin")
        self.staged[name] = cls
        return cls


def describe(ep: EntryPoint) -> str:
    """`entry point 'name = value' (distribution version)`, the distribution where it is known."""
    text = f"entry point '{ep.name} = {ep.value}'"
    dist = getattr(ep, "dist", None)
    if dist is not None:
        with contextlib.suppress(Exception):  # broken metadata must not hide the entry point itself
            text += f" ({dist.name} {dist.version})"
    return text


def _one_line(exc: BaseException) -> str:
    lines = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {lines[0]}" if lines else type(exc).__name__


def is_builtin(ep: EntryPoint) -> bool:
    dist = getattr(ep, "dist", None)
    name = getattr(dist, "name", None) if dist is not None else None
    if name is not None:
        return name.lower().replace("_", "-") == BUILTIN_DIST and ep.module == BUILTIN_MODULE
    return ep.module == BUILTIN_MODULE


def load(eps: Any = None) -> Registry:
    """A registry filled from `eps` (default: every installed `nodegraph.nodes` entry point). The built-in
    entry point loads first and must succeed (PluginError otherwise); the others follow sorted by name,
    each one skipped with a PluginWarning when broken."""
    eps = list(entry_points(group=GROUP) if eps is None else eps)
    builtin = [ep for ep in eps if is_builtin(ep)]
    if not builtin:
        raise PluginError(f"no built-in node types: no '{GROUP}' entry point for {BUILTIN_MODULE} (is sketchgraph "
                          "installed? run `pip install -e .` in the repository)")
    reg = Registry()
    for ep in builtin:
        reg.load_entry_point(ep, strict=True)
    for ep in sorted((ep for ep in eps if not is_builtin(ep)), key=lambda e: (e.name, e.value)):
        reg.load_entry_point(ep)
    return reg


_DEFAULT: Registry | None = None


def default() -> Registry:
    """The registry filled from every installed `nodegraph.nodes` entry point (loaded once)."""
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = load()
    return _DEFAULT


def module_of(type_name: str) -> str:
    """The package module of a registered node type (see `Registry.module`), from the default registry."""
    return default().module(type_name)


def node_module(type_name: str, sub: str) -> ModuleType:
    """`sub` imported from beside a registered node type, e.g. `node_module("curvature", "principal")`."""
    return default().submodule(type_name, sub)
