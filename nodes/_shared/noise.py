"""Float64 NumPy reference of the `perlin_noise` and `object_noise` nodes; `nodes/perlin_noise/improved_noise.glsl`
computes the same on the GPU.

Noise: Ken Perlin's improved noise (2002): his permutation table `PERM`, the quintic fade
6t^5 - 15t^4 + 10t^3, the 12 gradient directions picked by `hash & 15` exactly as in his reference
implementation, trilinear lerps. The table is never reshuffled, so `improved_noise(3.14, 42, 7)` is his
published 0.13691995878400012. Noise repeats every 256 units along each axis.

Seeds move the domain instead of the table. `seed_offset(seed)` is three PCG hashes (`hash_u32`,
chained from the seed reduced mod 2^32); each gives 24 bits, read as a number in [0, 256) with 16
fractional bits, low bit forced to 1:

    offset_k = ((h_k >> 8) | 1) / 2^16,   h_0 = hash_u32(seed mod 2^32),  h_{k+1} = hash_u32(h_k)

Since the noise period is 256, this picks a uniform place in the whole periodic domain, so two
seeds are on average ~85 cells apart per axis and their patterns are unrelated. The fractional part
is never 0, so pixel grids and integer object coordinates never sit on the lattice, where noise is 0.
With 24 significant bits the offset is exact in float32. The GPU gets it in two parts
(`seed_offset_parts`): the integer cell goes into the lattice index and only the fractional part
is added as a float, so float32 precision does not depend on the size of the offset.

Screen space (paper §3.2): for pixel (x, y) (row 0 = bottom row, the GL convention), the texture
coordinates are s = (x + 0.5)/W, t = (y + 0.5)/H, and with o = seed_offset(seed) and F = turbulence
(or fbm):

    P(s, t) = (s*W*scale, t*H*scale, 0) + o          (`scale` = noise cycles per pixel)
    off_s   = F(P(s, t)),   off_t = F(P(1 - s, 1 - t))

so s*W = x + 0.5 = gl_FragCoord.x and (1 - s)*W = W - gl_FragCoord.x. The GPU multiplies by `scale`
as `split_scale(scale)` = (hi, lo): hi has 10 significant bits, so (x + 0.5)*hi is exact in float32
for W, H <= 8192, and lo is the remainder. Both channels use the same offset, as in the paper, so
off_t(x, y) = off_s(W-1-x, H-1-y) and the two agree at the image centre.

Object space (paper §4.3): `noise3_at` evaluates F at points*scale + o for the first channel and at
points*scale + o + CHANNEL1_OFFSET for the second. CHANNEL1_OFFSET = (128.5, 85.25, 42.75) is half
the period along x (other hash chains along every axis, so unrelated values) with fractional parts
that put the second channel's lattice between the first one's.

Uncorrelated noise (paper §3.4, roughened profiles): `hash_u32` is the PCG hash of Jarzynski and
Olano, "Hash Functions for GPU Rendering" (JCGT 2020): one step of PCG's 32-bit LCG (multiplier
747796405, increment 2891336453) followed by PCG's RXS-M-XS output permutation. For pixel (x, y)
and channel c in {0, 1}:

    stream_c = hash_u32(hash_u32(seed) + 2*frame + c)                    (all mod 2^32)
    value    = (hash_u32(x + hash_u32(y + hash_u32(stream_c))) >> 8) / 2^24   in [0, 1)

Only uint32 arithmetic plus an exact conversion of a 24-bit integer, so the GPU gives the same bits.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

Mode = Literal["turbulence", "fbm"]
MODES: tuple[str, ...] = ("turbulence", "fbm")

# Ken Perlin's improved-noise permutation of 0..255 (2002 reference implementation).
PERM: NDArray[np.uint8] = np.array([
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69, 142,
    8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219, 203, 117,
    35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175, 74, 165, 71,
    134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230, 220, 105, 92, 41,
    55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76, 132, 187, 208, 89,
    18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173, 186, 3, 64, 52, 217, 226,
    250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206, 59, 227, 47, 16, 58, 17, 182,
    189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163, 70, 221, 153, 101, 155, 167, 43,
    172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232, 178, 185, 112, 104, 218, 246, 97,
    228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162, 241, 81, 51, 145, 235, 249, 14, 239, 107,
    49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204, 176, 115, 121, 50, 45, 127, 4, 150, 254, 138,
    236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141, 128, 195, 78, 66, 215, 61, 156, 180,
], dtype=np.uint8)
PERM.setflags(write=False)

_P = np.concatenate([PERM, PERM]).astype(np.int64)  # Perlin's doubled table p[0..511]

CHANNEL1_OFFSET: NDArray[np.float64] = np.array([128.5, 85.25, 42.75])
CHANNEL1_OFFSET.setflags(write=False)

_MASK32 = 0xFFFFFFFF


def perm_texture_bytes() -> bytes:
    """The 256 bytes of a 256x1 R8UI texture holding `PERM` (bound to `t_perm`).

    With moderngl: `ctx.texture((256, 1), 1, perm_texture_bytes(), dtype="u1")`, filter NEAREST
    (an integer texture with a linear filter is incomplete and reads as 0).
    """
    return PERM.tobytes()


# --- improved noise ------------------------------------------------------------------------------

def _fade(t: NDArray[np.float64]) -> NDArray[np.float64]:
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def _lerp(t: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    return a + t * (b - a)


def _grad(hash_: NDArray[np.int64], x: NDArray[np.float64], y: NDArray[np.float64],
          z: NDArray[np.float64]) -> NDArray[np.float64]:
    h = hash_ & 15
    u = np.where(h < 8, x, y)
    v = np.where(h < 4, y, np.where((h == 12) | (h == 14), x, z))
    return np.where((h & 1) == 0, u, -u) + np.where((h & 2) == 0, v, -v)


def improved_noise(x: ArrayLike, y: ArrayLike, z: ArrayLike) -> NDArray[np.float64]:
    """Perlin's improved noise at (x, y, z); broadcasts its arguments; values in [-1, 1]."""
    x, y, z = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (x, y, z)))
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    # np.mod of a float is exact, so this is floor(x) & 255 even far beyond the int64 range
    X, Y, Z = (np.mod(f, 256.0).astype(np.int64) for f in (fx, fy, fz))
    x, y, z = x - fx, y - fy, z - fz
    u, v, w = _fade(x), _fade(y), _fade(z)
    p = _P
    A = p[X] + Y
    AA = p[A] + Z
    AB = p[A + 1] + Z
    B = p[X + 1] + Y
    BA = p[B] + Z
    BB = p[B + 1] + Z
    return _lerp(w, _lerp(v, _lerp(u, _grad(p[AA], x, y, z), _grad(p[BA], x - 1, y, z)),
                          _lerp(u, _grad(p[AB], x, y - 1, z), _grad(p[BB], x - 1, y - 1, z))),
                 _lerp(v, _lerp(u, _grad(p[AA + 1], x, y, z - 1), _grad(p[BA + 1], x - 1, y, z - 1)),
                       _lerp(u, _grad(p[AB + 1], x, y - 1, z - 1), _grad(p[BB + 1], x - 1, y - 1, z - 1))))


def octaves_bound(octaves: int) -> float:
    """A bound on |turbulence| and |fbm| of `octaves` octaves (any point, any seed): improved noise lies in
    (-2, 2) (each corner's gradient term is +-u +-v with |u|, |v| < 1, blended with weights summing to 1), and
    octave i is divided by 2^i. Consumers that shift lookups by the noise use it (sketch's footprint)."""
    return 2.0 * (2.0 - 2.0 ** (1 - int(octaves)))


def _check_octaves(octaves: int) -> int:
    if isinstance(octaves, bool) or not isinstance(octaves, int | np.integer) or octaves < 0:
        raise ValueError(f"octaves: expected an integer >= 0, got {octaves!r}")
    return int(octaves)


def turbulence(x: ArrayLike, y: ArrayLike, z: ArrayLike, octaves: int) -> NDArray[np.float64]:
    """Perlin's turbulence: sum over i < octaves of |noise(2^i p)| / 2^i (>= 0)."""
    return _octaves(x, y, z, octaves, signed=False)


def fbm(x: ArrayLike, y: ArrayLike, z: ArrayLike, octaves: int) -> NDArray[np.float64]:
    """Signed fractal sum: sum over i < octaves of noise(2^i p) / 2^i."""
    return _octaves(x, y, z, octaves, signed=True)


def _octaves(x: ArrayLike, y: ArrayLike, z: ArrayLike, octaves: int, signed: bool) -> NDArray[np.float64]:
    octaves = _check_octaves(octaves)
    x, y, z = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (x, y, z)))
    total = np.zeros(x.shape)
    for i in range(octaves):
        k = 2.0 ** i
        n = improved_noise(k * x, k * y, k * z)
        total += (n if signed else np.abs(n)) / k
    return total


def _octave_fn(mode: str) -> Callable[[ArrayLike, ArrayLike, ArrayLike, int], NDArray[np.float64]]:
    if mode == "turbulence":
        return turbulence
    if mode == "fbm":
        return fbm
    raise ValueError(f"mode: expected one of {', '.join(MODES)}, got {mode!r}")


# --- hashing and seeds ---------------------------------------------------------------------------

def hash_u32(x: ArrayLike) -> NDArray[np.uint32]:
    """PCG hash (Jarzynski & Olano 2020: LCG step + RXS-M-XS output permutation), uint32 -> uint32.

    Any integers are taken mod 2^32. Computed in uint64 and masked, so nothing overflows.
    """
    a = np.asarray(x)
    if a.dtype.kind not in "iu":
        raise TypeError(f"hash_u32: expected integers, got dtype {a.dtype}")
    state = ((a.astype(np.uint64) & _MASK32) * np.uint64(747796405) + np.uint64(2891336453)) & _MASK32
    word = (((state >> ((state >> np.uint64(28)) + np.uint64(4))) ^ state) * np.uint64(277803737)) & _MASK32
    return ((word >> np.uint64(22)) ^ word).astype(np.uint32)


def _u32(v: int) -> int:
    return int(v) & _MASK32


def _hash_int(v: int) -> int:
    return int(hash_u32(np.uint64(_u32(v))))


def seed_offset_parts(seed: int) -> tuple[NDArray[np.int32], NDArray[np.float32]]:
    """`seed_offset(seed)` as (integer cell in [0, 256), fraction in (0, 1)); both exact, sum exact."""
    h = _u32(seed)
    cells, fracs = [], []
    for _ in range(3):
        h = _hash_int(h)
        v = (h >> 8) | 1
        cells.append(v >> 16)
        fracs.append((v & 0xFFFF) / 65536.0)
    return np.array(cells, dtype=np.int32), np.array(fracs, dtype=np.float32)


def seed_offset(seed: int) -> NDArray[np.float64]:
    """Deterministic domain offset in [0, 256)^3 with a non-zero 16-bit fraction (see module doc)."""
    cell, frac = seed_offset_parts(seed)
    return cell.astype(np.float64) + frac.astype(np.float64)


def split_scale(scale: float) -> tuple[float, float]:
    """`scale` = hi + lo (to ~2^-35 relative), hi with 10 significant bits, both float32-exact.

    (x + 0.5) * hi is then exact in float32 for x < 8192, so the GPU's noise coordinate is as
    accurate as its fractional part allows, however many pixels wide the image is.
    """
    if not math.isfinite(scale):
        raise ValueError(f"scale: expected a finite number, got {scale!r}")
    if scale == 0.0:
        return 0.0, 0.0
    m, e = math.frexp(scale)
    hi = math.ldexp(round(m * 1024.0), e - 10)
    lo = float(np.float32(scale - hi))
    return hi, lo


def screen_lattice_z(seed_cell: NDArray[np.int32], seed_frac: NDArray[np.float32], octaves: int) -> tuple[int, ...]:
    """The lattice z index of each octave of the screen-space noise (`screen_offsets`), as the shader derives it:
    the coordinate's z is the seed offset's alone (times 2^i at octave i), the same for every pixel and both
    channels, so octave i's cell is (cell_z * 2^i + floor(frac_z * 2^i)) mod 256, frac_z in float32."""
    cz, fz = int(seed_cell[2]) & 255, np.float32(seed_frac[2])
    out = []
    for i in range(_check_octaves(octaves)):
        out.append((cz + int(np.floor(fz * np.float32(2.0 ** i)))) & 255)
        cz = (cz * 2) & 255
    return tuple(out)


def gradient_table(z: int) -> NDArray[np.uint32]:
    """(256, 256) uint32, [Y, X]: the hashes (`& 15`) of the eight corners of lattice cell (X, Y, z) of Ken Perlin's
    improved noise, 4 bits each, in the order the shader blends them: (x, y, z) corners 000, 100, 010, 110, 001,
    101, 011, 111 from the low bits up. With z fixed (screen-space noise), one fetch of this table replaces the
    twelve permutation lookups of a noise value (`perlin_noise`: llvmpipe spends most of the pass on them)."""
    perm = PERM.astype(np.int64)

    def at(i: NDArray[np.int64]) -> NDArray[np.int64]:
        return perm[i & 255]

    x = np.arange(256, dtype=np.int64)[None, :]
    y = np.arange(256, dtype=np.int64)[:, None]
    a, b = at(x) + y, at(x + 1) + y
    aa, ab, ba, bb = at(a) + z, at(a + 1) + z, at(b) + z, at(b + 1) + z
    corners = (at(aa), at(ba), at(ab), at(bb), at(aa + 1), at(ba + 1), at(ab + 1), at(bb + 1))
    out = np.zeros((256, 256), np.uint32)
    for k, h in enumerate(corners):
        out |= ((h & 15).astype(np.uint32) << np.uint32(4 * k))
    return out


def _check_size(width: int, height: int) -> None:
    if int(width) != width or int(height) != height or width < 1 or height < 1:
        raise ValueError(f"size: expected positive integers width, height, got ({width!r}, {height!r})")


# --- what the node produces ----------------------------------------------------------------------

def screen_offsets(width: int, height: int, scale: float, octaves: int, seed: int,
                   mode: Mode = "turbulence") -> NDArray[np.float64]:
    """(H, W, 2) offsets (off_s, off_t) of paper §3.2; row 0 = bottom. Mapping: see module doc."""
    _check_size(width, height)
    fn = _octave_fn(mode)
    o = seed_offset(seed)
    px = np.arange(width, dtype=np.float64) + 0.5     # s * W
    py = np.arange(height, dtype=np.float64) + 0.5    # t * H
    sx, ty = np.meshgrid(px, py)                      # (H, W)
    z = np.full(sx.shape, o[2])
    off_s = fn(sx * scale + o[0], ty * scale + o[1], z, octaves)
    off_t = fn((width - sx) * scale + o[0], (height - ty) * scale + o[1], z, octaves)
    return np.stack([off_s, off_t], axis=-1)


def noise3_at(points: ArrayLike, octaves: int, seed: int, mode: Mode = "turbulence",
              scale: float = 1.0) -> NDArray[np.float64]:
    """(..., 2) turbulence/fbm at object-space points (..., 3): F(q), F(q + CHANNEL1_OFFSET),
    q = points * scale + seed_offset(seed)."""
    fn = _octave_fn(mode)
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim < 1 or pts.shape[-1] != 3:
        raise ValueError(f"points: expected shape (..., 3), got {pts.shape}")
    q = pts * scale + seed_offset(seed)
    r = q + CHANNEL1_OFFSET
    return np.stack([fn(q[..., 0], q[..., 1], q[..., 2], octaves),
                     fn(r[..., 0], r[..., 1], r[..., 2], octaves)], axis=-1)


def white_stream(seed: int, frame: int, channel: int) -> int:
    """Third hash key of channel `channel` (0 or 1) of `white_offsets`."""
    return _hash_int(_hash_int(seed) + 2 * _u32(frame) + int(channel))


def white_noise(kx: ArrayLike, ky: ArrayLike, kz: ArrayLike) -> NDArray[np.float64]:
    """(hash_u32(kx + hash_u32(ky + hash_u32(kz))) >> 8) / 2^24: uniform in [0, 1), 24 bits."""
    kx, ky, kz = (np.asarray(k).astype(np.uint64) & _MASK32 for k in (kx, ky, kz))
    h = hash_u32(kx + hash_u32(ky + hash_u32(kz)).astype(np.uint64))
    return (h >> np.uint32(8)).astype(np.float64) / 16777216.0


def white_offsets(width: int, height: int, seed: int, frame: int = 0,
                  cell_ratio: tuple[int, int] = (1, 1)) -> NDArray[np.float64]:
    """(H, W, 2) uncorrelated offsets in [0, 1) (paper §3.4); row 0 = bottom. Pixel i reads grain cell
    i * cell_ratio[0] // cell_ratio[1] (integers: exact on the GPU too), so with (reference size, shorter
    side) a grain covers one pixel of the reference size whatever the image size."""
    _check_size(width, height)
    num, den = (int(c) for c in cell_ratio)
    xs, ys = np.meshgrid(np.arange(width, dtype=np.uint64) * num // den,
                         np.arange(height, dtype=np.uint64) * num // den)
    return np.stack([white_noise(xs, ys, white_stream(seed, frame, c)) for c in (0, 1)], axis=-1)


# --- scalar transcription, used by the tests to check `improved_noise` ---------------------------

def _scalar_reference_noise(x: float, y: float, z: float) -> float:
    """Line-by-line Python transcription of Perlin's Java `ImprovedNoise.noise` (2002)."""
    p = [int(v) for v in PERM] * 2

    def fade(t: float) -> float:
        return t * t * t * (t * (t * 6 - 15) + 10)

    def lerp(t: float, a: float, b: float) -> float:
        return a + t * (b - a)

    def grad(hash_: int, x: float, y: float, z: float) -> float:
        h = hash_ & 15
        u = x if h < 8 else y
        v = y if h < 4 else (x if h == 12 or h == 14 else z)
        return (u if (h & 1) == 0 else -u) + (v if (h & 2) == 0 else -v)

    X = math.floor(x) & 255
    Y = math.floor(y) & 255
    Z = math.floor(z) & 255
    x -= math.floor(x)
    y -= math.floor(y)
    z -= math.floor(z)
    u, v, w = fade(x), fade(y), fade(z)
    A = p[X] + Y
    AA = p[A] + Z
    AB = p[A + 1] + Z
    B = p[X + 1] + Y
    BA = p[B] + Z
    BB = p[B + 1] + Z
    return lerp(w, lerp(v, lerp(u, grad(p[AA], x, y, z), grad(p[BA], x - 1, y, z)),
                        lerp(u, grad(p[AB], x, y - 1, z), grad(p[BB], x - 1, y - 1, z))),
                lerp(v, lerp(u, grad(p[AA + 1], x, y, z - 1), grad(p[BA + 1], x - 1, y, z - 1)),
                     lerp(u, grad(p[AB + 1], x, y - 1, z - 1), grad(p[BB + 1], x - 1, y - 1, z - 1))))


def turn_pairs(pairs: ArrayLike, spin: ArrayLike, scale: tuple[float, float] = (1.0, 1.0)) -> NDArray[np.float64]:
    """(..., 2) offset pairs turned by the angle of `spin` ((..., 2+) as rasterize.spin writes it, (cos, sin) of any
    length; (0, 0) where nothing was drawn: not turned), in a frame scaled by `scale` (pairs in texture units turned
    in pixels: `scale` the image size). float64 reference of the turns in object_noise's spin_turn.glsl and
    sketch.glsl."""
    s = np.asarray(spin, dtype=np.float64)[..., :2]
    n = np.linalg.norm(s, axis=-1, keepdims=True)
    s = np.where(n > 0, s / np.where(n > 0, n, 1.0), [1.0, 0.0])
    k = np.asarray(scale, dtype=np.float64)
    p = np.asarray(pairs, dtype=np.float64) * k
    return np.stack([s[..., 0] * p[..., 0] - s[..., 1] * p[..., 1],
                     s[..., 1] * p[..., 0] + s[..., 0] * p[..., 1]], axis=-1) / k
