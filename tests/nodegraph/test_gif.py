"""GIF films: one palette, ordered dithering that does not crawl, delays that follow the exact times. The files
are written by `FilmWriter`, read back by PyAV and by the small GIF block reader below."""

from __future__ import annotations

import av
import numpy as np
import pytest

from nodegraph.output.film import FilmWriter


def _blocks(data: bytes) -> dict:
    """The parts of a GIF file the tests look at: the global colour table, each frame's delay (centiseconds),
    and how many image descriptors carry a local colour table."""
    assert data[:6] in (b"GIF87a", b"GIF89a")
    flags, pos = data[10], 13
    table = None
    if flags & 0x80:
        n = 2 << (flags & 7)
        table = np.frombuffer(data[pos:pos + 3 * n], np.uint8).reshape(n, 3)
        pos += 3 * n
    delays, images, local = [], 0, 0

    def skip_sub_blocks(p: int) -> int:
        while data[p]:
            p += data[p] + 1
        return p + 1

    while data[pos] != 0x3B:
        if data[pos] == 0x21:  # extension: graphic control (0xF9) carries the delay
            if data[pos + 1] == 0xF9:
                delays.append(int.from_bytes(data[pos + 4:pos + 6], "little"))
            pos = skip_sub_blocks(pos + 2)
        elif data[pos] == 0x2C:  # image descriptor (10 bytes), optional local table, LZW size, data
            images += 1
            f = data[pos + 9]
            pos += 10
            if f & 0x80:
                local += 1
                pos += 3 * (2 << (f & 7))
            pos = skip_sub_blocks(pos + 1)
        else:
            raise AssertionError(f"unexpected GIF block {data[pos]:#x} at {pos}")
    return {"table": table, "delays": delays, "images": images, "local_tables": local}


def _write(path, frames, fps=24):
    w = FilmWriter(path, fps, (frames[0].shape[1], frames[0].shape[0]))
    for f in frames:
        w.write(f)
    return w.close()


def _decode(path):
    with av.open(str(path)) as c:
        return [(f.to_ndarray(format="rgb24"), f.pts) for f in c.decode(video=0)]


def _scene(n: int, w: int = 96, h: int = 64) -> list[np.ndarray]:
    """A still background that needs dithering (a grey ramp, a brown-to-blue band) with a dark disc moving
    along the bottom left; the right half never changes."""
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    bg = np.empty((h, w, 3))
    bg[:] = (40 + 200 * xx / (w - 1))[..., None]
    band = yy < h / 3
    t = xx / (w - 1)
    bg[band] = (np.stack([150 - 110 * t, 100 + 0 * t, 60 + 140 * t], axis=-1))[band]
    frames = []
    for i in range(n):
        f = bg.copy()
        f[(xx - 8 - 4 * i) ** 2 + (yy - 48) ** 2 < 36] = (30, 30, 30)
        frames.append(np.round(f).astype(np.uint8))
    return frames


def test_still_background_does_not_crawl(tmp_path):
    frames = _scene(8)
    out = _decode(_write(tmp_path / "s.gif", frames))
    assert len(out) == 8
    right = [f[:, 48:] for f, _ in out]
    for f in right[1:]:
        assert np.array_equal(f, right[0])  # byte-identical, frame after frame
    # the still part is dithered (the ramp falls between palette entries), and the disc did move
    assert len(np.unique(right[0].reshape(-1, 3), axis=0)) > 20
    assert not np.array_equal(out[0][0][40:, :40], out[-1][0][40:, :40])
    # the picture is right on average: 8x8 block means of the ramp within 1.5 levels of the input's
    got = out[0][0][24:64, 48:96].astype(np.float64).reshape(5, 8, 6, 8, 3).mean(axis=(1, 3))
    want = frames[0][24:64, 48:96].astype(np.float64).reshape(5, 8, 6, 8, 3).mean(axis=(1, 3))
    assert np.abs(got - want).max() < 1.5


@pytest.mark.parametrize("fps", [24, 25, 30])
def test_frame_delays_follow_the_exact_times(tmp_path, fps):
    n = 2 * fps + 1
    frames = [np.full((8, 8, 3), 4 * i % 256, np.uint8) for i in range(n)]
    path = _write(tmp_path / f"t{fps}.gif", frames, fps)
    delays = _blocks(path.read_bytes())["delays"]
    assert len(delays) == n
    times = np.concatenate([[0], np.cumsum(delays)])
    exact = [(200 * i + fps) // (2 * fps) for i in range(n + 1)]  # i·100/fps centiseconds, rounded half up
    assert times.tolist() == exact
    assert np.abs(times - np.arange(n + 1) * 100 / fps).max() <= 0.5  # no drift
    assert [pts for _, pts in _decode(path)] == exact[:-1]  # as a reader times them (1/100 s)


def test_one_palette_for_the_whole_film(tmp_path):
    frames = _scene(6)
    frames[3][:10, :10] = (250, 20, 200)  # a colour the first frame does not have
    path = _write(tmp_path / "p.gif", frames)
    info = _blocks(path.read_bytes())
    assert info["table"] is not None and len(info["table"]) == 256
    assert info["images"] == 6 and info["local_tables"] == 0
    table = {tuple(c) for c in info["table"].tolist()}
    for f, _ in _decode(path):
        assert {tuple(c) for c in np.unique(f.reshape(-1, 3), axis=0).tolist()} <= table


def test_grey_ramp_keeps_its_levels(tmp_path):
    # 256 grey levels, each an 8x8 block (one full Bayer tile), on a 16x16 grid of blocks
    levels = np.arange(256, dtype=np.uint8).reshape(16, 16)
    img = np.repeat(np.repeat(levels, 8, axis=0), 8, axis=1)
    frame = np.repeat(img[..., None], 3, axis=2)
    got = _decode(_write(tmp_path / "g.gif", [frame, frame]))[0][0].astype(np.float64)
    assert np.array_equal(got[..., 0], got[..., 1]) and np.array_equal(got[..., 1], got[..., 2])  # greys stay grey
    means = got[..., 0].reshape(16, 8, 16, 8).mean(axis=(1, 3))
    assert np.abs(means - levels).max() <= 0.75  # every level, not a posterised few
    assert len(np.unique(got[..., 0])) >= 48  # the palette's grey ramp (3-3-2 has 2 exact greys)


def test_first_frame_flat_colours_are_drawn_pure(tmp_path):
    frame = np.full((32, 48, 3), 255, np.uint8)
    colours = [(200, 60, 40), (40, 90, 180), (120, 170, 60), (233, 211, 140)]
    for i, c in enumerate(colours):
        frame[4:28, 2 + 11 * i:11 + 11 * i] = c
    got = _decode(_write(tmp_path / "c.gif", [frame]))[0][0]
    assert np.array_equal(got, frame)


def test_gif_above_100_fps_is_one_clear_error(tmp_path):
    from nodegraph.errors import SketchgraphError

    with pytest.raises(SketchgraphError, match=r"at most 100 frames/s, found 300"):
        FilmWriter(tmp_path / "fast.gif", 300, (8, 8))
    assert not list(tmp_path.iterdir())
    path = _write(tmp_path / "ok.gif", [np.full((4, 4, 3), 9 * i, np.uint8) for i in range(5)], 100)
    assert _blocks(path.read_bytes())["delays"] == [1] * 5
