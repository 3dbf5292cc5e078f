"""Pictures of node outputs kept beside the node cache's entries, so that a gallery rebuild whose nodes are
all cached reads neither the full-size EXR entries nor draws them again.

Records are stored in the node cache (`Cache.store`, an `arrays` entry) under the content key of the node
whose output they picture:
- `view`: the picture a contact sheet cell shows (`inspect_all.shown`: the buffer reduced to the cell's size,
  then colourised; float32, at most `cell` pixels a side), with its kind, note and format;
- `png`: the bytes of an output's full-size PNG as the gallery writes it, with the SHA-256 of its pixels;
- the same record under a contact sheet's own key (`build.sheet_key`: the SHA-256 of each cell's picture, the
  label lines, title and layout) and the port name `sheet`: the sheet's PNG bytes, so a rebuild of unchanged
  cells neither draws nor compresses the sheet again.

The record's name holds everything the picture depends on besides the node's key: the port, the planned
format, the visualisation versions, the cell size, the PNG level and the zlib and NumPy versions. So a record
is the picture the same code would draw again (a build with an empty cache checks that: `gallery verify`
renders with no cache and compares bytes). Records age out of the cache like node entries (least recently
used); `--cold` removes them with the rest.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...node import digest
from .. import viz


@dataclass
class View:
    panel: viz.Panel
    fmt: str


def _suffix(what: str, port: str, fmt: str | None, extra: Any) -> str:
    from ..inspect_all import PNG_LEVEL, VIEW_VERSION

    tag = digest({"what": what, "viz": viz.VERSION, "view": VIEW_VERSION, "png": PNG_LEVEL, "extra": extra,
                  "zlib": zlib.ZLIB_RUNTIME_VERSION, "numpy": np.__version__})[:16]
    return f"{port}.{fmt or 'value'}.{what}-{tag}"


class Views:
    """The view and PNG records of one node cache (None: no records; everything is drawn)."""

    def __init__(self, cache: Any, cell: int):
        self.cache = cache
        self.cell = cell
        self.hits = 0

    def _load(self, key: str, name: str) -> dict[str, np.ndarray] | None:
        if self.cache is None:
            return None
        loaded = self.cache.load(key, name)
        if loaded is None or loaded.kind != "arrays":
            return None
        return loaded.data.data

    def _store(self, key: str, name: str, data: dict[str, np.ndarray]) -> None:
        from ...values import Arrays

        if self.cache is not None:
            self.cache.store(key, name, "arrays", Arrays(data), {"node": "gallery view", "type": "view",
                                                                   "version": 1, "params": {}}, background=True)

    # -- contact sheet cells ---------------------------------------------------------------------------
    def view(self, key: str, port: str, fmt: str | None) -> View | None:
        d = self._load(key, _suffix("view", port, fmt, self.cell))
        if d is None or not {"kind", "note", "fmt"} <= set(d):
            return None
        image = d.get("image")
        if image is not None and (image.dtype != np.float32 or image.ndim != 3 or image.shape[2] != 3):
            return None
        self.hits += 1
        return View(viz.Panel(image, str(d["kind"]), str(d["note"])), str(d["fmt"]))

    def put_view(self, key: str, port: str, fmt: str | None, view: View) -> None:
        data = {"kind": np.array(view.panel.kind), "note": np.array(view.panel.note), "fmt": np.array(view.fmt)}
        if view.panel.image is not None:
            data["image"] = np.ascontiguousarray(view.panel.image, np.float32)
        self._store(key, _suffix("view", port, fmt, self.cell), data)

    # -- full-size output pictures ---------------------------------------------------------------------
    def png(self, key: str, port: str, fmt: str | None) -> tuple[bytes, str, list[int]] | None:
        from ...output.imageio import _png_complete

        d = self._load(key, _suffix("png", port, fmt, None))
        if d is None or not {"png", "pixels_sha256", "size"} <= set(d):
            return None
        data = d["png"].tobytes()
        if not _png_complete(data):
            return None
        self.hits += 1
        return data, str(d["pixels_sha256"]), [int(v) for v in d["size"]]

    def put_png(self, key: str, port: str, fmt: str | None, data: bytes, pixels_sha256: str,
                size: list[int]) -> None:
        self._store(key, _suffix("png", port, fmt, None), {
            "png": np.frombuffer(data, np.uint8), "pixels_sha256": np.array(pixels_sha256),
            "size": np.array(size, np.int64)})
