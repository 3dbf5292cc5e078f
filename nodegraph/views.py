"""The names of the framing choices (`--up`, `--view`, scene `up:`/`view:`), without NumPy: the command line
builds its options from them before anything heavy is imported (`sketchgraph --help`). The geometry that
uses them is `nodegraph.framing`."""

from __future__ import annotations

UP_AXES = ("x", "y", "z")
VIEWS = ("three-quarter", "front", "back", "left", "right", "top", "widest")
