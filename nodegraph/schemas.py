"""JSON Schema plumbing shared by the pipeline and scene schemas (`sketchgraph schema [--scene]`)."""

from __future__ import annotations

from typing import Any

DIALECT = "https://json-schema.org/draft/2020-12/schema"


def hoist_defs(sub: dict[str, Any], root_defs: dict[str, Any], prefix: str) -> dict[str, Any]:
    """Move the `$defs` of a schema that gets embedded in another (pydantic writes them per model) into the
    root's `$defs` as `PREFIX.NAME`, rewriting its `$ref`s to match; returns `sub` without `$defs`.
    A `$ref` is resolved against the document root, so definitions left nested would point nowhere."""
    defs = sub.pop("$defs", {})
    if not defs:
        return sub
    names = {f"#/$defs/{n}": f"#/$defs/{prefix}.{n}" for n in defs}

    def rewrite(node: Any) -> Any:
        if isinstance(node, dict):
            return {k: (names.get(v, v) if k == "$ref" and isinstance(v, str) else rewrite(v))
                    for k, v in node.items()}
        if isinstance(node, list):
            return [rewrite(v) for v in node]
        return node

    for n, d in defs.items():
        root_defs[f"{prefix}.{n}"] = rewrite(d)
    rewritten = rewrite(sub)
    sub.clear()
    sub.update(rewritten)
    return sub


def unresolved_refs(schema: dict[str, Any]) -> list[str]:
    """Every local `$ref` that does not name a root definition (a test helper as much as a check)."""
    defs = schema.get("$defs", {})
    out: list[str] = []

    def walk(node: Any) -> None:
        if isinstance(node, dict):
            ref = node.get("$ref")
            if isinstance(ref, str) and ref.startswith("#/$defs/") and ref.removeprefix("#/$defs/") not in defs:
                out.append(ref)
            for v in node.values():
                walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)

    walk(schema)
    return out
