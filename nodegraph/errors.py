"""Error hierarchy. Every error renders as one line: where, what was expected, what was found."""

from __future__ import annotations


class SketchgraphError(Exception):
    """Base class; `str(err)` is the one-line message shown to users."""


class Location:
    __slots__ = ("file", "line", "col")

    def __init__(self, file: str | None, line: int | None = None, col: int | None = None):
        self.file = file
        self.line = line
        self.col = col

    def __str__(self) -> str:
        parts = [self.file or "<input>"]
        if self.line is not None:
            parts.append(str(self.line))
            if self.col is not None:
                parts.append(str(self.col))
        return ":".join(parts)


class PipelineError(SketchgraphError):
    """A pipeline or scene file is invalid. Raised before any GL context exists."""

    def __init__(self, message: str, location: Location | None = None):
        self.message = message
        self.location = location
        super().__init__(f"{location}: {message}" if location else message)


class ArgumentError(SketchgraphError):
    """A Python API call got an argument it cannot use (nodegraph/api.py). Never raised bare: each error is also
    the builtin exception Python code expects for the fault (`ArgumentTypeError` is a `TypeError`,
    `ArgumentValueError` a `ValueError`), so `except TypeError` and `except SketchgraphError` both catch it. The
    message is one line naming the argument as the API spells it (`size=`, `frame=`), what was expected and
    what was found."""


class ArgumentTypeError(ArgumentError, TypeError):
    """An API argument of the wrong type (`size=100`, `frame='a'`, `size=(True, True)`: bool is not a number)."""


class ArgumentValueError(ArgumentError, ValueError):
    """An API argument of the right type but out of range or unusable (`frame=2**40`, `dtype='float16'`)."""


class PortTypeError(PipelineError):
    """A connection joins ports of incompatible types."""


class PipelineArgumentError(PipelineError, ArgumentValueError):
    """An API argument the pipeline cannot take: a `load` option (`scene=` not found, `size=` out of range, a `set=`
    naming no parameter) or an output or NODE.PORT it does not have. A `PipelineError`, as the same fault is on
    the command line, and an `ArgumentValueError` (so a `ValueError`)."""


class CycleError(PipelineError):
    """The node graph has a cycle."""


class MeshError(SketchgraphError):
    """A mesh file cannot be used (missing, unreadable, empty, NaN/Inf coordinates)."""


class ShaderError(SketchgraphError):
    """A GLSL program failed to compile or link; names the node, the file and the line."""


class GLUnavailableError(SketchgraphError):
    """No OpenGL 3.3+ context could be created (EGL or the GL driver is missing)."""


class CacheError(SketchgraphError):
    """A cache entry is unreadable or does not match its key (recovered by recomputing)."""


class PluginError(SketchgraphError):
    """A node type cannot be registered (not a Node subclass, bad ports or Params, a taken name), or the
    built-in node types failed to load."""


class NodeError(SketchgraphError):
    """A node failed at compute time; names the node and its type."""

    def __init__(self, message: str, node_id: str | None = None, node_type: str | None = None):
        self.message = message
        self.node_id = node_id
        self.node_type = node_type
        super().__init__(_node_prefix(node_id, node_type) + message)


def _node_prefix(node_id: str | None, node_type: str | None) -> str:
    if node_id is None:
        return ""
    return f"node '{node_id}' ({node_type}): " if node_type else f"node '{node_id}': "


def one_line(exc: BaseException, limit: int = 300) -> str:
    """An unexpected exception as one short line: its type and the first line of its message."""
    text = str(exc).strip().splitlines()
    first = text[0] if text else ""
    if len(first) > limit:
        first = first[: limit - 1] + "…"
    return f"{type(exc).__name__}: {first}" if first else type(exc).__name__
