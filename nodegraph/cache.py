"""Content-addressed disk cache: textures as EXR (OpenImageIO), arrays and strokes as .npz.

Every entry is `ROOT/renderer-<digest>/<key[:2]>/<key>.<port>.<ext>`: node keys do not name the GL
renderer, so each renderer's entries live in their own folder and are never read for another (every run,
serial or on a cluster, binds its cache to its context's renderer string). An EXR's header (an npz's
`__meta__`) carries the key, the port, the kind, the format, the size, the node type, its params and the
versions, so a cached file explains itself, and the checksum of its payload (`sketchgraph:checksum`; an npz's
`checksum`).

Promises (docs/reliability.md, tests/nodegraph/test_cache_faults.py, test_cache_checksum.py):

- Never serve a wrong entry: `load` checks an entry against what the plan expects of it (`Expect`: port,
  kind, format, width, height, layers, channels, pixel type), then its payload against its checksum. A file
  that fails to read, differs in any of these, or whose pixels or arrays are not those it was written with
  (bytes altered behind an intact header, a truncated file, another entry's payload), is deleted and
  recomputed with one `CacheWarning` naming the entry, the node, the port and what differed. Entries written
  before the size fields existed are checked against their pixels. Entries written before the checksum are
  stale: removed and recomputed without a warning (`Cache.stale` counts them).
- Not a file, never opened: `find` and `load` look at an entry's path with `lstat` before anything opens it.
  A directory, FIFO, socket or device node, or a symbolic link that leaves the cache root, dangles or leads to
  anything but a regular file, is refused without being opened (a FIFO would block `open` forever) and taken
  away with one `CacheWarning` (`discard_entry`): the name is removed (a link, never its target); a directory
  is removed when it is empty or holds only this cache's temporary files, and otherwise renamed aside to
  `<name>.unusable-<random>`, since what it holds is not ours to delete; either way the next run neither
  finds it nor warns again. npz entries are opened with O_NOFOLLOW | O_NONBLOCK and checked again with fstat;
  an EXR is opened by OpenImageIO by name right after the lstat (it takes no file descriptor).
- Checksums: zlib's CRC-32 of the payload as stored (an EXR's pixels in file order with its format and its
  drawn footprint; an npz's arrays by name, with their dtypes and shapes, its kind and format), computed by
  the writer (on the writer thread for background writes) and checked by every read. CRC-32 is among the
  fastest hashes Python has without a new dependency (blake2b measured 2.5-6x slower, sha1 1.1-2x, adler32
  0.6-1.2x the time but weaker): it catches any burst error up to 32 bits and any other damage but one in 4
  billion; it is no defence against someone who rewrites the checksum too (nothing here is: the cache trusts
  its folder). Measured on the project's 2-core machine (`sketchgraph bench checksum`,
  best of 7, three runs, load average 2.8-4.8), CRC-32 of 800x800 RGBA16F 1.6-2.2 ms, RGBA32F 4.5-8 ms;
  3840x2160 RGBA16F 31-47 ms, RGBA32F 39-95 ms (0.3-0.8 ms per MB): 3-16% of a whole cache read of a
  zip-compressed entry (most: G-buffers, edges, images), 6-38% of an uncompressed one (noise, `STORED_ABOVE`),
  which reads fastest.
- A failed write never fails the render: any error while writing (disk full, read-only folder, a file
  where the folder should be, a file-size limit, permission denied) loses only that entry, with one
  warning per run. Background writes report the same way, from the main thread (at `flush`, at the next
  `store`, at `close`, or at interpreter exit).
- Worth its cost: the executor asks `worth_writing` before a single render writes an output; an entry
  estimated at `ALWAYS_WRITE_MS` or more (stored bytes at `ENTRY_MS_PER_MB`) is written only when
  recomputing it costs as much (docs/architecture.md, step 5). An entry not written is never lost data:
  the next run computes it, as it would any miss.
- Bounded: least-recently-used entries (by mtime, refreshed on every hit) are evicted past the size
  limit, and temporary files count toward it. Writes are atomic: a temporary file
  `.tmp-<pid>@<host>-<random>.<ext>` in the entry's folder, then a rename. `prune` removes a temporary
  file when it has not been modified for `STALE_TEMP_SECONDS` (an hour), or when it names this host
  and a process id that no longer runs (a killed writer); never a live process's own. Only the client
  process prunes, and only through `prune` / `maybe_prune` (the executor calls them: at the end of a
  run, and every `PRUNE_FRACTION` of the limit written during a frame loop); writers never do.
"""

from __future__ import annotations

import atexit
import contextlib
import errno
import hashlib
import json
import os
import re
import secrets
import socket
import stat
import tempfile
import threading
import time
import warnings
import weakref
import zlib
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from . import types
from .values import Arrays, Strokes, Tex, TexArray

DEFAULT_LIMIT = 2 * 1024**3
FORMAT_VERSION = "1"
TEMP_PREFIX = ".tmp-"
STALE_TEMP_SECONDS = 3600.0  # a temporary file untouched this long is a leftover, whoever wrote it
PRUNE_FRACTION = 0.125  # a frame loop prunes whenever it has written this fraction of the limit
MAX_PENDING_WRITES = 6  # background writes queued at most; the next `store` waits for one to finish
WRITER_THREADS = 2
"""Background writes run two at a time: a single render's chosen entries are written while its image is
encoded, and the process waits for them at exit, when nothing else needs the cores (4K nienhaus_sketchy:
edges and noise took 0.32-0.56 s one after the other, each 0.14-0.30 s alone)."""
LOW_SPACE = 64 * 1024**2  # with less free space than this, a written EXR is read back before it is kept
ENTRY_MS_PER_MB = 20.0
"""Estimated cost of writing an entry and reading it back later, per MB of stored pixels (half or float):
zip-compressed EXR on the project's 2-core machine, the six 4K entries of nienhaus_sketchy took 10-35 ms/MB
write + read (median 19; load average 2.7; docs/performance.md "Big single renders"). Used by
`Cache.worth_writing`."""
STORED_ABOVE = 0.5
"""An EXR entry is written without compression when a sample of its rows deflates (zlib level 1) to more
than this fraction of their bytes (`exr_compression`): such pixels (noise: 0.82-0.84) gain about 3x from
EXR's zip, whose encode then costs about 2.5x the uncompressed write (4K noise, 33 MB of half: 0.31 s
against 0.11-0.13 s, read back in 0.08 s against 0.02 s); buffers that are mostly blank or smooth (G-buffer,
edges, images: 0.005-0.11) stay zip, 10-200x smaller."""
ALWAYS_WRITE_MS = 250.0
"""Entries estimated below this are written whatever their node costs: the background write hides them, the
estimate is too rough to second-guess them, and every render up to about 0.8 Mpx of float RGBA (800x800
included; more for half and fewer channels) keeps the promise that a changed param recomputes only what is
downstream of it."""


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
    data: Any  # np.ndarray (H,W,C) float16 or float32 / (L,H,W,C), Strokes or Arrays
    fmt: str | None = None
    # a texture's footprint and value bound as its node gave them (`values.Tex`), stored beside the pixels
    footprint: Any = None
    absmax: tuple[float, ...] | None = None


@dataclass(frozen=True)
class Expect:
    """What the plan expects of one entry; a field left None is not checked. `width`, `height` and `layers`
    apply to textures and texture arrays (strokes and arrays carry their own sizes as data)."""

    kind: str
    fmt: str | None = None
    width: int | None = None
    height: int | None = None
    layers: int | None = None


class EntryMismatch(ValueError):
    """An entry that reads but is not what the plan expects (wrong port, kind, format or shape)."""


class StaleEntry(ValueError):
    """An entry of an older layout (written before entries carried a checksum): removed and recomputed without a
    warning, as nothing says it is damaged."""


class NotRegular(Exception):
    """A path named like an entry that is not a regular file (a directory, FIFO, socket, device, or a symbolic
    link that leaves the cache or leads to no regular file), found with `lstat` alone: it is never opened."""

    def __init__(self, what: str, st: os.stat_result | None = None):
        super().__init__(what)
        self.st = st  # the lstat of the path itself (None: unknown)


CHECKSUM_ATTR = "sketchgraph:checksum"
"""The EXR header attribute (an npz entry's `__meta__` key: "checksum") holding the payload's checksum."""


def payload_checksum(arrays: Any, extra: str = "") -> str:
    """The checksum of an entry's payload, "crc32:<8 hex digits>": zlib's CRC-32 over each array's name, dtype
    and shape and then its raw bytes (arrays in the order given: (name, array) pairs or a dict), then `extra`
    (header fields that change what the payload means). Cost: module docstring, "Checksums"."""
    crc = 0
    for name, a in (arrays.items() if isinstance(arrays, dict) else arrays):
        a = np.ascontiguousarray(a)  # no copy for what np.load and OIIO return, or what the writers hand over
        if a.dtype.hasobject:
            raise TypeError(f"array {name!r} holds Python objects: no checksum")
        crc = zlib.crc32(f"{name}\0{a.dtype.str}\0{a.shape}\0".encode(), crc)
        crc = zlib.crc32(a.reshape(-1).view(np.uint8), crc)
    if extra:
        crc = zlib.crc32(extra.encode("utf-8", "surrogatepass"), crc)
    return f"crc32:{crc:08x}"


def verify_checksum(stored: Any, arrays: Any, extra: str = "") -> None:
    """Raise `StaleEntry` when the entry carries no checksum this version knows (an older layout), ValueError when
    its payload's checksum is not the stored one."""
    if not isinstance(stored, str) or not stored.startswith("crc32:"):
        raise StaleEntry("written before entries carried a checksum")
    got = payload_checksum(arrays, extra)
    if got != stored:
        raise ValueError(f"checksum mismatch: the payload has {got}, its header says {stored}")


def _what(st: os.stat_result) -> str:
    mode = st.st_mode
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISLNK, "a symbolic link")):
        if test(mode):
            return name
    return "not a regular file"


def check_regular(path: Path, within: Path) -> os.stat_result:
    """The lstat of `path` when it is a regular file, or a symbolic link to a regular file inside `within` (the
    cache root), found without opening anything (`lstat`; for a link, `realpath` and `stat` of its target).
    Raises `NotRegular` for anything else: a directory, FIFO, socket or device; a symbolic link whose target is
    outside `within`, missing, or not a regular file. FileNotFoundError when nothing is there."""
    st = os.lstat(path)
    if stat.S_ISREG(st.st_mode):
        return st
    if not stat.S_ISLNK(st.st_mode):
        raise NotRegular(f"{_what(st)}, not a regular file", st)
    target = os.path.realpath(path)
    root = os.path.realpath(within)
    if os.path.commonpath([target, root]) != root:
        raise NotRegular(f"a symbolic link to {target}, outside the cache", st)
    try:
        tst = os.stat(target)
    except OSError:
        raise NotRegular(f"a symbolic link to {target}, which does not lead to a file", st) from None
    if not stat.S_ISREG(tst.st_mode):
        raise NotRegular(f"a symbolic link to {_what(tst)}, not a regular file", st)
    return st


def open_regular(path: Path, within: Path) -> IO[bytes]:
    """`path` opened for reading when it is a regular file (`check_regular`: anything else raises `NotRegular`
    before any open). Opened with O_NOFOLLOW and O_NONBLOCK and checked again with fstat, so a FIFO put in its
    place between the two is refused, never waited on."""
    st = check_regular(path, within)
    target = path if stat.S_ISREG(st.st_mode) else Path(os.path.realpath(path))
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    fd = os.open(target, flags)
    try:
        fst = os.fstat(fd)
        if not stat.S_ISREG(fst.st_mode):
            raise NotRegular(f"{_what(fst)}, not a regular file", fst)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def discard_entry(path: Path, st: os.stat_result | None) -> str:
    """Take a bad entry out of the way, so it is neither read nor reported again; says what was done. A file of
    any kind (a damaged entry, FIFO, socket, device node, symbolic link: the name only, never its target) is
    removed unless another process has put a new file there since `st` (its lstat) was taken. A directory is
    removed when it is empty or holds only this cache's temporary files; any other directory is not ours to
    delete: it is renamed aside, `<name>.unusable-<random>` (a name no entry has)."""
    try:
        now = os.lstat(path)
    except FileNotFoundError:
        return "already gone"
    except OSError as exc:
        return f"not removed: {_reason(exc)}"
    if st is not None and (now.st_dev, now.st_ino) != (st.st_dev, st.st_ino):
        return "replaced meanwhile by another process"
    if not stat.S_ISDIR(now.st_mode):
        try:
            os.unlink(path)
        except FileNotFoundError:
            return "already gone"
        except OSError as exc:
            return f"not removed: {_reason(exc)}"
        return "removed"
    try:
        with os.scandir(path) as it:
            inside = list(it)
        if all(e.name.startswith(TEMP_PREFIX) and e.is_file(follow_symlinks=False) for e in inside):
            for e in inside:
                os.unlink(e.path)
            os.rmdir(path)
            return "removed"
    except FileNotFoundError:
        return "already gone"
    except OSError:
        pass  # not empty after all, or not ours to empty: renamed aside below
    aside = path.with_name(f"{path.name}.unusable-{secrets.token_hex(4)}")
    try:
        os.rename(path, aside)
    except OSError as exc:
        return f"not removed: {_reason(exc)}"
    return f"it holds other files: renamed aside to {aside.name}"


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


_PORT_KINDS = {"Texture": "texture", "TextureArray": "texture_array", "Strokes": "strokes", "Arrays": "arrays"}


def kind_of_port(port_type: types.PortType) -> str | None:
    """The storage kind a port of this type produces (None: never cached)."""
    return _PORT_KINDS.get(port_type.kind)


def value_mismatch(value: Any, expect: Expect) -> str | None:
    """What differs between a value about to be stored and what the plan expects of it (None: it matches).
    A value that does not match is not written: it would be discarded by every later `load`."""
    kind = kind_of(value)
    fmt = getattr(value, "fmt", None)
    w = h = layers = None
    if isinstance(value, (Tex, TexArray)):
        w, h = value.size
        layers = value.layers if isinstance(value, TexArray) else 1
    return _differences(expect, kind=kind, fmt=fmt, width=w, height=h, layers=layers)


def _differences(expect: Expect, *, kind: str | None = None,
                 fmt: str | None = None, width: int | None = None, height: int | None = None,
                 layers: int | None = None, channels: int | None = None, pixel: str | None = None) -> str | None:
    """A short list of what differs from `expect` ("kind texture_array, expected texture; width 32, expected
    64"); None when nothing does. Arguments left None are not known and not checked."""
    diffs = []
    if kind is not None and kind != expect.kind:
        diffs.append(f"kind {kind}, expected {expect.kind}")
        return "; ".join(diffs)  # the rest means nothing across kinds
    if expect.fmt is not None:
        if fmt is not None and fmt != expect.fmt:
            diffs.append(f"format {fmt}, expected {expect.fmt}")
        if channels is not None and channels != types.components(expect.fmt):
            diffs.append(f"{channels} channels, expected {types.components(expect.fmt)} ({expect.fmt})")
        want_pixel = _stored_pixel(expect.kind, expect.fmt)
        if pixel is not None and pixel != want_pixel:
            diffs.append(f"{pixel} pixels, expected {want_pixel} ({expect.fmt})")
    if expect.kind in ("texture", "texture_array"):
        for name, got, want in (("width", width, expect.width), ("height", height, expect.height)):
            if got is not None and want is not None and got != want:
                diffs.append(f"{name} {got}, expected {want}")
        if expect.kind == "texture_array" and layers is not None and expect.layers is not None \
                and layers != expect.layers:
            diffs.append(f"{layers} layers, expected {expect.layers}")
    return "; ".join(diffs) or None


def _stored_pixel(kind: str, fmt: str) -> str:
    """The pixel type an entry of this kind and format is stored in: EXR holds half or float (8-bit formats as
    half); a texture array's npz holds the texture's own dtype."""
    if kind == "texture":
        return "float" if types.precision(fmt) >= 2 else "half"
    return str(types.numpy_dtype(fmt))


def renderer_namespace(renderer: str) -> str:
    """The cache subfolder of one GL renderer (vendor, renderer and version string, digested): node keys
    do not name the renderer, so entries of different renderers live apart and are never read for each
    other (an llvmpipe texture is not served to an NVIDIA run, nor the other way round)."""
    return NAMESPACE_PREFIX + hashlib.sha256(renderer.encode("utf-8")).hexdigest()[:16]


NAMESPACE_PREFIX = "renderer-"
MESH_STORE = "meshes"
"""The folder under a cache root where nodegraph/scene/meshstore.py keeps parsed mesh files and what is derived from
them (no renderer namespace: parsing is the same for every renderer)."""


class Cache:
    """The disk cache under `root`. Entries live in the subfolder of the GL renderer that made them
    (`root/renderer-<digest>/<key[:2]>/...`); the renderer is given, or bound by the executor from its GL
    context before the first read or write (`bind`). Size limit, `info` and `prune` cover every renderer's
    entries under `root` together."""

    def __init__(self, root: Path | None = None, limit: int | None = None, renderer: str | None = None):
        self.base = Path(root) if root else default_root()
        self.namespace: str | None = None
        self.root = self.base  # where this cache's entries go: base/namespace once a renderer is bound
        if renderer is not None:
            self.bind(renderer)
        self.limit = default_limit() if limit is None else limit
        self._writer: ThreadPoolExecutor | None = None
        self._pending: list[Future] = []
        self._pending_bytes = 0
        self._inflight: dict[Path, Future] = {}  # entry base path -> its background write
        self._room = threading.BoundedSemaphore(MAX_PENDING_WRITES)
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0
        self.writes = 0
        self.recovered = 0  # entries discarded (not a file, unreadable, damaged or not what the plan expects)
        self.stale = 0  # entries removed without a warning: written before entries carried a checksum
        self.write_errors = 0  # writes that failed (each lost one entry, never the render)
        self.pruned = 0  # times `prune` ran
        self._written_since_prune = 0
        self._write_error: str | None = None  # first failure not yet reported (set on the writer thread too)
        self._write_warned = False
        self.ms_per_mb = ENTRY_MS_PER_MB  # the cost model of `worth_writing` (tests change it)
        self.always_write_ms = ALWAYS_WRITE_MS
        self.skipped = 0  # entries not written because recomputing them costs less (`worth_writing`)
        atexit.register(_report_at_exit, weakref.ref(self))

    @property
    def mesh_store(self) -> Path:
        """Where the mesh store keeps its entries for this cache (`MESH_STORE` under the root)."""
        return self.base / MESH_STORE

    def bind(self, renderer: str) -> None:
        """Read and write the entries of `renderer` from now on (the GL renderer string of the context)."""
        ns = renderer_namespace(renderer)
        if ns != self.namespace:
            self.namespace = ns
            self.root = self.base / ns

    # -- paths -----------------------------------------------------------------------------
    def _base(self, key: str, port: str) -> Path:
        return self.root / key[:2] / f"{key}.{port}"

    def find(self, key: str, port: str) -> Path | None:
        base = self._base(key, port)
        with self._lock:
            writing = self._inflight.get(base)
        if writing is not None:  # written in the background by this process: wait for it (`_store_safe` never raises)
            writing.result()
        for ext in (".exr", ".npz"):
            p = base.with_name(base.name + ext)
            if os.path.lexists(p):  # whatever is there, `load` looks at it (lstat) before opening anything
                return p
        return None

    # -- read ------------------------------------------------------------------------------
    def load(self, key: str, port: str, node_label: str = "", expect: Expect | None = None) -> Loaded | None:
        """The entry `port` (the entry's name within its key) of `key`, or None. An entry that is not a regular
        file (seen with lstat, never opened), does not read, fails its checksum, names another key or port, or
        differs from `expect`, is taken away (`discard_entry`) with one `CacheWarning`; one written before
        entries carried a checksum is removed without one."""
        path = self.find(key, port)
        if path is None:
            self.misses += 1
            return None
        st = None
        try:
            st = check_regular(path, self.base)
            loaded = _read_exr(path, key, port, expect) if path.suffix == ".exr" else _read_npz(path, key, port, expect,
                                                                                                within=self.base)
        except FileNotFoundError:  # evicted by another process between find and open: a plain miss
            self.misses += 1
            return None
        except NotRegular as exc:
            self.recovered += 1
            done = discard_entry(path, exc.st)
            warnings.warn(f"cache entry {path} for {node_label or 'a node'} is unusable ({exc}; {done}); "
                          "recomputing it", CacheWarning, stacklevel=2)
            self.misses += 1
            return None
        except StaleEntry:
            self.stale += 1
            discard_entry(path, st)
            self.misses += 1
            return None
        except Exception as exc:  # noqa: BLE001 - any failure: discard and recompute
            self.recovered += 1
            reason = str(exc) if isinstance(exc, EntryMismatch) else _reason(exc)
            done = discard_entry(path, st)
            tail = "" if done == "removed" else f"; {done}"
            warnings.warn(f"cache entry {path} for {node_label or 'a node'} is unusable ({reason}{tail}); "
                          "recomputing it", CacheWarning, stacklevel=2)
            self.misses += 1
            return None
        with contextlib.suppress(OSError):
            os.utime(path)  # LRU: a hit refreshes the entry
        self.hits += 1
        return loaded

    # -- write -----------------------------------------------------------------------------
    def entry_cost_ms(self, value: Any) -> float:
        """Estimated milliseconds to write `value`'s entry and read it back in a later run: its stored bytes
        (textures as half or float, as `store_value` writes them) at `ms_per_mb`."""
        if isinstance(value, (Tex, TexArray)):
            w, h = value.size
            layers = value.layers if isinstance(value, TexArray) else 1
            if isinstance(value, Tex):
                per = 4 if types.precision(value.fmt) >= 2 else 2
            else:
                per = int(np.dtype(types.numpy_dtype(value.fmt)).itemsize)
            stored = w * h * layers * types.components(value.fmt) * per
        else:
            stored = int(getattr(value, "nbytes", 0))
        return stored / 1e6 * self.ms_per_mb

    def worth_writing(self, value: Any, recompute_ms: float | None) -> bool:
        """Whether a computed value is worth an entry: always when it is cheap to store (under
        `always_write_ms`) or its recompute cost is unknown (None); otherwise when recomputing it (its node and
        the unstored nodes it would need, measured in this run) costs at least as much as writing and later
        reading the entry. Counts what it declines in `skipped`."""
        if recompute_ms is None:
            return True
        cost = self.entry_cost_ms(value)
        if cost < self.always_write_ms or recompute_ms >= cost:
            return True
        with self._lock:
            self.skipped += 1
        return False

    def store_value(self, key: str, port: str, value: Any, meta: dict[str, Any], background: bool = False) -> bool:
        """Write a node's output value (textures are read back to the host first). Returns False, writing
        nothing, for a value that is never cached; `load` gives it back as host data with its kind."""
        kind = kind_of(value)
        if kind is None:
            return False
        if kind == "texture":
            meta = self._texture_meta(value, meta)
        if kind == "texture" and types.numpy_dtype(value.fmt) == np.float16:
            # half textures are read and written as half: no conversion to float32 and back
            self.store(key, port, kind, value.read_native(), meta, value.fmt, background=background)
        elif kind in ("texture", "texture_array"):
            self.store(key, port, kind, value.read(), meta, value.fmt, background=background)
        else:
            self.store(key, port, kind, value, meta, background=background)
        return True

    def _texture_meta(self, value: Any, meta: dict[str, Any]) -> dict[str, Any]:
        """`meta` with a texture's footprint and value bound, written beside its pixels, so a texture loaded from
        the cache is drawn from only where its node drew (`nodegraph.gpu.footprint`)."""
        extra = {}
        if value.footprint is not None:
            fp = value.footprint
            extra["footprint"] = {"rect": [int(v) for v in fp.rect], "blank": [float(v) for v in fp.blank]}
        if value.absmax is not None:
            extra["absmax"] = [float(v) for v in value.absmax]
        return {**meta, **extra} if extra else meta

    def store(self, key: str, port: str, kind: str, data: Any, meta: dict[str, Any], fmt: str | None = None,
              background: bool = False) -> None:
        """Write one output. With `background`, the encode and the write happen on a worker thread. A failure
        never raises: it loses this entry and is reported once (`CacheWarning`)."""
        self.report_write_errors()
        if background:
            size = int(getattr(data, "nbytes", 0))
            self._room.acquire()  # bounded: a loop faster than the disk waits here instead of growing memory
            with self._lock:
                if self._writer is None:
                    self._writer = ThreadPoolExecutor(max_workers=WRITER_THREADS,
                                                      thread_name_prefix="sketchgraph-cache")
                self._pending_bytes += size
                fut = self._writer.submit(self._store_safe, key, port, kind, data, meta, fmt)
                self._pending.append(fut)
                base = self._base(key, port)
                self._inflight[base] = fut
            fut.add_done_callback(lambda f, n=size, b=base: self._done(f, n, b))
        else:
            self._store_safe(key, port, kind, data, meta, fmt)
            self.report_write_errors()

    def _done(self, fut: Future, size: int, base: Path) -> None:
        with self._lock:
            self._pending_bytes -= size
            if self._inflight.get(base) is fut:
                del self._inflight[base]
        self._room.release()

    @property
    def pending(self) -> int:
        """Background writes queued or running."""
        with self._lock:
            return sum(1 for f in self._pending if not f.done())

    def _store_safe(self, key: str, port: str, kind: str, data: Any, meta: dict[str, Any], fmt: str | None) -> None:
        try:
            self._store(key, port, kind, data, meta, fmt)
        except Exception as exc:  # noqa: BLE001 - a failed write loses only a cache entry, never the render
            with self._lock:
                self.write_errors += 1
                if self._write_error is None and not self._write_warned:
                    self._write_error = _reason(exc)

    def _store(self, key: str, port: str, kind: str, data: Any, meta: dict[str, Any], fmt: str | None) -> None:
        base = self._base(key, port)
        base.parent.mkdir(parents=True, exist_ok=True)
        if kind == "texture":
            final = base.with_name(base.name + ".exr")
            _atomic(final, lambda tmp: _write_exr(tmp, data, fmt or "RGBA32F", key, port, meta))
        else:
            final = base.with_name(base.name + ".npz")
            _atomic(final, lambda tmp: _write_npz(tmp, kind, data, key, port, meta, fmt))
        size = 0
        with contextlib.suppress(OSError):
            size = final.stat().st_size
        with self._lock:
            self.writes += 1
            self._written_since_prune += size

    def report_write_errors(self) -> None:
        """Warn (once per run) about a write that failed, here or on the writer thread; call it from the
        thread that owns the cache."""
        with self._lock:
            reason, self._write_error = self._write_error, None
            if reason is None or self._write_warned:
                return
            self._write_warned = True
        warnings.warn(f"cannot write to the disk cache {self.root} ({reason}); the result is still produced, "
                      "without caching it (later cache write failures in this run are not reported)",
                      CacheWarning, stacklevel=3)

    def new_run(self) -> None:
        """A new run begins: a write failure is reported again (once)."""
        with self._lock:
            self._write_warned = False

    def flush(self, progress: Any = None) -> None:
        """Wait for the background writes. `progress(text)`: told once if that takes over a second."""
        with self._lock:
            pending, self._pending = self._pending, []
        t0 = time.monotonic()
        told = False
        for i, fut in enumerate(pending):
            while True:
                try:
                    fut.result(timeout=0.25)  # `_store_safe` never raises
                    break
                except TimeoutError:
                    if progress is not None and not told and time.monotonic() - t0 > 1.0:
                        told = True
                        left = len(pending) - i
                        progress(f"finishing {left} cache write{'s' if left != 1 else ''} "
                                 f"({self._pending_bytes / 1024**2:.0f} MB) in {self.root}")
        self.report_write_errors()

    def close(self) -> None:
        self.flush()
        if self._writer is not None:
            self._writer.shutdown(wait=True)
            self._writer = None
        self.report_write_errors()

    # -- maintenance -----------------------------------------------------------------------
    def _scan(self) -> tuple[list[Entry], list[Entry]]:
        """(entries, temporary files) under the root; unreadable folders count as empty."""
        with self._lock:
            writing = list(self._inflight.values())
        for fut in writing:  # this process's background writes count as written (`_store_safe` never raises)
            fut.result()
        ents: list[Entry] = []
        temps: list[Entry] = []
        try:
            if not self.base.is_dir():
                return ents, temps
            paths = [*self.base.glob("*/*"), *self.base.glob(f"{NAMESPACE_PREFIX}*/*/*")]
        except OSError:
            return ents, temps
        for p in paths:
            is_temp = p.name.startswith(TEMP_PREFIX)
            if not is_temp and p.suffix not in (".exr", ".npz"):
                continue
            try:
                st = p.lstat()  # never follows a link: a link to /dev/zero counts as the link it is
            except OSError:
                continue
            (temps if is_temp else ents).append(Entry(p, st.st_size, st.st_mtime))
        return ents, temps

    def entries(self) -> list[Entry]:
        return self._scan()[0]

    def temp_files(self) -> list[Entry]:
        """Temporary files: writes in progress, or left by a writer that was killed."""
        return self._scan()[1]

    def info(self) -> dict[str, Any]:
        ents, temps = self._scan()
        return {
            "root": str(self.base),
            "renderers": len({e.path.parent.parent.name for e in ents
                              if e.path.parent.parent.name.startswith(NAMESPACE_PREFIX)}),
            "entries": len(ents),
            "bytes": sum(e.size for e in ents) + sum(t.size for t in temps),
            "limit": self.limit,
            "by_kind": {"exr": sum(1 for e in ents if e.path.suffix == ".exr"),
                        "npz": sum(1 for e in ents if e.path.suffix == ".npz")},
            "meshes": sum(1 for e in ents if e.path.parent == self.mesh_store),  # nodegraph/scene/meshstore.py
            "temp_files": len(temps),
            "temp_bytes": sum(t.size for t in temps),
        }

    def prune(self, limit: int | None = None) -> tuple[int, int]:
        """Remove stale temporary files, then evict least-recently-used entries until the total (temporary
        files included) is within `limit`. Returns (files, bytes) freed. Never raises for a file it cannot
        remove. Only the client process calls this (the executor, the `cache prune` command)."""
        limit = self.limit if limit is None else limit
        ents, temps = self._scan()
        files = freed = 0
        now = time.time()
        live = []
        for t in temps:
            if _stale_temp(t, now) and _unlink(t.path):
                files += 1
                freed += t.size
            else:
                live.append(t)
        ents.sort(key=lambda e: e.mtime)
        total = sum(e.size for e in ents) + sum(t.size for t in live)
        for e in ents:
            if total <= limit:
                break
            if not _unlink(e.path):
                continue
            total -= e.size
            freed += e.size
            files += 1
        with self._lock:
            self._written_since_prune = 0
            self.pruned += 1
        return files, freed

    def maybe_prune(self) -> bool:
        """Prune when the writes since the last prune exceed `PRUNE_FRACTION` of the limit (frame loops)."""
        with self._lock:
            due = self._written_since_prune > self.limit * PRUNE_FRACTION
        if due:
            self.prune()
        return due


def _report_at_exit(ref: weakref.ref[Cache]) -> None:
    """A cache never closed still reports a failed background write (the writer threads have finished by now)."""
    cache = ref()
    if cache is not None:
        with contextlib.suppress(Exception):
            cache.report_write_errors()


def _reason(exc: BaseException) -> str:
    """An error as a short phrase: 'No space left on device' for an OSError, else its type and first line."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0][:200]}" if text else type(exc).__name__


def _unlink(path: Path) -> bool:
    try:
        path.unlink()
    except FileNotFoundError:
        return True  # someone else removed it: freed all the same
    except OSError:
        return False
    return True


_HOST = re.sub(r"[^A-Za-z0-9.]", "_", socket.gethostname())[:64] or "host"
_TEMP_NAME = re.compile(re.escape(TEMP_PREFIX) + r"(\d+)@([A-Za-z0-9._]+)-")


def _temp_prefix() -> str:
    return f"{TEMP_PREFIX}{os.getpid()}@{_HOST}-"


def _stale_temp(t: Entry, now: float) -> bool:
    """A leftover temporary file: untouched for `STALE_TEMP_SECONDS`, or written on this host by a process
    that no longer runs. A name that says nothing about its writer (older versions) is judged by age only."""
    if now - t.mtime > STALE_TEMP_SECONDS:
        return True
    m = _TEMP_NAME.match(t.path.name)
    if m is None or m.group(2) != _HOST:
        return False
    pid = int(m.group(1))
    if pid == os.getpid():
        return False  # our own writer thread may be writing it right now
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:
        return False  # exists (another user's process)
    return False


def write_npz(final: Path, arrays: dict[str, np.ndarray]) -> None:
    """`arrays` as an .npz file at `final`, written as the cache writes its entries (a temporary file named so
    that pruning knows a leftover one, then renamed), for stores that live beside the entries (meshstore)."""

    def write(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)

    _atomic(final, write)


def _atomic(final: Path, write: Any) -> None:
    fd, tmp = tempfile.mkstemp(prefix=_temp_prefix(), suffix=final.suffix, dir=final.parent)
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


def _check_header(got_key: str | None, got_port: str | None, key: str, port: str) -> None:
    if got_key != key:
        raise ValueError(f"header key {(got_key or '')[:12] or 'missing'} does not match {key[:12]}")
    if got_port and got_port != port:  # every entry has carried its port; an empty one is not refused
        raise EntryMismatch(f"port {got_port}, expected {port}")


def _int_or_none(value: Any) -> int | None:
    try:
        return int(value)
    except (TypeError, ValueError):
        return None


def _write_exr(path: str, arr: np.ndarray, fmt: str, key: str, port: str, meta: dict[str, Any]) -> None:
    import OpenImageIO as oiio

    half = types.precision(fmt) < 2
    # EXR rows run top-down; half pixels handed over as half (when read so) are not converted, and float pixels of a
    # half entry are converted here, not by OIIO: the checksum is of the very values the file holds
    arr = np.ascontiguousarray(arr[::-1], dtype=np.float16 if half else np.float32)
    h, w, c = arr.shape
    pixel = oiio.HALF if half else oiio.FLOAT
    spec = oiio.ImageSpec(w, h, c, pixel)
    spec.channelnames = tuple("RGBA"[:c]) if c != 2 else ("R", "G")
    spec.attribute("compression", exr_compression(arr))
    for k, v in _meta_attrs(key, port, meta).items():
        spec.attribute(k, v)
    spec.attribute("sketchgraph:fmt", fmt)
    spec.attribute("sketchgraph:kind", "texture")
    drawn = {k: meta[k] for k in ("footprint", "absmax") if k in meta}
    drawn_text = json.dumps(drawn) if drawn else ""  # -0.0 stays -0.0 in JSON
    if drawn_text:
        spec.attribute("sketchgraph:drawn", drawn_text)
    spec.attribute(CHECKSUM_ATTR, payload_checksum([("pixels", arr)], _exr_extra(fmt, drawn_text)))
    out = oiio.ImageOutput.create(path if path.endswith(".exr") else path + ".exr")
    if out is None:
        raise OSError(oiio.geterror())
    # mkstemp gave a .exr suffix, so OIIO picks the EXR writer from the name
    if not out.open(path, spec):
        raise OSError(out.geterror())
    if not out.write_image(arr):
        err = out.geterror()
        out.close()
        raise OSError(err or "EXR write failed")
    if not out.close():
        raise OSError(out.geterror() or "EXR close failed")
    _check_complete(path, key, port)


def exr_compression(arr: np.ndarray, rows: int = 8) -> str:
    """The EXR compression of an entry's pixels, (H, W, C) in file order: "zip", or "none" where `rows` rows
    spread over the image deflate to more than `STORED_ABOVE` of their bytes (about 3 ms for 4K noise)."""
    import zlib

    if arr.size == 0:
        return "none"
    sample = np.ascontiguousarray(arr[np.linspace(0, arr.shape[0] - 1, min(rows, arr.shape[0])).astype(int)])
    return "none" if len(zlib.compress(memoryview(sample).cast("B"), 1)) > STORED_ABOVE * sample.nbytes else "zip"


def _check_complete(path: str, key: str, port: str) -> None:
    """OpenEXR can lose the error of its last write (seen with a file-size limit and with a full disk): the
    file is cut short but the writer reports success. So refuse a file that reached the process's file-size
    limit, and where the disk is nearly full, read the file back before keeping it."""
    size = os.stat(path).st_size
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    except (ImportError, OSError, ValueError):
        soft = -1
    if soft not in (-1, getattr(resource, "RLIM_INFINITY", -1)) and size >= soft:
        raise OSError(errno.EFBIG, f"File too large (the file-size limit of {soft} bytes)")
    st = os.statvfs(path)
    if st.f_bavail * st.f_frsize < LOW_SPACE:
        try:
            _read_exr(Path(path), key, port)
        except Exception as exc:  # noqa: BLE001 - whatever the reader says, the file is incomplete
            raise OSError(errno.ENOSPC, f"No space left on device (the entry was cut short: {_reason(exc)})") \
                from exc


def _read_exr(path: Path, key: str, port: str = "", expect: Expect | None = None) -> Loaded:
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        err = oiio.geterror() or "cannot open"
        if not path.exists():
            raise FileNotFoundError(err)
        raise OSError(err)
    try:
        spec = inp.spec()
        _check_header(spec.get_string_attribute("sketchgraph:key"), spec.get_string_attribute("sketchgraph:port"),
                      key, port or spec.get_string_attribute("sketchgraph:port"))
        fmt = spec.get_string_attribute("sketchgraph:fmt") or None
        if expect is not None:  # from the header alone, before reading any pixels
            kind = spec.get_string_attribute("sketchgraph:kind") or "texture"
            pixel = {str(oiio.TypeHalf): "half", str(oiio.TypeFloat): "float"}.get(str(spec.format), str(spec.format))
            if spec.channelformats:
                pixel = "mixed"
            diff = _differences(expect, kind=kind, fmt=fmt, width=spec.width, height=spec.height,
                                channels=spec.nchannels, pixel=pixel)
            if diff:
                raise EntryMismatch(diff)
        # half entries are read as half (float16 data: the same values, and a half texture uploads them as they
        # are instead of widening them to float32 here and narrowing them again for the upload; 800x800 RGBA
        # 21 + 16 ms of CPU on the 2-core machine); anything else as float32
        half = str(spec.format) == str(oiio.TypeHalf) and not spec.channelformats
        pixels = inp.read_image(oiio.HALF if half else oiio.FLOAT)
        if pixels is None or not isinstance(pixels, np.ndarray):
            raise OSError(inp.geterror() or "no pixels")
    finally:
        inp.close()
    arr = np.asarray(pixels, dtype=np.float16 if half else np.float32)
    arr = arr.reshape(spec.height, spec.width, spec.nchannels)
    drawn_text = spec.get_string_attribute("sketchgraph:drawn")
    verify_checksum(spec.get_string_attribute(CHECKSUM_ATTR) or None, [("pixels", arr)],
                    _exr_extra(fmt or "", drawn_text))  # in file order, as written
    arr = arr[::-1]
    fp, absmax = _drawn(drawn_text, spec.width, spec.height, spec.nchannels)
    return Loaded("texture", np.ascontiguousarray(arr), fmt, fp, absmax)


def _exr_extra(fmt: str, drawn_text: str) -> str:
    """What an EXR entry's checksum covers beside its pixels: the format the pixels are read as, and the footprint
    and value bound they are drawn with."""
    return f"{fmt}\0{drawn_text or ''}"


def _drawn(text: str | None, w: int, h: int, c: int) -> tuple[Any, tuple[float, ...] | None]:
    """The footprint and value bound stored with a texture entry (None for what is missing or does not fit the
    entry: an entry is used without them rather than refused)."""
    if not text:
        return None, None
    from .values import Footprint

    try:
        d = json.loads(text)
        fp = d.get("footprint")
        footprint = None
        if fp is not None:
            rect = tuple(int(v) for v in fp["rect"])
            blank = tuple(float(v) for v in fp["blank"])
            x, y, rw, rh = rect  # anything but four numbers raises, caught below
            if len(blank) == c and min(rect) >= 0 and x + rw <= w and y + rh <= h:
                footprint = Footprint(rect, blank)  # type: ignore[arg-type]
        absmax = tuple(float(v) for v in d["absmax"]) if d.get("absmax") is not None else None
        return footprint, absmax
    except (ValueError, TypeError, KeyError, AttributeError):
        return None, None


def _write_npz(path: str, kind: str, data: Any, key: str, port: str, meta: dict[str, Any], fmt: str | None) -> None:
    header: dict[str, Any] = {**_meta_attrs(key, port, meta), "kind": kind, "fmt": fmt}
    payload: dict[str, Any] = {}
    if kind == "texture_array":  # stored in the texture's own precision (8-bit tones stay 8-bit)
        arr = np.asarray(data, dtype=np.float32)
        dt = types.numpy_dtype(fmt) if fmt else np.dtype(np.float32)
        payload["data"] = np.clip(np.rint(arr * 255.0), 0, 255).astype(np.uint8) if dt == np.uint8 else arr.astype(dt)
        layers, h, w, _ = arr.shape
        header.update(w=int(w), h=int(h), layers=int(layers))
    elif kind == "strokes":
        s: Strokes = data
        payload["points"] = s.xy.astype(np.float32)
        payload["lengths"] = np.diff(s.starts).astype(np.int64)
        payload["size"] = np.array(s.size)
        payload["style"] = np.array([s.width, *s.color], dtype=np.float64)
        for name, value in s.attrs.items():  # the per-vertex attributes (values.STROKE_ATTRS)
            payload[f"v_{name}"] = value
    elif kind == "arrays":
        a: Arrays = data
        for name, value in a.data.items():
            payload[f"a_{name}"] = value
    else:
        raise ValueError(f"cannot cache values of kind {kind}")
    header["checksum"] = payload_checksum(sorted(payload.items()), _npz_extra(kind, fmt))
    payload["__meta__"] = np.array(json.dumps(header))
    with open(path, "wb") as fh:
        np.savez(fh, **payload)


def _npz_extra(kind: Any, fmt: Any) -> str:
    """What an npz entry's checksum covers beside its arrays: the kind and format they are read as."""
    return f"{kind}\0{fmt}"


def _read_npz(path: Path, key: str, port: str = "", expect: Expect | None = None,
              within: Path | None = None) -> Loaded:
    """The npz entry at `path` (opened with `open_regular`: a FIFO or device put in its place is never waited on
    or read); its header checked first, then its data against `expect`, then its checksum."""
    with open_regular(path, within if within is not None else path.parent) as fh, \
            np.load(fh, allow_pickle=False) as z:
        meta = json.loads(str(z["__meta__"]))
        if not isinstance(meta, dict):
            raise ValueError("the entry's __meta__ is not a JSON object")
        _check_header(meta.get("sketchgraph:key"), meta.get("sketchgraph:port"), key,
                      port or meta.get("sketchgraph:port", ""))
        kind = meta.get("kind")
        fmt = meta.get("fmt")
        if expect is not None:  # the header's own claims first
            diff = _differences(expect, kind=kind, fmt=fmt, width=_int_or_none(meta.get("w")),
                                height=_int_or_none(meta.get("h")), layers=_int_or_none(meta.get("layers")))
            if diff:
                raise EntryMismatch(diff)
        z_arrays = {k: z[k] for k in z.files if k != "__meta__"}  # read once: checked, then used

    def verified() -> None:
        verify_checksum(meta.get("checksum"), sorted(z_arrays.items()), _npz_extra(kind, fmt))

    if kind == "texture_array":
        raw = z_arrays["data"]
        if raw.ndim != 4:
            raise ValueError(f"texture array data has shape {raw.shape}, expected (layers, h, w, c)")
        if expect is not None:  # then what the data really is (entries older than the size fields too)
            layers, h, w, c = raw.shape
            diff = _differences(expect, width=w, height=h, layers=layers, channels=c, pixel=str(raw.dtype))
            if diff:
                raise EntryMismatch(diff)
        verified()
        data = raw.astype(np.float32) / 255.0 if raw.dtype == np.uint8 else raw.astype(np.float32)
        return Loaded(kind, data, fmt)
    if kind == "strokes":
        verified()
        pts, lengths = z_arrays["points"], z_arrays["lengths"]
        if pts.ndim != 2 or pts.shape[1] != 2 or lengths.ndim != 1 or (lengths < 0).any() \
                or int(lengths.sum()) != len(pts):
            raise ValueError(f"strokes of {pts.shape} points and {lengths.shape} lengths do not fit together")
        style = z_arrays["style"]
        size = tuple(int(v) for v in z_arrays["size"])
        if len(size) != 2 or len(style) != 4:
            raise ValueError("strokes size or style malformed")
        attrs = {k[2:]: v for k, v in z_arrays.items() if k.startswith("v_")}  # absent in older entries: defaults
        return Loaded(kind, Strokes.from_arrays(pts, np.r_[0, np.cumsum(lengths)], size, float(style[0]),
                                                tuple(float(c) for c in style[1:4]), attrs))
    if kind == "arrays":
        verified()
        return Loaded(kind, Arrays({k[2:]: v for k, v in z_arrays.items() if k.startswith("a_")}))
    raise ValueError(f"unknown entry kind {kind}")
