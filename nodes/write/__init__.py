"""write: save an image (PNG, EXR, TIFF, JPEG) when the pipeline runs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import Field, field_validator

from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.output.imageio import WRITABLE
from nodegraph.types import FILE, Texture


class Write(Node):
    """Writes its input to `path` (relative to the output directory: `--out-dir`, default the current
    directory, which it must not leave unless `--allow-outside-out-dir` is given; `~` is expanded, symlinks
    are followed; `####` becomes the frame number)
    and outputs the path written. EXR keeps the values (32-bit float); PNG/JPEG/TIFF are 8-bit,
    clipped to [0, 1], alpha dropped. A write always runs when its output is requested, even when the
    image itself comes from the cache."""

    version = "1"
    context_keys = frozenset({"size", "frame"})
    persist = "never"
    side_effect = True
    file_params = ("path",)
    inputs = {"image": Input(Texture(None), "Any texture.")}
    outputs = {"file": Output(FILE, "The path written.")}

    class Params(NodeParams):
        path: str = Field(description="File to write; the extension picks the format; #### = frame number.")

        @field_validator("path")
        @classmethod
        def _writable(cls, v: str) -> str:
            ext = Path(v).suffix.lower()
            if ext not in WRITABLE:
                raise ValueError(f"expected a path ending in one of {', '.join(WRITABLE)}, found "
                                 f"'{ext or 'no extension'}'")
            return v

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        from nodegraph.output.write import frame_path, write_value

        return {"file": write_value(inputs["image"], frame_path(str(self.output_path("path")), ctx.frame, False))}


NODE = Write
