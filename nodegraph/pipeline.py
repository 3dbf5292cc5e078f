"""Pipeline files: pydantic models, loading with positions, and every check made before GL exists.

```yaml
pipeline: nienhaus-sketchy
size: [800, 800]
reference_size: 800            # image-space params are pixels at this shorter side (docs/sizes.md)
scene: builtin:cloister        # or a scene YAML / mesh file, relative to this file
seed: 7
nodes:
  gbuf:  {type: rasterize}
  edges: {type: edge_detect, in: {normal_depth: gbuf.normal_depth}}
outputs:
  image: edges.out
```
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from . import yamlio
from .errors import CycleError, Location, PipelineError, PortTypeError
from .fsio import show_path
from .node import REFERENCE_SIZE, Node
from .registry import Registry, default
from .shipped import resolve

if TYPE_CHECKING:
    import networkx as nx

_ID = re.compile(r"^[A-Za-z_][A-Za-z0-9_\-]*$")


class NodeSpec(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)

    type: str = Field(description="Node type (see `sketchgraph nodes`).")
    in_: dict[str, str] = Field(default_factory=dict, alias="in",
                                description="Input connections: INPUT_PORT: NODE.OUTPUT_PORT.")
    params: dict[str, Any] = Field(default_factory=dict, description="Parameters of the node type.")
    doc: str = Field("", description="A note for readers of the pipeline.")


class PipelineSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    pipeline: str = Field(description="Name of the pipeline.")
    size: tuple[int, int] = Field((800, 800), description="Output size in pixels: [width, height].")
    reference_size: int = Field(REFERENCE_SIZE, ge=1, le=16384, description=(
        "The shorter side, in pixels, at which the nodes' image-space params (line widths, noise frequencies, "
        "paper grain, particle spacing: 'in pixels at the reference size') hold as written; at another size "
        "they scale by min(width, height) / reference_size, so the drawing is the same at every size "
        "(docs/sizes.md)."))
    scene: str = Field("builtin:cloister", description="builtin:NAME, a scene YAML, or a mesh file "
                                                       "(OBJ, PLY, OFF, STL), relative to this file.")
    seed: int = Field(0, description="Pipeline seed; every stochastic node derives its own from it, "
                                     "its node id and the frame.")
    nodes: dict[str, NodeSpec] = Field(description="The nodes, by id.")
    outputs: dict[str, str] = Field(description="Named outputs: NAME: NODE.PORT.")
    doc: str = Field("", description="What the pipeline does.")

    @field_validator("size")
    @classmethod
    def _positive(cls, v: tuple[int, int]) -> tuple[int, int]:
        if v[0] < 1 or v[1] < 1 or v[0] > MAX_SIZE or v[1] > MAX_SIZE:
            raise ValueError(f"width and height between 1 and {MAX_SIZE}")
        return v


PortRef = tuple[str, str]


@dataclass
class Pipeline:
    """A validated pipeline: node instances, typed connections, outputs, the loaded scene."""

    name: str
    file: str
    size: tuple[int, int]
    seed: int
    scene_spec: str
    nodes: dict[str, Node]
    connections: dict[str, dict[str, PortRef]]  # node -> input port -> (source node, source port)
    outputs: dict[str, PortRef]
    scene: Any = None
    spec: PipelineSpec | None = None
    raw_params: dict[str, dict[str, Any]] = field(default_factory=dict)
    reference_size: int = REFERENCE_SIZE  # the shorter side at which image-space params hold as written

    @property
    def px_scale(self) -> float:
        """min(width, height) / reference_size: what the nodes multiply their image-space params by."""
        from .node import px_scale

        return px_scale(self.size, self.reference_size)

    def graph(self) -> nx.DiGraph:
        import networkx as nx

        g = nx.DiGraph()
        for nid, node in self.nodes.items():
            g.add_node(nid, type=node.type_name)
        for nid, ins in self.connections.items():
            for port, (src, sport) in ins.items():
                g.add_edge(src, nid, ports=[*g.edges[src, nid]["ports"], (sport, port)]
                           if g.has_edge(src, nid) else [(sport, port)])
        return g

    def parse_ref(self, text: str) -> PortRef:
        """'node.port' (or just 'node' when it has one output, or an output name) -> (node, port)."""
        if text in self.outputs:
            return self.outputs[text]
        nid, _, port = text.partition(".")
        if nid not in self.nodes:
            raise PipelineError(f"unknown node '{nid}'" + yamlio.suggest(nid, self.nodes)
                                + f"; nodes: {', '.join(self.nodes)}")
        outs = self.nodes[nid].outputs
        if not port:
            if len(outs) != 1:
                raise PipelineError(f"node '{nid}' has several outputs ({', '.join(outs)}): name one as {nid}.PORT")
            port = next(iter(outs))
        if port not in outs:
            raise PipelineError(f"node '{nid}' ({self.nodes[nid].type_name}) has no output '{port}'"
                                + yamlio.suggest(port, outs) + f"; outputs: {', '.join(outs)}")
        return (nid, port)


def load(path: str | Path, *, overrides: list[str] = (), size: tuple[int, int] | None = None,
         scene: str | None = None, registry: Registry | None = None, load_scene: bool = True,
         out_dir: str | Path | None = None, allow_outside: bool = False, view: str | None = None,
         up: str | None = None, reference_size: int | None = None, fill: float | None = None) -> Pipeline:
    """Load and fully validate a pipeline file, or a shipped pipeline by name (`shipped.resolve`). Raises
    PipelineError (one line, file:line:col). Files that nodes write (`Node.file_params`) resolve against
    `out_dir` (default: the current directory) and must stay inside it unless `allow_outside`."""
    found = resolve(path)
    file = str(path) if found == Path(path) else str(found)  # messages name the file as the user wrote it
    data = yamlio.load(found)
    return build(data, file, overrides=overrides, size=size, scene=scene, registry=registry,
                 load_scene=load_scene, base_dir=found.parent, out_dir=out_dir, allow_outside=allow_outside,
                 view=view, up=up, reference_size=reference_size, fill=fill)


def loads(text: str, file: str = "<string>", **kw: Any) -> Pipeline:
    return build(yamlio.loads(text, file), file, **kw)


def build(data: Any, file: str, *, overrides: list[str] = (), size: tuple[int, int] | None = None,
          scene: str | None = None, registry: Registry | None = None, load_scene: bool = True,
          base_dir: Path | None = None, out_dir: str | Path | None = None, allow_outside: bool = False,
          view: str | None = None, up: str | None = None, reference_size: int | None = None,
          fill: float | None = None) -> Pipeline:
    """`view`, `up` and `fill` (`--view`, `--up`, `--fill`) frame the scene when it is a mesh file (scene.load_scene);
    `reference_size` replaces the file's (as `size` does)."""
    reg = registry or default()
    if not isinstance(data, dict):
        raise PipelineError(f"expected a mapping with keys pipeline, nodes, outputs; found {type(data).__name__}",
                            Location(file, 1, 1))
    spec = yamlio.validate(PipelineSpec, data, file)
    loc = _Locator(data, file)

    nodes: dict[str, Node] = {}
    raw_params: dict[str, dict[str, Any]] = {}
    for nid, nspec in spec.nodes.items():
        if not _ID.match(nid):
            raise PipelineError(f"node id '{nid}': expected letters, digits, '_' or '-' (no dots)",
                                loc.at(["nodes", nid], key=True))
        cls = reg.get(nspec.type)
        if cls is None:
            hint = yamlio.suggest(nspec.type, reg.names())
            raise PipelineError(f"node '{nid}': unknown node type '{nspec.type}'{hint} "
                                "(`sketchgraph nodes` lists them)", loc.at(["nodes", nid, "type"]))
        params = dict(nspec.params)
        raw_params[nid] = params
        nodes[nid] = cls(nid, _params(cls, params, data, file, ["nodes", nid, "params"], nid))

    for text in overrides:
        nid, pname, value, where = _parse_override(text, nodes)
        cls = type(nodes[nid])
        if pname not in cls.Params.model_fields:
            raise PipelineError(f"node '{nid}' ({cls.type_name}) has no parameter '{pname}'"
                                + yamlio.suggest(pname, cls.Params.model_fields)
                                + f"; parameters: {', '.join(cls.Params.model_fields) or 'none'}", where)
        merged = {**raw_params[nid], pname: value}
        try:
            params = cls.Params.model_validate(merged)
        except ValidationError as exc:
            err = yamlio.validation_error(exc, merged, None, what=f"node '{nid}'", model=cls.Params)
            raise PipelineError(err.message, where) from None
        raw_params[nid] = merged
        nodes[nid] = cls(nid, params)
    _resolve_files(nodes, spec, loc, overrides, out_dir, allow_outside)

    connections: dict[str, dict[str, PortRef]] = {nid: {} for nid in nodes}
    for nid, nspec in spec.nodes.items():
        node = nodes[nid]
        for port, ref in nspec.in_.items():
            where = loc.at(["nodes", nid, "in", port])
            if port not in node.inputs:
                raise PipelineError(f"node '{nid}' ({node.type_name}) has no input '{port}'"
                                    + yamlio.suggest(port, node.inputs)
                                    + f"; inputs: {', '.join(node.inputs) or 'none'}",
                                    loc.at(["nodes", nid, "in", port], key=True))
            src, sport = _parse_ref(ref, nodes, where, f"node '{nid}' input '{port}'")
            want, got = node.inputs[port].type, nodes[src].outputs[sport].type
            if not want.accepts(got):
                raise PortTypeError(f"node '{nid}' input '{port}': expected {want}, got {got} from {src}.{sport}",
                                    where)
            connections[nid][port] = (src, sport)
        problem = node.check_connections(set(connections[nid]))
        if problem:
            raise PipelineError(f"node '{nid}' ({node.type_name}): {problem}", loc.at(["nodes", nid], key=True))
        for port, inp in node.inputs.items():
            if port not in connections[nid] and not inp.optional:
                raise PipelineError(f"node '{nid}' ({node.type_name}) is missing input '{port}' ({inp.type}); "
                                    f"connect it with `in: {{{port}: NODE.PORT}}`", loc.at(["nodes", nid], key=True))

    outputs: dict[str, PortRef] = {}
    for name, ref in spec.outputs.items():
        outputs[name] = _parse_ref(ref, nodes, loc.at(["outputs", name]), f"output '{name}'")
    if not outputs:
        raise PipelineError("expected at least one entry under outputs", loc.at(["outputs"], key=True))

    pipe = Pipeline(name=spec.pipeline, file=file, size=tuple(size or spec.size), seed=spec.seed,
                    scene_spec=scene or spec.scene, nodes=nodes, connections=connections, outputs=outputs,
                    spec=spec, raw_params=raw_params,
                    reference_size=int(reference_size or spec.reference_size))
    _check_cycles(pipe, loc)
    _check_sizes(pipe, loc)
    if load_scene:
        from .scene.scene import load_scene as _load_scene

        if scene is not None:
            where = Location("--scene")
            base = Path.cwd()
        else:
            where = loc.at(["scene"])
            base = base_dir or Path.cwd()
        try:
            pipe.scene = _load_scene(pipe.scene_spec, base, view=view, up=up, fill=fill)
        except PipelineError as exc:
            if exc.location is not None:
                raise
            raise PipelineError(exc.message, where) from None
        except Exception as exc:  # MeshError and friends: keep the message, add where it came from
            if type(exc).__name__ in ("MeshError",):
                raise PipelineError(f"scene '{show_path(pipe.scene_spec, 80)}': {exc}", where) from None
            raise
    return pipe


def _resolve_files(nodes: dict[str, Node], spec: PipelineSpec, loc: _Locator, overrides: Any,
                   out_dir: str | Path | None, allow_outside: bool) -> None:
    """Resolve every file a node writes against the output directory (~ expanded, symlinks followed) into
    `node.paths`; one that leaves it is a PipelineError unless `allow_outside`. Params (and keys) keep the
    text as written."""
    root = Path(out_dir if out_dir is not None else Path.cwd()).expanduser().resolve()
    for nid, node in nodes.items():
        for name in node.file_params:
            text = str(getattr(node.params, name))
            target = (root / Path(text).expanduser()).resolve()
            node.paths[name] = target
            if allow_outside or target == root or target.is_relative_to(root):
                continue
            overridden = [o for o in overrides if o.partition("=")[0].strip() == f"{nid}.{name}"]
            if overridden:
                where = Location(f"--set {overridden[-1]}")
            elif name in spec.nodes[nid].params:
                where = loc.at(["nodes", nid, "params", name])
            else:
                where = loc.at(["nodes", nid], key=True)
            raise PipelineError(f"node '{nid}' ({node.type_name}) {name} '{text}' resolves to {target}, outside the "
                                f"output directory {root}; give a path inside it, choose another with --out-dir, "
                                "or pass --allow-outside-out-dir (API: allow_outside=True)", where)


def declared_shape(node: Node, port: str, size: tuple[int, int]) -> tuple[int, int, int] | None:
    """(width, height, layers) of an output where the node's class declares it (overrides `output_shape`);
    None where the output follows the image size or an input, which load time cannot know."""
    if type(node).output_shape is Node.output_shape:
        return None
    w, h, layers = node.output_shape(port, size)
    return (int(w), int(h), int(layers))


def _check_sizes(pipe: Pipeline, loc: _Locator) -> None:
    for nid, node in pipe.nodes.items():
        shapes = {port: declared_shape(pipe.nodes[src], sport, pipe.size)
                  for port, (src, sport) in pipe.connections[nid].items()}
        problem = node.check_size(pipe.size, shapes)
        if problem:
            raise PipelineError(f"node '{nid}' ({node.type_name}): {problem}", loc.at(["nodes", nid], key=True))


def _params(cls: type[Node], params: dict[str, Any], root: Any, file: str, prefix: list[Any], nid: str) -> Any:
    return yamlio.validate(cls.Params, params, file, prefix=prefix, root=root, what=f"node '{nid}' ({cls.type_name})")


def _parse_ref(ref: str, nodes: dict[str, Node], where: Location, what: str) -> PortRef:
    nid, dot, port = ref.partition(".")
    if not dot or not port:
        raise PipelineError(f"{what}: expected NODE.PORT, found '{ref}'", where)
    if nid not in nodes:
        raise PipelineError(f"{what}: unknown node '{nid}'" + yamlio.suggest(nid, nodes), where)
    outs = nodes[nid].outputs
    if port not in outs:
        raise PipelineError(f"{what}: node '{nid}' ({nodes[nid].type_name}) has no output '{port}'"
                            + yamlio.suggest(port, outs) + f"; outputs: {', '.join(outs)}", where)
    return nid, port


def _parse_override(text: str, nodes: dict[str, Node]) -> tuple[str, str, Any, Location]:
    shown = text if text.isprintable() else ascii(text)[1:-1]
    where = Location(f"--set {shown if len(shown) <= 80 else shown[:77] + '...'}")
    target, eq, value = text.partition("=")
    nid, dot, pname = target.strip().partition(".")
    if not eq or not dot or not pname:
        raise PipelineError("expected NODE.PARAM=VALUE", where)
    if nid not in nodes:
        raise PipelineError(f"unknown node '{nid}'" + yamlio.suggest(nid, nodes) + f"; nodes: {', '.join(nodes)}",
                            where)
    parsed = yamlio.value(value, where) if value.strip() else value
    return nid, pname, parsed, where


def _check_cycles(pipe: Pipeline, loc: _Locator) -> None:
    import networkx as nx

    g = pipe.graph()
    try:
        cycle = nx.find_cycle(g)
    except nx.NetworkXNoCycle:
        return
    names = [u for u, _ in cycle] + [cycle[0][0]]
    raise CycleError(f"cycle in the node graph: {' -> '.join(names)}; a node cannot depend on its own output",
                     loc.at(["nodes", cycle[0][0]], key=True))


MAX_SIZE = 16384
"""Largest width or height, from the command line or a pipeline's `size` (a GL context may allow less:
the executor checks its GL_MAX_TEXTURE_SIZE when it creates one)."""


def parse_size(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d{1,30})\s*[xX×]\s*(\d{1,30})\s*", text)
    if not m:
        shown = text if len(text) <= 60 else text[:57] + "..."
        raise PipelineError(f"--size: expected WIDTHxHEIGHT such as 1200x900, found '{shown}'")
    w, h = int(m.group(1)), int(m.group(2))
    if not (1 <= w <= MAX_SIZE and 1 <= h <= MAX_SIZE):
        raise PipelineError(f"--size: expected width and height between 1 and {MAX_SIZE}, found "
                            f"{w}x{h}")
    return w, h


class _Locator:
    def __init__(self, root: Any, file: str):
        self.root = root
        self.file = file

    def at(self, path: list[Any], key: bool = False) -> Location:
        return yamlio.locate(self.root, path, self.file, key=key)


def json_schema(registry: Registry | None = None) -> dict[str, Any]:
    """JSON Schema of the pipeline format with every node type's params, for editor completion."""
    from .schemas import DIALECT, hoist_defs

    reg = registry or default()
    schema = PipelineSpec.model_json_schema()
    defs: dict[str, Any] = schema.setdefault("$defs", {})
    variants = []
    for name, cls in reg.items():
        pschema = hoist_defs(cls.Params.model_json_schema(), defs, name)  # refs resolve from the root
        pschema.pop("title", None)
        variants.append({
            "type": "object",
            "description": (cls.doc or cls.__doc__ or "").strip().splitlines()[0] if (cls.doc or cls.__doc__) else name,
            "properties": {
                "type": {"const": name},
                "in": {"type": "object", "additionalProperties": False,
                       "properties": {p: {"type": "string", "description": f"{i.type}: {i.doc}"}
                                      for p, i in cls.inputs.items()}},
                "params": pschema,
                "doc": {"type": "string"},
            },
            "required": ["type"],
            "additionalProperties": False,
        })
    schema["properties"]["nodes"]["additionalProperties"] = {"oneOf": variants}
    defs.pop("NodeSpec", None)
    if not defs:
        schema.pop("$defs")
    schema["$schema"] = DIALECT
    schema["title"] = "sketchgraph pipeline"
    return schema
