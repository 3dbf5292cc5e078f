"""The node base class: typed ports on the class, a frozen pydantic `Params`, `key()` and `compute()`.

`key()` is cheap and never touches the GPU: it digests the node type, its code version, its GLSL
sources, its params, its input keys and the context values it reads. `compute()` does the work.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict

from .errors import NodeError
from .types import PortType


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
CONTEXT_KEYS = frozenset({"size", "frame", "seed", "scene", "camera", "px_scale"})

# The pipeline's `reference_size` (pixels on the shorter side) when it names none: image-space params (line
# widths, noise frequencies, grain, particle spacing) are "pixels at the reference size", and a node that
# declares the context key "px_scale" multiplies them by px_scale = min(width, height) / reference_size, so a
# pipeline draws the same picture at every size (docs/sizes.md).
REFERENCE_SIZE = 800


def px_scale(size: tuple[int, int], reference_size: int | None) -> float:
    """Image pixels per pixel at the reference size: min(width, height) / reference_size (1.0 exactly at it;
    None: the image is its own reference, 1.0)."""
    if reference_size is None:
        return 1.0
    return min(int(size[0]), int(size[1])) / int(reference_size)

# The `hold` convention of stochastic nodes: a `hold` param (frames per change of the node's noise, the boil
# rate; 0: the same noise for the whole sequence) makes the frame the node's seed and noise see, and the
# frame its key covers, `held_frame(frame, hold)`. Held frames share one key, so they share one cache entry.
HOLD_PARAM = "hold"


def held_frame(frame: int, hold: int | None) -> int:
    """The frame a node's noise is drawn for at `frame`: frame // hold * hold; 0 when hold is 0; `frame`
    itself when the node has no hold."""
    if hold is None:
        return int(frame)
    return 0 if hold == 0 else int(frame) // int(hold) * int(hold)


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
    # params that name files the node writes: resolved at load time against the output directory
    # (pipeline.build), where they must stay unless the user allows otherwise
    file_params: ClassVar[tuple[str, ...]] = ()
    # params the key leaves out because it covers them another way (`hold`: through the held frame, so the
    # key of a node that gained a hold param is the one it had before, and held frames share it)
    key_omits: ClassVar[frozenset[str]] = frozenset()
    doc: ClassVar[str] = ""

    class Params(NodeParams):
        pass

    def __init__(self, node_id: str, params: NodeParams | None = None):
        self.id = node_id
        self.params = params if params is not None else self.Params()
        self.paths: dict[str, Path] = {}  # file_params resolved by pipeline.build (absolute)

    @property
    def hold(self) -> int | None:
        """Frames per change of the node's noise (its `hold` param), or None when it has none."""
        value = getattr(self.params, HOLD_PARAM, None)
        return None if value is None else int(value)

    def held_frame(self, frame: int) -> int:
        """The frame this node's seed and noise see at `frame` (`held_frame` with its hold)."""
        return held_frame(frame, self.hold)

    def output_path(self, name: str) -> Path:
        """The file a `file_params` entry names: as resolved at load time, else the param itself (~ expanded)."""
        return self.paths.get(name) or Path(str(getattr(self.params, name))).expanduser()

    def check_connections(self, connected: set[str]) -> str | None:
        """At load time: a message if these connected inputs (with these params) cannot work (override)."""
        return None

    def check_size(self, size: tuple[int, int], inputs: dict[str, tuple[int, int, int] | None]) -> str | None:
        """At load time, once the image size is known (after --size): a message if the node cannot work at
        `size` (override). `inputs` maps each connected input to its source's (width, height, layers) where
        the source declares it (overrides `output_shape`), else None (it follows the image or an input)."""
        return None

    def passthrough(self, connected: set[str]) -> dict[str, str]:
        """Outputs that are one of the inputs unchanged, as {output: input} (override). The planner then
        reads the source directly: the output shares the source's cache entry and the node does not run."""
        return {}

    def unread_inputs(self, needed: frozenset[str], sources: dict[str, tuple[str, str, str]]) -> set[str]:
        """Connected inputs a run for the `needed` outputs does not read (override), given each input's source
        as {input: (source node type, id, port)}. The planner then passes them as None and asks nothing of
        their sources for them."""
        return set()

    def output_shape(self, port: str, size: tuple[int, int]) -> tuple[int, int, int]:
        """(width, height, layers) of a texture output at image size `size`, for memory estimates such as
        `run --explain` (override where an output is not screen-sized, e.g. a tile or a texture array)."""
        return (size[0], size[1], 1)

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

    @classmethod
    def shader_paths(cls) -> tuple[Path, ...]:
        """The node's shader files (`shaders` in `source_dir()`); made once per class."""
        found = cls.__dict__.get("_shader_paths")
        if found is None:
            found = tuple(cls.source_dir() / s for s in cls.shaders)
            cls._shader_paths = found  # type: ignore[attr-defined]
        return found

    def hash_extra(self, ctx: HashContext) -> Any:
        """Anything else the output depends on (override; must be cheap)."""
        return None

    def recorded_params(self) -> dict[str, Any]:
        """The params as records show them (gallery manifest): `key_omits` left out where at their default, so a
        record made before a node gained such a param (`hold`) still matches."""
        fields = type(self.params).model_fields
        skip = {n for n in self.key_omits if n in fields and getattr(self.params, n) == fields[n].default}
        return self.params.model_dump(mode="json", exclude=skip)

    def key_parts(self, ctx: HashContext, input_keys: dict[str, str]) -> dict[str, Any]:
        """What `key()` digests (tools/diff.py explains a changed key part by part)."""
        from .gpu.glsl import source_digest

        # the params' JSON form once per node (they are frozen), the shader paths once per class: a frame loop
        # asks for every node's key every frame
        params = self.__dict__.get("_key_params")
        if params is None or params[0] is not self.params:
            params = self._key_params = (self.params, self.params.model_dump(
                mode="json", exclude=set(self.key_omits) if self.key_omits else None))
        return {
            "type": self.type_name,
            "version": self.version,
            "glsl": [source_digest(p) for p in self.shader_paths()],
            "params": params[1],
            "inputs": input_keys,
            "context": ctx.values_for(self),
            "extra": self.hash_extra(ctx),
        }

    def key(self, ctx: HashContext, input_keys: dict[str, str]) -> str:
        return digest(self.key_parts(ctx, input_keys))

    # -- work --------------------------------------------------------------------------------
    def compute(self, ctx: RunContext, inputs: dict[str, Any], needed: frozenset[str]) -> dict[str, Any]:
        """Produce the `needed` outputs (a subset of `outputs`) from `inputs`."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<{self.type_name} {self.id!r}>"


class HashContext:
    """Context values visible to `Node.key()`: size, frame, seed, scene and camera digests, px_scale."""

    def __init__(self, size: tuple[int, int], frame: int, seed: int, scene: Any | None,
                 reference_size: int | None = None):
        self.size = size
        self.frame = frame
        self.seed = seed
        self.scene = posed(scene, frame)
        self.reference_size = None if reference_size is None else int(reference_size)
        self._memo: dict[str, Any] = {}  # the values every node sees alike, computed once per context

    @property
    def px_scale(self) -> float:
        return px_scale(self.size, self.reference_size)

    def values_for(self, node: Node) -> dict[str, Any]:
        """The context values `node` reads (its `context_keys`), the frame held by its `hold`. `px_scale` is
        left out where it is 1.0: there a node computes exactly what it did before it read the scale (a
        multiplication by 1), so its key, and the cache entries and records made with it, stay as they were."""
        return {k: node.held_frame(self.frame) if k == "frame" else self.value(k, node.id)
                for k in sorted(node.context_keys) if not (k == "px_scale" and self.px_scale == 1.0)}

    def value(self, name: str, node_id: str) -> Any:
        if name in ("scene", "camera"):  # the same for every node: the camera's matrices once per frame
            if name not in self._memo:
                self._memo[name] = self._value(name, node_id)
            return self._memo[name]
        return self._value(name, node_id)

    def _value(self, name: str, node_id: str) -> Any:
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
        if name == "px_scale":
            return self.px_scale
        raise KeyError(f"unknown context value {name!r}; known: {sorted(CONTEXT_KEYS)}")


@dataclass(frozen=True, init=False)
class RunContext:
    """What a node's `compute()` sees, as a plain value: the node, the GL wrapper, the image size, the frame,
    the pipeline seed, the scene, the planned formats of the node's texture outputs and the pipeline's
    reference size (`px_scale`: image pixels per pixel at the reference size).

    `gl` may be given as the GL wrapper or as a zero-argument callable that returns it, so a node that never
    touches the GPU never creates a context. Tests build one directly:
    `RunContext(node, gl=gl, size=(64, 64), frame=0, pipeline_seed=3)`; without `reference_size` the image
    is its own reference (px_scale 1: params in pixels of this image), as a node run outside a pipeline
    measures it. The executor passes the pipeline's.
    """

    node: Node
    gl_source: Any = None
    size: tuple[int, int] = (800, 800)
    frame: int = 0
    pipeline_seed: int = 0
    scene: Any = None
    formats: Mapping[str, str] = field(default_factory=dict)  # output port -> planned texture format
    reference_size: int | None = None

    def __init__(self, node: Node, *, gl: Any = None, size: tuple[int, int] = (800, 800), frame: int = 0,
                 pipeline_seed: int = 0, scene: Any = None, formats: Mapping[str, str] | None = None,
                 reference_size: int | None = None) -> None:
        object.__setattr__(self, "node", node)
        object.__setattr__(self, "gl_source", gl)
        object.__setattr__(self, "size", (int(size[0]), int(size[1])))
        object.__setattr__(self, "frame", int(frame))
        object.__setattr__(self, "pipeline_seed", int(pipeline_seed))
        object.__setattr__(self, "scene", posed(scene, frame))
        object.__setattr__(self, "formats", dict(formats or {}))
        object.__setattr__(self, "reference_size", None if reference_size is None else int(reference_size))

    @property
    def px_scale(self) -> float:
        """Image pixels per pixel at the pipeline's reference size: min(width, height) / reference_size. A
        node multiplies its image-space params by it (and declares the context key "px_scale")."""
        return px_scale(self.size, self.reference_size)

    @property
    def gl(self) -> Any:
        """The GL wrapper (`nodegraph.gpu.gl.GL`); created on first use when given as a callable."""
        src = self.gl_source
        if src is None:
            from .gpu import gl as glmod

            return glmod.get()
        return src() if callable(src) else src

    @property
    def noise_frame(self) -> int:
        """The frame the node's noise is drawn for: its frame held by its `hold` (`Node.held_frame`) where the
        node reads the frame, else 0."""
        return self.node.held_frame(self.frame) if "frame" in self.node.context_keys else 0

    @property
    def seed(self) -> int:
        """This node's seed: from the pipeline seed, the node id, and the frame if the node reads it (held by
        the node's `hold`: the same seed for every frame of a hold)."""
        return derive_seed(self.pipeline_seed, self.node.id, self.noise_frame)

    def seed_for_frame(self, frame: int) -> int:
        return derive_seed(self.pipeline_seed, self.node.id, frame)

    def input_scene(self, inputs: Mapping[str, Any]) -> Any:
        """The scene a node draws: its `scene` input where connected, else the pipeline's; a NodeError when
        there is neither."""
        scene = inputs.get("scene") or self.scene
        if scene is None:
            raise NodeError("needs a scene: connect `scene` or give the pipeline one", self.node.id,
                            self.node.type_name)
        return scene

    @property
    def camera(self) -> Any:
        return self.scene.camera_at(self.frame) if self.scene is not None else None

    def format(self, port: str) -> str:
        """The planned format of a texture output (the declared format where the port is not planned)."""
        return self.formats.get(port) or self.node.outputs[port].type.fmt or "RGBA16F"

    def target(self, port: str, size: tuple[int, int] | None = None, filter: str = "linear") -> Any:
        """A pooled texture for output `port`, at the image size unless `size` is given."""
        return self.gl.texture(size or self.size, self.format(port), filter=filter)

    def program(self, filename: str, defines: dict[str, Any] | None = None) -> Any:
        """A compiled program from a GLSL file beside the node (cached by source and defines)."""
        return self.gl.program(self.node.source_dir() / filename, defines, node=self.node.id)


def posed(scene: Any, frame: int) -> Any:
    """An animated scene at `frame` (`Scene.at`): nodes see still geometry, and keys cover the pose."""
    return scene.at(int(frame)) if getattr(scene, "animation", None) is not None else scene


def derive_seed(pipeline_seed: int, node_id: str, frame: int) -> int:
    """A 32-bit seed from the pipeline seed, the node id and the frame: same inputs, same bytes."""
    h = hashlib.sha256(f"{pipeline_seed}:{node_id}:{frame}".encode()).digest()
    return int.from_bytes(h[:4], "little")
