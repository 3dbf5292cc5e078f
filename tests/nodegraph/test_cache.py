"""The disk cache: a value of each stored kind round-trips through `store_value` and `load`; the kind decides
the file (EXR for textures, .npz for the rest); values that are never cached write nothing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph.cache import Cache, kind_of
from nodegraph.values import Arrays, Strokes

META = {"node": "n", "type": "test", "version": 1, "params": {"a": 1}, "package": "0"}
KEY = "ab" + "0" * 62


def _roundtrip(cache: Cache, value, port: str, background: bool = False):
    assert cache.store_value(KEY, port, value, META, background=background)
    cache.flush()
    return cache.load(KEY, port)


@pytest.mark.parametrize("background", [False, True])
def test_texture_round_trips_as_exr(gl, tmp_path: Path, rng, background):
    cache = Cache(tmp_path / "c")
    arr = rng.random((6, 5, 4), dtype=np.float32)
    tex = gl.upload(arr, "RGBA32F")
    loaded = _roundtrip(cache, tex, "out.RGBA32F", background)
    gl.release(tex)
    assert cache.find(KEY, "out.RGBA32F").suffix == ".exr"
    assert loaded.kind == "texture" and loaded.fmt == "RGBA32F"
    np.testing.assert_array_equal(loaded.data, arr)
    cache.close()


def test_half_texture_keeps_its_format(gl, tmp_path: Path, rng):
    cache = Cache(tmp_path / "c")
    tex = gl.upload(rng.random((4, 3, 1), dtype=np.float32), "R16F")
    want = tex.read()
    loaded = _roundtrip(cache, tex, "edges.R16F")
    gl.release(tex)
    assert loaded.kind == "texture" and loaded.fmt == "R16F"
    np.testing.assert_array_equal(loaded.data, want)


def test_texture_array_round_trips_in_its_own_precision(gl, tmp_path: Path, rng):
    cache = Cache(tmp_path / "c")
    data = np.round(rng.random((3, 8, 8, 1)) * 255.0).astype(np.float32) / 255.0
    arr = gl.texture_array((8, 8), 3, "R8", data)
    want = arr.read()
    loaded = _roundtrip(cache, arr, "tones")
    gl.release(arr)
    assert cache.find(KEY, "tones").suffix == ".npz"
    assert loaded.kind == "texture_array" and loaded.fmt == "R8"
    np.testing.assert_allclose(loaded.data, want, atol=1e-6)


def test_strokes_round_trip(tmp_path: Path):
    cache = Cache(tmp_path / "c")
    polys = [np.array([[0.0, 1.0], [2.5, 3.0], [4.0, 4.5]], np.float32), np.array([[7.0, 8.0], [9.0, 1.0]], np.float32)]
    loaded = _roundtrip(cache, Strokes(polys, (32, 16), 1.5, (0.2, 0.3, 0.4)), "strokes")
    assert loaded.kind == "strokes"
    s = loaded.data
    assert isinstance(s, Strokes) and s.size == (32, 16) and s.width == 1.5
    assert s.color == pytest.approx((0.2, 0.3, 0.4))
    assert len(s.polylines) == 2 and all(np.array_equal(a, b) for a, b in zip(s.polylines, polys, strict=True))


def test_empty_strokes_round_trip(tmp_path: Path):
    loaded = _roundtrip(Cache(tmp_path / "c"), Strokes([], (8, 8)), "strokes")
    assert loaded.kind == "strokes" and loaded.data.polylines == [] and loaded.data.size == (8, 8)


def test_arrays_round_trip(tmp_path: Path, rng):
    cache = Cache(tmp_path / "c")
    data = {"kmin": rng.random(10), "dmin": rng.random((10, 3)).astype(np.float32), "reason": np.arange(10)}
    loaded = _roundtrip(cache, Arrays(data), "out")
    assert loaded.kind == "arrays" and set(loaded.data.data) == set(data)
    for k, v in data.items():
        assert loaded.data[k].dtype == v.dtype
        np.testing.assert_array_equal(loaded.data[k], v)


def test_values_that_are_never_cached_write_nothing(tmp_path: Path):
    cache = Cache(tmp_path / "c")
    assert kind_of(object()) is None
    assert not cache.store_value(KEY, "scene", object(), META)
    assert cache.find(KEY, "scene") is None and cache.writes == 0


def test_a_wrong_key_is_discarded(tmp_path: Path):
    cache = Cache(tmp_path / "c")
    _roundtrip(cache, Arrays({"x": np.zeros(3)}), "out")
    other = "ab" + "1" * 62
    path = cache.find(KEY, "out")
    path.rename(path.with_name(path.name.replace(KEY, other)))
    with pytest.warns(UserWarning, match="unusable"):
        assert cache.load(other, "out") is None


def test_serial_runs_read_and_write_their_renderers_namespace(gl, tmp_path) -> None:
    """An executor binds its cache to its GL renderer: entries land in root/renderer-<digest>/ and a run on
    another renderer (a cache bound to another string) finds none of them; info and prune see all."""
    from nodegraph import pipeline as pl
    from nodegraph.cache import Cache, renderer_namespace
    from nodegraph.executor import Executor

    pipe = pl.loads("pipeline: t\nsize: [24, 16]\nscene: builtin:box\nnodes:\n  g: {type: rasterize}\n"
                    "outputs: {image: g.color}\n", "t.yaml")
    cache = Cache(tmp_path)
    ex = Executor(pipe, cache, gl=gl)
    ex.run()
    ex.close()
    ns = renderer_namespace(gl.renderer)
    assert cache.namespace == ns and {p.name for p in tmp_path.iterdir()} == {ns}
    key = ex.keys()["g"]
    assert Cache(tmp_path, renderer=gl.renderer).find(key, ex._entry("g", "color")) is not None
    assert Cache(tmp_path, renderer="NVIDIA Corporation NVIDIA H200 4.6").find(key, ex._entry("g", "color")) is None
    assert Cache(tmp_path).info()["entries"] == len(cache.entries()) >= 1


@pytest.mark.parametrize("fmt", ["RGBA16F", "R16F", "RGBA8", "R8"])
def test_half_entries_load_as_half_and_upload_the_same_texels(gl, tmp_path: Path, rng, fmt):
    # entries stored as half are read as float16 (no float32 copy on the way to a half texture): the same values,
    # and a texture made from them reads back as the original did; 8-bit textures round-trip every level
    cache = Cache(tmp_path / "c")
    c = 4 if fmt.startswith("RGBA") else 1
    if fmt.endswith("8"):
        arr = (np.arange(256 * c, dtype=np.float32).reshape(16, 16, c) % 256) / 255.0
    else:
        arr = (rng.standard_normal((9, 7, c)) * 40).astype(np.float32)
    tex = gl.upload(arr, fmt)
    want = tex.read()
    loaded = _roundtrip(cache, tex, f"out.{fmt}")
    gl.release(tex)
    assert loaded.data.dtype == np.float16
    again = gl.upload(loaded.data, fmt)
    np.testing.assert_array_equal(again.read(), want)
    gl.release(again)
    cache.close()


@pytest.mark.parametrize("kind", ["noise", "blank", "smooth"])
def test_incompressible_entries_are_stored_uncompressed_and_round_trip_exactly(gl, tmp_path: Path, rng, kind):
    # the compression is chosen from a sample of rows (`exr_compression`): noise is written as it is, buffers that
    # deflate well stay zip; either way the entry reads back bit for bit
    import OpenImageIO as oiio

    h, w = 64, 96
    if kind == "noise":
        arr = rng.standard_normal((h, w, 2)).astype(np.float32)
    elif kind == "blank":
        arr = np.zeros((h, w, 2), np.float32)
        arr[20:30, 40:50] = 1.0
    else:
        arr = np.dstack(np.meshgrid(np.linspace(0, 1, w), np.linspace(0, 1, h))).astype(np.float32)
    cache = Cache(tmp_path / "c")
    tex = gl.upload(arr, "RG16F")
    want = tex.read_native()
    loaded = _roundtrip(cache, tex, "out.RG16F")
    gl.release(tex)
    np.testing.assert_array_equal(loaded.data.view(np.uint16), want.view(np.uint16))
    inp = oiio.ImageInput.open(str(cache.find(KEY, "out.RG16F")))
    stored = inp.spec().get_string_attribute("compression")
    inp.close()
    assert stored == ("none" if kind == "noise" else "zip")
    cache.close()
