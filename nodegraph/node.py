"""The node base class: typed ports on the class, a frozen pydantic `Params`, `key()` and `compute()`.

`key()` is cheap and never touches the GPU: it digests the node type, its code version, its GLSL
sources, its params, its input keys and the context values it reads. `compute()` does the work.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict

from .types import PortType

if TYPE_CHECKING:
    from .executor import RunContext


class NodeParams(BaseModel):
    """Base for every node's `Params`: unknown fields are errors, values are immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True)


@dataclass(frozen=True)
class Input:
    type: PortType
    doc: str = ""
    optional: bool = False


@dataclass(frozen=True)
class Output:
    type: PortType
    doc: str = ""


def canonical_json(value: Any) -> str:
    def default(obj: Any) -> Any:
        if isinstance(obj, BaseModel):
            return obj.model_dump(mode="json")
        if isinstance(obj, np.ndarray):
            return obj.tolist()
        if isinstance(obj, (np.floating, np.integer)):
            return obj.item()
        if isinstance(obj, (set, frozenset)):
            return sorted(obj)
        if isinstance(obj, Path):
            return str(obj)
        raise TypeError(f"cannot hash {type(obj).__name__}")

    return json.dumps(value, sort_keys=True, separators=(",", ":"), default=default)


def digest(value: Any) -> str:
    return hashlib.sha256(canonical_json(value).encode()).hexdigest()


# context values a node may read; each node lists the ones it reads in `context_keys`
CONTEXT_KEYS = frozenset({"size", "frame", "seed", "scene", "camera"})


class Node:
    """One processing stage. Subclasses declare ports, `Params`, `version`, `shaders` and `compute`."""

    type_name: ClassVar[str] = ""
    version: ClassVar[str] = "1"
    inputs: ClassVar[dict[str, Input]] = {}
    outputs: ClassVar[dict[str, Output]] = {}
    shaders: ClassVar[tuple[str, ...]] = ()  # GLSL files beside the node; their source is hashed
    context_keys: ClassVar[frozenset[str]] = frozenset({"size"})
    # "always": expensive, persisted to the disk cache even inside frame loops (computed once);
    # "auto": persisted for single renders, never inside a frame loop; "never": not worth a disk write.
    persist: ClassVar[str] = "auto"
    side_effect: ClassVar[bool] = False  # always computed when planned (writes files); never cached
    doc: ClassVar[str] = ""

    class Params(NodeParams):
        pass

    def __init__(self, node_id: str, params: NodeParams | None = None):
        self.id = node_id
        self.params = params if params is not None else self.Params()

    def check_connections(self, connected: set[str]) -> str | None:
        """At load time: a message if these connected inputs (with these params) cannot work (override)."""
        return None

    def passthrough(self, connected: set[str]) -> dict[str, str]:
        """Outputs that are one of the inputs unchanged, as {output: input} (override). The planner then
        reads the source directly: the output shares the source's cache entry and the node does not run."""
        return {}

    # -- hashing -----------------------------------------------------------------------------
    @classmethod
    def source_dir(cls) -> Path:
        """The node's folder (its GLSL lives there); looked up once per class."""
        found = cls.__dict__.get("_source_dir")
        if found is None:
            import inspect

            found = Path(inspect.getfile(cls)).parent
            cls._source_dir = found  # type: ignore[attr-defined]
        return found

    def hash_extra(self, ctx: HashContext) -> Any:
        """Anything else the output depends on (override; must be cheap)."""
        return None

    def key(self, ctx: HashContext, input_keys: dict[str, str]) -> str:
        from .glsl import source_digest

        ctx_values = {k: ctx.value(k, self.id) for k in sorted(self.context_keys)}
        return digest({
            "type": self.type_name,
            "version": self.version,
            "glsl": [source_digest(self.source_dir() / s) for s in self.shaders],
            "params": self.params,
            "inputs": input_keys,
            "context": ctx_values,
            "extra": self.hash_extra(ctx),
        })

    # -- work --------------------------------------------------------------------------------
    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        """Produce the `needed` outputs (a subset of `outputs`) from `inputs`."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<{self.type_name} {self.id!r}>"


class HashContext:
    """Context values visible to `Node.key()`: size, frame, seed, scene and camera digests."""

    def __init__(self, size: tuple[int, int], frame: int, seed: int, scene: Any | None):
        self.size = size
        self.frame = frame
        self.seed = seed
        self.scene = scene

    def value(self, name: str, node_id: str) -> Any:
        if name == "size":
            return list(self.size)
        if name == "frame":
            return self.frame
        if name == "seed":
            return derive_seed(self.seed, node_id, 0)
        if name == "scene":
            return self.scene.content_hash() if self.scene is not None else None
        if name == "camera":
            if self.scene is None:
                return None
            cam = self.scene.camera_at(self.frame)
            # the matrices themselves, at this aspect: a change in how a camera projects changes the key
            w, h = self.size
            return digest([cam.view_matrix().tolist(), cam.projection_matrix(w / h).tolist()])
        raise KeyError(f"unknown context value {name!r}; known: {sorted(CONTEXT_KEYS)}")


def derive_seed(pipeline_seed: int, node_id: str, frame: int) -> int:
    """A 32-bit seed from the pipeline seed, the node id and the frame: same inputs, same bytes."""
    h = hashlib.sha256(f"{pipeline_seed}:{node_id}:{frame}".encode()).digest()
    return int.from_bytes(h[:4], "little")
