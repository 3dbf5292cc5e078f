"""strokes_svg: save strokes as an SVG drawing (one path per stroke) when the pipeline runs."""

from __future__ import annotations

from typing import Any

from pydantic import Field, field_validator

from nodegraph.node import Input, Node, NodeParams, Output, RunContext
from nodegraph.types import FILE, STROKES


class StrokesSvg(Node):
    """Writes its strokes to `path` (relative to the output directory: `--out-dir`, default the current
    directory, which it must not leave unless `--allow-outside-out-dir` is given; `~` is expanded, symlinks
    are followed; `####` becomes the frame number) as
    an SVG document, one `<path>` per stroke in the strokes' colour and width, y flipped so it looks like
    the image: a drawing to edit in a vector program. Outputs the path written. Like `write`, it always
    runs when its output is requested, even when the strokes come from the cache."""

    version = "1"
    context_keys = frozenset({"size", "frame"})
    persist = "never"
    side_effect = True
    file_params = ("path",)
    inputs = {"strokes": Input(STROKES, "Polylines in pixels, y up (particle_sketch.strokes).")}
    outputs = {"file": Output(FILE, "The path written.")}

    class Params(NodeParams):
        path: str = Field(description="SVG file to write (must end in .svg); #### = frame number.")

        @field_validator("path")
        @classmethod
        def _svg(cls, v: str) -> str:
            if not v.lower().endswith(".svg"):
                raise ValueError(f"path {v!r}: expected a file ending in .svg")
            return v

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        from nodegraph.output.write import frame_path, write_value

        path = frame_path(str(self.output_path("path")), ctx.frame, False)
        return {"file": write_value(inputs["strokes"], path)}


NODE = StrokesSvg
