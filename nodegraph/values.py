"""Values that flow along edges: GPU textures stay on the GPU; arrays and strokes live on the CPU."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import types


@dataclass(frozen=True)
class Footprint:
    """Where a texture's content may differ from one value: outside `rect` ((x, y, w, h) in pixels, rows from the
    bottom) every texel holds `blank` (one value a channel). Given by the node that made the texture when it
    knows (the G-buffer outside the objects' projected boxes); `nodegraph.gpu.footprint` explains the use."""

    rect: tuple[int, int, int, int]
    blank: tuple[float, ...]


@dataclass(eq=False)
class Tex:
    """A 2D texture on the GPU (row 0 is the bottom row, OpenGL's convention). `footprint`: where its content can
    differ from a blank value, when its node knows (None: anywhere). `absmax`: a bound on |value| for each
    channel, when its node knows one (noise)."""

    texture: object  # moderngl.Texture
    fmt: str
    footprint: Footprint | None = None
    absmax: tuple[float, ...] | None = None

    @property
    def size(self) -> tuple[int, int]:
        return self.texture.size  # type: ignore[attr-defined]

    @property
    def nbytes(self) -> int:
        w, h = self.size
        return w * h * types.bytes_per_pixel(self.fmt)

    def read(self) -> np.ndarray:
        """Read back as float32 (H, W, C); 8-bit formats are scaled to [0, 1]."""
        w, h = self.size
        return _read(self.texture, (h, w, types.components(self.fmt)), self.fmt)

    def read_native(self) -> np.ndarray:
        """Read back in the format's own dtype (uint8 for 8-bit formats, unscaled), without a conversion."""
        w, h = self.size
        return _read(self.texture, (h, w, types.components(self.fmt)), self.fmt, native=True)


def _read(texture: object, shape: tuple[int, ...], fmt: str, native: bool = False) -> np.ndarray:
    """One copy from GL into a writable array; float32 formats (and `native` reads) come back as they are."""
    dt = types.numpy_dtype(fmt)
    raw = np.empty(shape, dtype=dt)
    texture.read_into(raw, alignment=1)  # type: ignore[attr-defined]
    if dt == np.float32 or native:
        return raw
    arr = raw.astype(np.float32)
    if dt == np.uint8:
        arr /= 255.0
    return arr


@dataclass(eq=False)
class TexArray:
    """A 2D texture array on the GPU (layers, e.g. the 32 tones of a tonal art map)."""

    texture: object  # moderngl.TextureArray
    fmt: str

    @property
    def size(self) -> tuple[int, int]:
        w, h, _ = self.texture.size  # type: ignore[attr-defined]
        return (w, h)

    @property
    def layers(self) -> int:
        return self.texture.size[2]  # type: ignore[attr-defined]

    @property
    def nbytes(self) -> int:
        w, h = self.size
        return w * h * self.layers * types.bytes_per_pixel(self.fmt)

    def read(self) -> np.ndarray:
        """(layers, H, W, C) float32."""
        w, h = self.size
        return _read(self.texture, (self.layers, h, w, types.components(self.fmt)), self.fmt)


@dataclass(eq=False)
class Strokes:
    """Polylines in pixel coordinates (x right, y up from the bottom row) on a canvas of `size`."""

    polylines: list[np.ndarray]
    size: tuple[int, int]
    width: float = 1.0
    color: tuple[float, float, float] = (0.1, 0.1, 0.1)

    @property
    def nbytes(self) -> int:
        return sum(p.nbytes for p in self.polylines)


@dataclass(eq=False)
class Arrays:
    """Named NumPy arrays (per-vertex curvature, ...), cached as .npz."""

    data: dict[str, np.ndarray] = field(default_factory=dict)

    def __getitem__(self, key: str) -> np.ndarray:
        return self.data[key]

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in self.data.values())


def nbytes(value: object) -> int:
    return int(getattr(value, "nbytes", 0))


def to_uint8(arr: np.ndarray) -> np.ndarray:
    """Float values as 8-bit file values: clipped to [0, 1], times 255, rounded to nearest."""
    return np.clip(np.rint(np.asarray(arr, dtype=np.float32) * 255.0), 0, 255).astype(np.uint8)
