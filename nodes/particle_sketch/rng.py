"""Counter-based random numbers of the particle sketcher, identical in NumPy and in pure Python.

One 64-bit key from the node's generator (`draw_key`), then splitmix64 of (key, stroke, index): a
stroke's start candidates and forces do not depend on other strokes or on the batch size, and the
pure-Python reference, the NumPy lanes and the compiled engine (`jit`, which keeps its own compiled copy
of `mix`) draw the very same numbers.
"""

from __future__ import annotations

import numpy as np

MASK = (1 << 64) - 1
GOLD = 0x9E3779B97F4A7C15
STROKE = 0xD1B54A32D192ED03
M1, M2 = 0xBF58476D1CE4E5B9, 0x94D049BB133111EB
TO_UNIT = 1.0 / 9007199254740992.0  # 2^-53
TO_UNIT32 = 1.0 / 4294967296.0  # 2^-32


def mix_py(z: int) -> int:
    """splitmix64's output function (after its increment)."""
    z = (z + GOLD) & MASK
    z = ((z ^ (z >> 30)) * M1) & MASK
    z = ((z ^ (z >> 27)) * M2) & MASK
    return z ^ (z >> 31)


def unit_py(key: int, i: int) -> float:
    """The i-th number in [0, 1) of stream `key`."""
    return (mix_py((key + i * GOLD) & MASK) >> 11) * TO_UNIT


def point_py(key: int, i: int, w: int, h: int) -> tuple[float, float]:
    """The i-th uniform point of [0, w) x [0, h) of stream `key`: one 64-bit output, 32 bits per axis."""
    z = mix_py((key + i * GOLD) & MASK)
    return (z >> 32) * TO_UNIT32 * w, (z & 0xFFFFFFFF) * TO_UNIT32 * h


def stroke_key_py(key: int, stroke: int, which: int) -> int:
    """Stream key of a stroke's start candidates (which=0) or forces (which=1)."""
    return mix_py((key + (2 * stroke + which) * STROKE) & MASK)


_U64 = np.uint64
_GOLD_U, _STROKE_U, _M1_U, _M2_U = _U64(GOLD), _U64(STROKE), _U64(M1), _U64(M2)
_S11, _S27, _S30, _S31, _S32 = _U64(11), _U64(27), _U64(30), _U64(31), _U64(32)
_LOW32, _TWO_U = _U64(0xFFFFFFFF), _U64(2)
PAIR = np.array([0, 1], np.uint64)


def mix_np(z: np.ndarray) -> np.ndarray:
    z = z + _GOLD_U
    z = (z ^ (z >> _S30)) * _M1_U
    z = (z ^ (z >> _S27)) * _M2_U
    return z ^ (z >> _S31)


def unit_np(key: np.ndarray, i: np.ndarray) -> np.ndarray:
    """Elementwise `unit_py`; `i` is uint64."""
    return (mix_np(key + i * _GOLD_U) >> _S11).astype(np.float64) * TO_UNIT


def point_np(key: np.ndarray, i: np.ndarray, w: int, h: int) -> tuple[np.ndarray, np.ndarray]:
    """(hash z, flat pixel index) of `point_py`'s points: the pixel is (hi32(z) w >> 32,
    lo32(z) h >> 32), exactly the floor of the float coordinates (u32 * w < 2^53 is exact).
    `mix_np`'s operations, in place."""
    z = key + i * _GOLD_U
    z += _GOLD_U
    z ^= z >> _S30
    z *= _M1_U
    z ^= z >> _S27
    z *= _M2_U
    z ^= z >> _S31
    ix = z >> _S32
    ix *= _U64(w)
    ix >>= _S32
    flat = z & _LOW32
    flat *= _U64(h)
    flat >>= _S32
    flat *= _U64(w)
    flat += ix
    return z, flat.view(np.int64)  # < 2^63


def point_of(z: np.ndarray, w: int, h: int) -> np.ndarray:
    """Complex position of hashes z, computed as `point_py` does."""
    return ((z >> _S32).astype(np.float64) * TO_UNIT32 * w
            + 1j * ((z & _LOW32).astype(np.float64) * TO_UNIT32 * h))


def stroke_key_np(key: int, strokes: np.ndarray, which: int) -> np.ndarray:
    return mix_np(_U64(key) + (_TWO_U * strokes.astype(np.uint64) + _U64(which)) * _STROKE_U)


def draw_key(rng: np.random.Generator | None) -> int:
    return int((rng if rng is not None else np.random.default_rng(0)).integers(0, 2**64, dtype=np.uint64))
