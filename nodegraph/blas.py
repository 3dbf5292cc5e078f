"""One BLAS kernel on every x86-64 machine, so the same inputs give the same bytes.

NumPy and SciPy ship OpenBLAS built for many CPUs; at load time it picks the kernels of the CPU it finds.
Matrix products then round differently from one CPU family to the next: with the AVX-512 kernels
(SkylakeX and later) the built-in scenes' transforms come out a last bit away from the AVX2 (Haswell)
ones, which changed every built-in scene's content hash, so every cache key, and failed `gallery verify`
on a machine of another kind (measured: the manifest built on an AVX2 machine, verified on a Sapphire
Rapids one). Pinning OpenBLAS to its Haswell kernels, which every x86-64 CPU with AVX2 and FMA runs, gives
the same results on all of them; nothing here leans on BLAS for speed (4x4 transforms, small solves).

OpenBLAS reads the choice (`OPENBLAS_CORETYPE`) once, when NumPy loads it, so the pin is set when
`nodegraph` is imported first (the `sketchgraph` command, Dask workers, the tests), never over a value the
user set; a program that imported NumPy before `nodegraph` keeps its CPU's kernels (docs/api.md).

OpenBLAS also runs on one thread (`OPENBLAS_NUM_THREADS=1`, set the same way): its thread pool starts when
NumPy loads and spins for a while, 0.15 s of CPU per process on the 2-core machine (an AMD EPYC: `import
numpy` 0.24-0.32 s of CPU against 0.13 on one thread; the first image with a warm cache 1.46-1.55 s against
1.27-1.35), which is a sixth of a first image and, in a frame loop, time taken from llvmpipe's own threads;
the products here are 4x4 transforms and N x 3 by 3 x 3, below the size where OpenBLAS splits work anyway,
and one thread gives the same bits (it splits rows and columns, never the summed dimension)."""

from __future__ import annotations

import os
import platform
import sys

PINNED_CORE = "Haswell"
THREADS = "1"
NEEDS = frozenset({"avx2", "fma"})


def cpu_flags() -> frozenset[str]:
    """The CPU's feature flags from /proc/cpuinfo (empty where there is none)."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    return frozenset(line.split(":", 1)[1].split())
    except OSError:
        pass
    return frozenset()


def pin_kernel() -> str | None:
    """Set OPENBLAS_CORETYPE to the pinned kernel where that still takes effect and the CPU runs it; the
    value in force afterwards (None: OpenBLAS chooses)."""
    if ("OPENBLAS_CORETYPE" not in os.environ and "numpy" not in sys.modules
            and platform.machine().lower() in ("x86_64", "amd64") and cpu_flags() >= NEEDS):
        os.environ["OPENBLAS_CORETYPE"] = PINNED_CORE
    return os.environ.get("OPENBLAS_CORETYPE")


def limit_threads() -> str | None:
    """Set OPENBLAS_NUM_THREADS to `THREADS` where that still takes effect and the user set none; the value
    in force afterwards (None: OpenBLAS chooses, one thread a core)."""
    if "OPENBLAS_NUM_THREADS" not in os.environ and "numpy" not in sys.modules:
        os.environ["OPENBLAS_NUM_THREADS"] = THREADS
    return os.environ.get("OPENBLAS_NUM_THREADS")
