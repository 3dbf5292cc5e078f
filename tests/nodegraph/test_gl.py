"""`GL.read_uint8`, `GL.read_png_rows` and `GL.read_yuv420` (8-bit file values made on the GPU) against NumPy:
x * 255 in float32 rounded half to even and clamped, NaN as 0, rows top first; PNG rows as a filter byte 0 and
the row's grey or RGB bytes; film planes as BT.601 limited-range 4:2:0 of those values. Files written from
the rows decode (OpenImageIO) to the same values. `GL.clear_each` against the values it was given."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodegraph import types
from nodegraph.gpu.gl import PngBlock, PngRowsBuffer
from nodegraph.output import imageio

FORMATS = ["R8", "RGBA8", "R16F", "RG16F", "RGBA16F", "R32F", "RG32F", "RGBA32F"]
# widths where the PNG row stream is and is not 4-aligned, and multiples of 16 pixels, whose rows
# `read_png_rows` makes in its wide pass (16 bytes a fragment, grey and RGB alike)
SIZES = [(1, 1), (2, 3), (7, 5), (33, 17), (64, 9), (16, 2), (48, 3), (80, 4), (96, 1)]


def _texture(gl, rng, fmt: str, w: int, h: int):
    c = types.components(fmt)
    a = rng.random((h, w, c), dtype=np.float32) * 1.4 - 0.2  # out of [0, 1] on both sides
    ties = ((rng.integers(0, 255, (h, w, c)) + 0.5) / 255.0).astype(np.float32)
    a = np.where(rng.random((h, w, c)) < 0.4, ties, a)  # values whose x * 255 lands at or near .5
    if not fmt.endswith("8"):
        a[0, 0, 0] = np.nan
    return gl.upload(a, fmt)


def _reference(tex) -> np.ndarray:
    """(H, W, 4) uint8, row 0 at the top, from the texture's float read-back (NumPy only)."""
    x = tex.read().astype(np.float32)
    h, w, c = x.shape
    v = np.rint(x * np.float32(255.0))
    v = np.where(np.isnan(v), 0.0, np.clip(v, 0.0, 255.0)).astype(np.uint8)
    out = np.zeros((h, w, 4), np.uint8)
    out[:, :, 3] = 255  # what GL samples for missing channels: colour 0, alpha 1
    out[:, :, :c] = v
    return out[::-1]


@pytest.mark.parametrize("fmt", FORMATS)
def test_read_uint8_and_png_rows_match_numpy(gl, rng, fmt):
    for w, h in SIZES:
        tex = _texture(gl, rng, fmt, w, h)
        try:
            want = _reference(tex)
            np.testing.assert_array_equal(gl.read_uint8(tex), want)
            rows, c = gl.read_png_rows(tex)
            assert c == (1 if types.components(fmt) == 1 else 3)
            expect = np.zeros((h, 1 + w * c), np.uint8)
            expect[:, 1:] = want[:, :, :c].reshape(h, w * c)
            assert rows.dtype == np.uint8 and rows.shape == (h * (1 + w * c),)
            np.testing.assert_array_equal(rows.reshape(h, -1), expect, err_msg=f"{fmt} {w}x{h}")
        finally:
            gl.release(tex)


def _blank_outside(gl, rng, fmt: str, cases):
    """For each ((w, h), rect): `_blank_texture`'s texture, footprint and label; released after use."""
    for size, rect in cases:
        tex, fp, label = _blank_texture(gl, rng, fmt, size, rect)
        try:
            yield tex, fp, label
        finally:
            gl.release(tex)


def _blank_texture(gl, rng, fmt: str, size, rect):
    """A texture of `fmt` holding random values inside `rect` and one random blank value outside, with no
    footprint yet, the footprint to give it, and a label."""
    from nodegraph.values import Footprint

    c = types.components(fmt)
    w, h = size
    blank = tuple(float(v) for v in rng.random(c) * 1.3 - 0.1)
    rough = _texture(gl, rng, fmt, w, h)
    values = rough.read()
    gl.release(rough)
    x, y, rw, rh = rect
    filled = np.broadcast_to(np.asarray(blank, np.float32), values.shape).copy()
    filled[y:y + rh, x:x + rw] = values[y:y + rh, x:x + rw]
    return gl.upload(filled, fmt), Footprint(rect, blank), f"{fmt} {w}x{h} {rect}"


@pytest.mark.parametrize("fmt", FORMATS)
def test_png_rows_of_a_texture_with_a_footprint_are_the_whole_rows(gl, rng, fmt):
    # only the footprint's fragments are packed and read back, the rest is the blank texel's bytes repeated:
    # the same rows as the whole pass for rectangles inside, at and across the edges, and an empty one
    cases = [((80, 12), (7, 2, 30, 5)), ((80, 12), (0, 0, 80, 5)), ((96, 9), (50, 0, 46, 9)),
             ((48, 3), (1, 1, 1, 1)), ((64, 9), (10, 4, 0, 0)), ((160, 30), (33, 7, 91, 20))]
    for tex, fp, label in _blank_outside(gl, rng, fmt, cases):
        whole, cw = gl.read_png_rows(tex)
        tex.footprint = fp
        part, cp = gl.read_png_rows(tex)
        assert cw == cp
        np.testing.assert_array_equal(part, whole, err_msg=label)


def test_pack_png_read_later_with_slots_alternating_gives_each_frames_rows(gl, rng):
    # as a sequence uses it: frames packed into alternating slots and read a frame later, their footprints
    # moving and changing size (new targets), placed inside the image and against its right and top edges
    cases = [((320, 200), (40, 30, 150, 90)), ((320, 200), (200, 150, 120, 50)), ((320, 200), (0, 0, 320, 200)),
             ((320, 200), (3, 60, 17, 3)), ((320, 200), (260, 0, 60, 200)), ((320, 200), (100, 100, 0, 0))]
    textures, wanted = [], []
    try:
        for size, rect in cases:
            tex, fp, label = _blank_texture(gl, rng, "RGBA16F", size, rect)
            textures.append(tex)
            wanted.append((gl.read_png_rows(tex)[0], label))  # the whole pass, read at once
            tex.footprint = fp
        packs = []
        kept = PngRowsBuffer()  # as a writer thread lays out one frame after another
        for i, tex in enumerate(textures):
            packs.append(gl.pack_png(tex, i % 2))
            if i >= 1:
                block = packs[i - 1].read()
                np.testing.assert_array_equal(block.rows(), wanted[i - 1][0], err_msg=wanted[i - 1][1])
                np.testing.assert_array_equal(block.rows(kept), wanted[i - 1][0], err_msg=wanted[i - 1][1])
        block = packs[-1].read()
        np.testing.assert_array_equal(block.rows(), wanted[-1][0], err_msg=wanted[-1][1])
        np.testing.assert_array_equal(block.rows(kept), wanted[-1][0], err_msg=wanted[-1][1])
    finally:
        for tex in textures:
            gl.release(tex)


@pytest.mark.parametrize("fmt", FORMATS)
def test_yuv420_planes_of_a_texture_with_a_footprint_are_the_whole_planes(gl, rng, fmt):
    # only the fragments over the footprint are converted and read back, the rest is the blank pixel's Y, U, V
    # (odd sizes and rows of a width not a multiple of 4 convert the whole frame)
    cases = [((80, 12), (7, 2, 30, 5)), ((96, 64), (0, 0, 50, 64)), ((160, 48), (33, 7, 91, 20)),
             ((64, 30), (5, 5, 0, 0)), ((82, 30), (5, 5, 20, 9)), ((33, 17), (3, 3, 9, 9))]
    for tex, fp, label in _blank_outside(gl, rng, fmt, cases):
        whole = gl.read_yuv420(tex)
        tex.footprint = fp
        part = gl.read_yuv420(tex)
        for plane in ("y_even", "y_odd", "u", "v"):
            np.testing.assert_array_equal(getattr(part, plane), getattr(whole, plane), err_msg=f"{label} {plane}")


def test_pack_yuv420_read_later_with_slots_alternating_gives_each_frames_planes(gl, rng):
    # as a film uses it: frames packed into alternating slots and read a frame later, whole frames between
    # footprints that move, change size (new targets) and bring new blank values (found while a whole frame
    # waits to be read), against the right and top edges
    cases = [((320, 200), None), ((320, 200), (40, 30, 150, 90)), ((320, 200), None),
             ((320, 200), (200, 150, 120, 50)), ((320, 200), (3, 60, 17, 3)), ((320, 200), (260, 0, 60, 200)),
             ((320, 200), (100, 100, 0, 0))]
    textures, wanted = [], []
    try:
        for size, rect in cases:
            tex, fp, label = _blank_texture(gl, rng, "RGBA16F", size, rect or (0, 0, *size))
            textures.append(tex)
            wanted.append((gl.read_yuv420(tex), label))  # the whole pass, read at once
            if rect is not None:
                tex.footprint = fp
        packs = []

        def check(i):
            got, (want, label) = packs[i].read(), wanted[i]
            for plane in ("y_even", "y_odd", "u", "v"):
                np.testing.assert_array_equal(getattr(got, plane), getattr(want, plane), err_msg=f"{label} {plane}")

        for i, tex in enumerate(textures):
            packs.append(gl.pack_yuv420(tex, i % 2))
            if i >= 1:
                check(i - 1)
        check(len(textures) - 1)
    finally:
        for tex in textures:
            gl.release(tex)


def test_a_png_from_gpu_rows_is_the_png_of_the_values(gl, rng, tmp_path):
    tex = _texture(gl, rng, "RGBA16F", 37, 11)
    try:
        rows, c = gl.read_png_rows(tex)
        want = _reference(tex)[:, :, :3]
    finally:
        gl.release(tex)
    gpu = imageio.write_png_rows(tmp_path / "gpu.png", rows, 37, 11, c, level=1)
    host = imageio.write_png8(tmp_path / "host.png", np.ascontiguousarray(want), level=1)
    assert gpu.read_bytes() == host.read_bytes()
    decoded = imageio.read(gpu)  # float, row 0 at the bottom
    np.testing.assert_array_equal(np.rint(decoded[::-1] * 255).astype(np.uint8), want)


def test_write_png_rows_refuses_rows_of_the_wrong_length(tmp_path):
    from nodegraph.errors import SketchgraphError

    with pytest.raises(SketchgraphError, match="expected 2 rows of 1 \\+ 3 x 3 bytes"):
        imageio.write_png_rows(tmp_path / "x.png", np.zeros(19, np.uint8), 3, 2, 3)
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("level", [0, 1, 3, 6, 9])
def test_every_png_level_decodes_to_the_same_values(rng, tmp_path, level):
    """Levels 1-3 are ISA-L's deflate where it is installed, the others zlib's: the same pixels either way."""
    img = rng.integers(0, 256, (23, 31, 3), dtype=np.uint8)
    img[5:, :] = img[5, :]  # compressible rows too
    path = imageio.write_png8(tmp_path / f"l{level}.png", img, level)
    np.testing.assert_array_equal(np.rint(imageio.read(path)[::-1] * 255).astype(np.uint8), img)
    if level == 0:  # stored: the rows and a little framing
        assert path.stat().st_size > img.size


def _planes(p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    w, h = p.size
    y = np.empty((h, w), np.uint8)
    y[0::2], y[1::2] = p.y_even[:, :w], p.y_odd[:, :w]
    return y, p.u[:, :w // 2], p.v[:, :w // 2]


@pytest.mark.parametrize("fmt", ["R8", "RGBA8", "R16F", "RG16F", "RGBA32F"])
def test_read_yuv420_matches_numpy(gl, rng, fmt):
    """The GPU's planes against float64 NumPy of the same conversion (tests.helpers.yuv420_reference) on the
    8-bit values `read_uint8` gives: rounded half to even, 1 off allowed only within 1e-3 of a tie."""
    from tests.helpers import assert_rounds_to, yuv420_reference

    for w, h in SIZES + [(6, 6), (98, 64)]:  # odd and even sizes; heights 2 mod 4 and 0 mod 4
        tex = _texture(gl, rng, fmt, w, h)
        try:
            u8 = _reference(tex)
            rgb = np.repeat(u8[:, :, :1], 3, axis=2) if types.components(fmt) == 1 else u8[:, :, :3]
            p = gl.read_yuv420(tex)
        finally:
            gl.release(tex)
        assert p.size == (w + w % 2, h + h % 2)
        for got, ref, name in zip(_planes(p), yuv420_reference(rgb), "YUV", strict=True):
            assert got.shape == ref.shape
            assert_rounds_to(got, ref, f"{fmt} {w}x{h} {name}")


def test_read_yuv420_has_swscales_matrix_and_range(gl, rng):
    """The matrix and range are swscale's default for rgb24 -> yuv420p (what PyAV did for the films before):
    Y within 1 of swscale's (it rounds in fixed point). Chroma differs in the vertical filter only: swscale
    averages 2 columns and filters rows with [1, 3, 3, 1] / 8, this pass takes the 2 x 2 box (same siting);
    on frames whose columns are uniform, where the two agree, chroma is within 1 too."""
    av = pytest.importorskip("av")
    for uniform in (False, True):
        a = rng.random((36, 64, 4), dtype=np.float32)
        if uniform:
            a[:] = a[:1]
        tex = gl.upload(a, "RGBA8")
        try:
            rgb = np.ascontiguousarray(_reference(tex)[:, :, :3])
            p = gl.read_yuv420(tex)
        finally:
            gl.release(tex)
        sws = av.VideoFrame.from_ndarray(rgb, format="rgb24").reformat(format="yuv420p")
        for i, (got, plane) in enumerate(zip(_planes(p), sws.planes, strict=True)):
            want = np.frombuffer(plane, np.uint8).reshape(plane.height, plane.line_size)[:, :plane.width]
            if i == 0 or uniform:
                assert np.abs(got.astype(int) - want.astype(int)).max() <= 1, (uniform, i)



@pytest.mark.parametrize("formats", [("RGBA32F",), ("RGBA16F",), ("RGBA32F", "RGBA16F"), ("RGBA16F", "RGBA32F"),
                                     ("RGBA32F", "RGBA8")])
@pytest.mark.parametrize("depth", [1.0, None])
@pytest.mark.parametrize("values", [[(0.0,) * 4, (1.0, 0.0, 0.0, 0.0), (0.0,) * 4], [(0.0,) * 4, (0.0,) * 4],
                                    [(0.5, 0.25), (1.0,), (0.5, 0.25)], [(-0.0, -0.0), (0.0, 0.0)],
                                    [(0.25, -0.0, 1.0, 0.5)], [(0.3, 0.7, 0.1, 1.0), (1 / 3, 0.0, 0.2, 0.6)]])
def test_clear_each_gives_each_attachment_its_own_value_over_stale_contents(gl, values, depth, formats):
    """The clear of the G-buffer and of footprinted passes (`GL.clear_each`): each colour attachment holds what
    a plain clear of it alone to its own value (padded to RGBA) stores, bit for bit, the depth `depth` or
    what it held, over a pooled texture's earlier contents; the framebuffer's masks are whole again
    afterwards: float32, half and 8-bit attachments, alone or mixed in one framebuffer."""
    fmts = [formats[i % len(formats)] for i in range(len(values))]
    texs = [gl.texture((5, 3), f) for f in fmts]
    fbo = gl.framebuffer(texs, gl.depth_buffer((5, 3)))
    fbo.clear(0.7, 0.3, 0.2, 0.9, depth=0.25)
    gl.clear_each(fbo, values, depth=depth)
    for tex, value, fmt in zip(texs, values, fmts, strict=True):
        ref = gl.texture((5, 3), fmt)
        gl.ctx.framebuffer(color_attachments=[ref.texture]).clear(*(tuple(value) + (0.0,) * (4 - len(value))))
        assert tex.read_native().tobytes() == ref.read_native().tobytes()  # by bits: -0.0 is not 0.0
        gl.release(ref)
        exact = np.float32(tuple(value) + (0.0,) * (4 - len(value)))
        want = exact.astype(types.numpy_dtype(fmt))
        if fmt != "RGBA8" and np.array_equal(want.astype(np.float32), exact):  # held exactly: the value's own bits
            assert tex.read_native().tobytes() == np.broadcast_to(want, (3, 5, 4)).tobytes()
    assert fbo.color_mask in (((True,) * 4,) * len(values), (True,) * 4) and fbo.depth_mask
    stored = np.frombuffer(fbo.read(viewport=(0, 0, 5, 3), components=1, attachment=-1, dtype="f4", alignment=1),
                           "f4")
    np.testing.assert_allclose(stored, 1.0 if depth is not None else 0.25, atol=1e-6)  # a 24-bit depth buffer
    for tex in texs:
        gl.release(tex)


def _frame(data, size: tuple[int, int], channels: int) -> PngBlock:
    """A random PngBlock of a `size` frame: a block somewhere in the rows (or none), a blank of 0 or 255."""
    w, h = size
    stride = channels * w
    blank = np.full(channels, data.draw(st.sampled_from([0, 255])), np.uint8)
    if data.draw(st.booleans(), "no block"):
        return PngBlock(size, channels, None, 0, 0, blank)
    r0 = data.draw(st.integers(0, h - 1), "row0")
    r1 = data.draw(st.integers(r0 + 1, h), "row end")
    b0 = data.draw(st.integers(0, stride - 1), "byte0")
    b1 = data.draw(st.integers(b0 + 1, stride), "byte end")
    seed = data.draw(st.integers(0, 2**32 - 1), "bytes")
    block = np.random.default_rng(seed).integers(0, 256, (r1 - r0, b1 - b0), dtype=np.uint8)
    return PngBlock(size, channels, block, r0, b0, blank)


def _rows_by_hand(b: PngBlock) -> np.ndarray:
    w, h = b.size
    out = np.zeros((h, 1 + b.channels * w), np.uint8)
    for y in range(h):
        for x in range(w):
            out[y, 1 + b.channels * x:1 + b.channels * (x + 1)] = b.blank
    if b.block is not None:
        bh, bw = b.block.shape
        out[b.row0:b.row0 + bh, 1 + b.byte0:1 + b.byte0 + bw] = b.block
    return out.reshape(-1)


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_a_rows_buffer_kept_from_frame_to_frame_lays_out_each_frame_as_a_new_one(data):
    # blocks moving, growing, shrinking, vanishing, the blank and the frame size changing: each frame laid out
    # in the kept buffer is the frame's rows as written out byte by byte
    kept = PngRowsBuffer()
    channels = data.draw(st.sampled_from([1, 3]), "channels")
    size = (data.draw(st.integers(1, 9), "w"), data.draw(st.integers(1, 7), "h"))
    for _ in range(data.draw(st.integers(1, 6), "frames")):
        if data.draw(st.integers(0, 4), "resize") == 0:
            size = (data.draw(st.integers(1, 9), "w"), data.draw(st.integers(1, 7), "h"))
        frame = _frame(data, size, channels)
        np.testing.assert_array_equal(frame.rows(kept), _rows_by_hand(frame))
