"""load_image: an image file as a texture."""

from __future__ import annotations

import hashlib
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field, field_validator

from nodegraph.node import HashContext, Node, NodeParams, Output, RunContext
from nodegraph.output import imageio
from nodegraph.types import Texture


@lru_cache(maxsize=64)
def _digest(path: str, mtime: float, size: int) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class LoadImage(Node):
    """Reads an image through OpenImageIO (EXR, PNG, TIFF, JPEG, ...) as an RGBA texture at the image's
    own size: grey becomes (v, v, v, 1), two channels (r, g, 0, 1), RGB gets alpha 1. 8-bit files are
    scaled to [0, 1]; EXR values are kept. Rows are flipped to OpenGL's bottom-up order. The path is
    relative to the current directory; the key follows the file's content."""

    version = "1"
    context_keys = frozenset()
    persist = "never"  # a source: the file is its own cache
    outputs = {"out": Output(Texture("RGBA32F"), "The image, RGBA.")}

    class Params(NodeParams):
        path: str = Field(description="Image file.")

        @field_validator("path")
        @classmethod
        def _exists(cls, v: str) -> str:
            if not Path(v).is_file():
                raise ValueError(f"image file not found: {Path(v).absolute()}")
            return v

    def output_shape(self, port: str, size: tuple[int, int]) -> tuple[int, int, int]:
        """The image's own size, from its header (no pixels are read)."""
        from nodegraph.fsio import native_stderr, oiio

        io = oiio()
        with native_stderr():  # a broken file is said in one line when it is read (`compute`)
            inp = io.ImageInput.open(str(self.params.path))
            if inp is None:
                io.geterror()  # taken, so that OpenImageIO does not print it at exit
                return (size[0], size[1], 1)
            spec = inp.spec()
            inp.close()
        return (spec.width, spec.height, 1)

    def hash_extra(self, ctx: HashContext) -> Any:
        p = Path(self.params.path).resolve()
        st = p.stat()
        return _digest(str(p), st.st_mtime, st.st_size)

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        img = imageio.read(self.params.path)
        h, w, c = img.shape
        rgba = np.ones((h, w, 4), np.float32)
        if c == 1:
            rgba[..., :3] = img
        else:
            rgba[..., : min(c, 4)] = img[..., :4]
            if c == 2:
                rgba[..., 2] = 0.0
        return {"out": ctx.gl.upload(rgba, ctx.format("out"))}


NODE = LoadImage
