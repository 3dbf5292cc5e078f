"""Which colour texture's alpha marks exactly the pixels a window-depth texture covers.

rasterize writes its `color` (alpha 1 on every drawn fragment, 0 elsewhere) and its `depth` (the drawn
fragment's window depth, which passed the "<" test against the cleared far plane 1.0, so is below 1;
1.0 elsewhere) in the same fragments of one pass. So `depth < 1` exactly where `color.a > 0`, and a node
that only needs "does a surface lie behind this texel" (sketch, when its own `depth` output is not
needed) may read the colour's alpha at that texel instead of the depth: one texture fewer in its pass.

The relation is recorded per pair of texture values (the identical objects the executor hands out), so it
holds only while both are those values: a texture read back from the disk cache, or any other pair of
inputs, is not in the table, and the consumer reads the depth as before (the same pixels either way)."""

from __future__ import annotations

import weakref
from typing import Any

_COVERED_BY: weakref.WeakKeyDictionary[Any, Any] = weakref.WeakKeyDictionary()


def record(depth: Any, color: Any) -> None:
    """`color`'s alpha is > 0 exactly where `depth` < 1 (both written by one pass)."""
    _COVERED_BY[depth] = color


def same_coverage(depth: Any, color: Any) -> bool:
    """Whether `color.a > 0` is known to mark exactly the texels where `depth < 1`."""
    return depth is not None and color is not None and _COVERED_BY.get(depth) is color
