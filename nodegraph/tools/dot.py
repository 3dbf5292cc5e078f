"""A pipeline as Graphviz DOT text (`sketchgraph graph`): one record per node (inputs | id and type |
outputs), an edge per connection labelled with its port type, an oval per named output.

Every name is escaped for where it lands: quoted IDs and labels escape backslashes, quotes and line
breaks; record fields also escape the characters that structure a record (braces, bars, angle brackets).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..pipeline import Pipeline

_RECORD_SPECIAL = "{}|<>"


def _escape(text: str) -> str:
    """Text inside a quoted DOT string that Graphviz shows as written (escString rules: `\\\\` is a
    backslash, `\\n` a line break)."""
    out = str(text).replace("\\", "\\\\").replace('"', '\\"')
    return out.replace("\r\n", "\\n").replace("\n", "\\n").replace("\r", "\\n")


def quote(text: str) -> str:
    """A quoted DOT ID or label for any text."""
    return f'"{_escape(text)}"'


def field(text: str) -> str:
    """Text for a record field, before the label is quoted: record structure characters escaped too."""
    out = _escape(text)
    for ch in _RECORD_SPECIAL:
        out = out.replace(ch, "\\" + ch)
    return out


def _port(name: str) -> str:
    """A record port name: only letters, digits and '_' survive unescaped everywhere, so map the rest."""
    return "".join(c if c.isalnum() or c == "_" else f"_{ord(c):x}_" for c in str(name))


def to_dot(pipe: Pipeline) -> str:
    lines = [f"digraph {quote(pipe.name)} {{", "  rankdir=LR;", '  node [shape=record, fontname="Helvetica"];']
    for nid, node in pipe.nodes.items():
        ins = "|".join(f"<i_{_port(p)}> {field(p)}" for p in node.inputs)
        outs = "|".join(f"<o_{_port(p)}> {field(p)}" for p in node.outputs)
        middle = f"{field(nid)}\\n({field(node.type_name)})|{{{outs}}}"
        label = f"{{{{{ins}}}|{middle}}}" if ins else f"{{{middle}}}"
        lines.append(f'  {quote(nid)} [label="{label}"];')
    for nid, conns in pipe.connections.items():
        for port, (src, sport) in conns.items():
            ptype = pipe.nodes[src].outputs[sport].type
            lines.append(f"  {quote(src)}:o_{_port(sport)} -> {quote(nid)}:i_{_port(port)} "
                         f"[label={quote(str(ptype))}];")
    for name, (nid, port) in pipe.outputs.items():
        lines.append(f"  {quote('out:' + name)} [shape=oval, label={quote(name)}];")
        lines.append(f"  {quote(nid)}:o_{_port(port)} -> {quote('out:' + name)};")
    lines.append("}")
    return "\n".join(lines)
