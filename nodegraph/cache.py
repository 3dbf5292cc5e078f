"""Content-addressed disk cache: textures as EXR (OpenImageIO), arrays and strokes as .npz.

Every entry is `ROOT/<key[:2]>/<key>.<port>.<ext>`; an EXR's header carries the key, the node type,
its params and the versions, so a cached file explains itself. Writes are atomic (temporary file,
then rename). A file that fails to read, or whose header does not match its key, is deleted and
recomputed with a warning. The cache is bounded: least-recently-used entries (by mtime, refreshed on
every hit) are evicted past the size limit.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
import threading
import warnings
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from . import types
from .values import Arrays, Strokes, Tex, TexArray

DEFAULT_LIMIT = 2 * 1024**3
FORMAT_VERSION = "1"


class CacheWarning(UserWarning):
    pass


def default_root() -> Path:
    env = os.environ.get("SKETCHGRAPH_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sketchgraph"


def default_limit() -> int:
    env = os.environ.get("SKETCHGRAPH_CACHE_LIMIT")
    if not env:
        return DEFAULT_LIMIT
    try:
        limit = parse_bytes(env)
    except (ValueError, OverflowError):
        limit = -1
    if limit < 0:
        from .errors import SketchgraphError

        shown = "".join(c if c.isprintable() else "?" for c in env[:40]) + ("..." if len(env) > 40 else "")
        raise SketchgraphError(f"SKETCHGRAPH_CACHE_LIMIT: expected a size such as 500M, 2G or 0, found '{shown}'")
    return limit


def parse_bytes(text: str) -> int:
    t = text.strip().upper().removesuffix("B").removesuffix("I")
    mult = {"K": 1024, "M": 1024**2, "G": 1024**3, "T": 1024**4}
    if t and t[-1] in mult:
        return int(float(t[:-1]) * mult[t[-1]])
    return int(float(t))


@dataclass
class Entry:
    path: Path
    size: int
    mtime: float


@dataclass
class Loaded:
    kind: str  # "texture" | "texture_array" | "strokes" | "arrays"
    data: Any  # np.ndarray (H,W,C) / (L,H,W,C), Strokes or Arrays
    fmt: str | None = None


def kind_of(value: Any) -> str | None:
    """How a value is stored: "texture" (EXR), "texture_array", "strokes" or "arrays" (.npz); None for values
    that are never cached (scenes and meshes are sources). The one switch on value type for storage."""
    if isinstance(value, Tex):
        return "texture"
    if isinstance(value, TexArray):
        return "texture_array"
    if isinstance(value, Strokes):
        return "strokes"
    if isinstance(value, Arrays):
        return "arrays"
    return None


class Cache:
    def __init__(self, root: Path | None = None, limit: int | None = None):
        self.root = Path(root) if root else default_root()
        self.limit = default_limit() if limit is None else limit
        self._writer: ThreadPoolExecutor | None = None
        self._pending: list[Future] = []
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0
        self.writes = 0
        self.recovered = 0

    # -- paths -----------------------------------------------------------------------------
    def _base(self, key: str, port: str) -> Path:
        return self.root / key[:2] / f"{key}.{port}"

    def find(self, key: str, port: str) -> Path | None:
        base = self._base(key, port)
        for ext in (".exr", ".npz"):
            p = base.with_name(base.name + ext)
            if p.exists():
                return p
        return None

    # -- read ------------------------------------------------------------------------------
    def load(self, key: str, port: str, node_label: str = "") -> Loaded | None:
        path = self.find(key, port)
        if path is None:
            self.misses += 1
            return None
        try:
            loaded = _read_exr(path, key) if path.suffix == ".exr" else _read_npz(path, key)
        except Exception as exc:  # noqa: BLE001 - any failure: discard and recompute
            self.recovered += 1
            warnings.warn(f"cache entry {path} for {node_label or 'a node'} is unusable ({exc}); "
                          "recomputing it", CacheWarning, stacklevel=2)
            with contextlib.suppress(OSError):
                path.unlink()
            self.misses += 1
            return None
        with contextlib.suppress(OSError):
            os.utime(path)  # LRU: a hit refreshes the entry
        self.hits += 1
        return loaded

    # -- write -----------------------------------------------------------------------------
    def store_value(self, key: str, port: str, value: Any, meta: dict[str, Any], background: bool = False) -> bool:
        """Write a node's output value (textures are read back to the host first). Returns False, writing
        nothing, for a value that is never cached; `load` gives it back as host data with its kind."""
        kind = kind_of(value)
        if kind is None:
            return False
        if kind in ("texture", "texture_array"):
            self.store(key, port, kind, value.read(), meta, value.fmt, background=background)
        else:
            self.store(key, port, kind, value, meta, background=background)
        return True

    def store(self, key: str, port: str, kind: str, data: Any, meta: dict[str, Any], fmt: str | None = None,
              background: bool = False) -> None:
        """Write one output. With `background`, the encode and the write happen on a worker thread."""
        if background:
            with self._lock:
                if self._writer is None:
                    self._writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="sketchgraph-cache")
                self._pending.append(self._writer.submit(self._store, key, port, kind, data, meta, fmt))
        else:
            self._store(key, port, kind, data, meta, fmt)

    def _store(self, key: str, port: str, kind: str, data: Any, meta: dict[str, Any], fmt: str | None) -> None:
        base = self._base(key, port)
        base.parent.mkdir(parents=True, exist_ok=True)
        if kind == "texture":
            final = base.with_name(base.name + ".exr")
            _atomic(final, lambda tmp: _write_exr(tmp, data, fmt or "RGBA32F", key, port, meta))
        else:
            final = base.with_name(base.name + ".npz")
            _atomic(final, lambda tmp: _write_npz(tmp, kind, data, key, port, meta, fmt))
        self.writes += 1

    def flush(self) -> None:
        with self._lock:
            pending, self._pending = self._pending, []
        for fut in pending:
            try:
                fut.result()
            except Exception as exc:  # noqa: BLE001 - a failed write loses only a cache entry
                warnings.warn(f"cache write failed: {exc}", CacheWarning, stacklevel=2)

    def close(self) -> None:
        self.flush()
        if self._writer is not None:
            self._writer.shutdown(wait=True)
            self._writer = None

    # -- maintenance -----------------------------------------------------------------------
    def entries(self) -> list[Entry]:
        out = []
        if not self.root.exists():
            return out
        for p in self.root.glob("*/*"):
            if p.suffix in (".exr", ".npz") and not p.name.startswith(".tmp"):
                try:
                    st = p.stat()
                except OSError:
                    continue
                out.append(Entry(p, st.st_size, st.st_mtime))
        return out

    def info(self) -> dict[str, Any]:
        ents = self.entries()
        return {
            "root": str(self.root),
            "entries": len(ents),
            "bytes": sum(e.size for e in ents),
            "limit": self.limit,
            "by_kind": {"exr": sum(1 for e in ents if e.path.suffix == ".exr"),
                        "npz": sum(1 for e in ents if e.path.suffix == ".npz")},
        }

    def prune(self, limit: int | None = None) -> tuple[int, int]:
        """Evict least-recently-used entries until the total is within `limit`. Returns (files, bytes) freed."""
        limit = self.limit if limit is None else limit
        ents = sorted(self.entries(), key=lambda e: e.mtime)
        total = sum(e.size for e in ents)
        files = freed = 0
        for e in ents:
            if total <= limit:
                break
            try:
                e.path.unlink()
            except OSError:
                continue
            total -= e.size
            freed += e.size
            files += 1
        return files, freed


def _atomic(final: Path, write: Any) -> None:
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=final.suffix, dir=final.parent)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, final)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _meta_attrs(key: str, port: str, meta: dict[str, Any]) -> dict[str, str]:
    return {
        "sketchgraph:key": key,
        "sketchgraph:port": port,
        "sketchgraph:format": FORMAT_VERSION,
        "sketchgraph:node": str(meta.get("node", "")),
        "sketchgraph:type": str(meta.get("type", "")),
        "sketchgraph:version": str(meta.get("version", "")),
        "sketchgraph:params": json.dumps(meta.get("params", {}), sort_keys=True, default=str),
        "sketchgraph:package": str(meta.get("package", "")),
    }


def _write_exr(path: str, arr: np.ndarray, fmt: str, key: str, port: str, meta: dict[str, Any]) -> None:
    import OpenImageIO as oiio

    arr = np.ascontiguousarray(arr[::-1], dtype=np.float32)  # EXR rows run top-down
    h, w, c = arr.shape
    pixel = oiio.FLOAT if types.precision(fmt) >= 2 else oiio.HALF
    spec = oiio.ImageSpec(w, h, c, pixel)
    spec.channelnames = tuple("RGBA"[:c]) if c != 2 else ("R", "G")
    spec.attribute("compression", "zip" if c * w * h > 0 else "none")
    for k, v in _meta_attrs(key, port, meta).items():
        spec.attribute(k, v)
    spec.attribute("sketchgraph:fmt", fmt)
    out = oiio.ImageOutput.create(path if path.endswith(".exr") else path + ".exr")
    if out is None:
        raise OSError(oiio.geterror())
    # mkstemp gave a .exr suffix, so OIIO picks the EXR writer from the name
    if not out.open(path, spec):
        raise OSError(out.geterror())
    if not out.write_image(arr):
        raise OSError(out.geterror())
    out.close()


def _read_exr(path: Path, key: str) -> Loaded:
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(oiio.geterror() or "cannot open")
    try:
        spec = inp.spec()
        got = spec.get_string_attribute("sketchgraph:key")
        if got != key:
            raise ValueError(f"header key {got[:12] or 'missing'} does not match {key[:12]}")
        fmt = spec.get_string_attribute("sketchgraph:fmt") or None
        pixels = inp.read_image(oiio.FLOAT)
        if pixels is None or not isinstance(pixels, np.ndarray):
            raise OSError(inp.geterror() or "no pixels")
    finally:
        inp.close()
    arr = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)[::-1]
    return Loaded("texture", np.ascontiguousarray(arr), fmt)


def _write_npz(path: str, kind: str, data: Any, key: str, port: str, meta: dict[str, Any], fmt: str | None) -> None:
    payload: dict[str, Any] = {"__meta__": np.array(json.dumps({**_meta_attrs(key, port, meta), "kind": kind,
                                                                 "fmt": fmt}))}
    if kind == "texture_array":  # stored in the texture's own precision (8-bit tones stay 8-bit)
        arr = np.asarray(data, dtype=np.float32)
        dt = types.numpy_dtype(fmt) if fmt else np.dtype(np.float32)
        payload["data"] = np.clip(np.rint(arr * 255.0), 0, 255).astype(np.uint8) if dt == np.uint8 else arr.astype(dt)
    elif kind == "strokes":
        s: Strokes = data
        lengths = np.array([len(p) for p in s.polylines], dtype=np.int64)
        payload["points"] = (np.concatenate(s.polylines).astype(np.float32) if s.polylines
                             else np.zeros((0, 2), np.float32))
        payload["lengths"] = lengths
        payload["size"] = np.array(s.size)
        payload["style"] = np.array([s.width, *s.color], dtype=np.float64)
    elif kind == "arrays":
        a: Arrays = data
        for name, value in a.data.items():
            payload[f"a_{name}"] = value
    else:
        raise ValueError(f"cannot cache values of kind {kind}")
    with open(path, "wb") as fh:
        np.savez(fh, **payload)


def _read_npz(path: Path, key: str) -> Loaded:
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(str(z["__meta__"]))
        if meta.get("sketchgraph:key") != key:
            raise ValueError("header key does not match")
        kind = meta["kind"]
        if kind == "texture_array":
            data = np.array(z["data"])
            data = data.astype(np.float32) / 255.0 if data.dtype == np.uint8 else data.astype(np.float32)
            return Loaded(kind, data, meta.get("fmt"))
        if kind == "strokes":
            pts, lengths = np.array(z["points"]), np.array(z["lengths"])
            splits = np.cumsum(lengths)[:-1]
            polys = np.split(pts, splits) if len(lengths) else []
            style = z["style"]
            size = tuple(int(v) for v in z["size"])
            return Loaded(kind, Strokes(list(polys), size, float(style[0]), tuple(float(c) for c in style[1:4])))
        if kind == "arrays":
            return Loaded(kind, Arrays({k[2:]: np.array(z[k]) for k in z.files if k.startswith("a_")}))
    raise ValueError(f"unknown entry kind {kind}")
