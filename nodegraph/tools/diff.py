"""`sketchgraph diff`: which nodes' keys differ between two pipelines (or one pipeline with two sets of
overrides) and why, and for every output that differs the max and mean absolute difference and a
difference image.

Why a key differs is found by comparing the parts `Node.key()` digests (type, code version, GLSL,
params, input keys, context values, extras) node by node; a part list that does not reproduce the
node's key is reported as such rather than guessed at.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..fsio import atomic_write_text
from ..node import HashContext, Node, digest
from ..pipeline import Pipeline
from ..plan import plan
from . import viz


@dataclass
class NodeDiff:
    node: str
    status: str  # same | changed | only_a | only_b
    reasons: list[str] = field(default_factory=list)
    key_a: str = ""
    key_b: str = ""


@dataclass
class PortDiff:
    node: str
    port: str
    max_abs: float | None = None
    mean_abs: float | None = None
    differing: float | None = None  # fraction of pixels (or elements) that differ at all
    nan_mismatch: int = 0
    note: str = ""
    image: str | None = None
    panels: tuple[Any, Any, Any] | None = field(default=None, repr=False)  # display images A, B, |A-B|

    def as_dict(self) -> dict[str, Any]:
        return {"node": self.node, "port": self.port, "max_abs": self.max_abs, "mean_abs": self.mean_abs,
                "differing_fraction": self.differing, "nan_mismatch": self.nan_mismatch, "note": self.note,
                "image": self.image}


# -- keys ------------------------------------------------------------------------------------------------
def key_parts(node: Node, hctx: HashContext, input_keys: dict[str, str]) -> dict[str, Any]:
    """The parts `Node.key()` digests, in the same shape (so `digest(parts)` is the key)."""
    return node.key_parts(hctx, input_keys)


def node_keys(pipe: Pipeline, frame: int = 0) -> tuple[dict[str, str], dict[str, dict[str, Any]]]:
    """Keys and key parts of every planned node."""
    hctx = HashContext(pipe.size, frame, pipe.seed, pipe.scene, pipe.reference_size)
    keys: dict[str, str] = {}
    parts: dict[str, dict[str, Any]] = {}
    for nid in plan(pipe).order:
        node = pipe.nodes[nid]
        ins = {p: f"{keys[s]}.{sp}" for p, (s, sp) in sorted(pipe.connections[nid].items())}
        parts[nid] = key_parts(node, hctx, ins)
        keys[nid] = node.key(hctx, ins)
    return keys, parts


def _short(value: Any, limit: int = 60) -> str:
    text = json.dumps(value, sort_keys=True, default=str) if not isinstance(value, str) else value
    return text if len(text) <= limit else text[:limit - 1] + "…"


def compare_keys(a: Pipeline, b: Pipeline, frame: int = 0) -> list[NodeDiff]:
    """Per node (A's topological order, then B's extra nodes): same or not, and why."""
    keys_a, parts_a = node_keys(a, frame)
    keys_b, parts_b = node_keys(b, frame)
    out: list[NodeDiff] = []
    for nid in list(keys_a) + [n for n in keys_b if n not in keys_a]:
        if nid not in keys_b:
            out.append(NodeDiff(nid, "only_a", ["only in A" + (" (in B but not needed by its outputs)"
                                                               if nid in b.nodes else "")], key_a=keys_a[nid]))
            continue
        if nid not in keys_a:
            out.append(NodeDiff(nid, "only_b", ["only in B" + (" (in A but not needed by its outputs)"
                                                               if nid in a.nodes else "")], key_b=keys_b[nid]))
            continue
        ka, kb = keys_a[nid], keys_b[nid]
        if ka == kb:
            out.append(NodeDiff(nid, "same", key_a=ka, key_b=kb))
            continue
        out.append(NodeDiff(nid, "changed", _reasons(a, b, nid, parts_a[nid], parts_b[nid], ka, kb), ka, kb))
    return out


def _reasons(a: Pipeline, b: Pipeline, nid: str, pa: dict[str, Any], pb: dict[str, Any], ka: str,
             kb: str) -> list[str]:
    reasons: list[str] = []
    if digest(pa) != ka or digest(pb) != kb:
        return ["key differs (the node's key covers more than diff knows how to explain)"]
    if pa["type"] != pb["type"]:
        reasons.append(f"type {pa['type']} → {pb['type']}")
    if pa["version"] != pb["version"]:
        reasons.append(f"code version {pa['version']} → {pb['version']}")
    if pa["glsl"] != pb["glsl"]:
        reasons.append("GLSL source changed")
    da, db = (p if isinstance(p, dict) else p.model_dump(mode="json") for p in (pa["params"], pb["params"]))
    for name in sorted(set(da) | set(db)):
        if da.get(name) != db.get(name):
            reasons.append(f"param {name}: {_short(da.get(name))} → {_short(db.get(name))}")
    conn_a, conn_b = a.connections.get(nid, {}), b.connections.get(nid, {})
    for port in sorted(set(pa["inputs"]) | set(pb["inputs"])):
        sa, sb = conn_a.get(port), conn_b.get(port)
        if sa != sb:
            was, now = ".".join(sa) if sa else "unconnected", ".".join(sb) if sb else "unconnected"
            reasons.append(f"input {port}: {was} → {now}")
        elif pa["inputs"].get(port) != pb["inputs"].get(port):
            reasons.append(f"input {port} ← {'.'.join(sa)} changed")  # type: ignore[arg-type]
    for name in sorted(set(pa["context"]) | set(pb["context"])):
        va, vb = pa["context"].get(name), pb["context"].get(name)
        if va == vb:
            continue
        if name in ("scene", "camera"):
            reasons.append(f"{name} changed ({_short(str(va), 12)} → {_short(str(vb), 12)})")
        elif name == "seed":
            reasons.append(f"seed changed (pipeline seed {a.seed} → {b.seed})")
        else:
            reasons.append(f"{name}: {_short(va)} → {_short(vb)}")
    if _short(pa["extra"], 10**6) != _short(pb["extra"], 10**6):
        reasons.append("node-specific hash input changed (hash_extra)")
    return reasons or ["key differs"]


# -- pixels ----------------------------------------------------------------------------------------------
def _as_array(value: Any) -> np.ndarray | None:
    from ..values import Strokes, Tex, TexArray

    if isinstance(value, (Tex, TexArray)):
        return value.read()
    if isinstance(value, np.ndarray):
        return value
    if isinstance(value, Strokes):
        from ..output.strokes import rasterize_strokes

        return rasterize_strokes(value)
    return None


def compare_values(node: str, port: str, va: Any, vb: Any, doc: str = "") -> PortDiff:
    from ..values import Arrays

    if isinstance(va, Arrays) and isinstance(vb, Arrays):
        worst, total, count = 0.0, 0.0, 0
        notes = []
        for name in sorted(set(va.data) | set(vb.data)):
            x, y = va.data.get(name), vb.data.get(name)
            if x is None or y is None or np.shape(x) != np.shape(y):
                notes.append(f"{name}: shapes differ")
                continue
            d = np.abs(np.asarray(x, np.float64) - np.asarray(y, np.float64))
            d = d[np.isfinite(d)]
            if d.size:
                worst, total, count = max(worst, float(d.max())), total + float(d.sum()), count + d.size
        return PortDiff(node, port, worst, total / count if count else 0.0, note="; ".join(notes))
    a, b = _as_array(va), _as_array(vb)
    if a is None or b is None:
        return PortDiff(node, port, note=f"not comparable as pixels ({type(va).__name__})")
    if a.shape != b.shape:
        return PortDiff(node, port, note=f"shapes differ: {a.shape} vs {b.shape}")
    a64, b64 = a.astype(np.float64), b.astype(np.float64)
    fa, fb = np.isfinite(a64), np.isfinite(b64)
    both = fa & fb
    d = np.where(both, np.abs(a64 - b64), 0.0)
    nan_mismatch = int((fa != fb).sum())
    per_pixel = d.max(axis=-1)
    if per_pixel.ndim == 3:  # a texture array: (L, H, W)
        differing = float((per_pixel > 0).mean())
    else:
        differing = float(((per_pixel > 0) | ~np.all(fa == fb, axis=-1)).mean())
    max_abs = float(d.max()) if d.size else 0.0
    mean_abs = float(d[both].mean()) if both.any() else 0.0
    pd = PortDiff(node, port, max_abs, mean_abs, differing, nan_mismatch)
    if per_pixel.ndim == 2:
        img = viz.heat(per_pixel, max_abs)[::-1]
        img[~np.all(fa == fb, axis=-1)[::-1]] = viz.NONFINITE
        pd.panels = (viz.visualize(va, port, doc).image, viz.visualize(vb, port, doc).image,
                     np.ascontiguousarray(img))
    else:
        strips = [viz.heat(layer, max_abs)[::-1] for layer in per_pixel]
        pd.panels = (viz.visualize(va, port, doc).image, viz.visualize(vb, port, doc).image,
                     np.ascontiguousarray(np.concatenate(strips, axis=1)))
    return pd


@dataclass
class DiffReport:
    nodes: list[NodeDiff]
    ports: list[PortDiff]
    out: Path | None = None

    @property
    def changed(self) -> list[NodeDiff]:
        return [n for n in self.nodes if n.status != "same"]

    def as_dict(self) -> dict[str, Any]:
        return {"nodes": [{"node": n.node, "status": n.status, "reasons": n.reasons, "key_a": n.key_a,
                           "key_b": n.key_b} for n in self.nodes],
                "outputs": [p.as_dict() for p in self.ports]}


def diff(a: Pipeline, b: Pipeline, frame: int = 0, cache: Any = None, out: Path | None = None,
         pixels: bool = True, cell: int = 192) -> DiffReport:
    """Keys first (cheap); then, if anything differs and `pixels`, render both and compare every output
    of every changed node that both have. Difference images go to `out`."""
    from .inspect_all import debug_executor

    nodes = compare_keys(a, b, frame)
    report = DiffReport(nodes, [], out)
    changed = [n.node for n in nodes if n.status == "changed"]
    if not pixels or not changed:
        return report
    values: list[dict[tuple[str, str], Any]] = []
    for pipe in (a, b):
        ex = debug_executor(pipe, cache)
        try:
            result = ex.run(frame)
            # read everything back now: the next run may reuse these textures
            values.append({ref: _snapshot(v) for ref, v in result.values.items() if ref[0] in changed})
        finally:
            ex.close()
            ex.clear_memory()
    va, vb = values
    for nid in changed:
        for port in sorted({p for (n, p) in va if n == nid} & {p for (n, p) in vb if n == nid}):
            doc = b.nodes[nid].outputs[port].doc if port in b.nodes[nid].outputs else ""
            report.ports.append(compare_values(nid, port, va[(nid, port)], vb[(nid, port)], doc))
    if out is not None:
        _write(report, out, cell)
    return report


def _snapshot(value: Any) -> Any:
    from ..values import Tex, TexArray

    if isinstance(value, (Tex, TexArray)):
        return value.read()
    return value


def _write(report: DiffReport, out: Path, cell: int) -> None:
    out.mkdir(parents=True, exist_ok=True)
    cells: list[viz.Cell] = []
    for p in report.ports:
        if p.panels is None or (p.max_abs == 0 and not p.nan_mismatch):
            continue
        img_a, img_b, img_d = p.panels
        name = f"{p.node}.{p.port}.diff.png"
        viz.write_png(out / name, img_d)
        p.image = name
        cells += [viz.Cell(img_a, [f"{p.node}.{p.port}", "A"]), viz.Cell(img_b, ["", "B"]),
                  viz.Cell(img_d, ["|A-B|", f"max {p.max_abs:.3g} mean {p.mean_abs:.3g}"])]
    if cells:
        viz.write_png(out / "diff_sheet.png", viz.contact_sheet(cells, cell=cell, columns=3, title="A | B | |A-B|"))
    atomic_write_text(out / "diff.json", json.dumps(report.as_dict(), indent=1, sort_keys=True) + "\n")


def format_report(report: DiffReport) -> str:
    lines = []
    changed = report.changed
    same = [n.node for n in report.nodes if n.status == "same"]
    lines.append(f"keys: {len(changed)} of {len(report.nodes)} nodes differ")
    width = max((len(n.node) for n in changed), default=0)
    for n in changed:
        lines.append(f"  {n.node:<{width}}  {'; '.join(n.reasons)}")
    if same:
        lines.append(f"  same: {', '.join(same)}")
    if report.ports:
        lines.append("pixels (absolute difference over all channels):")
        width = max(len(f"{p.node}.{p.port}") for p in report.ports)
        for p in report.ports:
            name = f"{p.node}.{p.port}"
            if p.max_abs is None:
                lines.append(f"  {name:<{width}}  {p.note}")
                continue
            if p.max_abs == 0 and not p.nan_mismatch and not p.note:
                lines.append(f"  {name:<{width}}  identical values (the key differs, the output does not)")
                continue
            extra = f"  ({100 * p.differing:.2f}% of pixels differ)" if p.differing is not None else ""
            nan = f"  {p.nan_mismatch} NaN/Inf mismatches" if p.nan_mismatch else ""
            where = f"  {report.out / p.image}" if report.out is not None and p.image else ""
            lines.append(f"  {name:<{width}}  max {p.max_abs:.4g}  mean {p.mean_abs:.4g}{extra}{nan}{where}")
    return "\n".join(lines)
