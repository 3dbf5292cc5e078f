"""How the curvature node hands out its arrays, as its consumers (pencil_shade) read them: field names per
object and the codes of where a vertex's directions came from."""

from __future__ import annotations

from enum import IntEnum

# per-object arrays, named f"o{index}_{field}"
FIELDS = ("kmin", "kmax", "dmin", "dmax", "normal", "confidence", "reason", "source", "key")


def object_field(index: int, name: str) -> str:
    return f"o{index}_{name}"


class DirectionSource(IntEnum):
    """Where a vertex's output directions came from."""

    MEASURED = 0
    SMOOTHED = 1
    FIXED_FRAME = 2
