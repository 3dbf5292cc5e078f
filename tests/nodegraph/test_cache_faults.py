"""The disk cache under bad entries and faults, in this process: an entry with the right key but the wrong
content is discarded and recomputed with one warning naming node, port and what differed; a failed write
never fails the render and warns once; temporary files are counted and stale ones pruned; frame loops stay
within the limit. The same faults made by real processes are in test_cache_processes.py."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import Field

from nodegraph import cache as cachemod
from nodegraph import pipeline as pl
from nodegraph.cache import Cache, CacheWarning
from nodegraph.executor import Executor
from nodegraph.node import Node, NodeParams, Output
from nodegraph.registry import Registry
from nodegraph.types import ARRAYS, STROKES, Texture, TextureArray
from nodegraph.values import Arrays, Strokes
from tests.nodegraph import entryfaults as ef

COUNTS: dict[str, int] = {}
META = {"node": "x", "type": "test", "version": "1", "params": {}, "package": "0"}


def _count(node: Node) -> None:
    COUNTS[node.id] = COUNTS.get(node.id, 0) + 1


class Img(Node):
    """Two screen-sized textures of one node (so one port's file can be put where the other's belongs)."""

    outputs = {"out": Output(Texture("RGBA32F")), "mask": Output(Texture("R16F"))}

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        _count(self)
        w, h = ctx.size
        ramp = np.linspace(0.0, 1.0, w * h * 4, dtype=np.float32).reshape(h, w, 4)
        out = {"out": ctx.gl.upload(ramp, ctx.format("out"))}
        if "mask" in needed:
            out["mask"] = ctx.gl.upload(ramp[..., :1] * 0.5, ctx.format("mask"))
        return out


class Tones(Node):
    """A texture array that is not screen-sized: its shape comes from `output_shape`."""

    outputs = {"tones": Output(TextureArray("R8"))}

    class Params(NodeParams):
        size: int = Field(16, description="tile size")
        layers: int = Field(3, description="layers")

    def output_shape(self, port: str, size: tuple[int, int]) -> tuple[int, int, int]:
        return (self.params.size, self.params.size, self.params.layers)

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        _count(self)
        s, n = self.params.size, self.params.layers
        data = (np.arange(n * s * s, dtype=np.float32).reshape(n, s, s, 1) % 256) / 255.0
        return {"tones": ctx.gl.texture_array((s, s), n, ctx.format("tones"), data)}


class Curv(Node):
    outputs = {"out": Output(ARRAYS)}

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        _count(self)
        return {"out": Arrays({"kmin": np.linspace(-1, 1, 7), "ids": np.arange(7, dtype=np.int32)})}


class Lines(Node):
    outputs = {"strokes": Output(STROKES)}

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        _count(self)
        polys = [np.array([[0, 0], [3, 1], [7, 5]], np.float32), np.array([[1, 5], [2, 2]], np.float32)]
        return {"strokes": Strokes(polys, ctx.size, 1.5, (0.1, 0.2, 0.3))}


class Liar(Img):
    """Says its outputs are 4x4 (they are screen-sized): its values must not be cached."""

    def output_shape(self, port: str, size: tuple[int, int]) -> tuple[int, int, int]:
        return (4, 4, 1)


class Noise(Node):
    """A new 32x32 float texture every frame, persisted even in frame loops (fills a cache fast)."""

    outputs = {"out": Output(Texture("RGBA32F"))}
    context_keys = frozenset({"size", "frame"})
    persist = "always"

    def compute(self, ctx: Any, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        _count(self)
        w, h = ctx.size
        arr = np.random.default_rng(ctx.frame).random((h, w, 4), dtype=np.float32)
        return {"out": ctx.gl.upload(arr, ctx.format("out"))}


REG = Registry()
for _cls, _name in ((Img, "img"), (Tones, "tones"), (Curv, "curv"), (Lines, "lines"), (Liar, "liar"),
                    (Noise, "noise")):
    REG.add(_cls, _name)

TEXT = """\
pipeline: faults
size: [8, 6]
nodes:
  img: {type: img}
  tam: {type: tones}
  curv: {type: curv}
  lines: {type: lines}
outputs:
  image: img.out
  mask: img.mask
  tones: tam.tones
  curv: curv.out
  lines: lines.strokes
"""


def load(text: str = TEXT) -> pl.Pipeline:
    return pl.loads(text, "faults.yaml", registry=REG, load_scene=False)


@pytest.fixture(autouse=True)
def _reset():
    COUNTS.clear()


_host = ef.host_value
_assert_same = ef.assert_same_values


def _run(gl: Any, root: Path, text: str = TEXT) -> tuple[dict, list[str], Executor]:
    """One run as a command would do it (a new executor and cache object); its values on the host and the
    CacheWarnings it gave."""
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        ex = Executor(load(text), Cache(root), gl=gl)
        res = ex.run()
        values = {ref: _host(v) for ref, v in res.values.items()}
        ex.close()
    return values, [str(w.message) for w in rec if issubclass(w.category, CacheWarning)], ex


def _entry(ex: Executor, nid: str, port: str) -> Path:
    path = ex.cache.find(ex.keys()[nid], ex._entry(nid, port))
    assert path is not None, f"no entry for {nid}.{port}"
    return path


def _name(ex: Executor, nid: str, port: str) -> str:
    return ex._entry(nid, port)


def _exr_raw(path: Path, arr: np.ndarray, pixel: str, attrs: dict[str, str]) -> None:
    """An EXR with any pixel type and header, written by OIIO directly (a file no code path here writes)."""
    import OpenImageIO as oiio

    h, w, c = arr.shape
    spec = oiio.ImageSpec(w, h, c, oiio.HALF if pixel == "half" else oiio.FLOAT)
    for k, v in attrs.items():
        spec.attribute(k, v)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec) and out.write_image(np.ascontiguousarray(arr, np.float32))
    out.close()


def _exr_attrs(path: Path) -> dict[str, str]:
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    inp.close()
    return {a.name: a.value for a in spec.extra_attribs if a.name.startswith("sketchgraph:")}


def _npz_meta(path: Path) -> dict[str, Any]:
    with np.load(path) as z:
        return json.loads(str(z["__meta__"]))


def _rewrite_npz(path: Path, dest: Path, meta_change: Callable[[dict], dict] | None = None,
                 data: np.ndarray | None = None) -> None:
    """Rewrite an npz entry at `dest` with its header changed and/or its `data` replaced."""
    with np.load(path) as z:
        payload = {k: np.array(z[k]) for k in z.files}
    meta = json.loads(str(payload["__meta__"]))
    if meta_change is not None:
        meta = meta_change(meta)
    payload["__meta__"] = np.array(json.dumps(meta))
    if data is not None:
        payload["data"] = data
    tmp = dest.with_name("rewrite.tmp")
    with open(tmp, "wb") as fh:
        np.savez(fh, **payload)
    tmp.replace(dest)


# -- tampering: each makes a readable entry with the right key whose content is not what the plan expects ----
def t_other_port(ex: Executor) -> None:
    shutil.copyfile(_entry(ex, "img", "mask"), _entry(ex, "img", "out"))


def t_exr(shape: tuple[int, int, int], fmt: str = "RGBA32F") -> Callable[[Executor], None]:
    def tamper(ex: Executor) -> None:
        path = _entry(ex, "img", "out")
        cachemod._write_exr(str(path), np.zeros(shape, np.float32), fmt, ex.keys()["img"], _name(ex, "img", "out"),
                            META)
    return tamper


def t_half_pixels(ex: Executor) -> None:
    path = _entry(ex, "img", "out")
    _exr_raw(path, np.zeros((6, 8, 4), np.float32), "half", _exr_attrs(path))  # header unchanged: RGBA32F


def t_array_for_texture(ex: Executor) -> None:
    tex = _entry(ex, "img", "out")
    tex.unlink()
    # a texture array's npz, relabelled with the texture's key and entry name
    _rewrite_npz(_entry(ex, "tam", "tones"), tex.with_suffix(".npz"), lambda m: {
        **m, "sketchgraph:key": ex.keys()["img"], "sketchgraph:port": _name(ex, "img", "out")})


def t_texture_for_array(ex: Executor) -> None:
    arr = _entry(ex, "tam", "tones")
    arr.unlink()
    cachemod._write_exr(str(arr.with_suffix(".exr")), np.zeros((16, 16, 1), np.float32), "R8", ex.keys()["tam"],
                        _name(ex, "tam", "tones"), META)


def t_array(data: np.ndarray, legacy: bool = False) -> Callable[[Executor], None]:
    """Tones entry with other data; its header's size fields updated (or, `legacy`, removed as before they
    existed) so that only the data itself can tell."""
    def tamper(ex: Executor) -> None:
        path = _entry(ex, "tam", "tones")

        def meta(m: dict) -> dict:
            m = {k: v for k, v in m.items() if k not in ("w", "h", "layers")}
            if not legacy:
                m.update(w=data.shape[2], h=data.shape[1], layers=data.shape[0])
            return m
        _rewrite_npz(path, path, meta, data)
    return tamper


def t_swap_kind(src: str, dst: str) -> Callable[[Executor], None]:
    """The npz of one node (strokes or arrays) relabelled as the other's."""
    nodes = {"curv": ("curv", "out"), "lines": ("lines", "strokes")}

    def tamper(ex: Executor) -> None:
        s, d = nodes[src], nodes[dst]
        _rewrite_npz(_entry(ex, *s), _entry(ex, *d), lambda m: {
            **m, "sketchgraph:key": ex.keys()[d[0]], "sketchgraph:port": _name(ex, *d)})
    return tamper


TAMPERED = [
    ("another port's file", t_other_port, "img", "out", "port mask.R16F, expected out.RGBA32F"),
    ("width", t_exr((6, 9, 4)), "img", "out", "width 9, expected 8"),
    ("height", t_exr((5, 8, 4)), "img", "out", "height 5, expected 6"),
    ("channels", t_exr((6, 8, 3)), "img", "out", "3 channels, expected 4"),
    ("format", t_exr((6, 8, 4), "RGBA16F"), "img", "out", "format RGBA16F, expected RGBA32F"),
    ("pixel type", t_half_pixels, "img", "out", "half pixels, expected float"),
    ("texture array for a texture", t_array_for_texture, "img", "out", "kind texture_array, expected texture"),
    ("texture for a texture array", t_texture_for_array, "tam", "tones", "kind texture, expected texture_array"),
    ("layers", t_array(np.zeros((2, 16, 16, 1), np.uint8)), "tam", "tones", "2 layers, expected 3"),
    ("array size", t_array(np.zeros((3, 12, 16, 1), np.uint8)), "tam", "tones", "height 12, expected 16"),
    ("array pixel type", t_array(np.zeros((3, 16, 16, 1), np.float32)), "tam", "tones",
     "float32 pixels, expected uint8"),
    ("array channels", t_array(np.zeros((3, 16, 16, 2), np.uint8)), "tam", "tones", "2 channels, expected 1"),
    ("legacy header, wrong layers", t_array(np.zeros((2, 16, 16, 1), np.uint8), legacy=True), "tam", "tones",
     "2 layers, expected 3"),
    ("strokes for arrays", t_swap_kind("lines", "curv"), "curv", "out", "kind strokes, expected arrays"),
    ("arrays for strokes", t_swap_kind("curv", "lines"), "lines", "strokes", "kind arrays, expected strokes"),
]


@pytest.mark.parametrize(("what", "tamper", "node", "port", "diff"), TAMPERED, ids=[t[0] for t in TAMPERED])
def test_a_wrong_entry_is_discarded_and_recomputed_with_one_warning(gl, tmp_path: Path, what, tamper, node, port,
                                                                   diff):
    root = tmp_path / "c"
    want, warned, ex = _run(gl, root)
    assert warned == [] and set(COUNTS) == {"img", "tam", "curv", "lines"}
    tamper(ex)
    COUNTS.clear()
    got, warned, _ = _run(gl, root)
    assert len(warned) == 1, warned
    assert f"node '{node}' port '{port}'" in warned[0] and diff in warned[0], warned[0]
    assert dict(COUNTS) == {node: 1}  # only the node whose entry was wrong
    _assert_same(got, want)
    COUNTS.clear()
    again, warned, _ = _run(gl, root)  # the recomputed entry replaced the wrong one
    assert warned == [] and COUNTS == {}
    _assert_same(again, want)


def test_entries_written_before_the_new_header_fields_are_still_served(gl, tmp_path: Path):
    root = tmp_path / "c"
    want, _, ex = _run(gl, root)
    exr = _entry(ex, "img", "out")
    attrs = {k: v for k, v in _exr_attrs(exr).items() if k != "sketchgraph:kind"}
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(exr))
    pixels = inp.read_image(oiio.FLOAT)
    inp.close()
    _exr_raw(exr, pixels, "float", attrs)
    t_array(np.array(np.load(_entry(ex, "tam", "tones"))["data"]), legacy=True)(ex)
    assert "layers" not in _npz_meta(_entry(ex, "tam", "tones"))
    assert "sketchgraph:kind" not in _exr_attrs(exr)
    COUNTS.clear()
    got, warned, _ = _run(gl, root)
    assert warned == [] and COUNTS == {}
    _assert_same(got, want)


def test_a_value_unlike_its_declared_shape_is_not_cached(gl, tmp_path: Path):
    text = TEXT.replace("img: {type: img}", "img: {type: liar}")
    root = tmp_path / "c"
    want, warned, ex = _run(gl, root, text)
    assert len(warned) == 2 and all("is not cached" in w and "width 8, expected 4" in w for w in warned)
    assert ex.cache.find(ex.keys()["img"], _name(ex, "img", "out")) is None
    COUNTS.clear()
    got, warned, _ = _run(gl, root, text)  # computed again, never served wrong
    assert COUNTS == {"img": 1} and len(warned) == 2
    _assert_same(got, want)


# -- failed writes -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("background", [False, True])
def test_a_failed_write_warns_once_and_raises_nothing(tmp_path: Path, background):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the cache folder should be")
    cache = Cache(blocker)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        for i in range(5):
            cache.store(f"{i:02d}" + "0" * 62, "out", "arrays", Arrays({"x": np.arange(3)}), META,
                        background=background)
        cache.close()
    msgs = [str(w.message) for w in rec]
    assert len(msgs) == 1 and "cannot write to the disk cache" in msgs[0] and "still produced" in msgs[0], msgs
    assert cache.write_errors == 5 and cache.writes == 0
    assert cache.info()["entries"] == 0 and cache.prune() == (0, 0)  # a file as root: nothing to scan


def test_a_render_whose_cache_writes_fail_still_gives_its_values(gl, tmp_path: Path):
    want, _, _ = _run(gl, tmp_path / "ok")
    blocker = tmp_path / "file"
    blocker.write_text("x")
    got, warned, ex = _run(gl, blocker)
    assert len(warned) == 1 and "cannot write" in warned[0]
    _assert_same(got, want)
    assert ex.cache.write_errors == 5  # img.out, img.mask, tones, curv, lines: each lost, one warning


def test_a_failed_background_write_is_reported_at_exit_when_the_cache_is_never_closed(tmp_path: Path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code = ("import numpy as np, warnings\n"
            "from nodegraph.cache import Cache\n"
            "from nodegraph.values import Arrays\n"
            "warnings.simplefilter('always')\n"
            f"c = Cache({str(blocker)!r})\n"
            "for i in range(3):\n"
            "    c.store(f'{i:02d}' + '0' * 62, 'out', 'arrays', Arrays({'x': np.arange(3)}), {}, background=True)\n"
            "print('done')\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "done"
    assert r.stderr.count("cannot write to the disk cache") == 1, r.stderr
    assert "Traceback" not in r.stderr


# -- bounded ------------------------------------------------------------------------------------------------
def _temp(folder: Path, name: str, size: int, age: float = 0.0) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / name
    p.write_bytes(b"\0" * size)
    if age:
        t = time.time() - age
        os.utime(p, (t, t))
    return p


def test_temporary_files_are_counted_and_only_stale_ones_pruned(tmp_path: Path):
    cache = Cache(tmp_path / "c")
    cache.store("ab" + "0" * 62, "out", "arrays", Arrays({"x": np.arange(100)}), META)
    entry_bytes = cache.info()["bytes"]
    host = cachemod._HOST
    dead = subprocess.Popen(["true"])
    dead.wait()  # a process that has exited (and been reaped): its pid runs nothing now
    live = subprocess.Popen(["sleep", "30"])
    try:
        d = tmp_path / "c" / "ab"
        gone_writer = _temp(d, f".tmp-{dead.pid}@{host}-aaaa.exr", 1000)
        old = _temp(d, ".tmp-zzzz.npz", 2000, age=2 * cachemod.STALE_TEMP_SECONDS)  # an older version's name
        other_host = _temp(d, f".tmp-{dead.pid}@elsewhere-bbbb.exr", 3000)  # cannot be judged from here
        mine = _temp(d, f".tmp-{os.getpid()}@{host}-cccc.exr", 4000)  # our writer thread's, maybe mid-write
        writing = _temp(d, f".tmp-{live.pid}@{host}-dddd.exr", 5000)  # another live process's
        info = cache.info()
        assert info["temp_files"] == 5 and info["temp_bytes"] == 15000
        assert info["entries"] == 1 and info["bytes"] == entry_bytes + 15000
        files, freed = cache.prune()
        assert (files, freed) == (2, 3000)
        assert not gone_writer.exists() and not old.exists()
        assert other_host.exists() and mine.exists() and writing.exists()
        assert cache.info()["entries"] == 1
        # live temporary files count toward the limit: entries go first
        assert cache.prune(12000)[0] == 1 and cache.info()["entries"] == 0
    finally:
        live.kill()
        live.wait()


def test_a_frame_loop_prunes_while_it_runs_and_at_its_end(gl, tmp_path: Path):
    text = "pipeline: loop\nsize: [32, 32]\nnodes:\n  n: {type: noise}\noutputs:\n  image: n.out\n"
    limit = 64 * 1024
    cache = Cache(tmp_path / "c", limit=limit)
    ex = Executor(load(text), cache, gl=gl, mode="loop")
    peak = 0
    for frame in range(24):
        ex.run(frame)
        # frames here take microseconds; in a real loop each takes longer than a write: let the writer keep up
        cache.flush()
        peak = max(peak, cache.info()["bytes"])
    ex.close()
    one = max(e.size for e in cache.entries())
    assert COUNTS == {"n": 24} and cache.writes == 24 and one > 12000  # ~16 KiB each, 24 of them: 6x the limit
    assert cache.info()["bytes"] <= limit
    assert cache.pruned >= 12  # during the loop (every frame's write is over an eighth of the limit), and at its end
    assert peak <= limit * (1 + cachemod.PRUNE_FRACTION) + 2 * one
