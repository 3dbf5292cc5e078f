"""The mesh store under damaged and forged entries (nodegraph/scene/meshstore.py): an entry whose arrays were
altered behind its metadata fails its checksum; one forged with a matching checksum still has to pass the checks
of its contents (finite vertices, face indices inside the vertices, render indices inside the render vertices,
dtypes and shapes), so it never reaches GL; a FIFO, a directory or a link to /dev/zero named like an entry is never
opened. Each gives the mesh (or arrays) of a fresh parse, one CacheWarning naming the entry, and leaves a good
entry in its place."""

from __future__ import annotations

import os
import stat
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from nodegraph.cache import Cache, CacheWarning
from nodegraph.scene import meshes, meshstore
from tests.nodegraph import entryfaults as ef
from tests.nodegraph.test_meshstore import OBJ, _tube_obj


@pytest.fixture
def store(tmp_path: Path):
    meshstore.use_cache(Cache(tmp_path / "cache"))
    meshes.clear_mesh_cache()
    yield meshstore.root()
    meshstore.configure(None)
    meshes.clear_mesh_cache()


def _fresh(path: Path) -> meshes.Mesh:
    """The mesh parsed with no store at all."""
    root = meshstore.root()
    meshstore.configure(None)
    meshes.clear_mesh_cache()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", meshes.MeshWarning)
            return meshes.load_mesh(path)
    finally:
        meshstore.configure(root)
        meshes.clear_mesh_cache()


def _load(path: Path) -> tuple[meshes.Mesh, list[str]]:
    """load_mesh in a new process (as far as the in-memory memo goes): the mesh and the CacheWarnings given."""
    meshes.clear_mesh_cache()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = meshes.load_mesh(path)
    return mesh, [str(w.message) for w in caught if issubclass(w.category, CacheWarning)]


def _same_mesh(a: meshes.Mesh, b: meshes.Mesh) -> None:
    assert a.vertices.dtype == b.vertices.dtype and a.faces.dtype == b.faces.dtype
    assert a.vertices.tobytes() == b.vertices.tobytes() and a.faces.tobytes() == b.faces.tobytes()


def _good(entry: Path, names: tuple[str, ...], check: meshstore.Check) -> bool:
    """A regular file that reads as a good entry (the damaged one is gone, a new one is in its place)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning here would mean the entry is still bad
        return stat.S_ISREG(os.lstat(entry).st_mode) and meshstore._read(entry, names, check) is not None


def _mesh_entry(store: Path) -> Path:
    (entry,) = store.glob("*.mesh.npz")
    return entry


def rewrite(change: Callable[[dict[str, np.ndarray]], None], forge: bool) -> Callable[[Path], None]:
    """The entry's arrays changed; its metadata kept as it was (`forge` False: the checksum no longer matches), or
    made to match them (checksum and profile recomputed: only the checks of the contents are left)."""
    def tamper(entry: Path) -> None:
        arrays, meta = ef.npz_contents(entry)
        change(arrays)
        ef.write_npz(entry, arrays, ef.forge_meta(arrays, meta, mesh_store=True) if forge else meta)
    return tamper


def nan_vertex(arrays: dict[str, np.ndarray]) -> None:
    arrays["vertices"] = arrays["vertices"].copy()
    arrays["vertices"][2, 1] = np.nan


def face_out_of_range(arrays: dict[str, np.ndarray]) -> None:
    arrays["faces"] = arrays["faces"].copy()
    arrays["faces"][1, 2] = len(arrays["vertices"]) + 100_000_000


def negative_face(arrays: dict[str, np.ndarray]) -> None:
    arrays["faces"] = arrays["faces"].copy()
    arrays["faces"][0, 0] = -1


def faces_as_int64(arrays: dict[str, np.ndarray]) -> None:
    arrays["faces"] = arrays["faces"].astype(np.int64)


def vertices_2d(arrays: dict[str, np.ndarray]) -> None:
    arrays["vertices"] = np.ascontiguousarray(arrays["vertices"][:, :2])


def swap_with_other_mesh(entry: Path) -> None:
    """The payload of another mesh's entry under this entry's metadata."""
    other = entry.parent / "other.npz"
    assert other.exists()
    arrays, _ = ef.npz_contents(other)
    _, meta = ef.npz_contents(entry)
    ef.write_npz(entry, arrays, meta)


def flip_stored_bytes(entry: Path) -> None:
    """Bytes in the middle of the file changed (inside a stored array: the zip's own CRC catches it)."""
    raw = bytearray(entry.read_bytes())
    i = len(raw) // 2
    raw[i:i + 8] = bytes(b ^ 0xFF for b in raw[i:i + 8])
    entry.write_bytes(bytes(raw))


MESH_FAULTS = [
    ("NaN in vertices", rewrite(nan_vertex, False), "checksum mismatch"),
    ("NaN in vertices, forged checksum", rewrite(nan_vertex, True), "vertices hold NaN or Inf"),
    ("face index out of range", rewrite(face_out_of_range, False), "checksum mismatch"),
    ("face index out of range, forged checksum", rewrite(face_out_of_range, True), "outside the 5 vertices"),
    ("negative face index, forged checksum", rewrite(negative_face, True), "outside the 5 vertices"),
    ("faces int64, forged checksum", rewrite(faces_as_int64, True), "expected int32 (m, 3)"),
    ("vertices (n, 2), forged checksum", rewrite(vertices_2d, True), "expected float64 (n, 3)"),
    ("payload of another mesh", swap_with_other_mesh, "checksum mismatch"),
    ("bytes altered in the file", flip_stored_bytes, ""),
    ("truncated", ef.truncate, ""),
    ("empty directory", lambda e: ef.put_directory(e, "empty"), "a directory, not a regular file; removed"),
    ("directory of temporary files", lambda e: ef.put_directory(e, "temps"),
     "a directory, not a regular file; removed"),
    ("symbolic link to /dev/zero", lambda e: ef.put_symlink(e, "/dev/zero"),
     "a symbolic link to /dev/zero, outside the cache; removed"),
]


@pytest.mark.parametrize(("what", "tamper", "reason"), MESH_FAULTS, ids=[f[0] for f in MESH_FAULTS])
def test_a_bad_mesh_entry_is_parsed_again_with_one_warning_and_replaced(store, tmp_path, what, tamper, reason):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    other = tmp_path / "other.obj"
    other.write_text(OBJ.replace("v 0.5 1.2 0.5", "v 0.5 2.0 0.5"))
    first, warned = _load(path)
    entry = _mesh_entry(store)
    _load(other)
    (other_entry,) = set(store.glob("*.mesh.npz")) - {entry}
    other_entry.rename(store / "other.npz")
    tamper(entry)
    mesh, warned = _load(path)
    _same_mesh(mesh, _fresh(path))
    assert len(warned) == 1 and str(entry) in warned[0] and reason in warned[0], warned
    assert _good(entry, ("vertices", "faces"), meshstore._check_mesh)
    again, warned = _load(path)
    assert warned == []
    _same_mesh(again, first)


def test_a_fifo_named_like_a_mesh_entry_is_never_opened(store, tmp_path, monkeypatch):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    _load(path)
    entry = _mesh_entry(store)
    with ef.fifo_at(entry, tmp_path / "guard") as was_opened:
        rec = ef.OpenRecorder(monkeypatch)
        mesh, warned = _load(path)
        monkeypatch.undo()
        assert not rec.opened(entry) and not was_opened()
    _same_mesh(mesh, _fresh(path))
    assert len(warned) == 1 and str(entry) in warned[0] and "a FIFO, not a regular file; removed" in warned[0]
    assert _good(entry, ("vertices", "faces"), meshstore._check_mesh)


def test_a_directory_with_other_files_is_renamed_aside_once(store, tmp_path):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    _load(path)
    entry = _mesh_entry(store)
    ef.put_directory(entry, "user")
    mesh, warned = _load(path)
    _same_mesh(mesh, _fresh(path))
    (aside,) = store.glob(entry.name + ".unusable-*")
    assert len(warned) == 1 and f"renamed aside to {aside.name}" in warned[0]
    assert (aside / "notes.txt").read_text() == "mine"
    assert _load(path)[1] == []


def test_an_entry_without_a_checksum_is_parsed_again_without_a_warning(store, tmp_path):
    """An entry of the layout before checksums (version 1, no checksum, no profile): stale, replaced silently."""
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    first, _ = _load(path)
    entry = _mesh_entry(store)
    arrays, meta = ef.npz_contents(entry)
    ef.write_npz(entry, arrays, {k: v for k, v in meta.items() if k not in ("checksum", "arrays")})
    mesh, warned = _load(path)
    assert warned == []
    _same_mesh(mesh, first)
    assert "checksum" in ef.npz_contents(entry)[1]


# -- derived arrays: the render streams of a large mesh (the index buffer a draw reads) -----------------------
def _render_entry(store: Path) -> Path:
    (entry,) = store.glob("*.render40_0.npz")
    return entry


def indices_past_the_end(arrays: dict[str, np.ndarray]) -> None:
    arrays["indices"] = arrays["indices"].copy()
    arrays["indices"][7, 1] = 100_000_000


def nan_position(arrays: dict[str, np.ndarray]) -> None:
    arrays["positions"] = arrays["positions"].copy()
    arrays["positions"][3, 0] = np.nan


def source_vertex_out_of_range(arrays: dict[str, np.ndarray]) -> None:
    arrays["source_vertex"] = arrays["source_vertex"].copy()
    arrays["source_vertex"][0] = 10**9


def short_normals(arrays: dict[str, np.ndarray]) -> None:
    arrays["normals"] = arrays["normals"][:-1].copy()


RENDER_FAULTS = [
    ("indices past the end", rewrite(indices_past_the_end, False), "checksum mismatch"),
    ("indices past the end, forged checksum", rewrite(indices_past_the_end, True), "outside the"),
    ("NaN position, forged checksum", rewrite(nan_position, True), "NaN"),
    ("source vertex out of range, forged checksum", rewrite(source_vertex_out_of_range, True), "source_vertex in"),
    ("a stream one row short, forged checksum", rewrite(short_normals, True), "normals has"),
    ("symbolic link to /dev/zero", lambda e: ef.put_symlink(e, "/dev/zero"), "outside the cache; removed"),
]


@pytest.mark.parametrize(("what", "tamper", "reason"), RENDER_FAULTS, ids=[f[0] for f in RENDER_FAULTS])
def test_bad_render_streams_never_reach_a_draw(store, tmp_path, monkeypatch, what, tamper, reason):
    path = tmp_path / "tube.obj"
    path.write_text(_tube_obj())
    mesh, _ = _load(path)
    want = mesh._render_arrays(40.0)
    mesh.render_arrays(40.0)
    entry = _render_entry(store)
    tamper(entry)
    mesh, _ = _load(path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = mesh.render_arrays(40.0)
    warned = [str(w.message) for w in caught if issubclass(w.category, CacheWarning)]
    assert len(warned) == 1 and str(entry) in warned[0] and reason in warned[0], warned
    for f in ("positions", "normals", "smooth_normals", "indices", "component", "source_vertex"):
        a, b = getattr(want, f), getattr(got, f)
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), f
    names = ("positions", "normals", "smooth_normals", "indices", "component", "source_vertex")
    assert _good(entry, names, lambda arrays, meta: meshstore._check_derived(arrays, meta, mesh))
    mesh, _ = _load(path)
    monkeypatch.setattr(meshes.Mesh, "_render_arrays", lambda *_a: pytest.fail("computed again"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", CacheWarning)
        assert mesh.render_arrays(40.0).indices.tobytes() == want.indices.tobytes()  # the new entry is served


def test_a_forged_memo_value_out_of_its_recorded_range_is_refused(store, tmp_path):
    """A derived value with no structure the store knows (corner slots: 0, 1 or 2) is held to the profile it was
    written with: dtype, shape, finiteness and the range of its integers."""
    path = tmp_path / "tube.obj"
    path.write_text(_tube_obj())
    mesh, _ = _load(path)
    calls = []

    def make() -> dict[str, np.ndarray]:
        calls.append(1)
        return {"value": np.arange(30, dtype=np.uint8).reshape(10, 3) % 3}

    code = (str(path),)
    first = meshstore.memo_arrays(mesh, "slots", make, code, ("value",))
    (entry,) = store.glob("*.slots.npz")
    arrays, meta = ef.npz_contents(entry)
    arrays["value"] = arrays["value"].copy()
    arrays["value"][4, 1] = 200
    from nodegraph import cache as cachemod

    meta["checksum"] = cachemod.payload_checksum(sorted(arrays.items()))  # the checksum forged, not the profile
    ef.write_npz(entry, arrays, meta)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = meshstore.memo_arrays(mesh, "slots", make, code, ("value",))
    warned = [str(w.message) for w in caught if issubclass(w.category, CacheWarning)]
    assert len(warned) == 1 and "values in [0, 200]" in warned[0] and len(calls) == 2
    assert again["value"].tobytes() == first["value"].tobytes()
