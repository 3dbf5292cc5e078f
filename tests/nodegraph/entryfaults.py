"""Fault injection for cache and mesh-store entries (tests/nodegraph/test_cache_checksum.py,
test_meshstore_faults.py): damage an EXR's pixel data while keeping its header, truncate a file, rewrite an npz's
arrays with or without a matching checksum, put a FIFO, a directory or a symbolic link where an entry belongs, and
record every path this process opens, with a FIFO that tells (from another process) whether anyone opened it."""

from __future__ import annotations

import builtins
import contextlib
import io
import json
import os
import struct
import subprocess
import sys
import textwrap
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from nodegraph.values import Arrays, Strokes, Tex, TexArray

EXR_MAGIC = 20000630


def exr_chunks(path: Path) -> list[tuple[int, int]]:
    """(offset, size) of the pixel data of every chunk of a single-part scanline EXR, read from its offset table
    (the header before it is left alone)."""
    raw = path.read_bytes()
    magic, version = struct.unpack_from("<ii", raw, 0)
    assert magic == EXR_MAGIC and not version & 0x1200, "a single-part scanline EXR"
    pos = 8
    while raw[pos] != 0:  # attributes: name\0 type\0 size value
        pos = raw.index(b"\0", pos) + 1
        pos = raw.index(b"\0", pos) + 1
        (size,) = struct.unpack_from("<i", raw, pos)
        pos += 4 + size
    table = pos + 1
    (first,) = struct.unpack_from("<Q", raw, table)
    count = (first - table) // 8
    out = []
    for i in range(count):
        (off,) = struct.unpack_from("<Q", raw, table + 8 * i)
        _, size = struct.unpack_from("<ii", raw, off)
        out.append((off + 8, size))
    return out


def alter_exr_payload(path: Path, nbytes: int = 16) -> None:
    """XOR `nbytes` bytes in the middle of the middle chunk's pixel data: the header, the offset table and every
    chunk's size stay as they were."""
    chunks = exr_chunks(path)
    off, size = chunks[len(chunks) // 2]
    start = off + max(0, size // 2 - nbytes // 2)
    with open(path, "r+b") as fh:
        fh.seek(start)
        data = bytearray(fh.read(min(nbytes, size)))
        fh.seek(start)
        fh.write(bytes(b ^ 0x5A for b in data))


def truncate(path: Path, keep: float = 0.6) -> None:
    size = path.stat().st_size
    with open(path, "r+b") as fh:
        fh.truncate(int(size * keep))


def npz_contents(path: Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    with np.load(path) as z:
        arrays = {k: np.array(z[k]) for k in z.files if k != "__meta__"}
        meta = json.loads(str(z["__meta__"]))
    return arrays, meta


def write_npz(path: Path, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
    """An npz entry with these arrays and this metadata, written in place (as another program would)."""
    tmp = path.with_name("rewrite.tmp")
    with open(tmp, "wb") as fh:
        np.savez(fh, __meta__=np.array(json.dumps(meta)), **arrays)
    tmp.replace(path)


def forge_meta(arrays: dict[str, np.ndarray], meta: dict[str, Any], mesh_store: bool) -> dict[str, Any]:
    """`meta` with a checksum (and for the mesh store an array profile) that match `arrays`: an entry whose only
    defence left is the check of its contents (the worst case: not a damaged file, a forged one)."""
    from nodegraph import cache as cachemod

    if mesh_store:
        from nodegraph.scene import meshstore

        return {**meta, "checksum": cachemod.payload_checksum(sorted(arrays.items())),
                "arrays": meshstore._profile(arrays)}
    extra = cachemod._npz_extra(meta.get("kind"), meta.get("fmt"))
    return {**meta, "checksum": cachemod.payload_checksum(sorted(arrays.items()), extra)}


def put_directory(path: Path, contents: str) -> None:
    """A directory named like the entry: "empty", "temps" (only temporary files of this cache) or "user" (a file
    of someone else's)."""
    path.unlink()
    path.mkdir()
    if contents == "temps":
        (path / ".tmp-1@host-aaaa.exr").write_bytes(b"x" * 10)
    elif contents == "user":
        (path / "notes.txt").write_text("mine")


def put_symlink(path: Path, target: str | Path) -> None:
    path.unlink()
    os.symlink(target, path)


class OpenRecorder:
    """Every path opened in this process (builtins.open, io.open, os.open, np.load by name, OpenImageIO's
    ImageInput.open) while installed; `opened(path)` says whether `path` was among them."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch):
        self.paths: list[str] = []
        rec = self.paths

        def wrap(fn: Callable) -> Callable:
            def recorded(file: Any, *a: Any, **k: Any) -> Any:
                if isinstance(file, (str, bytes, os.PathLike)):
                    rec.append(os.fsdecode(file))
                return fn(file, *a, **k)
            return recorded

        monkeypatch.setattr(builtins, "open", wrap(builtins.open))
        monkeypatch.setattr(io, "open", wrap(io.open))
        monkeypatch.setattr(os, "open", wrap(os.open))
        monkeypatch.setattr(np, "load", wrap(np.load))
        import OpenImageIO as oiio

        monkeypatch.setattr(oiio.ImageInput, "open", staticmethod(wrap(oiio.ImageInput.open)))

    def opened(self, path: Path) -> bool:
        want = os.path.abspath(path)
        return any(os.path.abspath(p) == want for p in self.paths)


_GUARD = textwrap.dedent("""
    import os, sys, time
    fifo, marker = sys.argv[1], sys.argv[2]
    while True:
        try:
            fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)  # succeeds only while a reader has the FIFO open
        except OSError:
            time.sleep(0.005)
            continue
        with open(marker, "a") as fh:
            fh.write("opened\\n")
        os.close(fd)  # the reader sees end of file: it never waits forever
        time.sleep(0.005)
""")


@contextlib.contextmanager
def fifo_at(path: Path, guard_dir: Path) -> Iterator[Callable[[], bool]]:
    """A FIFO at `path` (where an entry belongs), which would make any open() for reading wait forever, watched
    by another process through a hard link of its own: if anything opens it, the watcher notices (and lets the
    reader go, so the test fails instead of hanging). Yields `was_opened()`."""
    guard_dir.mkdir(parents=True, exist_ok=True)
    fifo = guard_dir / "watched.fifo"
    marker = guard_dir / "opened.txt"
    os.mkfifo(fifo)
    if path.exists() or path.is_symlink():
        path.unlink()
    os.link(fifo, path)  # the same FIFO under the entry's name; the watcher's name outlives its removal
    watcher = subprocess.Popen([sys.executable, "-c", _GUARD, str(fifo), str(marker)])
    try:
        yield lambda: marker.exists()
    finally:
        watcher.kill()
        watcher.wait()


def host_value(value: Any) -> Any:
    """A node value as plain host data, comparable with ==."""
    if isinstance(value, (Tex, TexArray)):
        return (value.fmt, value.read())
    if isinstance(value, Strokes):
        return (value.size, value.width, value.color, [p.tolist() for p in value.polylines])
    if isinstance(value, Arrays):
        return {k: (v.dtype.str, v.tolist()) for k, v in value.data.items()}
    return value


def assert_same_values(a: dict, b: dict) -> None:
    """Two runs' host values equal, arrays bit for bit."""
    assert a.keys() == b.keys()
    for ref in a:
        x, y = a[ref], b[ref]
        if isinstance(x, tuple) and len(x) == 2 and isinstance(x[1], np.ndarray):
            assert x[0] == y[0], ref
            np.testing.assert_array_equal(x[1], y[1], err_msg=str(ref))
        else:
            assert x == y, ref
