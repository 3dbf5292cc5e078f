"""Work, not time: how much a call does, for tests that bound it (a wall-clock limit fails on a loaded machine
and passes a slow algorithm on a fast one; these counts are the same on every machine)."""

from __future__ import annotations

import sys
import tracemalloc
from collections.abc import Callable
from typing import Any


def python_lines(f: Callable[[], Any]) -> tuple[int, Any]:
    """(lines of Python executed by `f()`, its result): any Python loop costs at least a line a step, so a
    call that walks n things in Python counts at least n. C code (NumPy, libyaml) counts nothing. A tracer
    already set (coverage, a debugger) is put back afterwards."""
    lines = 0

    def tracer(frame, event, arg):  # noqa: ANN001, ANN202, ARG001
        nonlocal lines
        lines += event == "line"
        return tracer

    old = sys.gettrace()
    sys.settrace(tracer)
    try:
        result = f()
    finally:
        sys.settrace(old)
    return lines, result


def peak_bytes(f: Callable[[], Any]) -> tuple[int, Any]:
    """(the most memory `f()` held at once, Python objects and NumPy arrays, beyond what was held before; its
    result)."""
    tracemalloc.start()
    try:
        result = f()
        return tracemalloc.get_traced_memory()[1], result
    finally:
        tracemalloc.stop()
