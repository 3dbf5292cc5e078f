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
of the code that computes the value, so an edit to that code is a new key, never a stale entry. An entry
that does not read is computed again and replaced, with a `CacheWarning` (as a node entry is); one of an
older layout is replaced without one; a store that cannot be written is skipped without a word: the store
only saves time. Derived arrays are stored for meshes of at least `MIN_FACES` faces (below that computing
them is about as cheap as reading them), and never for a posed mesh (skinned or morphed: a new mesh every
frame of a film)."""

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
    hit = _read(entry, ("vertices", "faces"))
    if hit is not None:
        arrays, meta = hit
        v, f = arrays["vertices"], arrays["faces"]
        notes = meta.get("warnings")
        if (v.ndim == 2 and v.shape[1] == 3 and v.dtype == np.float64 and f.ndim == 2 and f.shape[1] == 3
                and f.dtype == np.int32 and isinstance(notes, list)):
            for note in notes:
                warnings.warn(str(note), category, stacklevel=3)  # at load_mesh's caller
            return build(v, f)
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
    hit = _read(entry, names)
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


def _read(entry: Path, names: tuple[str, ...]) -> tuple[dict[str, np.ndarray], dict[str, Any]] | None:
    """The entry's arrays `names` and its metadata; None for a miss. A store that cannot be opened (no entry,
    a file where its folder should be, no permission) is a plain miss; an entry that opens but does not read
    is a damaged one: it is removed, with a CacheWarning."""
    try:
        fh = open(entry, "rb")  # noqa: SIM115 - closed below, after np.load has read what it needs
    except OSError:
        return None
    try:
        with fh, np.load(fh, allow_pickle=False) as z:
            meta = json.loads(str(z["__meta__"]))
            if not isinstance(meta, dict) or meta.get("version") != VERSION:
                return None
            arrays = {n: z[n] for n in names}
    except Exception as exc:  # noqa: BLE001 - anything that does not read is computed again and replaced
        from ..cache import CacheWarning, _reason

        warnings.warn(f"mesh store entry {entry} is unusable ({_reason(exc)}); computing it again", CacheWarning,
                      stacklevel=2)
        with contextlib.suppress(OSError):
            entry.unlink()
        return None
    with contextlib.suppress(OSError):
        os.utime(entry)  # least recently used goes first when the cache is pruned
    return arrays, meta


def _write(entry: Path, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
    from ..cache import write_npz

    try:
        entry.parent.mkdir(parents=True, exist_ok=True)
        write_npz(entry, {"__meta__": np.array(json.dumps({**meta, "version": VERSION})), **arrays})
    except Exception:  # noqa: BLE001 - a full or read-only disk costs the next run its parse, nothing else
        return
