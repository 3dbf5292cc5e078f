"""The mesh store (nodegraph/scene/meshstore.py): a mesh file parsed in one process is read from the disk in the
next, the same arrays to the bit, its warnings given again, a changed or damaged file parsed anew, and the
framing's front direction kept with it."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from nodegraph.cache import Cache, CacheWarning
from nodegraph.scene import framing, meshes, meshstore, scene

# a square pyramid whose base is split in two triangles, every face wound outward, plus one degenerate face (a
# repeated vertex): the repair drops it with a MeshWarning
OBJ = """v 0 0 0
v 1 0 0
v 1 0 1
v 0 0 1
v 0.5 1.2 0.5
f 1 2 3
f 1 3 4
f 2 1 5
f 3 2 5
f 4 3 5
f 1 4 5
f 1 1 5
"""


@pytest.fixture
def store(tmp_path: Path):
    root = Cache(tmp_path / "cache").mesh_store
    meshstore.use_cache(Cache(tmp_path / "cache"))
    meshes.clear_mesh_cache()
    yield root
    meshstore.configure(None)
    meshes.clear_mesh_cache()


def _load(path: Path) -> tuple[meshes.Mesh, list[str]]:
    meshes.clear_mesh_cache()  # a new process, as far as the in-memory memo goes
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = meshes.load_mesh(path)
    return mesh, [str(w.message) for w in caught if issubclass(w.category, meshes.MeshWarning)]


def _no_parse(*_a, **_k):
    raise AssertionError("the file was parsed again")


def test_a_second_load_reads_the_store_with_the_same_bits_and_warnings(store, tmp_path, monkeypatch):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    first, said = _load(path)
    assert len(first.faces) == 6 and len(said) == 1 and "degenerate" in said[0]
    assert len(list(store.glob("*.mesh.npz"))) == 1
    monkeypatch.setattr(meshes, "_igl_read", _no_parse)
    again, said_again = _load(path)
    assert again.vertices.tobytes() == first.vertices.tobytes() and again.faces.tobytes() == first.faces.tobytes()
    assert again.vertices.dtype == np.float64 and again.faces.dtype == np.int32
    assert (again.name, again.source) == (first.name, first.source)
    assert again.content_hash() == first.content_hash()
    assert said_again == said


def test_a_changed_file_is_parsed_again(store, tmp_path):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    first, _ = _load(path)
    path.write_text(OBJ.replace("v 0.5 1.2 0.5", "v 0.5 2.0 0.5"))
    changed, _ = _load(path)
    assert changed.vertices[4, 1] == 2.0 and first.vertices[4, 1] == 1.2
    assert len(list(store.glob("*.mesh.npz"))) == 2


def test_a_copy_elsewhere_names_its_own_path_in_its_warnings(store, tmp_path):
    a, b = tmp_path / "a" / "p.obj", tmp_path / "b" / "p.obj"
    for p in (a, b):
        p.parent.mkdir()
        p.write_text(OBJ)
    _, said_a = _load(a)
    _, said_b = _load(b)
    assert str(a) in said_a[0] and str(b) in said_b[0]


@pytest.mark.parametrize("damage", [b"", b"not a zip file", None])
def test_a_damaged_entry_is_parsed_again_and_replaced(store, tmp_path, damage):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    first, _ = _load(path)
    (entry,) = store.glob("*.mesh.npz")
    if damage is None:  # a readable entry of another version
        with np.load(entry) as z:
            arrays = {k: z[k] for k in z.files}
        arrays["__meta__"] = np.array('{"version": "0", "warnings": []}')
        with open(entry, "wb") as fh:
            np.savez(fh, **arrays)
    else:
        entry.write_bytes(damage)
    meshes.clear_mesh_cache()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = meshes.load_mesh(path)
    said = [str(w.message) for w in caught if issubclass(w.category, meshes.MeshWarning)]
    damaged = [str(w.message) for w in caught if issubclass(w.category, CacheWarning)]
    assert again.vertices.tobytes() == first.vertices.tobytes() and len(said) == 1
    # damage is said once, naming the entry; an entry of an older layout is replaced without a word
    assert (damaged == []) if damage is None else (len(damaged) == 1 and entry.name in damaged[0])
    with np.load(entry) as z:
        assert z["faces"].tobytes() == first.faces.tobytes()  # rewritten


def test_an_unwritable_store_only_costs_the_parse(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    meshstore.configure(blocker / "meshes")  # a folder under a file: nothing can be written there
    try:
        path = tmp_path / "pyramid.obj"
        path.write_text(OBJ)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mesh, said = _load(path)
            mesh.hole_share()
        assert len(mesh.faces) == 6 and len(said) == 1
        # a store that cannot be opened is a miss, not a damaged entry: the node cache says what is wrong
        assert not [w for w in caught if issubclass(w.category, CacheWarning)]
    finally:
        meshstore.configure(None)
        meshes.clear_mesh_cache()


def test_without_a_store_every_process_parses(tmp_path, monkeypatch):
    meshstore.configure(None)
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    _load(path)
    monkeypatch.setattr(meshes, "_igl_read", _no_parse)
    with pytest.raises(AssertionError, match="parsed again"):
        _load(path)


def test_the_front_direction_is_kept_and_the_camera_is_the_same(store, tmp_path, monkeypatch):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    first = scene.mesh_scene(path).camera
    assert len(list(store.glob("*.front.npz"))) == 1
    monkeypatch.setattr(framing, "detect_front", _no_parse)
    monkeypatch.setattr(meshes, "_igl_read", _no_parse)
    meshes.clear_mesh_cache()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", meshes.MeshWarning)
        again = scene.mesh_scene(path).camera
    assert again.view_matrix().tobytes() == first.view_matrix().tobytes()
    assert again.projection_matrix(1.0).tobytes() == first.projection_matrix(1.0).tobytes()


def test_entries_are_counted_and_pruned_with_the_cache(store, tmp_path):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    scene.mesh_scene(path)
    cache = Cache(store.parent)
    assert cache.info()["entries"] == cache.info()["meshes"] == 3  # the parsed file, its up axis and its front
    cache.prune(limit=0)
    assert not list(store.glob("*.npz"))


def test_the_command_line_keeps_meshes_under_its_cache_and_not_with_no_cache(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from nodegraph.cli import main

    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    runner = CliRunner()
    try:
        for flag, cache in (("--no-cache", tmp_path / "c1"), (None, tmp_path / "c2")):
            meshes.clear_mesh_cache()
            args = ["run", "nienhaus_sketchy", "--scene", str(path), "--size", "32x32", "--cache-dir", str(cache),
                    "-o", str(tmp_path / "x.png")] + ([flag] if flag else [])
            result = runner.invoke(main, args, catch_exceptions=False)
            assert result.exit_code == 0, result.output
        assert not (tmp_path / "c1").exists()
        assert len(list((tmp_path / "c2" / "meshes").glob("*.mesh.npz"))) == 1
    finally:
        meshstore.configure(None)
        meshes.clear_mesh_cache()


def test_a_cluster_worker_keeps_meshes_under_the_shared_cache(tmp_path):
    """A worker opening a pipeline on a mesh file reads what another process parsed (the same store as the
    client's, under the shared cache root); with no cache (False) it parses."""
    from nodegraph import distributed as dist

    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    spec = dist.PipeSpec.make("nienhaus_sketchy", scene=str(path), size="32x32")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", meshes.MeshWarning)
            dist.WorkerState().pipeline(spec, str(tmp_path / "shared"))
            assert len(list((tmp_path / "shared" / "meshes").glob("*.mesh.npz"))) == 1
            meshes.clear_mesh_cache()
            dist.WorkerState().pipeline(spec, False)
            assert meshstore.root() is None
    finally:
        meshstore.configure(None)
        meshes.clear_mesh_cache()


def _tube_obj(around: int = 50, along: int = 26) -> str:
    """An open tube (no caps: two boundary loops) of 2 x around x along triangles, over MIN_FACES."""
    lines = []
    for j in range(along + 1):
        for i in range(around):
            a = 2 * np.pi * i / around
            lines.append(f"v {np.cos(a):.6f} {j / along * 1.5:.6f} {0.7 * np.sin(a):.6f}")
    for j in range(along):
        for i in range(around):
            v00, v01 = j * around + i + 1, j * around + (i + 1) % around + 1
            v10, v11 = v00 + around, v01 + around
            lines += [f"f {v00} {v10} {v01}", f"f {v01} {v10} {v11}"]
    return "\n".join(lines) + "\n"


def test_derived_arrays_of_a_large_mesh_come_back_the_same_without_being_computed(store, tmp_path, monkeypatch):
    from nodegraph_nodes import pencil_shade
    from nodegraph_nodes.rasterize import enlarge_normals

    path = tmp_path / "tube.obj"
    path.write_text(_tube_obj())

    def derived() -> tuple[scene.Scene, meshes.Mesh, meshes.RenderArrays, float, np.ndarray, np.ndarray]:
        meshes.clear_mesh_cache()
        sc = scene.mesh_scene(path)
        mesh = sc.objects[0].mesh
        ra = mesh.render_arrays(40.0)
        return (sc, mesh, ra, mesh.hole_share(), enlarge_normals(mesh, 40.0),
                pencil_shade._mesh_corner_slots(mesh, ra, 40.0))

    sc, mesh, ra, holes, enlarge, slots = derived()
    assert mesh.n_faces >= meshstore.MIN_FACES and holes > 0
    assert slots.tobytes() == pencil_shade.corner_slots(ra.indices, ra.n_vertices).tobytes()
    assert {p.name.split(".")[-2] for p in store.glob("*.npz")} >= {"mesh", "front", "up", "holes", "render40_0",
                                                                    "enlarge40_0", "slots40_0"}
    for where, name in ((meshes.Mesh, "_render_arrays"), (meshes.Mesh, "_edge_stats"), (framing, "detect_up"),
                        (framing, "up_choice"), (framing, "detect_front"), (meshes, "_igl_read")):
        monkeypatch.setattr(where, name, _no_parse)
    monkeypatch.setattr("nodegraph_nodes.rasterize._enlarge_normals", _no_parse)
    monkeypatch.setattr(pencil_shade, "corner_slots", _no_parse)
    sc2, mesh2, ra2, holes2, enlarge2, slots2 = derived()
    assert holes2 == holes and enlarge2.tobytes() == enlarge.tobytes() and enlarge2.dtype == np.float32
    assert slots2.tobytes() == slots.tobytes() and slots2.dtype == np.int64
    for f in ("positions", "normals", "smooth_normals", "indices", "component", "source_vertex"):
        a, b = getattr(ra, f), getattr(ra2, f)
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), f
    assert sc2.camera.view_matrix().tobytes() == sc.camera.view_matrix().tobytes()


def test_a_small_mesh_computes_its_arrays_in_place(store, tmp_path):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    _load(path)[0].render_arrays(40.0)
    assert not list(store.glob("*.render*.npz"))


def test_changed_code_is_a_new_key(store, tmp_path):
    path = tmp_path / "tube.obj"
    path.write_text(_tube_obj())
    mesh, _ = _load(path)
    code = tmp_path / "code.py"
    code.write_text("one = 1\n")
    calls = []

    def make() -> np.ndarray:
        calls.append(1)
        return np.arange(3.0)

    for _ in range(2):
        meshstore.memo(mesh, "probe", make, (str(code),))
    assert len(calls) == 1  # the second came from the store
    code.write_text("one = 2\n")
    meshstore._code_digests.clear()  # a new process reads the code again
    meshstore.memo(mesh, "probe", make, (str(code),))
    assert len(calls) == 2


def test_a_file_rewritten_while_it_is_read_is_not_stored(store, tmp_path, monkeypatch):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    parse = meshes._load_uncached

    def rewritten_meanwhile(p):
        mesh = parse(p)
        path.write_text(OBJ.replace("v 0.5 1.2 0.5", "v 0.5 2.0 0.5"))  # another writer, mid-read
        return mesh

    monkeypatch.setattr(meshes, "_load_uncached", rewritten_meanwhile)
    _load(path)
    assert not list(store.glob("*.mesh.npz"))


def test_a_posed_mesh_stores_nothing(store, tmp_path):
    """A skinned or morphed mesh is a new mesh every frame: nothing of its own is stored. Its topology (welding,
    holes) is its rest pose's (`Mesh.topology_mesh`), stored once for the rest mesh whatever the frame count."""
    path = tmp_path / "tube.obj"
    path.write_text(_tube_obj())
    rest, _ = _load(path)
    derived = []
    for frame in range(3):
        posed = meshes.Mesh("posed", rest.vertices * (1.0 + 0.1 * frame), rest.faces, rest=rest)
        posed.render_arrays(40.0)
        posed.hole_share()
        derived.append(sorted(p.name for p in store.glob("*.npz") if not p.name.endswith(".mesh.npz")))
    assert derived[0] == derived[1] == derived[2]  # nothing per frame
    rest_key = rest.content_hash()[:12]
    assert all(rest_key in name for name in derived[0]), derived[0]
    rest.hole_share()  # the rest mesh itself is a mesh like any other
    assert len(list(store.glob("*.holes.npz"))) == 1
