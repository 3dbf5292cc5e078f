"""load_mesh: a mesh file as a value (OBJ, PLY, OFF, STL; glTF as one still mesh at t = 0)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import Field, field_validator

from nodegraph.errors import MeshError
from nodegraph.node import HashContext, Node, NodeParams, Output, RunContext
from nodegraph.scene.gltf import load_any_mesh as load_mesh
from nodegraph.types import MESH


class LoadMesh(Node):
    """Reads a mesh through libigl (OBJ, OFF, STL; PLY by our own reader), with the repairs and errors
    of `--scene` (degenerate and duplicate faces dropped with one warning; NaN/Inf coordinates, empty
    or unreadable files are errors naming the file). The path is relative to the current directory.
    The key follows the file's content."""

    version = "1"
    context_keys = frozenset()
    persist = "never"
    outputs = {"out": Output(MESH, "The mesh.")}

    class Params(NodeParams):
        path: str = Field(description="Mesh file (.obj, .ply, .off, .stl, .gltf, .glb).")

        @field_validator("path")
        @classmethod
        def _readable(cls, v: str) -> str:
            try:
                load_mesh(Path(v))
            except MeshError as exc:
                raise ValueError(str(exc)) from None
            return v

    def hash_extra(self, ctx: HashContext) -> Any:
        return load_mesh(Path(self.params.path)).content_hash()

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        return {"out": load_mesh(Path(self.params.path))}


NODE = LoadMesh
