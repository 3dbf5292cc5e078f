"""OpenBLAS is pinned to one kernel and one thread where nodegraph loads first, so results do not depend on the
CPU family and no thread pool spins beside llvmpipe (nodegraph/blas.py): checked in fresh processes, asking
OpenBLAS which kernel it runs and on how many threads."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from nodegraph import blas

# the kernel the process's OpenBLAS (NumPy's bundled copy) runs, printed last
CORE = """
import ctypes, glob, numpy
lib = ctypes.CDLL(glob.glob(numpy.__path__[0] + '.libs/libscipy_openblas64_*.so')[0])
lib.scipy_openblas_get_corename64_.restype = ctypes.c_char_p
print(lib.scipy_openblas_get_corename64_().decode())
"""


# the number of threads it runs on, printed last
THREADS = """
import ctypes, glob, numpy
lib = ctypes.CDLL(glob.glob(numpy.__path__[0] + '.libs/libscipy_openblas64_*.so')[0])
print(lib.scipy_openblas_get_num_threads64_())
"""


def _ask(first: str, probe: str, variable: str, env_value: str | None) -> str:
    env = {k: v for k, v in os.environ.items() if k != variable}
    if env_value is not None:
        env[variable] = env_value
    out = subprocess.run([sys.executable, "-c", first + "\n" + probe], env=env, capture_output=True, text=True,
                         check=True)
    return out.stdout.split()[-1]


def _core(first: str, env_value: str | None = None) -> str:
    return _ask(first, CORE, "OPENBLAS_CORETYPE", env_value)


def _threads(first: str, env_value: str | None = None) -> int:
    return int(_ask(first, THREADS, "OPENBLAS_NUM_THREADS", env_value))


needs_avx2 = pytest.mark.skipif(not blas.cpu_flags() >= blas.NEEDS,
                                reason="the pinned kernel needs a CPU with AVX2 and FMA")


@needs_avx2
def test_nodegraph_first_runs_the_pinned_kernel():
    assert _core("import nodegraph") == blas.PINNED_CORE


@pytest.mark.slow  # a Python process, 0.7 s
@needs_avx2
def test_the_users_choice_is_kept():
    # Sandybridge (AVX) runs on every CPU that runs the pinned one
    assert _core("import nodegraph", env_value="Sandybridge") == "Sandybridge"


@pytest.mark.slow  # a Python process, 0.7 s
def test_numpy_loaded_first_is_left_alone():
    code = "import numpy, os, nodegraph\nassert 'OPENBLAS_CORETYPE' not in os.environ"
    _core(code)  # raises CalledProcessError if the pin was set after NumPy had loaded OpenBLAS


several_cores = pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="OpenBLAS runs one thread on one core anyway")


@pytest.mark.slow  # a Python process, 0.7 s
@several_cores
def test_nodegraph_first_runs_one_blas_thread():
    assert _threads("import nodegraph") == 1


@pytest.mark.slow  # a Python process, 0.7 s
@several_cores
def test_the_users_thread_count_is_kept():
    assert _threads("import nodegraph", env_value="2") == 2


@pytest.mark.slow  # a Python process, 0.7 s
def test_numpy_loaded_first_keeps_its_threads():
    code = "import numpy, os, nodegraph\nassert 'OPENBLAS_NUM_THREADS' not in os.environ"
    _threads(code)  # raises CalledProcessError if the limit was set after NumPy had loaded OpenBLAS
