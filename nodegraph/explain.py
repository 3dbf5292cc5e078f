"""`run --explain`: what will run and why, what comes from the cache, buffer formats and memory."""

from __future__ import annotations

from typing import Any

from . import types


def explain(ex: Any, frame: int = 0) -> str:
    pipe, plan = ex.pipeline, ex.plan
    keys = ex.keys(frame)
    lines = [f"plan for {pipe.file} ({pipe.size[0]}x{pipe.size[1]}, frame {frame}): "
             f"{len(plan.order)} of {len(pipe.nodes)} nodes"]
    total = 0
    for nid in plan.order:
        node = pipe.nodes[nid]
        where = "compute"
        if ex.cache is not None and node.persist != "never":
            ports = plan.needed[nid]
            if ports and all(ex.cache.find(keys[nid], ex._entry(nid, p)) for p in ports):
                where = "disk cache"
        reasons = ", ".join(dict.fromkeys(plan.reasons.get(nid, [])))
        lines.append(f"  {nid} ({node.type_name}): {where}; needed by {reasons}")
        for port in sorted(plan.needed[nid]):
            fmt = plan.formats.get((nid, port))
            if fmt:
                w, h = pipe.size
                nbytes = w * h * types.bytes_per_pixel(fmt)
                total += nbytes
                declared = node.outputs[port].type.fmt
                why = "" if fmt == declared else f" (declared {declared}; consumers need no more)"
                lines.append(f"      {port}: {fmt} {nbytes / 1024**2:.1f} MiB{why}")
            else:
                lines.append(f"      {port}: {node.outputs[port].type}")
    skipped = [n for n in pipe.nodes if n not in plan.order]
    if skipped:
        lines.append(f"  not needed: {', '.join(skipped)}")
    lines.append(f"  texture memory: {total / 1024**2:.1f} MiB")
    return "\n".join(lines)
