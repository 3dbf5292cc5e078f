"""sketchgraph's engine: typed node graphs from YAML, run on the GPU through moderngl, cached as EXR."""

from __future__ import annotations

__version__ = "0.1.0"

from .errors import (  # noqa: E402
    CycleError,
    GLUnavailableError,
    MeshError,
    NodeError,
    PipelineError,
    PortTypeError,
    ShaderError,
    SketchgraphError,
)

__all__ = [
    "CycleError", "GLUnavailableError", "MeshError", "NodeError", "PipelineError", "PortTypeError", "ShaderError",
    "SketchgraphError", "__version__",
]
