"""Mesh files parsed once: the repaired arrays of each mesh file, and what is derived from a mesh, kept on
disk between runs.

A command that renders a user's mesh spent most of a warm-cache run reading it: for ogre.obj (124k faces,
3.7 MB) libigl's reader took 0.53 s and its import 0.31 s, and the front direction of the default view
(`framing.detect_front`) 0.53 s, nearly all of it importing scipy.spatial, against 38 ms in the nodes. A
G-buffer drawn again in a new process paid about 1.1 s more (hole share, render streams, enlargement
directions, up axis), and pencil_shade 0.76 s for its corner slots. The store keeps what those steps give.

Where: `<cache root>/meshes/` (the node cache's root: `--cache-dir`, `SKETCHGRAPH_CACHE_DIR` or the
default), set wherever a disk cache is opened (`render.open_cache`, `api.Session.load`, cluster workers,
gallery builds); `--no-cache` leaves it unset, and then every process computes everything. Entries are
`.npz`, so `sketchgraph cache info` counts them and pruning evicts them with the node entries, least
recently used first (a hit refreshes an entry).

Keys: a parsed file by the digest of its bytes and its absolute path (the `MeshWarning`s a file's reading
gave name the path; they are stored with the arrays and given again on every hit); a value derived from a
mesh (`memo`, `memo_arrays`) by the mesh's content hash. Every key also holds the digest of the source files
of the code that computes the value, so an edit to that code is a new key, never a stale entry.

Entries are checked before anything in them is used (tests/nodegraph/test_meshstore_faults.py): the path with
`lstat` first (a FIFO, directory, device or a link out of the store is never opened: `cache.check_regular`),
then the CRC-32 of the arrays against the `checksum` in `__meta__` (`cache.payload_checksum`; written with
every entry), then the arrays against the profile written beside them (`arrays`: dtype, shape, finite or not,
the range of integers), and last against what no metadata can vouch for: a parsed mesh has (n, 3) finite
float64 vertices and (m, 3) int32 faces in [0, n); render streams (`indices` beside `positions`) index inside
their vertices, have one row a vertex, finite positions, and `source_vertex` inside the mesh, so a forged entry
with a matching checksum still never sends an index past a buffer's end to GL. An entry that fails any of
these is taken away (`cache.discard_entry`: removed; a directory that holds other files renamed aside) and
computed again, with one `CacheWarning` naming it (as a node entry is); one of an older layout (another version,
or written before the checksum) is replaced without one; a store that cannot be written is skipped without a
word: the store only saves time.

Derived arrays are stored for meshes of at least `MIN_FACES` faces (below that computing them is about as cheap
as reading them), and never for a posed mesh (skinned or morphed: a new mesh every frame of a film)."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

VERSION = "1"
"""Part of every key, with the code's digest: a change to the stored layout bumps it."""

MIN_FACES = 2000
"""Meshes with fewer faces compute `memo_arrays` values in place (spot's 5.9k faces: render streams 17 ms)."""

_code_digests: dict[tuple[str, ...], str] = {}

_root: Path | None = None


def configure(root: Path | None) -> None:
    """Keep parsed meshes under `root` (None: parse in every process)."""
    global _root
    _root = Path(root) if root is not None else None


def use_cache(cache: Any) -> None:
    """Keep parsed meshes in `cache`'s mesh store (`Cache.mesh_store`); None: parse in every process."""
    configure(None if cache is None else cache.mesh_store)


def root() -> Path | None:
    return _root


def code_digest(*sources: str | Path) -> str:
    """The digest of these source files' bytes (kept for the process): part of a key, so a value computed by
    code that has since changed is never read."""
    key = tuple(str(s) for s in sources)
    digest = _code_digests.get(key)
    if digest is None:
        h = hashlib.blake2b(VERSION.encode(), digest_size=16)
        for src in key:
            try:
                h.update(Path(src).read_bytes())
            except OSError:
                h.update(f"unreadable:{src}".encode())
        digest = _code_digests[key] = h.hexdigest()
    return digest


def load(path: Path, parse: Callable[[Path], Any], build: Callable[[np.ndarray, np.ndarray], Any],
         category: type[Warning], code: tuple[str, ...]) -> Any:
    """The mesh `parse(path)` gives (anything with `vertices`, float64, and `faces`, int32), or `build(vertices,
    faces)` from the store when this file's bytes were parsed before by the code in the files `code`; the
    warnings of `category` the parse gave are given either way (`nodegraph.scene.meshes` passes its Mesh and
    MeshWarning)."""
    store = _root
    if store is None:
        return parse(path)
    try:
        before = _stamp(path)
        h = hashlib.blake2b(digest_size=20)
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return parse(path)
    h.update(f"\0{code_digest(*code)}\0{path}".encode("utf-8", "surrogateescape"))
    entry = store / f"{h.hexdigest()}.mesh.npz"
    hit = _read(entry, ("vertices", "faces"), _check_mesh)
    if hit is not None:
        arrays, meta = hit
        for note in meta["warnings"]:
            warnings.warn(str(note), category, stacklevel=3)  # at load_mesh's caller
        return build(arrays["vertices"], arrays["faces"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = parse(path)
    notes = [str(w.message) for w in caught if issubclass(w.category, category)]
    with contextlib.suppress(OSError):
        if _stamp(path) == before:  # not rewritten while it was hashed and parsed (the entry would lie)
            _write(entry, {"vertices": mesh.vertices, "faces": mesh.faces}, {"warnings": notes, "source": str(path)})
    for w in caught:  # after the entry is safe (a filter may turn one into an error), as a hit gives them
        warnings.warn(w.message, w.category, stacklevel=3)
    return mesh


def memo(mesh: Any, what: str, make: Callable[[], Any], code: tuple[str, ...], always: bool = False) -> np.ndarray:
    """`make()` as a float64 array (it must depend on the mesh's vertices and faces alone, through the code in
    the files `code`), stored by the mesh's content hash under the name `what`. `always`: store it for a
    mesh of any size (a value whose cost is not the mesh's: the front direction imports scipy.spatial)."""
    out = memo_arrays(mesh, what, lambda: {"value": np.asarray(make(), dtype=np.float64)}, code, ("value",),
                      always=always)
    return out["value"]


def memo_arrays(mesh: Any, what: str, make: Callable[[], dict[str, np.ndarray]], code: tuple[str, ...],
                names: tuple[str, ...], always: bool = False) -> dict[str, np.ndarray]:
    """`make()` (the arrays `names`, which depend on the mesh's vertices and faces alone, through the code in
    the files `code`), stored by the mesh's content hash under the name `what`; read back with the same
    names, dtypes and shapes."""
    store = _root
    if store is None or _skip(mesh, always):
        return make()
    entry = store / f"{mesh.content_hash()[:32]}.{code_digest(*code)[:12]}.{what.replace('.', '_')}.npz"
    hit = _read(entry, names, lambda arrays, meta: _check_derived(arrays, meta, mesh))
    if hit is not None and hit[1].get("what") == what:
        return hit[0]
    arrays = make()
    _write(entry, arrays, {"what": what})
    return arrays


def _stamp(path: Path) -> tuple[int, int]:
    st = os.stat(path)
    return st.st_mtime_ns, st.st_size


def _skip(mesh: Any, always: bool) -> bool:
    """Values computed in place: a posed mesh's (skinned or morphed, a new mesh every frame: storing them would
    write an entry a frame), and a small mesh's unless `always`."""
    if getattr(mesh, "rest", None) is not None:
        return True
    return not always and int(len(mesh.faces)) < MIN_FACES


Check = Callable[[dict[str, np.ndarray], dict[str, Any]], None]


def _read(entry: Path, names: tuple[str, ...], check: Check) -> tuple[dict[str, np.ndarray], dict[str, Any]] | None:
    """The entry's arrays `names` and its metadata; None for a miss. A store that cannot be opened (no entry,
    a file where its folder should be, no permission) is a plain miss, and so is an entry of an older layout
    (another version, or no checksum), removed without a word. Anything else that is not a good entry is
    taken away (`cache.discard_entry`) with one CacheWarning naming it: a path that is not a regular file (seen
    with lstat, never opened: a FIFO, a directory, a link to /dev/zero), an entry that does not read, one
    whose arrays do not match its checksum, and one whose arrays fail `check` (ValueError: the shapes, dtypes,
    finite values and index ranges that are all that stands between an entry and a GL draw)."""
    from .. import cache as c

    store = entry.parent
    st = None
    try:
        st = c.check_regular(entry, store)
        fh = c.open_regular(entry, store)
    except c.NotRegular as exc:
        done = c.discard_entry(entry, exc.st)
        warnings.warn(f"mesh store entry {entry} is unusable ({exc}; {done}); computing it again", c.CacheWarning,
                      stacklevel=2)
        return None
    except OSError:
        return None
    try:
        with fh, np.load(fh, allow_pickle=False) as z:
            meta = json.loads(str(z["__meta__"]))
            if not isinstance(meta, dict) or meta.get("version") != VERSION:
                raise c.StaleEntry(f"version {meta.get('version') if isinstance(meta, dict) else None}")
            stored = {n: z[n] for n in z.files if n != "__meta__"}
        c.verify_checksum(meta.get("checksum"), sorted(stored.items()))
        missing = [n for n in names if n not in stored]
        if missing:
            raise ValueError(f"no array {missing[0]!r}")
        arrays = {n: stored[n] for n in names}
        _check_profile(arrays, meta)
        check(arrays, meta)
    except c.StaleEntry:  # an older layout: replaced without a word (the next write puts the new one there)
        c.discard_entry(entry, st)
        return None
    except Exception as exc:  # noqa: BLE001 - anything that does not read is computed again and replaced
        done = c.discard_entry(entry, st)
        tail = "" if done == "removed" else f"; {done}"
        warnings.warn(f"mesh store entry {entry} is unusable ({c._reason(exc)}{tail}); computing it again",
                      c.CacheWarning, stacklevel=2)
        return None
    with contextlib.suppress(OSError):
        os.utime(entry)  # least recently used goes first when the cache is pruned
    return arrays, meta


def _profile(arrays: dict[str, np.ndarray]) -> dict[str, dict[str, Any]]:
    """What each array of an entry is, stored beside it: dtype, shape, whether all its values are finite
    (floats), the range of its values (integers)."""
    out: dict[str, dict[str, Any]] = {}
    for name, a in arrays.items():
        a = np.asarray(a)
        p: dict[str, Any] = {"dtype": a.dtype.str, "shape": list(a.shape)}
        if a.dtype.kind == "f":
            p["finite"] = bool(np.isfinite(a).all())
        elif a.dtype.kind in "iub" and a.size:
            p["range"] = [int(a.min()), int(a.max())]
        out[name] = p
    return out


def _check_profile(arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
    """The arrays are numbers of the dtype and shape their entry says, finite where they were finite when
    written, integers in the range they had (ValueError otherwise)."""
    profile = meta.get("arrays")
    if not isinstance(profile, dict):
        raise ValueError("no array profile")
    for name, a in arrays.items():
        p = profile.get(name)
        if not isinstance(p, dict):
            raise ValueError(f"no profile for array {name!r}")
        if a.dtype.kind not in "biuf":
            raise ValueError(f"array {name!r} is {a.dtype}, not numbers")
        if a.dtype.str != p.get("dtype") or list(a.shape) != p.get("shape"):
            raise ValueError(f"array {name!r} is {a.dtype.str} {list(a.shape)}, its entry says "
                             f"{p.get('dtype')} {p.get('shape')}")
        if a.dtype.kind == "f" and p.get("finite") is not False and not np.isfinite(a).all():
            raise ValueError(f"array {name!r} holds NaN or Inf")
        if a.dtype.kind in "iub" and a.size:
            lo, hi = (p.get("range") or [None, None])[:2]
            if lo is None or int(a.min()) < lo or int(a.max()) > hi:
                raise ValueError(f"array {name!r} has values in [{a.min()}, {a.max()}], its entry says {lo, hi}")


def _check_mesh(arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
    """A parsed mesh, whatever its metadata says: (n, 3) finite float64 vertices, (m, 3) int32 faces that index
    them, and a list of warnings."""
    v, f = arrays["vertices"], arrays["faces"]
    if not (v.ndim == 2 and v.shape[1] == 3 and v.dtype == np.float64):
        raise ValueError(f"vertices are {v.dtype} {v.shape}, expected float64 (n, 3)")
    if not (f.ndim == 2 and f.shape[1] == 3 and f.dtype == np.int32):
        raise ValueError(f"faces are {f.dtype} {f.shape}, expected int32 (m, 3)")
    if not np.isfinite(v).all():
        raise ValueError("vertices hold NaN or Inf")
    if f.size and (int(f.min()) < 0 or int(f.max()) >= len(v)):
        raise ValueError(f"face indices in [{f.min()}, {f.max()}], outside the {len(v)} vertices")
    if not isinstance(meta.get("warnings"), list):
        raise ValueError("no list of warnings")


def _check_derived(arrays: dict[str, np.ndarray], meta: dict[str, Any], mesh: Any) -> None:
    """A value derived from `mesh`, whatever its metadata says: render streams (`indices` beside `positions`,
    the index buffer a draw reads) index inside their vertices, every per-vertex stream has one row a vertex,
    positions are finite, and `source_vertex` names vertices of the mesh."""
    if "indices" in arrays and "positions" in arrays:
        pos, idx = arrays["positions"], arrays["indices"]
        k = len(pos) if pos.ndim else 0
        if idx.dtype.kind not in "iu":
            raise ValueError(f"indices are {idx.dtype}, not integers")
        if idx.size and (int(idx.min()) < 0 or int(idx.max()) >= k):
            raise ValueError(f"indices in [{idx.min()}, {idx.max()}], outside the {k} vertices")
        if not np.isfinite(pos).all():
            raise ValueError("positions hold NaN or Inf")
        for name, a in arrays.items():
            if name != "indices" and (a.ndim == 0 or len(a) != k):
                raise ValueError(f"{name} has {len(a) if a.ndim else 0} rows for {k} vertices")
    src = arrays.get("source_vertex")
    if src is not None and src.size and (src.dtype.kind not in "iu" or int(src.min()) < 0
                                         or int(src.max()) >= int(mesh.n_vertices)):
        raise ValueError(f"source_vertex in [{src.min()}, {src.max()}], outside the mesh's {mesh.n_vertices} vertices")


def _write(entry: Path, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
    from ..cache import payload_checksum, write_npz

    try:
        entry.parent.mkdir(parents=True, exist_ok=True)
        arrays = {n: np.asarray(a) for n, a in arrays.items()}
        full = {**meta, "version": VERSION, "checksum": payload_checksum(sorted(arrays.items())),
                "arrays": _profile(arrays)}
        write_npz(entry, {"__meta__": np.array(json.dumps(full)), **arrays})
    except Exception:  # noqa: BLE001 - a full or read-only disk costs the next run its parse, nothing else
        return
