"""`sketchgraph bench checksum`: what the cache entries' checksum costs (nodegraph/cache.py, "Checksums"): the
time to checksum the pixels of an 800x800 and a 3840x2160 RGBA16F / RGBA32F buffer with the chosen hash
(zlib.crc32, `payload_checksum`) and with the alternatives considered, and the share of the checksum in a whole
cache read (`Cache.load` of an EXR entry, checksum included), for pixels that EXR stores zip-compressed (smooth)
and uncompressed (noise). Times are the best and the median of the repeats, in ms of wall time.

    sketchgraph bench checksum [--repeats 7] [--json F]
"""

from __future__ import annotations

import hashlib
import json
import statistics
import tempfile
import time
import zlib
from pathlib import Path
from typing import Any

import click
import numpy as np

from ... import cache as cachemod
from ...fsio import atomic_write_text

SIZES = {"800x800": (800, 800), "4K": (2160, 3840)}
FORMATS = {"RGBA16F": np.float16, "RGBA32F": np.float32}
HASHES = {
    "crc32 (chosen)": lambda a: cachemod.payload_checksum([("pixels", a)]),
    "adler32": lambda a: zlib.adler32(a.reshape(-1).view(np.uint8)),
    "blake2b": lambda a: hashlib.blake2b(a.reshape(-1).view(np.uint8), digest_size=16).digest(),
    "sha1": lambda a: hashlib.sha1(a.reshape(-1).view(np.uint8)).digest(),
}


def timed(fn: Any, repeats: int) -> tuple[float, float]:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t) * 1e3)
    return min(times), statistics.median(times)


def pixels(h: int, w: int, dtype: type, content: str) -> np.ndarray:
    if content == "noise":
        return np.random.default_rng(0).random((h, w, 4), dtype=np.float32).astype(dtype)
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    return np.stack([x / w, y / h, (x + y) / (w + h), np.ones_like(x)], axis=-1).astype(dtype)


@click.command()
@click.option("--repeats", default=7, show_default=True, help="Timed repeats of each measurement.")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def command(repeats: int, json_path: Path | None) -> None:
    """Cost of the cache entries' checksum: per buffer size and format, and its share of a cache read."""
    figures: dict[str, Any] = {"zlib": zlib.ZLIB_RUNTIME_VERSION, "repeats": repeats, "buffers": []}
    click.echo(f"zlib {zlib.ZLIB_RUNTIME_VERSION}, numpy {np.__version__}, repeats {repeats}; ms best / median")
    with tempfile.TemporaryDirectory() as tmp:
        cache = cachemod.Cache(Path(tmp), limit=1 << 40)
        for size, (h, w) in SIZES.items():
            for fmt, dtype in FORMATS.items():
                arr = pixels(h, w, dtype, "smooth")
                mb = arr.nbytes / 1e6
                hashes = {name: timed(lambda f=f, a=arr: f(a), repeats) for name, f in HASHES.items()}
                line = ", ".join(f"{n} {b:.1f}/{m:.1f}" for n, (b, m) in hashes.items())
                click.echo(f"{size} {fmt} ({mb:.1f} MB) hash: {line}")
                row: dict[str, Any] = {"size": size, "format": fmt, "mb": mb,
                                       "hash_ms": {n: {"best": b, "median": m} for n, (b, m) in hashes.items()},
                                       "reads": []}
                figures["buffers"].append(row)
                crc = hashes["crc32 (chosen)"][0]
                for content in ("smooth", "noise"):
                    data = pixels(h, w, dtype, content)
                    key = f"{len(size):02d}" + "0" * 62
                    port = f"{content}.{fmt}"
                    cache.store(key, port, "texture", data, {}, fmt)
                    comp = cachemod.exr_compression(np.ascontiguousarray(data[::-1]))
                    assert cache.load(key, port) is not None
                    best, med = timed(lambda k=key, p=port: cache.load(k, p), repeats)
                    click.echo(f"    cache read, {content} ({comp}): {best:.1f}/{med:.1f} ms; checksum share "
                               f"{100 * crc / med:.0f}% of the median read ({100 * crc / best:.0f}% of the best)")
                    row["reads"].append({"content": content, "compression": comp, "best_ms": best,
                                         "median_ms": med, "checksum_share_of_median": crc / med})
        cache.close()
    if json_path:
        atomic_write_text(json_path, json.dumps(figures, indent=2) + "\n")
