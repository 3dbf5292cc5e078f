"""Values leaving the engine: frame ranges parsed, frame file names made, node values turned into images and
written (PNG, EXR, SVG), frames written from the GPU."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from ..errors import SketchgraphError
from ..scene.timeline import MAX_FRAME, MAX_FRAMES


def parse_frames(text: str | None) -> list[int]:
    if text is None:
        return [0]
    shown = text if len(text) <= 60 else text[:57] + "..."
    m = re.fullmatch(r"\s*(-?\d{1,30})\s*(?::\s*(-?\d{1,30})\s*(?::\s*(\d{1,30})\s*)?)?", text)
    if not m:
        raise SketchgraphError(f"--frames: expected N or START:END[:STEP] (END exclusive), found '{shown}'")
    numbers = [int(g) for g in m.groups() if g is not None]
    if any(abs(n) > MAX_FRAME for n in numbers):
        raise SketchgraphError(f"--frames: expected frame numbers between {-MAX_FRAME} and {MAX_FRAME}, found "
                               f"'{shown}'")
    start = numbers[0]
    if m.group(2) is None:
        return [start]
    end, step = int(m.group(2)), int(m.group(3) or 1)
    if end <= start or step < 1:
        raise SketchgraphError(f"--frames: empty range '{shown}'")
    frames = range(start, end, step)
    if len(frames) > MAX_FRAMES:
        raise SketchgraphError(f"--frames: expected at most {MAX_FRAMES} frames, found {len(frames)} in '{shown}'")
    return list(frames)


def frame_path(pattern: str, frame: int, many: bool) -> Path:
    m = re.search(r"#+", pattern)
    if m:
        return Path(pattern[:m.start()] + str(frame).zfill(len(m.group(0))) + pattern[m.end():])
    if many:
        p = Path(pattern)
        return p.with_name(f"{p.stem}_{frame:04d}{p.suffix}")
    return Path(pattern)


def frame_name_re(pattern: str) -> re.Pattern[str] | None:
    """The file names `frame_path(pattern, frame, ...)` gives (one frame or many) in the pattern's folder, the
    frame number as group 1 where there is one; None where `####` is in a folder's name (frames in many folders)."""
    p = Path(pattern)
    m = re.search(r"#+", p.name)
    if "#" in str(p.parent):
        return None
    if m:
        return re.compile(re.escape(p.name[:m.start()]) + r"(-?\d+)" + re.escape(p.name[m.end():]))
    return re.compile(re.escape(p.name) + "|" + re.escape(p.stem) + r"_(-?\d+)" + re.escape(p.suffix))


def to_image(value: Any) -> Any:
    """A node value as a float (H, W, C) array for writing."""
    import numpy as np

    from ..values import Strokes, Tex, TexArray

    if isinstance(value, np.ndarray):  # already read back (film.render_frames reads on the render thread)
        return value
    if isinstance(value, Tex):
        return value.read()
    if isinstance(value, TexArray):
        arr = value.read()
        return np.concatenate(list(arr), axis=1)  # layers side by side
    if isinstance(value, Strokes):
        from .strokes import rasterize_strokes

        return rasterize_strokes(value)
    raise SketchgraphError(f"cannot write a {type(value).__name__} as an image")


def write_value(value: Any, path: Path, meta: dict[str, str] | None = None, page: Any = None) -> Path:
    """`page`: an `svg.Page` for an SVG (physical size in mm); strokes that carry line kinds (mesh_lines) or a
    page are written as a layered SVG (`svg.layered_svg`), plain strokes (particle_sketch) as before."""
    from ..values import Strokes
    from . import imageio

    if isinstance(value, Path):  # a File output: the node already wrote it
        return value

    if path.suffix.lower() == ".svg":
        if not isinstance(value, Strokes):
            raise SketchgraphError(f"{path}: only Strokes can be written as SVG")
        from ..fsio import atomic_write_text

        if page is not None or bool(value.attrs["kind"].any()):
            from .svg import layered_svg

            return atomic_write_text(path, layered_svg(value, page))
        from .strokes import to_svg

        return atomic_write_text(path, to_svg(value))
    arr = to_image(value)
    if path.suffix.lower() != ".exr" and arr.shape[2] == 4:
        arr = arr[:, :, :3]
    return imageio.write(path, arr, meta, half=False)


class Bytes8:
    """A frame already converted to 8-bit file values on the GPU (`GL.read_uint8`: (H, W, 4), row 0 at the
    top) and how many channels the texture has (1: grey; otherwise RGB is written)."""

    def __init__(self, data: Any, channels: int):  # np.ndarray
        self.data = data
        self.channels = channels

    def png(self) -> Any:
        return self.data[:, :, :1] if self.channels == 1 else self.data[:, :, :3]


class PngRows:
    """A frame already laid out on the GPU as a PNG's row bytes: the `PngBlock` read back (`GL.pack_png`);
    `write` lays the rows out (`PngBlock.rows`), compresses and writes them, all on the caller's thread (a
    writer thread in a sequence)."""

    def __init__(self, block: Any):  # gl.PngBlock
        self.block = block
        self.size: tuple[int, int] = block.size
        self.channels: int = block.channels

    @classmethod
    def of(cls, tex: Any, gl: Any) -> PngRows:
        return cls(gl.read_png_block(tex))

    @property
    def data(self) -> Any:
        """The stream (1-D uint8, h * (1 + w * channels) bytes)."""
        return self.block.rows()

    def write(self, path: Path, level: int | None = None, sync: bool = True, rows_buffer: Any = None) -> Path:
        """`rows_buffer`: a `gl.PngRowsBuffer` to lay the rows out in (one per writer thread)."""
        from . import imageio

        w, h = self.size
        return imageio.write_png_rows(path, self.block.rows(rows_buffer), w, h, self.channels,
                                      imageio.PNG_LEVEL if level is None else level, sync)


def write_frame(value: Any, path: Path, gl: Any, png_level: int | None = None, page: Any = None) -> Path:
    """A rendered image, alone or one frame of a sequence: a texture bound for a PNG is converted to 8 bits and
    laid out as PNG rows on the GPU (`PngRows`), then compressed by `imageio.write_png_rows` at `png_level`
    (as `film.SequenceWriter` does); anything else goes to `write_value`. The same pixels as `write_value`
    (OpenImageIO's PNG writer, which single images used before: 74-114 ms of CPU for the default 800x800
    image against 5 ms at level 1, and 153 KB against 149 KB), and serial and distributed sequences give the
    same bytes. `gl`: the GL wrapper, or a function giving it (called only for a texture)."""
    from ..values import Tex

    if isinstance(value, Tex) and path.suffix.lower() == ".png":
        return PngRows.of(value, gl() if callable(gl) else gl).write(path, png_level)
    return write_value(value, path, page=page)
