"""sketchgraph's engine: typed node graphs from YAML, run on the GPU through moderngl, cached as EXR."""

from __future__ import annotations

__version__ = "0.1.0"

from .blas import limit_threads as _limit_blas_threads  # noqa: E402
from .blas import pin_kernel as _pin_blas_kernel  # noqa: E402

_pin_blas_kernel()  # before anything loads NumPy: the same bytes on every x86-64 CPU (nodegraph/blas.py)
_limit_blas_threads()  # and one OpenBLAS thread: no thread pool spinning beside llvmpipe's (nodegraph/blas.py)

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

_API = ("Pipe", "Session", "default_session", "load")


def __getattr__(name: str) -> object:
    # the API is imported on first use, so `import nodegraph` (and the CLI's start-up) stays light
    if name in _API:
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'nodegraph' has no attribute {name!r}")


__all__ = [*_API,
    "CycleError", "GLUnavailableError", "MeshError", "NodeError", "PipelineError", "PortTypeError", "ShaderError",
    "SketchgraphError", "__version__",
]
