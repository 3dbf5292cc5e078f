"""scene: a scene as a value, for nodes that take a `Scene` input."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import Field, field_validator

from nodegraph.node import HashContext, Input, Node, NodeParams, Output, RunContext
from nodegraph.scene.scene import load_scene, scene_for_mesh
from nodegraph.types import MESH, SCENE


class SceneNode(Node):
    """A scene from `path` (builtin:NAME, a scene YAML, or a mesh file, relative to the current
    directory), or a connected mesh framed as a one-object scene (as `--scene mesh.obj` frames it).
    Connect `out` to a node's `scene` input to draw something other than the pipeline's scene, for
    example a second scene rasterized into another G-buffer."""

    version = "1"
    context_keys = frozenset()
    persist = "never"  # a source: loading is cheaper than a cache entry
    inputs = {"mesh": Input(MESH, "A mesh to frame as a one-object scene (instead of `path`).", optional=True)}
    outputs = {"out": Output(SCENE, "The scene.")}

    class Params(NodeParams):
        path: str | None = Field(None, description="builtin:NAME, a scene YAML or a mesh file; not with `mesh`.")

        @field_validator("path")
        @classmethod
        def _loads(cls, v: str | None) -> str | None:
            if v is not None:
                load_scene(v, Path.cwd())  # a missing or broken file is a load-time error
            return v

    def check_connections(self, connected: set[str]) -> str | None:
        if ("mesh" in connected) == (self.params.path is not None):
            return "give either params.path or the `mesh` input, not both or neither"
        return None

    def hash_extra(self, ctx: HashContext) -> Any:
        return load_scene(self.params.path, Path.cwd()).at(ctx.frame).content_hash() if self.params.path else None

    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        if "mesh" in inputs:
            return {"out": scene_for_mesh(inputs["mesh"])}
        return {"out": load_scene(self.params.path, Path.cwd()).at(ctx.frame)}


NODE = SceneNode
