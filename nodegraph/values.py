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


# Line kinds a stroke vertex can carry (`Strokes.kind` holds the index into this tuple). "stroke" is a plain
# drawn stroke with no surface meaning (particle_sketch's); the others are lines found on a mesh (mesh_lines).
LINE_KINDS = ("stroke", "contour", "crease", "boundary", "border", "suggestive", "ridge", "valley", "hatching",
              "intersection")

# The per-vertex attributes of `Strokes`: name -> (dtype, trailing shape, fill value when not given).
STROKE_ATTRS: dict[str, tuple[type, tuple[int, ...], float]] = {
    "depth": (np.float32, (), np.nan),  # linear view depth (scene units along the view axis); NaN: unknown
    "obj": (np.int32, (), -1),  # object index in the scene (-1: none)
    "face": (np.int32, (), -1),  # face index in that object's mesh (-1: none)
    "bary": (np.float32, (3,), np.nan),  # barycentric coordinates of the surface point in `face`
    "pos": (np.float32, (3,), np.nan),  # object-space position of the surface point (posed mesh)
    "kind": (np.uint8, (), 0),  # index into LINE_KINDS
    "visible": (np.bool_, (), True),  # False: hidden behind the surface (the hidden layer)
    "width": (np.float32, (), np.nan),  # stroke width in pixels; NaN: the strokes' `width`
    "tone": (np.float32, (), 1.0),  # darkness in [0, 1] (1 = full ink)
}


class Strokes:
    """Polylines with per-vertex attributes on a canvas of `size` pixels, stored flat (the stroke schema).

    * `xy` (N, 2) float32: screen position in pixels, x right, y up from the bottom row (pixel centres at
      i + 0.5);
    * `starts` (M + 1,) int64: stroke i is vertices `starts[i]:starts[i + 1]` (starts[0] = 0, starts[-1] = N);
    * `attrs`: one (N, ...) array per name in STROKE_ATTRS (depth, obj, face, bary, pos, kind, visible, width,
      tone; each always present, filled with its default where the maker did not know it);
    * `width` (pixels) and `color` (RGB in [0, 1]): the style of strokes whose per-vertex width is NaN.

    Made from a list of (n, 2) polylines (`Strokes(polylines, size, width, color)`, particle strokes) or from
    flat arrays (`Strokes.from_arrays`). A maker splits strokes where kind or visibility changes, so a
    stroke's first vertex gives both for the whole stroke (`stroke_kind`, `stroke_visible`). Cached by the
    engine as .npz like other CPU values."""

    def __init__(self, polylines: list[np.ndarray] | tuple[np.ndarray, ...] = (), size: tuple[int, int] = (0, 0),
                 width: float = 1.0, color: tuple[float, float, float] = (0.1, 0.1, 0.1),
                 attrs: dict[str, np.ndarray] | None = None):
        polys = [np.asarray(p, dtype=np.float32).reshape(-1, 2) for p in polylines]
        lengths = np.array([len(p) for p in polys], dtype=np.int64)
        xy = np.concatenate(polys) if polys else np.zeros((0, 2), np.float32)
        self._set(xy, np.r_[0, np.cumsum(lengths)].astype(np.int64), size, width, color, attrs)

    @classmethod
    def from_arrays(cls, xy: np.ndarray, starts: np.ndarray, size: tuple[int, int], width: float = 1.0,
                    color: tuple[float, float, float] = (0.1, 0.1, 0.1),
                    attrs: dict[str, np.ndarray] | None = None) -> Strokes:
        s = cls.__new__(cls)
        s._set(np.asarray(xy, np.float32).reshape(-1, 2), np.asarray(starts, np.int64).reshape(-1), size, width,
               color, attrs)
        return s

    def _set(self, xy: np.ndarray, starts: np.ndarray, size: tuple[int, int], width: float,
             color: tuple[float, float, float], attrs: dict[str, np.ndarray] | None) -> None:
        n = len(xy)
        if len(starts) == 0 or starts[0] != 0 or starts[-1] != n or (np.diff(starts) < 0).any():
            raise ValueError(f"stroke starts {starts[:4]}... do not index {n} vertices (need 0 ... {n}, rising)")
        self.xy = xy
        self.starts = starts
        self.size = (int(size[0]), int(size[1]))
        self.width = float(width)
        self.color = tuple(float(c) for c in color)
        self.attrs: dict[str, np.ndarray] = {}
        given = dict(attrs or {})
        unknown = set(given) - set(STROKE_ATTRS)
        if unknown:
            raise ValueError(f"unknown stroke attributes {sorted(unknown)}; known: {', '.join(STROKE_ATTRS)}")
        for name, (dt, shape, fill) in STROKE_ATTRS.items():
            a = given.get(name)
            if a is None:
                a = np.full((n, *shape), fill, dtype=dt)
            else:
                a = np.asarray(a, dtype=dt)
                if a.shape != (n, *shape):
                    raise ValueError(f"stroke attribute {name} has shape {a.shape}, expected {(n, *shape)}")
            self.attrs[name] = a
        self._polys: list[np.ndarray] | None = None

    def __getitem__(self, name: str) -> np.ndarray:
        return self.attrs[name]

    def __len__(self) -> int:
        return len(self.starts) - 1

    @property
    def n_vertices(self) -> int:
        return len(self.xy)

    @property
    def polylines(self) -> list[np.ndarray]:
        """The strokes as a list of (n, 2) views into `xy`."""
        if self._polys is None:
            self._polys = np.split(self.xy, self.starts[1:-1]) if len(self) else []
        return self._polys

    def lengths(self) -> np.ndarray:
        """(M,) length of each stroke in pixels."""
        seg = np.hypot(*np.diff(self.xy.astype(np.float64), axis=0).T) if self.n_vertices > 1 else np.zeros(0)
        seg = np.r_[0.0, np.cumsum(seg)]
        if self.n_vertices == 0:
            return np.zeros(len(self))
        if not len(self):
            return np.zeros(0)
        lens = np.diff(self.starts)
        last = np.maximum(self.starts[1:] - 1, self.starts[:-1])
        return np.where(lens > 0, seg[np.minimum(last, len(seg) - 1)] - seg[np.minimum(self.starts[:-1], len(seg) - 1)],
                        0.0)

    def stroke_attr(self, name: str) -> np.ndarray:
        """(M, ...) an attribute at each stroke's first vertex (fill value for an empty stroke)."""
        a = self.attrs[name]
        dt, shape, fill = STROKE_ATTRS[name]
        out = np.full((len(self), *shape), fill, dtype=dt)
        nonempty = np.diff(self.starts) > 0
        out[nonempty] = a[self.starts[:-1][nonempty]]
        return out

    @property
    def nbytes(self) -> int:
        return self.xy.nbytes + self.starts.nbytes + sum(a.nbytes for a in self.attrs.values())

    def subset(self, keep: np.ndarray) -> Strokes:
        """The strokes where `keep` (M,) bool is true."""
        keep = np.asarray(keep, bool)
        lens = np.diff(self.starts)
        vmask = np.repeat(keep, lens)
        starts = np.r_[0, np.cumsum(lens[keep])].astype(np.int64)
        return Strokes.from_arrays(self.xy[vmask], starts, self.size, self.width, self.color,
                                   {k: v[vmask] for k, v in self.attrs.items()})


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
