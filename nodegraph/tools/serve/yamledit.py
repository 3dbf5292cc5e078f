"""Write node parameters back into a pipeline YAML file, keeping everything else of its text: comments, key
order, blank lines and the style of the values that did not change.

The document is composed with PyYAML (which knows where each node starts and ends in the text); each changed
value's text span is replaced by the value written in YAML's flow style (JSON spelling: `[[0.01, 0], [0, 0.01]]`,
`0.4`, `"name"`). A parameter the file does not spell yet is added to the node's `params` (created where
missing), in flow or block style as the surrounding mapping is written. The edited text is parsed again and
must give exactly the requested values, or nothing is written.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import yaml

from ...errors import PipelineError


def flow(value: Any) -> str:
    """A value in YAML flow style (JSON's spelling, which YAML reads back as the same value)."""
    if isinstance(value, float) and not math.isfinite(value):
        raise PipelineError(f"cannot write the non-finite number {value!r} to YAML here")
    if isinstance(value, Mapping):  # plain keys where YAML reads them back as the same strings
        return "{" + ", ".join(f"{_key(k)}: {flow(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(flow(v) for v in value) + "]"
    return json.dumps(value, allow_nan=False)


def _key(key: Any) -> str:
    text = str(key)
    plain = text.isidentifier() and yaml.safe_load(text) == text
    return text if plain else json.dumps(text)


def _get(mapping: yaml.MappingNode, key: str) -> tuple[yaml.Node, yaml.Node] | None:
    for k, v in mapping.value:
        if isinstance(k, yaml.ScalarNode) and k.value == key:
            return k, v
    return None


def _end(node: yaml.Node) -> int:
    """Where a node's own text ends: a block collection's end mark lies past the comments and blank lines that
    follow it, so take its last child's end instead."""
    if isinstance(node, yaml.ScalarNode) or getattr(node, "flow_style", False):
        return node.end_mark.index
    children = [c for kv in node.value for c in kv] if isinstance(node, yaml.MappingNode) else list(node.value)
    return _end(children[-1]) if children else node.end_mark.index


def _line_start(text: str, index: int) -> int:
    return text.rfind("\n", 0, index) + 1


def _edits_for(text: str, root: yaml.MappingNode, node_id: str, values: Mapping[str, Any]
               ) -> list[tuple[int, int, str]]:
    nodes = _get(root, "nodes")
    if nodes is None or not isinstance(nodes[1], yaml.MappingNode):
        raise PipelineError("the file has no `nodes:` mapping to write parameters into")
    found = _get(nodes[1], node_id)
    if found is None or not isinstance(found[1], yaml.MappingNode):
        raise PipelineError(f"node '{node_id}' is not a mapping in the file; cannot write its parameters")
    node_key, node = found
    params = _get(node, "params")
    edits: list[tuple[int, int, str]] = []
    missing: dict[str, Any] = {}
    if params is not None and isinstance(params[1], yaml.MappingNode):
        pmap = params[1]
        for name, value in values.items():
            hit = _get(pmap, name)
            if hit is None:
                missing[name] = value
            else:
                edits.append((hit[1].start_mark.index, _end(hit[1]), flow(value)))
        if missing:
            edits.append(_insert(text, pmap, missing))
    elif params is not None:  # `params:` with nothing (null) after it
        edits.append((params[1].start_mark.index, _end(params[1]), flow(dict(values))))
    else:
        edits.append(_insert(text, node, {"params": dict(values)}))
    return edits


def _insert(text: str, mapping: yaml.MappingNode, entries: Mapping[str, Any]) -> tuple[int, int, str]:
    """An edit adding `entries` to a mapping, written in the mapping's own style."""
    if mapping.flow_style or not mapping.value:
        body = ", ".join(f"{k}: {flow(v)}" for k, v in entries.items())
        if not mapping.value:  # `{}`
            return mapping.start_mark.index, _end(mapping), "{" + body + "}"
        close = text.rindex("}", 0, _end(mapping))
        return close, close, ", " + body
    first_key = mapping.value[0][0]
    indent = " " * first_key.start_mark.column
    at = _end(mapping.value[-1][1])
    body = "".join(f"\n{indent}{k}: {flow(v)}" for k, v in entries.items())
    return at, at, body


def set_params(text: str, changes: Mapping[str, Mapping[str, Any]]) -> str:
    """`text` with `changes` ({node id: {param: value}}) written into its nodes' `params`."""
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as exc:
        raise PipelineError(f"cannot write parameters: the file does not parse ({' '.join(str(exc).split())})") \
            from None
    if not isinstance(root, yaml.MappingNode):
        raise PipelineError("cannot write parameters: the file is not a mapping")
    edits: list[tuple[int, int, str]] = []
    for node_id, values in changes.items():
        if values:
            edits += _edits_for(text, root, node_id, values)
    out = text
    for start, end, new in sorted(edits, key=lambda e: (e[0], e[1]), reverse=True):
        out = out[:start] + new + out[end:]
    check = yaml.safe_load(out)
    for node_id, values in changes.items():
        got = ((check.get("nodes") or {}).get(node_id) or {}).get("params") or {}
        for name, value in values.items():
            if name not in got or json.loads(flow(got[name])) != json.loads(flow(value)):
                raise PipelineError(f"cannot write {node_id}.{name} back to the file (it reads back as "
                                    f"{got.get(name)!r}); nothing written")
    return out
