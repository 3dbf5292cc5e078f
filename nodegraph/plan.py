"""Planning: which nodes a set of requested outputs needs, which pass-through outputs resolve to which
source, and the format of every texture (the highest precision its consumers ask for, never more than
declared). Pure: no GPU, no cache."""

from __future__ import annotations

from dataclasses import dataclass, field

from . import types
from .pipeline import Pipeline, PortRef


@dataclass
class Plan:
    pipeline: Pipeline
    requested: list[PortRef]
    order: list[str]  # topological, ancestors of the requested outputs only
    needed: dict[str, frozenset[str]]  # node -> output ports someone in the plan consumes
    formats: dict[PortRef, str]  # texture outputs -> allocated format
    reasons: dict[str, list[str]] = field(default_factory=dict)  # node -> requested outputs that need it
    aliases: dict[PortRef, PortRef] = field(default_factory=dict)  # pass-through output -> its source
    # node -> connected inputs that its run for the needed outputs does not read (`unread_inputs`)
    unread: dict[str, frozenset[str]] = field(default_factory=dict)

    def read_connections(self, nid: str) -> dict[str, PortRef]:
        """The connections of `nid` that its run reads: input port -> source (as connected)."""
        skip = self.unread.get(nid, frozenset())
        return {p: ref for p, ref in self.pipeline.connections[nid].items() if p not in skip}


def _aliases(pipe: Pipeline) -> dict[PortRef, PortRef]:
    """Pass-through outputs resolved to the output that really holds the value (chains followed)."""
    direct: dict[PortRef, PortRef] = {}
    for nid, node in pipe.nodes.items():
        for out_port, in_port in node.passthrough(set(pipe.connections[nid])).items():
            direct[(nid, out_port)] = pipe.connections[nid][in_port]
    resolved = {}
    for ref in direct:
        src = direct[ref]
        while src in direct:
            src = direct[src]
        resolved[ref] = src
    return resolved


def plan(pipe: Pipeline, requested: list[PortRef] | None = None) -> Plan:
    req = list(requested) if requested else list(dict.fromkeys(pipe.outputs.values()))
    aliases = _aliases(pipe)
    import networkx as nx

    g = pipe.graph()
    keep: set[str] = set()
    reasons: dict[str, list[str]] = {}
    out_names = {ref: name for name, ref in pipe.outputs.items()}
    for nid, port in req:
        label = out_names.get((nid, port), f"{nid}.{port}")
        for a in nx.ancestors(g, nid) | {nid}:
            keep.add(a)
            reasons.setdefault(a, []).append(label)
    order = [n for n in nx.lexicographical_topological_sort(g) if n in keep]
    # Consumers before producers: a node runs when one of its outputs that is not a pass-through is
    # needed, and only a running node needs its inputs. Pass-throughs are read at their source.
    needed: dict[str, set[str]] = {n: set() for n in order}
    consumers: dict[PortRef, list[str | None]] = {}
    for ref in req:
        src = aliases.get(ref, ref)
        needed[src[0]].add(src[1])
        consumers.setdefault(src, []).append(None)  # None: a requested output, full precision
    unread: dict[str, frozenset[str]] = {}
    for nid in reversed(order):
        if not needed[nid]:
            continue
        node = pipe.nodes[nid]
        sources = {}
        for in_port, ref in pipe.connections[nid].items():
            src = aliases.get(ref, ref)
            sources[in_port] = (pipe.nodes[src[0]].type_name, src[0], src[1])
        skip = frozenset(node.unread_inputs(frozenset(needed[nid]), sources)) & set(pipe.connections[nid])
        if skip:
            unread[nid] = skip
        for in_port, ref in pipe.connections[nid].items():
            if in_port in unread.get(nid, ()):
                continue
            src = aliases.get(ref, ref)
            needed[src[0]].add(src[1])
            consumers.setdefault(src, []).append(pipe.nodes[nid].inputs[in_port].type.fmt)
    formats: dict[PortRef, str] = {}
    for (nid, port), wants in consumers.items():
        declared = pipe.nodes[nid].outputs[port].type
        if not declared.is_texture or declared.fmt is None:
            continue
        rank = max(types.precision(declared.fmt) if w is None else types.precision(w) for w in wants)
        formats[(nid, port)] = types.with_precision(declared.fmt, min(rank, types.precision(declared.fmt)))
    return Plan(pipe, req, order, {n: frozenset(p) for n, p in needed.items()}, formats, reasons, aliases, unread)
