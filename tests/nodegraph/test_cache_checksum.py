"""Cache entries carry a checksum of their payload, and a path named like an entry is looked at before it is
opened (nodegraph/cache.py, "Checksums" and "Not a file"): an entry whose pixels or arrays were altered behind a
header that still matches, a truncated one, two entries with their payloads swapped, a FIFO, a directory or a
symbolic link where an entry belongs, each gives the image of a fresh compute with one CacheWarning naming the
entry, and is gone afterwards; a FIFO is never opened. Entries written before the checksum are recomputed
without a word."""

from __future__ import annotations

import os
import shutil
import stat
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from nodegraph import cache as cachemod
from nodegraph import pipeline as pl
from nodegraph.cache import Cache, CacheWarning
from nodegraph.executor import Executor
from nodegraph.node import Node, Output
from nodegraph.registry import Registry
from nodegraph.types import ARRAYS, STROKES, Texture, TextureArray
from nodegraph.values import Arrays, Strokes
from tests.nodegraph import entryfaults as ef

COUNTS: dict[str, int] = {}
META = {"node": "x", "type": "test", "version": "1", "params": {}, "package": "0"}
KEY = "cd" + "0" * 62


def _count(node: Node) -> None:
    COUNTS[node.id] = COUNTS.get(node.id, 0) + 1


class Smooth(Node):
    """A float ramp: stored zip-compressed."""

    outputs = {"out": Output(Texture("RGBA32F"))}

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        _count(self)
        w, h = ctx.size
        ramp = np.linspace(0.0, 1.0, w * h * 4, dtype=np.float32).reshape(h, w, 4)
        return {"out": ctx.gl.upload(ramp, "RGBA32F")}


def _noise(seed: int, fmt: str) -> type[Node]:
    class Noisy(Node):
        """Noise: stored uncompressed, so altered bytes read as other pixels, not as a broken stream."""

        outputs = {"out": Output(Texture(fmt))}

        def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
            _count(self)
            w, h = ctx.size
            arr = np.random.default_rng(seed).random((h, w, 4), dtype=np.float32)
            return {"out": ctx.gl.upload(arr, fmt)}
    return Noisy


class Tones(Node):
    outputs = {"tones": Output(TextureArray("R8"))}

    def output_shape(self, port: str, size: tuple[int, int]) -> tuple[int, int, int]:
        return (16, 16, 3)

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        _count(self)
        data = (np.arange(3 * 16 * 16, dtype=np.float32).reshape(3, 16, 16, 1) % 256) / 255.0
        return {"tones": ctx.gl.texture_array((16, 16), 3, "R8", data)}


class Curv(Node):
    outputs = {"out": Output(ARRAYS)}

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        _count(self)
        return {"out": Arrays({"kmin": np.linspace(-1, 1, 64), "ids": np.arange(64, dtype=np.int32)})}


class Lines(Node):
    outputs = {"strokes": Output(STROKES)}

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        _count(self)
        polys = [np.array([[0, 0], [3, 1], [7, 5]], np.float32), np.array([[1, 5], [2, 2]], np.float32)]
        return {"strokes": Strokes(polys, ctx.size, 1.5, (0.1, 0.2, 0.3))}


REG = Registry()
for _cls, _name in ((Smooth, "smooth"), (_noise(1, "RGBA32F"), "noise_a"), (_noise(2, "RGBA32F"), "noise_b"),
                    (_noise(3, "RGBA16F"), "noise_h"), (Tones, "tones"), (Curv, "curv"), (Lines, "lines")):
    REG.add(_cls, _name)

TEXT = """\
pipeline: checksums
size: [40, 24]
nodes:
  smooth: {type: smooth}
  noise_a: {type: noise_a}
  noise_b: {type: noise_b}
  noise_h: {type: noise_h}
  tam: {type: tones}
  curv: {type: curv}
  lines: {type: lines}
outputs:
  smooth: smooth.out
  a: noise_a.out
  b: noise_b.out
  h: noise_h.out
  tones: tam.tones
  curv: curv.out
  lines: lines.strokes
"""
NODES = {"smooth", "noise_a", "noise_b", "noise_h", "tam", "curv", "lines"}
PORTS = {"smooth": "out", "noise_a": "out", "noise_b": "out", "noise_h": "out", "tam": "tones", "curv": "out",
         "lines": "strokes"}


@pytest.fixture(autouse=True)
def _reset():
    COUNTS.clear()


_host = ef.host_value
_assert_same = ef.assert_same_values


def _run(gl: Any, root: Path) -> tuple[dict, list[str], Executor]:
    """One run as a command does it (a new executor and cache): its values on the host and its CacheWarnings."""
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        ex = Executor(pl.loads(TEXT, "checksums.yaml", registry=REG, load_scene=False), Cache(root), gl=gl)
        res = ex.run()
        values = {ref: _host(v) for ref, v in res.values.items()}
        ex.close()
    return values, [str(w.message) for w in rec if issubclass(w.category, CacheWarning)], ex


def _entry(ex: Executor, nid: str) -> Path:
    path = ex.cache.find(ex.keys()[nid], ex._entry(nid, PORTS[nid]))
    assert path is not None, f"no entry for {nid}"
    return path


def _is_good_entry(path: Path) -> bool:
    """A regular file that reads back with a matching checksum (the bad entry is gone, a new one is there)."""
    if not stat.S_ISREG(os.lstat(path).st_mode):
        return False
    name = path.name.split(".", 1)
    key, port = name[0], name[1].rsplit(".", 1)[0]
    reader = cachemod._read_exr if path.suffix == ".exr" else cachemod._read_npz
    reader(path, key, port)  # raises on any mismatch
    return True


# -- the faults: each damages the entries of `nodes` and keeps what a header check would look at --------------
def swap_exr_pixels(ex: Executor) -> None:
    """noise_a's and noise_b's pixels exchanged, each file keeping its own header (checksum included)."""
    import OpenImageIO as oiio

    a, b = _entry(ex, "noise_a"), _entry(ex, "noise_b")
    pix = {}
    specs = {}
    for p in (a, b):
        inp = oiio.ImageInput.open(str(p))
        specs[p] = oiio.ImageSpec(inp.spec())
        pix[p] = inp.read_image(oiio.FLOAT)
        inp.close()
    for p, other in ((a, b), (b, a)):
        out = oiio.ImageOutput.create(str(p))
        assert out.open(str(p), specs[p]) and out.write_image(pix[other])
        out.close()


def alter_npz(nid: str, change: Callable[[dict[str, np.ndarray]], None]) -> Callable[[Executor], None]:
    def tamper(ex: Executor) -> None:
        path = _entry(ex, nid)
        arrays, meta = ef.npz_contents(path)
        change(arrays)
        ef.write_npz(path, arrays, meta)  # the header as it was: its checksum no longer matches
    return tamper


def swap_npz_payloads(ex: Executor) -> None:
    """curv's arrays and an arrays payload of the same names but other values, header kept."""
    path = _entry(ex, "curv")
    arrays, meta = ef.npz_contents(path)
    arrays = {k: v[::-1].copy() for k, v in arrays.items()}
    ef.write_npz(path, arrays, meta)


def _flip(arrays: dict[str, np.ndarray], name: str) -> None:
    a = arrays[name].copy()
    a.reshape(-1)[len(a.reshape(-1)) // 2] += 1
    arrays[name] = a


FAULTS = [
    ("EXR bytes altered, uncompressed, header kept", lambda ex: ef.alter_exr_payload(_entry(ex, "noise_a")),
     {"noise_a"}, "checksum mismatch"),
    ("EXR bytes altered, half, header kept", lambda ex: ef.alter_exr_payload(_entry(ex, "noise_h")),
     {"noise_h"}, "checksum mismatch"),
    ("EXR bytes altered, zip-compressed, header kept", lambda ex: ef.alter_exr_payload(_entry(ex, "smooth")),
     {"smooth"}, ""),
    ("EXR truncated", lambda ex: ef.truncate(_entry(ex, "noise_a")), {"noise_a"}, ""),
    ("EXR truncated, zip-compressed", lambda ex: ef.truncate(_entry(ex, "smooth")), {"smooth"}, ""),
    ("two EXR entries' pixels swapped", swap_exr_pixels, {"noise_a", "noise_b"}, "checksum mismatch"),
    ("npz arrays altered, header kept", alter_npz("curv", lambda a: _flip(a, "a_kmin")), {"curv"},
     "checksum mismatch"),
    ("npz texture array altered, header kept", alter_npz("tam", lambda a: _flip(a, "data")), {"tam"},
     "checksum mismatch"),
    ("npz strokes altered, header kept", alter_npz("lines", lambda a: _flip(a, "points")), {"lines"},
     "checksum mismatch"),
    ("npz payload swapped for another", swap_npz_payloads, {"curv"}, "checksum mismatch"),
    ("npz truncated", lambda ex: ef.truncate(_entry(ex, "curv")), {"curv"}, ""),
    ("empty directory named like an EXR entry", lambda ex: ef.put_directory(_entry(ex, "noise_a"), "empty"),
     {"noise_a"}, "a directory, not a regular file; removed"),
    ("directory of temporary files named like an npz entry",
     lambda ex: ef.put_directory(_entry(ex, "curv"), "temps"), {"curv"}, "a directory, not a regular file; removed"),
    ("symbolic link to /dev/zero", lambda ex: ef.put_symlink(_entry(ex, "noise_a"), "/dev/zero"), {"noise_a"},
     "a symbolic link to /dev/zero, outside the cache; removed"),
    ("symbolic link to /dev/zero for an npz", lambda ex: ef.put_symlink(_entry(ex, "tam"), "/dev/zero"), {"tam"},
     "a symbolic link to /dev/zero, outside the cache; removed"),
    ("dangling symbolic link", lambda ex: ef.put_symlink(_entry(ex, "smooth"), "nowhere.exr"), {"smooth"},
     "does not lead to a file; removed"),
]


@pytest.mark.parametrize(("what", "tamper", "nodes", "reason"), FAULTS, ids=[f[0] for f in FAULTS])
def test_a_damaged_entry_gives_the_fresh_result_with_one_warning_and_is_gone(gl, tmp_path: Path, what, tamper,
                                                                            nodes, reason):
    root = tmp_path / "c"
    want, warned, ex = _run(gl, root)
    assert warned == [] and set(COUNTS) == NODES
    paths = {nid: _entry(ex, nid) for nid in nodes}
    tamper(ex)
    COUNTS.clear()
    got, warned, _ = _run(gl, root)
    _assert_same(got, want)  # the image and data of a fresh compute
    assert set(COUNTS) == nodes and all(n == 1 for n in COUNTS.values())  # only the damaged ones, once
    assert len(warned) == len(nodes), warned  # one warning an entry, naming it
    for nid, path in paths.items():
        (line,) = [w for w in warned if str(path) in w]
        assert f"node '{nid}' port '{PORTS[nid]}'" in line and reason in line, line
        assert _is_good_entry(path)  # the bad one gone, the recomputed one in its place
    COUNTS.clear()
    again, warned, _ = _run(gl, root)
    assert warned == [] and COUNTS == {}
    _assert_same(again, want)


@pytest.mark.parametrize("nid", ["noise_a", "curv"])
def test_a_fifo_named_like_an_entry_is_never_opened(gl, tmp_path: Path, monkeypatch, nid):
    root = tmp_path / "c"
    want, _, ex = _run(gl, root)
    path = _entry(ex, nid)
    COUNTS.clear()
    with ef.fifo_at(path, tmp_path / "guard") as was_opened:
        rec = ef.OpenRecorder(monkeypatch)
        got, warned, _ = _run(gl, root)
        monkeypatch.undo()
        assert not rec.opened(path) and not was_opened()
    _assert_same(got, want)
    assert dict(COUNTS) == {nid: 1}
    assert len(warned) == 1 and str(path) in warned[0] and "a FIFO, not a regular file; removed" in warned[0]
    assert _is_good_entry(path)
    COUNTS.clear()
    _, warned, _ = _run(gl, root)
    assert warned == [] and COUNTS == {}


def test_a_special_file_is_refused_by_load_without_being_opened_and_removed(tmp_path: Path, monkeypatch):
    cache = Cache(tmp_path / "c")
    cache.store(KEY, "out", "arrays", Arrays({"x": np.arange(5)}), META)
    path = cache.find(KEY, "out")
    with ef.fifo_at(path, tmp_path / "guard") as was_opened:
        rec = ef.OpenRecorder(monkeypatch)
        with pytest.warns(CacheWarning, match="a FIFO, not a regular file; removed") as caught:
            assert cache.load(KEY, "out") is None
        monkeypatch.undo()
        assert len(caught) == 1 and not rec.opened(path) and not was_opened()
    assert not os.path.lexists(path) and cache.recovered == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert cache.load(KEY, "out") is None  # a plain miss now: nothing to say twice


def test_a_directory_that_holds_other_files_is_renamed_aside_once(gl, tmp_path: Path):
    root = tmp_path / "c"
    want, _, ex = _run(gl, root)
    path = _entry(ex, "noise_a")
    ef.put_directory(path, "user")
    COUNTS.clear()
    got, warned, _ = _run(gl, root)
    _assert_same(got, want)
    assert COUNTS == {"noise_a": 1} and len(warned) == 1 and str(path) in warned[0]
    (aside,) = path.parent.glob(path.name + ".unusable-*")
    assert "it holds other files: renamed aside to " + aside.name in warned[0]
    assert (aside / "notes.txt").read_text() == "mine"  # not ours to delete
    assert _is_good_entry(path)
    COUNTS.clear()
    _, warned, _ = _run(gl, root)
    assert warned == [] and COUNTS == {}  # said once, not on every run


def test_a_symbolic_link_to_an_entry_inside_the_cache_is_served(gl, tmp_path: Path):
    root = tmp_path / "c"
    want, _, ex = _run(gl, root)
    for nid in ("noise_a", "curv"):
        path = _entry(ex, nid)
        moved = root / "elsewhere" / path.name
        moved.parent.mkdir(exist_ok=True)
        shutil.move(path, moved)
        os.symlink(moved, path)
    COUNTS.clear()
    got, warned, _ = _run(gl, root)
    assert warned == [] and COUNTS == {}
    _assert_same(got, want)


def test_a_symbolic_link_to_a_file_outside_the_cache_is_refused(gl, tmp_path: Path):
    root = tmp_path / "c"
    want, _, ex = _run(gl, root)
    path = _entry(ex, "noise_a")
    outside = tmp_path / "outside.exr"
    shutil.move(path, outside)
    os.symlink(outside, path)
    COUNTS.clear()
    got, warned, _ = _run(gl, root)
    _assert_same(got, want)
    assert COUNTS == {"noise_a": 1} and len(warned) == 1 and "outside the cache; removed" in warned[0]
    assert outside.exists() and _is_good_entry(path)  # the link removed, never its target


def test_entries_without_a_checksum_are_recomputed_without_a_warning(gl, tmp_path: Path):
    """Entries written before the checksum existed are stale: removed and recomputed, silently (an upgrade would
    otherwise warn once for every entry of a cache)."""
    import OpenImageIO as oiio

    root = tmp_path / "c"
    want, _, ex = _run(gl, root)
    exr = _entry(ex, "noise_a")
    inp = oiio.ImageInput.open(str(exr))
    spec = oiio.ImageSpec(inp.spec())
    pixels = inp.read_image(oiio.FLOAT)
    inp.close()
    spec.erase_attribute(cachemod.CHECKSUM_ATTR)
    out = oiio.ImageOutput.create(str(exr))
    assert out.open(str(exr), spec) and out.write_image(pixels)
    out.close()
    npz = _entry(ex, "curv")
    arrays, meta = ef.npz_contents(npz)
    del meta["checksum"]
    ef.write_npz(npz, arrays, meta)
    COUNTS.clear()
    got, warned, ex2 = _run(gl, root)
    assert warned == [] and COUNTS == {"noise_a": 1, "curv": 1} and ex2.cache.stale == 2
    _assert_same(got, want)
    assert _is_good_entry(exr) and _is_good_entry(npz)


def test_every_entry_carries_the_checksum_of_its_payload(gl, tmp_path: Path):
    import OpenImageIO as oiio

    _, _, ex = _run(gl, tmp_path / "c")
    for nid in NODES:
        path = _entry(ex, nid)
        if path.suffix == ".exr":
            inp = oiio.ImageInput.open(str(path))
            spec = inp.spec()
            stored = spec.get_string_attribute(cachemod.CHECKSUM_ATTR)
            pixels = inp.read_image(spec.format)
            inp.close()
            extra = cachemod._exr_extra(spec.get_string_attribute("sketchgraph:fmt"),
                                        spec.get_string_attribute("sketchgraph:drawn"))
            assert stored == cachemod.payload_checksum([("pixels", pixels)], extra)
        else:
            arrays, meta = ef.npz_contents(path)
            assert meta["checksum"] == cachemod.payload_checksum(
                sorted(arrays.items()), cachemod._npz_extra(meta["kind"], meta["fmt"]))
        assert stored.startswith("crc32:") if path.suffix == ".exr" else meta["checksum"].startswith("crc32:")


def test_the_checksum_sees_bytes_shape_dtype_and_names():
    a = np.arange(12, dtype=np.float32).reshape(3, 4)
    base = cachemod.payload_checksum([("x", a)])
    assert base == cachemod.payload_checksum([("x", a.copy())]) == cachemod.payload_checksum({"x": a})
    b = a.copy()
    b.reshape(-1).view(np.uint8)[17] ^= 1
    others = [cachemod.payload_checksum([("x", b)]), cachemod.payload_checksum([("x", a.reshape(4, 3))]),
              cachemod.payload_checksum([("x", a.view(np.int32))]), cachemod.payload_checksum([("y", a)]),
              cachemod.payload_checksum([("x", a)], "RGBA16F")]
    assert len({base, *others}) == 6
    assert cachemod.payload_checksum([("x", a[:, ::2])]) == cachemod.payload_checksum([("x", a[:, ::2].copy())])
