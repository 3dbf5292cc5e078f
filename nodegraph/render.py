"""The library face's plumbing: open a pipeline with the command line's overrides, parse sizes and frame
ranges, name frame files, turn node values into images and write them. The CLI, the tools and the Python
API (`nodegraph.api`) all call these."""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .errors import SketchgraphError

if TYPE_CHECKING:
    from .pipeline import Pipeline


def open_pipeline(path: str, overrides: tuple[str, ...] = (), size: str | None = None, scene: str | None = None,
                  load_scene: bool = True) -> Pipeline:
    from . import pipeline as pl

    return pl.load(path, overrides=list(overrides), size=pl.parse_size(size) if size else None, scene=scene,
                   load_scene=load_scene)


def open_cache(no_cache: bool, cache_dir: Path | None) -> Any:
    from .cache import Cache

    return None if no_cache else Cache(cache_dir)


def parse_frames(text: str | None) -> list[int]:
    if text is None:
        return [0]
    m = re.fullmatch(r"\s*(-?\d+)\s*(?::\s*(-?\d+)\s*(?::\s*(\d+)\s*)?)?", text)
    if not m:
        raise SketchgraphError(f"--frames: expected N or START:END[:STEP] (END exclusive), found '{text}'")
    start = int(m.group(1))
    if m.group(2) is None:
        return [start]
    end, step = int(m.group(2)), int(m.group(3) or 1)
    if end <= start or step < 1:
        raise SketchgraphError(f"--frames: empty range '{text}'")
    return list(range(start, end, step))


def frame_path(pattern: str, frame: int, many: bool) -> Path:
    m = re.search(r"#+", pattern)
    if m:
        return Path(pattern[:m.start()] + str(frame).zfill(len(m.group(0))) + pattern[m.end():])
    if many:
        p = Path(pattern)
        return p.with_name(f"{p.stem}_{frame:04d}{p.suffix}")
    return Path(pattern)


def to_image(value: Any) -> Any:
    """A node value as a float (H, W, C) array for writing."""
    import numpy as np

    from .values import Strokes, Tex, TexArray

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


def write_value(value: Any, path: Path, meta: dict[str, str] | None = None) -> Path:
    from . import imageio
    from .values import Strokes

    if isinstance(value, Path):  # a File output: the node already wrote it
        return value

    if path.suffix.lower() == ".svg":
        if not isinstance(value, Strokes):
            raise SketchgraphError(f"{path}: only Strokes can be written as SVG")
        from .strokes import to_svg

        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(to_svg(value))
        return path
    arr = to_image(value)
    if path.suffix.lower() != ".exr" and arr.shape[2] == 4:
        arr = arr[:, :, :3]
    return imageio.write(path, arr, meta, half=False)
