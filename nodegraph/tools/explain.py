"""`run --explain`: what will run and why, what comes from the cache, buffer formats and memory.

It walks the plan the way the executor materialises values: from the requested outputs backwards, a
pass-through is read at its source, an output on disk is loaded (and its node's inputs are not
needed), anything else is computed, which needs its inputs.
"""

from __future__ import annotations

from typing import Any

from .. import types


def explain(ex: Any, frame: int = 0) -> str:
    pipe, plan = ex.pipeline, ex.plan
    keys = ex.keys(frame)
    status: dict[str, str] = {}

    def visit(nid: str, port: str) -> None:
        src = plan.aliases.get((nid, port))
        if src is not None:
            status.setdefault(nid, f"pass-through to {src[0]}.{src[1]}")
            visit(*src)
            return
        if status.get(nid) == "compute":
            return
        node = pipe.nodes[nid]
        cached = node.persist != "never" and not node.side_effect and ex.is_stored(nid, port, keys[nid])
        if cached:
            status.setdefault(nid, "disk cache")
            return
        status[nid] = "compute"
        for s, sp in pipe.connections[nid].values():
            visit(s, sp)

    for ref in plan.requested:
        visit(*ref)
    lines = [f"plan for {pipe.file} ({pipe.size[0]}x{pipe.size[1]}, frame {frame}): "
             f"{sum(1 for s in status.values() if s == 'compute')} of {len(pipe.nodes)} nodes compute"]
    total = 0
    for nid in plan.order:
        node = pipe.nodes[nid]
        reasons = ", ".join(dict.fromkeys(plan.reasons.get(nid, [])))
        where = status.get(nid, "skipped, the cache holds what depends on it")
        lines.append(f"  {nid} ({node.type_name}): {where}; for {reasons}" if nid not in status
                     else f"  {nid} ({node.type_name}): {where}; needed by {reasons}")
        if nid not in status or where.startswith("pass-through"):
            continue
        for port in sorted(plan.needed[nid]):
            ptype = node.outputs[port].type
            fmt = plan.formats.get((nid, port)) or (ptype.fmt if ptype.is_texture else None)
            if fmt:
                w, h, layers = node.output_shape(port, pipe.size)
                nbytes = w * h * layers * types.bytes_per_pixel(fmt)
                total += nbytes
                why = "" if fmt == ptype.fmt else f" (declared {ptype.fmt}; consumers need no more)"
                shape = f"{w}x{h}" + (f"x{layers}" if layers > 1 else "")
                lines.append(f"      {port}: {fmt} {shape} {nbytes / 1024**2:.1f} MiB{why}")
            else:
                lines.append(f"      {port}: {node.outputs[port].type}")
    skipped = [n for n in pipe.nodes if n not in plan.order]
    if skipped:
        lines.append(f"  not needed: {', '.join(skipped)} (no requested output depends on them)")
    lines.append(f"  texture memory: {total / 1024**2:.1f} MiB")
    return "\n".join(lines)
