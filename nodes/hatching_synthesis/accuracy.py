"""Accuracy of tonal art map synthesis: how close each tone's measured darkness comes to its target, how
evenly a tone covers the tile, and how many strokes the darkest tone needs. `sketchgraph bench accuracy
--families hatching` runs `measure`."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np


def _quiet(msg: str) -> None:
    pass


def _median_ms(fn: Callable[[], Any], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1000.0)
    return statistics.median(times)


def strokes_needed(size: int, stroke_width: float, tones: int = 32, max_darkness: float = 0.8) -> int:
    """Strokes the darkest tone takes (to 64 strokes): the smallest cap that synthesis accepts."""
    from .tam import synthesize_tam

    def ok(cap: int) -> bool:
        try:
            synthesize_tam(size=size, tones=2, strokes=cap, stroke_width=stroke_width, max_darkness=max_darkness)
            return True
        except ValueError:
            return False

    hi = 256
    while not ok(hi):
        hi *= 2
        if hi > 1 << 22:
            raise RuntimeError("hatching: darkness never reached")
    lo = hi // 2 if hi > 256 else 0
    while hi - lo > 64:
        mid = (lo + hi) // 2
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return hi


def local_tone_error(tam: np.ndarray, blocks: int = 8) -> float:
    """RMS over tones of the standard deviation of darkness over blocks x blocks tiles of the texture:
    how unevenly a tone covers the tile (what a viewer sees as blotches)."""
    t, h, w = tam.shape
    bh, bw = h // blocks, w // blocks
    d = 1.0 - tam[:, :bh * blocks, :bw * blocks].reshape(t, blocks, bh, blocks, bw).mean(axis=(2, 4))
    return float(np.sqrt(np.mean(d.reshape(t, -1).std(axis=1) ** 2)))


def measure(quick: bool, log: Callable[[str], None] = _quiet) -> dict[str, Any]:
    """The `hatching` family of `sketchgraph bench accuracy`: tonal art maps by texture size and stroke width;
    tone errors against the targets, local (blotch) error, strokes needed, time."""
    from .tam import measured_darkness, synthesize_tam, tone_targets

    sizes = [64, 128, 256] if quick else [64, 128, 256, 512]
    widths = [1.1] if quick else [0.7, 1.1, 2.0]
    entries = []
    for size in sizes:
        for sw in widths:
            ms = _median_ms(lambda size=size, sw=sw: synthesize_tam(size=size, stroke_width=sw, strokes=400000),
                            1 if size >= 512 else 3)
            tam = synthesize_tam(size=size, stroke_width=sw, strokes=400000)
            err = np.abs(measured_darkness(tam) - tone_targets(32, 0.8))
            entries.append({"method": f"{size}px w{sw:g}", "size": size, "stroke_width": sw,
                            "strokes": None if quick else strokes_needed(size, sw),
                            "tone_error_max": float(err.max()), "tone_error_mean": float(err.mean()),
                            "local_tone_error": local_tone_error(tam), "ms": ms})
    log("  hatching: " + ", ".join(f"{e['method']} {e['ms']:.0f} ms local {e['local_tone_error']:.3f}"
                                   for e in entries))
    return {"entries": entries, "tones": 32, "max_darkness": 0.8}
