"""Tonal art map (TAM) synthesis after Lee, Kwon and Lee, "Real-time pencil rendering" (NPAR 2006).

A TAM is a stack of ``tones`` tileable hatching textures, tone 0 the lightest.  Tones are *nested*: tone k
holds every stroke of tone k-1 plus new ones, so a renderer blending neighbouring tones never sees strokes
appear and vanish (the "same basis" problem of earlier implementations).

Stroke model (all lengths in pixels of the ``size`` x ``size`` tile unless said otherwise):

* a stroke is a near-horizontal band of width ``stroke_width``, starting at a random column, with a random
  length drawn uniformly from ``stroke_length`` (fractions of the tile width, at most 0.98 so a stroke never
  meets its own tail), a vertical position from a golden-ratio sequence with a seeded offset, jittered
  uniformly by ``y_jitter`` tile heights (so every prefix of strokes, hence every tone, covers the tile
  evenly instead of clumping), a random slope within +-``max_angle`` degrees and a
  sinusoidal wobble ``wobble_amplitude * sin(2 pi f x / size + phase)`` with f drawn from
  ``wobble_frequency`` * [0.75, 1.25] and a random phase;
* its opacity is the exact area coverage of the band over each pixel row (antialiasing), times a
  per-stroke pressure in [1 - ``pressure_jitter``, 1], times an end taper (opacity ramps up over the first
  and down over the last ``taper`` of its length), times a fixed paper grain in [1 - ``grain``, 1];
* coordinates wrap modulo ``size`` in x and y, so the tile repeats seamlessly.

Darkening (the paper's rule).  A stroke of colour ``c_s`` drawn with opacity ``a`` over a pixel has the
effective colour ``1 - a (1 - c_s)``; with ``c_t`` the pixel's current value (1 = white paper)::

    c_a  = c_t * a * (1 - c_s)          # the most this stroke may darken the pixel
    c_a *= mu_w   if c_t > white_threshold   # white preservation (see below)
    c_t' = c_t - mu_b * c_a

White preservation (our reading of mu_w): while a pixel is still near-white (its value before the stroke is
above ``white_threshold``) the darkening is scaled by ``mu_w`` < 1.  First touches on bare paper (and the
faint antialiased fringes of strokes) therefore stay light, while pixels that already carry graphite darken
at the full rate ``mu_b``; this keeps white gaps open between strokes and gives hatching, not a grey wash.
Strokes are applied in a fixed (seeded) order and the rule is evaluated exactly in that order per pixel.

Darkness of a tone is ``1 - mean(value)``.  Strokes are added one at a time until the running darkness
reaches each tone's target (:func:`tone_targets`, evenly spaced from 0, blank paper, to ``max_darkness``);
the tone is the tile at that moment.  A tone may overshoot its target by the last stroke's contribution
(measured at most 4e-4 at the defaults); the sequence is monotonic by construction.  ``strokes`` caps the count
(3322 strokes reach the darkest tone at the defaults).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

__all__ = ["measured_darkness", "synthesize_tam", "tone_targets"]

# Strokes are generated and composited in chunks of this many (exact: the per-pixel state carries over).
_CHUNK = 256
# Random attributes per stroke (one row each, drawn chunk by chunk from one stream).
_N_ATTR = 8
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def tone_targets(tones: int, max_darkness: float) -> np.ndarray:
    """Target mean darkness (1 - mean value) per tone: ``linspace(0, max_darkness, tones)``, float64."""
    if tones < 2:
        raise ValueError(f"tones must be >= 2, got {tones}")
    if not 0.0 < max_darkness < 1.0:
        raise ValueError(f"max_darkness must be in (0, 1), got {max_darkness}")
    return np.linspace(0.0, max_darkness, tones)


def measured_darkness(tam: np.ndarray) -> np.ndarray:
    """Mean darkness ``1 - mean(value)`` of each tone of a (tones, h, w) stack, float64."""
    tam = np.asarray(tam)
    if tam.ndim != 3:
        raise ValueError(f"expected a (tones, height, width) array, got shape {tam.shape}")
    return 1.0 - tam.reshape(tam.shape[0], -1).mean(axis=1, dtype=np.float64)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _paper_grain(size: int, grain: float, rng: np.random.Generator) -> np.ndarray:
    """Tileable grain multiplier in [1 - grain, 1]: white noise, wrapped 3x3 box blur, rescaled."""
    noise = rng.random((size, size))
    blurred = sum(np.roll(noise, (dy, dx), axis=(0, 1)) for dy in (-1, 0, 1) for dx in (-1, 0, 1))
    lo, hi = blurred.min(), blurred.max()
    unit = (blurred - lo) / (hi - lo) if hi > lo else np.zeros_like(blurred)
    return (1.0 - grain * unit).ravel()


def _stroke_chunks(
    size: int,
    seed: int,
    stroke_width: float,
    stroke_length: tuple[float, float],
    max_angle: float,
    y_jitter: float,
    wobble_amplitude: float,
    wobble_frequency: float,
    pressure_jitter: float,
    taper: float,
    grain: float,
    chunk: int = _CHUNK,
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Endless seeded stroke sequence, ``chunk`` strokes at a time: (pixel index, stroke id, opacity).

    Touches come in stroke order and have opacity > 0; one stroke touches a pixel at most once (its length
    is below the tile width and its rows span less than the tile height).
    """
    stroke_ss, grain_ss = np.random.SeedSequence(seed).spawn(2)
    rng = np.random.default_rng(stroke_ss)
    y_offset = float(rng.random())
    grain_px = _paper_grain(size, grain, np.random.default_rng(grain_ss))
    lo_len, hi_len = stroke_length
    first_id = 0
    while True:
        u = rng.random((chunk, _N_ATTR)).T
        ids = np.arange(first_id, first_id + chunk)
        x0 = u[0] * size
        # Vertical positions: a golden-ratio sequence with a seeded offset, jittered by y_jitter tile heights,
        # so every prefix of the sequence (every tone) covers the tile evenly.
        y0 = (np.modf(y_offset + ids * _GOLDEN)[0] + y_jitter * (u[1] - 0.5)) * size
        length = (lo_len + (hi_len - lo_len) * u[2]) * size
        slope = np.tan(np.radians(max_angle * (2.0 * u[3] - 1.0)))
        phase = 2.0 * np.pi * u[4]
        omega = 2.0 * np.pi * wobble_frequency * (0.75 + 0.5 * u[5]) / size
        amp = wobble_amplitude * (0.5 + 0.5 * u[6])
        pressure = 1.0 - pressure_jitter * u[7]
        ncols = np.maximum(np.rint(length).astype(np.int64), 1)

        j = np.arange(int(ncols.max()))[None, :]  # (1, J) column offset along the stroke
        xc = j + 0.5
        arg = omega[:, None] * xc + phase[:, None]
        yc = y0[:, None] + slope[:, None] * xc + amp[:, None] * np.sin(arg)  # (S, J) centre line
        dydx = slope[:, None] + (amp * omega)[:, None] * np.cos(arg)
        half = 0.5 * stroke_width * np.sqrt(1.0 + dydx * dydx)  # vertical half-thickness of the band

        ramp = np.maximum(taper * ncols, 1.0)[:, None]
        strength = pressure[:, None] * _smoothstep(xc / ramp) * _smoothstep((ncols[:, None] - xc) / ramp)
        strength[j >= ncols[:, None]] = 0.0

        rows = np.floor(yc - half)[:, :, None] + np.arange(int(math.ceil(2.0 * half.max())) + 1)
        cover = np.minimum(rows + 1.0, (yc + half)[:, :, None]) - np.maximum(rows, (yc - half)[:, :, None])
        alpha = np.clip(cover, 0.0, 1.0) * strength[:, :, None]  # exact row coverage of the band

        xi = (np.floor(x0).astype(np.int64)[:, None] + j) % size
        pix = rows.astype(np.int64) % size * size + xi[:, :, None]
        keep = alpha > 0.0
        pix = pix[keep]
        sid = np.broadcast_to(ids[:, None, None], keep.shape)[keep]
        yield pix, sid, alpha[keep] * grain_px[pix]
        first_id += chunk


def synthesize_tam(
    size: int = 256,
    tones: int = 32,
    strokes: int = 20000,
    mu_b: float = 0.6,
    mu_w: float = 0.5,
    c_s: float = 0.1,
    max_darkness: float = 0.8,
    wobble_amplitude: float = 1.0,
    wobble_frequency: float = 2.0,
    stroke_width: float = 1.1,
    seed: int = 0,
    *,
    stroke_length: tuple[float, float] = (0.2, 0.6),
    max_angle: float = 4.0,
    y_jitter: float = 0.25,
    white_threshold: float = 0.9,
    pressure_jitter: float = 0.35,
    taper: float = 0.15,
    grain: float = 0.35,
) -> np.ndarray:
    """Nested, tileable pencil-hatching tones, shape (tones, size, size) float32, 1 = white, tone 0 lightest.

    ``strokes`` caps the number of strokes drawn for the darkest tone; ValueError if ``max_darkness`` is not
    reached within it.  ``taper`` is a fraction of each stroke's length; see the module docstring for the
    stroke and darkening model.
    """
    targets = tone_targets(tones, max_darkness)
    lo_len, hi_len = (float(v) for v in stroke_length)
    checks = [
        (size >= 8, f"size must be >= 8, got {size}"),
        (strokes >= 1, f"strokes must be >= 1, got {strokes}"),
        (0.0 < mu_b <= 1.0, f"mu_b must be in (0, 1], got {mu_b}"),
        (0.0 < mu_w <= 1.0, f"mu_w must be in (0, 1], got {mu_w}"),
        (0.0 <= c_s < 1.0, f"c_s must be in [0, 1), got {c_s}"),
        (0.0 < stroke_width <= size / 4, f"stroke_width must be in (0, size/4], got {stroke_width}"),
        (wobble_amplitude >= 0.0, f"wobble_amplitude must be >= 0, got {wobble_amplitude}"),
        (wobble_frequency >= 0.0, f"wobble_frequency must be >= 0, got {wobble_frequency}"),
        (0.0 < lo_len <= hi_len <= 0.98, f"stroke_length needs 0 < lo <= hi <= 0.98, got {stroke_length}"),
        (0.0 <= max_angle < 45.0, f"max_angle must be in [0, 45) degrees, got {max_angle}"),
        (y_jitter >= 0.0, f"y_jitter must be >= 0, got {y_jitter}"),
        (0.0 < white_threshold < 1.0, f"white_threshold must be in (0, 1), got {white_threshold}"),
        (0.0 <= pressure_jitter < 1.0, f"pressure_jitter must be in [0, 1), got {pressure_jitter}"),
        (0.0 <= taper <= 0.5, f"taper must be in [0, 0.5], got {taper}"),
        (0.0 <= grain < 1.0, f"grain must be in [0, 1), got {grain}"),
    ]
    for ok, message in checks:
        if not ok:
            raise ValueError(message)
    if mu_b == 1.0 and c_s == 0.0:
        raise ValueError("mu_b = 1 with c_s = 0 paints pixels pure black in one stroke; lower one of them")

    chunks = _stroke_chunks(
        size, seed, stroke_width, (lo_len, hi_len), max_angle, y_jitter,
        wobble_amplitude, wobble_frequency, pressure_jitter, taper, grain,
    )  # fmt: skip

    npix = size * size
    log_white = math.log(white_threshold)
    value = np.ones(npix)  # current tile, float64
    total = 0.0  # running sum of darkening over all pixels: darkness * npix
    ends = np.full(tones, np.iinfo(np.int64).max, dtype=np.int64)  # strokes in tone k = ends[k]
    ends[targets <= 0.0] = 0
    known = int(np.count_nonzero(targets <= 0.0))  # tones whose stroke count is settled
    stack = np.ones((tones, npix))  # per tone, the value after its last stroke touching the pixel
    drawn = 0
    goal = targets * npix

    while known < tones:
        if drawn >= strokes:
            raise ValueError(
                f"max_darkness {max_darkness} not reached within {strokes} strokes (darkness "
                f"{total / npix:.3f}); raise strokes, mu_b or stroke_width"
            )
        pix, sid, alpha = next(chunks)
        n = _CHUNK
        if drawn + n > strokes:  # the cap falls inside this chunk
            n = strokes - drawn
            inside = sid < strokes
            pix, sid, alpha = pix[inside], sid[inside], alpha[inside]

        # Group touches per pixel, keeping stroke order inside a pixel (stable sort).
        order = np.argsort(pix.astype(np.uint16) if npix <= 1 << 16 else pix, kind="stable")
        pix, sid, alpha = pix[order], sid[order], alpha[order]
        first = np.empty(pix.shape, dtype=bool)
        first[:1] = True
        np.not_equal(pix[1:], pix[:-1], out=first[1:])
        start = np.maximum.accumulate(np.where(first, np.arange(pix.size), 0))

        def seg_exclusive(x: np.ndarray, start: np.ndarray = start) -> np.ndarray:
            inclusive = np.cumsum(x)
            exclusive = inclusive - x
            return exclusive - exclusive[start]

        ink = alpha * (1.0 - c_s) * mu_b
        log_f = np.log1p(-ink)
        log_fw = np.log1p(-ink * mu_w)
        log_c0 = np.log(value[pix])
        # While the value before a touch is above the threshold the white factor applies; under white-only
        # factors the value is non-increasing, so the white touches of a pixel are a prefix and this is exact.
        white = (log_c0 + seg_exclusive(log_fw)) > log_white
        log_step = np.where(white, log_fw, log_f)
        log_before = log_c0 + seg_exclusive(log_step)
        before = np.exp(log_before)
        after = np.exp(log_before + log_step)

        # Running darkness after each stroke of the chunk settles the tones whose targets it crosses.
        gain = np.bincount(sid - drawn, weights=before - after, minlength=n)
        running = total + np.cumsum(gain)
        while known < tones and running[-1] >= goal[known]:
            ends[known] = drawn + int(np.searchsorted(running, goal[known])) + 1
            known += 1
        total = float(running[-1])

        # Carry the tile state (every stroke of the chunk) into the next chunk.
        tail = np.empty(pix.shape, dtype=bool)
        tail[-1:] = True
        tail[:-1] = first[1:]
        value[pix[tail]] = after[tail]

        # A stroke belongs to the first tone whose end lies beyond it (unsettled ends are +inf, so final).
        tone = np.searchsorted(ends, sid, side="right")
        used = tone < tones
        pix, tone, after = pix[used], tone[used], after[used]
        key = tone * npix + pix
        last = np.ones(key.shape, dtype=bool)
        if key.size > 1:
            # Keys are sorted within a pixel; the last touch of a (pixel, tone) group holds its value.
            np.not_equal(key[:-1], key[1:], out=last[:-1])
        flat = stack.reshape(-1)
        flat[key[last]] = np.minimum(flat[key[last]], after[last])

        drawn += n

    np.minimum.accumulate(stack, axis=0, out=stack)
    return stack.reshape(tones, size, size).astype(np.float32)
