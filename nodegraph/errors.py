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


class PortTypeError(PipelineError):
    """A connection joins ports of incompatible types."""


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
        if node_id is not None and node_type is not None:
            text = f"node '{node_id}' ({node_type}): {message}"
        elif node_id is not None:
            text = f"node '{node_id}': {message}"
        elif node_type is not None:
            text = f"{node_type}: {message}"
        else:
            text = message
        super().__init__(text)
