"""Port types: `Texture[RGBA16F]`, `Texture[R32F]`, `TextureArray[R8]`, `Scene`, `Mesh`, `Strokes`, `Arrays`.

A texture type names channels and precision. An input accepts an output with the same kind and
channel count whose precision is at least the input's (`Texture[*]` accepts any texture). The engine
allocates each texture output at the highest precision any planned consumer asks for, capped at the
output's declared format: buffers get the precision their consumers need, decided from port types.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

# name -> (components, bytes per component, moderngl dtype, precision rank)
FORMATS: dict[str, tuple[int, int, str, int]] = {
    "R8": (1, 1, "f1", 0), "RG8": (2, 1, "f1", 0), "RGBA8": (4, 1, "f1", 0),
    "R16F": (1, 2, "f2", 1), "RG16F": (2, 2, "f2", 1), "RGBA16F": (4, 2, "f2", 1),
    "R32F": (1, 4, "f4", 2), "RG32F": (2, 4, "f4", 2), "RGBA32F": (4, 4, "f4", 2),
}
_PRECISION_SUFFIX = {0: "8", 1: "16F", 2: "32F"}
_CHANNEL_NAMES = {1: "R", 2: "RG", 4: "RGBA"}
TEXTURE_KINDS = ("Texture", "TextureArray")


def components(fmt: str) -> int:
    return FORMATS[fmt][0]


def precision(fmt: str) -> int:
    return FORMATS[fmt][3]


def with_precision(fmt: str, rank: int) -> str:
    return _CHANNEL_NAMES[components(fmt)] + _PRECISION_SUFFIX[rank]


def bytes_per_pixel(fmt: str) -> int:
    comps, size, _, _ = FORMATS[fmt]
    return comps * size


def numpy_dtype(fmt: str) -> np.dtype:
    return np.dtype({"f1": np.uint8, "f2": np.float16, "f4": np.float32}[FORMATS[fmt][2]])


@dataclass(frozen=True)
class PortType:
    kind: str
    fmt: str | None = None  # texture format; None on an input means "any"

    def __post_init__(self) -> None:
        if self.fmt is not None and self.fmt not in FORMATS:
            raise ValueError(f"unknown texture format {self.fmt!r}; known: {', '.join(FORMATS)}")

    def __str__(self) -> str:
        if self.kind in TEXTURE_KINDS:
            return f"{self.kind}[{self.fmt or '*'}]"
        return self.kind

    @property
    def is_texture(self) -> bool:
        return self.kind in TEXTURE_KINDS

    def accepts(self, produced: PortType) -> bool:
        """Can an input of this type be fed by an output of type `produced`?"""
        if self.kind != produced.kind:
            return False
        if not self.is_texture or self.fmt is None:
            return True
        assert produced.fmt is not None
        return components(self.fmt) == components(produced.fmt) and precision(produced.fmt) >= precision(self.fmt)


_PARSE = re.compile(r"^(\w+)(?:\[(\w+|\*)\])?$")


def parse(text: str) -> PortType:
    m = _PARSE.match(text.strip())
    if not m:
        raise ValueError(f"bad port type {text!r}")
    kind, fmt = m.group(1), m.group(2)
    return PortType(kind, None if fmt in (None, "*") else fmt)


def Texture(fmt: str | None = None) -> PortType:  # noqa: N802 - reads like the type it builds
    return PortType("Texture", fmt)


def TextureArray(fmt: str | None = None) -> PortType:  # noqa: N802
    return PortType("TextureArray", fmt)


SCENE = PortType("Scene")
MESH = PortType("Mesh")
STROKES = PortType("Strokes")
ARRAYS = PortType("Arrays")
FILE = PortType("File")  # a path a node wrote (side effects such as `write`)
