"""The glTF files the benchmarks build in code (the coherence shots, the flicker torso, the posing character):
a pygltflib document and its one binary buffer, written as .glb."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np


class GltfDoc:
    """`doc` (pygltflib.GLTF2, one scene) and `g` (the pygltflib module); `accessor` appends an array to the
    buffer (4-byte aligned) with its view and accessor; `write` saves the document with the buffer as .glb."""

    def __init__(self, **doc: Any) -> None:
        import pygltflib as g

        self.g = g
        self.doc = g.GLTF2(scene=0, scenes=[g.Scene(nodes=[])], **doc)
        self.blob = bytearray()

    def accessor(self, array: np.ndarray, kind: str, ctype: int = 5126, minmax: bool = False) -> int:
        """Index of a new accessor over `array` (rows: elements of `kind`, components of glTF type `ctype`);
        `minmax`: with its min and max (POSITION and animation times need them)."""
        a = np.ascontiguousarray(array)
        self.blob += b"\0" * (-len(self.blob) % 4)
        self.doc.bufferViews.append(self.g.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=a.nbytes))
        self.blob += a.tobytes()
        acc = self.g.Accessor(bufferView=len(self.doc.bufferViews) - 1, componentType=ctype, count=len(a), type=kind)
        if minmax:
            flat = a.reshape(len(a), -1).astype(np.float64)
            acc.min, acc.max = flat.min(axis=0).tolist(), flat.max(axis=0).tolist()
        self.doc.accessors.append(acc)
        return len(self.doc.accessors) - 1

    def write(self, path: Path) -> Path:
        self.doc.buffers = [self.g.Buffer(byteLength=len(self.blob))]
        self.doc.set_binary_blob(bytes(self.blob))
        self.doc.save_binary(str(path))
        return path


def quaternion(axis: Any, degrees: float) -> list[float]:
    """The (x, y, z, w) rotation by `degrees` about `axis`, as glTF stores it."""
    a = np.asarray(axis, np.float64)
    a = a / np.linalg.norm(a)
    h = math.radians(degrees) / 2.0
    return [*(a * math.sin(h)).tolist(), math.cos(h)]
