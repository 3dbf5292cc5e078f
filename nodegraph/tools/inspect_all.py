"""`sketchgraph inspect PIPELINE --all -o DIR`: every planned node output as an EXR (exact values) and a
PNG that fits its type, a contact sheet, a JSON summary and an HTML page in topological order.

Intermediates are read with the formats the ordinary run gives them: requesting an intermediate
would otherwise promote it to its declared precision and change what its consumers see.
"""

from __future__ import annotations

import html
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

from ..executor import Executor, RunResult, describe
from ..fsio import atomic_output, atomic_write_text
from ..pipeline import Pipeline, PortRef
from ..plan import plan
from . import viz


@dataclass
class PortView:
    node: str
    port: str
    value: Any
    fmt: str
    panel: viz.Panel  # the picture at full size where asked for, else `thumb`
    stats: list[dict[str, Any]]
    thumb: viz.Panel | None = None  # the picture at the size a contact sheet cell shows it
    host: Any = None  # texture data, read back (or loaded) once: (H, W, C) or (L, H, W, C) float32, GL order

    @property
    def sheet_panel(self) -> viz.Panel:
        return self.thumb if self.thumb is not None else self.panel


@dataclass
class NodeView:
    node: str
    type: str
    status: str
    ms: float
    key: str
    inputs: dict[str, str]
    params: dict[str, Any]
    ports: list[PortView] = field(default_factory=list)


@dataclass
class Inspection:
    pipeline: Pipeline
    frame: int
    nodes: list[NodeView]
    generation: dict[str, int]
    not_planned: list[str]
    outputs: dict[str, PortRef]

    @property
    def total_ms(self) -> float:
        return sum(n.ms for n in self.nodes)

    def ports(self) -> list[PortView]:
        return [p for n in self.nodes for p in n.ports]


def all_ports(pipe: Pipeline) -> list[PortRef]:
    """Every output port the ordinary run of the pipeline's outputs produces or reads, in topological
    order: the ports nodes compute, and pass-through outputs that a node or a pipeline output reads."""
    base = plan(pipe)
    used = set(base.requested)
    for nid in base.order:
        if base.needed[nid]:  # a node that runs reads every input it has connected
            used.update(pipe.connections[nid].values())
    return [(nid, port) for nid in base.order for port in pipe.nodes[nid].outputs
            if port in base.needed[nid] or (nid, port) in used]


def debug_executor(pipe: Pipeline, cache: Any, mode: str = "single", gl: Any = None,
                   keep_host: bool = False) -> Executor:
    """An executor that keeps every planned output, each in the format the ordinary run allocates."""
    base = plan(pipe)
    ex = Executor(pipe, cache, mode=mode, requested=all_ports(pipe), gl=gl, like=base, keep_host=keep_host)
    assert ex.plan.order == base.order, "requesting intermediates must not change the plan"
    return ex


def inspect_run(ex: Executor, frame: int = 0, result: RunResult | None = None, stats: bool = True,
                full: bool | set[PortRef] = True, box: int = 192) -> Inspection:
    """Run (unless given the result) and describe every planned output: each texture is read back once (or
    taken from the host copy it was loaded from, `Executor(keep_host=True)`), drawn at the size a `box` contact
    sheet cell shows it (`shown`), and at full size where `full` says so (True: every port; a set: those
    ports). `stats`: with per-channel statistics (the gallery's sheets do not show them)."""
    result = result if result is not None else ex.run(frame)
    pipe = ex.pipeline
    g = pipe.graph().subgraph(ex.plan.order)
    generation = {nid: i for i, gen in enumerate(nx.topological_generations(g)) for nid in gen}
    params = pipe_params(pipe)
    nodes = []
    for nid in ex.plan.order:
        st = result.stats[nid]
        view = NodeView(nid, st.type, st.status, st.ms, st.key,
                        {p: f"{s}.{sp}" for p, (s, sp) in sorted(pipe.connections[nid].items())}, params.get(nid, {}))
        for port in sorted(p for n, p in ex.plan.requested if n == nid):
            value = result.values.get((nid, port))
            if value is None:
                continue
            doc = pipe.nodes[nid].outputs[port].doc
            host = read_once(ex, value)
            thumb = shown(value, host, port, doc, box)
            whole = full is True or (full is not False and (nid, port) in full)
            panel = viz.visualize(host if host is not None else value, port, doc) if whole else thumb
            view.ports.append(PortView(nid, port, value, st.outputs.get(port) or describe(value), panel,
                                       value_stats(value, host) if stats else [], thumb, host))
        nodes.append(view)
    return Inspection(pipe, frame, nodes, generation, [n for n in pipe.nodes if n not in ex.plan.order],
                      dict(pipe.outputs))


def pipe_params(pipe: Pipeline) -> dict[str, dict[str, Any]]:
    return {nid: node.params.model_dump(mode="json") for nid, node in pipe.nodes.items()}


def read_once(ex: Executor, value: Any) -> Any:
    """A texture's data as `read()` gives it: the executor's host copy where it loaded the value from the disk
    cache, else one read-back. None for values that are not textures."""
    from ..values import Tex, TexArray

    if not isinstance(value, (Tex, TexArray)):
        return None
    host = ex.host_copy(value)
    return host if host is not None else value.read()


def value_stats(value: Any, host: Any = None) -> list[dict[str, Any]]:
    """Per-channel min/max/mean/NaN of textures (`host`: their data, read once) and arrays (named arrays by
    name)."""
    from ..values import Arrays, Strokes, Tex, TexArray

    if isinstance(value, (Tex, TexArray)):
        return [s.as_dict() for s in channel_stats(host if host is not None else value.read())]
    if isinstance(value, Arrays):
        out = []
        for name, arr in value.data.items():
            a = np.asarray(arr)
            if a.dtype.kind not in "fiub" or a.size == 0:
                continue
            flat = a.reshape(len(a), -1) if a.ndim > 1 else a.reshape(-1, 1)
            if flat.shape[1] > 4:  # many columns: one summary over all values
                flat = flat.reshape(-1, 1)
            for s in viz.channel_stats(flat, [f"{name}[{i}]" for i in range(flat.shape[1])] if flat.shape[1] > 1
                                       else [name]):
                out.append(s.as_dict())
        return out
    if isinstance(value, Strokes):
        pts = np.concatenate(value.polylines) if value.polylines else np.zeros((0, 2), np.float32)
        return [s.as_dict() for s in viz.channel_stats(pts, ["x", "y"])]
    return []


def channel_stats(arr: np.ndarray) -> list[viz.ChannelStats]:
    """`viz.channel_stats` of a texture's (..., C) data, the same figures without its float64 copy where every
    value is finite: min and max are exact in float32, the mean is summed in float64."""
    a = np.asarray(arr)
    if a.dtype != np.float32 or not np.isfinite(a).all():
        return viz.channel_stats(a)
    flat = a.reshape(-1, a.shape[-1])
    names = list("RGBA"[:flat.shape[1]]) if flat.shape[1] <= 4 else [str(i) for i in range(flat.shape[1])]
    out = []
    for i in range(flat.shape[1]):
        ch = np.ascontiguousarray(flat[:, i])
        if ch.size == 0:
            out.append(viz.ChannelStats(names[i], float("nan"), float("nan"), float("nan"), 0, 0))
            continue
        out.append(viz.ChannelStats(names[i], float(ch.min()), float(ch.max()),
                                    float(ch.sum(dtype=np.float64) / ch.size), 0, 0))
    return out


# -- visualising at the size it is shown ------------------------------------------------------------------
VIEW_VERSION = "1"  # bump when the reduced pictures change (gallery build keys include it)


def _spans(n: int, m: int) -> np.ndarray:
    """Start of each of `m` integer spans tiling `n` pixels (the spans of `viz.resize_area`)."""
    return np.arange(m) * n // m


def box_sum(a: np.ndarray, height: int, width: int) -> np.ndarray:
    """Float64 sums of (H, W, ...) over the spans of a (height, width) grid (shrinking only)."""
    h, w = a.shape[:2]
    s = np.add.reduceat(a, _spans(h, height), axis=0, dtype=np.float64) if height < h else a.astype(np.float64)
    return np.add.reduceat(s, _spans(w, width), axis=1) if width < w else s


def box_area(h: int, w: int, height: int, width: int) -> np.ndarray:
    """Pixels per span of the (height, width) grid over (h, w), float64 (height, width)."""
    ys, xs = _spans(h, height), _spans(w, width)
    return np.outer(np.diff(np.append(ys, h)), np.diff(np.append(xs, w))).astype(np.float64)


def shown_size(h: int, w: int, box: int, kind: str = "") -> tuple[int, int]:
    """(height, width) a buffer is reduced to so that its picture fits `box` (never enlarged): the picture of
    a `vector2` buffer is two of it side by side."""
    wide = 2 * w + max(1, w // 100) if kind == "vector2" else w
    s = min(1.0, box / max(h, wide))
    return max(1, round(h * s)), max(1, round(w * s))


def reduce_and_colour(d: np.ndarray, kind: str, height: int, width: int) -> tuple[np.ndarray, str]:
    """A display-order (H, W, C) buffer drawn as `kind` at (height, width): each shown pixel is the area average
    of the buffer pixels it covers, colourised afterwards. Pixels that are not finite, and for `depth` the
    background (exactly 0 or 1) and for `position` the uncovered pixels, are averaged apart and mixed in by the
    share of the pixel they cover, so a silhouette is neither a false depth nor a false position. Object ids
    are not averaged: each shown pixel takes the id at the centre of its span."""
    h, w, c = d.shape
    if kind == "ids":
        ys = (_spans(h, height) + np.append(_spans(h, height)[1:], h)) // 2
        xs = (_spans(w, width) + np.append(_spans(w, width)[1:], w)) // 2
        return viz._ids(np.ascontiguousarray(d[ys][:, xs]))
    finite = np.isfinite(d)
    all_finite = bool(finite.all())
    ok = None if all_finite else finite.all(axis=2)  # pixels with every channel finite
    fg = ok
    if kind == "depth":
        ch = d[:, :, 0]
        surface = (ch != 0.0) & (ch != 1.0) if all_finite else ok & (ch != 0.0) & (ch != 1.0)
        if surface.any():
            fg = surface
    elif kind == "position" and c == 4:
        fg = d[:, :, 3] > 0 if all_finite else ok & (d[:, :, 3] > 0)
    area = box_area(h, w, height, width)
    if fg is None:  # every pixel counts: the plain area average
        mean = box_sum(d, height, width) / area[:, :, None]
        share = np.ones((height, width))
    else:
        n = box_sum(fg.astype(np.float32), height, width)
        share = n / area
        mean = box_sum(np.where(fg[:, :, None], d, np.float32(0)), height, width) / np.maximum(n, 1)[:, :, None]
    bad = np.zeros((height, width)) if ok is None else 1.0 - box_sum(ok.astype(np.float32), height, width) / area
    m32 = mean.astype(np.float32)
    if kind == "depth":
        vals = m32[:, :, 0][share > 0]
        lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (0.0, 1.0)
        g = (0.12 + 0.88 * (1.0 - viz._normalize(m32[:, :, 0], lo, hi))).astype(np.float64)
        back = np.clip(1.0 - share - bad, 0.0, 1.0)
        img = g[:, :, None] * share[:, :, None] + back[:, :, None] * viz.BACKGROUND
        note = f"depth {lo:.4g}..{hi:.4g}, near bright"
    elif kind == "position":
        img, note = viz._position(np.concatenate([m32[:, :, :3], share[:, :, None].astype(np.float32)], axis=2)
                                  if c == 4 else m32)
        img = img * share[:, :, None]
    else:
        img, note = viz._DRAW[kind](m32)
        if kind == "vector2":  # both halves share the pixels' shares
            gap = img.shape[1] - 2 * width
            share = np.concatenate([share, np.ones((height, gap)), share], axis=1)
            bad = np.concatenate([bad, np.zeros((height, gap)), bad], axis=1)
        img = img * share[:, :, None] if fg is not None else img
    if ok is not None:
        img = img + bad[:, :, None] * viz.NONFINITE
    return np.clip(img, 0.0, 1.0).astype(np.float32), note


def shown_texture(arr: np.ndarray, port: str, doc: str = "", box: int = 192) -> viz.Panel:
    """An (H, W, C) texture in GL order, drawn at the size it is shown in a `box` cell (`reduce_and_colour`)."""
    a = np.asarray(arr, np.float32)
    kind = viz.classify(port, a.shape[2], doc)
    height, width = shown_size(a.shape[0], a.shape[1], box, kind)
    img, note = reduce_and_colour(a[::-1], kind, height, width)
    return viz.Panel(img, kind, note)


def shown_array(arr: np.ndarray, port: str, doc: str = "", box: int = 192, per_row: int = 16,
                gap: int = 2) -> viz.Panel:
    """A texture array (L, H, W, C) as `viz.visualize_array`'s strip of layers, each layer reduced to the size
    its tile is shown at in a `box` cell."""
    n, h, w, c = arr.shape
    cols, rows = min(n, per_row), -(-n // per_row)
    full_w, full_h = cols * (w + gap) - gap, rows * (h + gap) - gap
    s = min(1.0, box / max(full_w, full_h))
    th, tw, g = max(1, round(h * s)), max(1, round(w * s)), max(1, round(gap * s))
    kind = viz.classify(port, c, doc)
    out = np.empty((rows * (th + g) - g, cols * (tw + g) - g, 3), np.float32)
    out[:] = viz.SHEET_BG
    for i, layer in enumerate(np.asarray(arr, np.float32)):
        r, k = divmod(i, per_row)
        img, _ = reduce_and_colour(layer[::-1], "grey" if kind == "vector2" else kind, th, tw)
        out[r * (th + g):r * (th + g) + th, k * (tw + g):k * (tw + g) + tw] = img[:, :tw]
    return viz.Panel(out, "strip", f"{n} layers ({kind})")


def shown(value: Any, host: Any, port: str, doc: str = "", box: int = 192) -> viz.Panel:
    """Any node value as it is shown in a `box` cell of a contact sheet; `host`: its texture data, read once."""
    from ..values import Strokes, Tex, TexArray

    if isinstance(value, Tex):
        return shown_texture(host, port, doc, box)
    if isinstance(value, TexArray):
        return shown_array(host, port, doc, box)
    if isinstance(value, Strokes):  # drawn at full size (points are splatted), then area-averaged
        panel = viz.visualize(value, port, doc)
        return viz.Panel(viz.fit(panel.image, box), panel.kind, panel.note)
    return viz.visualize(value, port, doc)


# -- writing ---------------------------------------------------------------------------------------------
def write_exact(value: Any, base: Path, attrs: dict[str, str], host: Any = None) -> Path | None:
    """The exact value: textures (and arrays, layers side by side) as float EXR, strokes as SVG, arrays as npz.
    `host`: a texture's data, read once."""
    from ..output import imageio
    from ..output.strokes import to_svg
    from ..values import Arrays, Strokes, Tex, TexArray

    if isinstance(value, (Tex, TexArray)) and host is None:
        host = value.read()
    if isinstance(value, Tex):
        return imageio.write(base.with_name(base.name + ".exr"), host, attrs, half=False)
    if isinstance(value, TexArray):
        return imageio.write(base.with_name(base.name + ".exr"), np.concatenate(list(host), axis=1), attrs,
                             half=False)
    if isinstance(value, Strokes):
        p = base.with_name(base.name + ".svg")
        atomic_write_text(p, to_svg(value))
        return p
    if isinstance(value, Arrays):
        p = base.with_name(base.name + ".npz")
        with atomic_output(p) as tmp:
            np.savez(tmp, **value.data)
        return p
    return None


def sheet(insp: Inspection, cell: int = 192, title: str | None = None) -> np.ndarray:
    """One contact sheet of every planned output, in topological order. Labels hold nothing that changes
    between runs (no timings, no cache status), so the sheet of a pipeline is always the same bytes."""
    cells = [viz.Cell(p.sheet_panel.image, [f"{p.node}.{p.port}", f"{p.fmt} {p.sheet_panel.kind}"])
             for p in insp.ports()]
    w, h = insp.pipeline.size
    return viz.contact_sheet(cells, cell=cell, title=title if title is not None else
                             f"{insp.pipeline.name} {w}x{h} frame {insp.frame}")


def write_inspection(insp: Inspection, out: Path, exact: bool = True, cell: int = 192) -> dict[str, Any]:
    """DIR/NODE.PORT.{exr,png}, DIR/contact_sheet.png, DIR/stats.json and DIR/index.html. The PNGs are
    compressed at the frame sequences' fast level (`imageio.PNG_LEVEL`): at the gallery's zlib level 6 they
    took 0.52 s of `inspect pencil --all` on ogre (8 pictures, 800x800 to 800x2404), a sixth of the command."""
    from ..output import imageio

    out.mkdir(parents=True, exist_ok=True)
    images: dict[PortRef, str] = {}
    exacts: dict[PortRef, str] = {}
    for p in insp.ports():
        base = out / f"{p.node}.{p.port}"
        if p.panel.image is not None:
            write_png(base.with_name(base.name + ".png"), p.panel.image, imageio.PNG_LEVEL)
            images[(p.node, p.port)] = base.name + ".png"
        if exact:
            written = write_exact(p.value, base, {"sketchgraph:port": f"{p.node}.{p.port}",
                                                   "sketchgraph:format": p.fmt}, p.host)
            if written is not None:
                exacts[(p.node, p.port)] = written.name
    write_png(out / "contact_sheet.png", sheet(insp, cell), imageio.PNG_LEVEL)
    summary = summarize(insp, images, exacts)
    atomic_write_text(out / "stats.json", json.dumps(summary, indent=1, sort_keys=True) + "\n")
    atomic_write_text(out / "index.html", html_page(insp, images, exacts, "contact_sheet.png"))
    return summary


PNG_LEVEL = 6
"""zlib level of the gallery's pictures (`write_png`): zlib's own level, so a picture's bytes depend on its pixels
and zlib only, as the gallery's manifest needs."""


def write_png(path: Path, img: np.ndarray, level: int = PNG_LEVEL) -> np.ndarray:
    """A display-order float RGB picture in [0, 1] as an 8-bit PNG through `imageio.write_png8` (no row filters:
    several times faster than OIIO's writer, and the same bytes for the same pixels with the same compressor).
    `level`: the gallery's `PNG_LEVEL` unless given (`write_inspection` gives `imageio.PNG_LEVEL`). Returns the
    8-bit pixels written."""
    from ..output import imageio

    img8 = viz.to_uint8(img)
    imageio.write_png8(path, img8, level)
    return img8


def summarize(insp: Inspection, images: dict[PortRef, str] | None = None,
              exacts: dict[PortRef, str] | None = None) -> dict[str, Any]:
    images, exacts = images or {}, exacts or {}
    return {
        "pipeline": insp.pipeline.file, "name": insp.pipeline.name, "frame": insp.frame,
        "size": list(insp.pipeline.size), "total_ms": round(insp.total_ms, 3),
        "nodes": [{
            "node": n.node, "type": n.type, "status": n.status, "ms": round(n.ms, 3), "key": n.key,
            "inputs": n.inputs, "params": n.params,
            "ports": [{"port": p.port, "format": p.fmt, "view": p.panel.kind, "note": p.panel.note,
                       "png": images.get((p.node, p.port)), "exact": exacts.get((p.node, p.port)),
                       "stats": p.stats} for p in n.ports],
        } for n in insp.nodes],
        "not_planned": insp.not_planned,
    }


# -- HTML ------------------------------------------------------------------------------------------------
CSS = """
:root { color-scheme: dark; --bg: #1d1e20; --card: #2a2b2e; --line: #3c3d41; --dim: #9a9a96; --fg: #ecece8;
        --accent: #e8a04a; }
* { box-sizing: border-box; }
body { margin: 0; padding: 16px 20px; background: var(--bg); color: var(--fg);
       font: 13px/1.45 system-ui, -apple-system, "Segoe UI", sans-serif; }
h1 { font-size: 20px; margin: 0 0 4px; } h2 { font-size: 16px; margin: 0 0 6px; }
a { color: var(--accent); }
.dim { color: var(--dim); }
.flow { display: flex; gap: 14px; align-items: flex-start; overflow-x: auto; padding: 8px 0; }
.gen { display: flex; flex-direction: column; gap: 14px; min-width: 300px; }
.gen > .label { color: var(--dim); font-size: 11px; text-transform: uppercase; letter-spacing: .06em; }
.card { background: var(--card); border: 1px solid var(--line); border-radius: 6px; padding: 10px; width: 300px; }
.card:target { outline: 2px solid var(--accent); }
.badge { display: inline-block; padding: 0 6px; border-radius: 9px; font-size: 11px; margin-left: 4px;
         background: #444; }
.badge.computed { background: #7a4b1c; } .badge.disk { background: #255a3a; } .badge.memory { background: #24486e; }
.badge.pass-through { background: #4a3a6e; }
figure { margin: 8px 0 0; }
figure img { display: block; max-width: 100%; max-height: 240px; background: #111; image-rendering: auto; }
figcaption { font-size: 12px; margin-top: 3px; }
table { border-collapse: collapse; font: 11px/1.3 ui-monospace, "SFMono-Regular", Menlo, monospace; margin-top: 4px; }
td, th { padding: 1px 6px 1px 0; text-align: right; } th { color: var(--dim); font-weight: normal; }
td:first-child, th:first-child { text-align: left; }
.bad { color: #ff6b6b; }
ul.inputs { margin: 4px 0; padding-left: 16px; }
pre { background: #151617; border: 1px solid var(--line); padding: 8px; overflow-x: auto; font-size: 12px; }
details > summary { cursor: pointer; color: var(--dim); }
.sheet img { max-width: 100%; }
"""

# Checks that every image loaded and says so on the console (and on <html data-images=...>), so a headless
# browser, or anyone with the developer tools open, sees a broken link at once.
IMAGE_CHECK = """
window.addEventListener('load', function () {
  var bad = [];
  for (var i = 0; i < document.images.length; i++) {
    var im = document.images[i];
    if (!(im.complete && im.naturalWidth > 0)) bad.push(im.getAttribute('src'));
  }
  document.documentElement.setAttribute('data-images', bad.length ? 'broken' : 'ok');
  document.documentElement.setAttribute('data-image-count', String(document.images.length));
  bad.forEach(function (s) { console.error('image failed to load: ' + s); });
});
"""


def page(title: str, body: str) -> str:
    e = html.escape
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f'<link rel="icon" href="data:,">\n<title>{e(title)}</title>\n<style>{CSS}</style>\n'
            f'<script>{IMAGE_CHECK}</script>\n</head>\n<body>\n{body}\n</body>\n</html>\n')


def fmt_num(x: float) -> str:
    if x != x:  # NaN: no finite values
        return "–"
    return f"{x:.4g}"


def stats_table(stats: list[dict[str, Any]]) -> str:
    if not stats:
        return ""
    rows = "".join(
        f"<tr><td>{html.escape(s['channel'])}</td><td>{fmt_num(s['min'])}</td><td>{fmt_num(s['max'])}</td>"
        f"<td>{fmt_num(s['mean'])}</td><td class=\"{'bad' if s['nan'] or s['inf'] else ''}\">{s['nan']}"
        f"{'+' + str(s['inf']) + ' inf' if s['inf'] else ''}</td></tr>" for s in stats)
    return f"<table><tr><th>ch</th><th>min</th><th>max</th><th>mean</th><th>NaN</th></tr>{rows}</table>"


def html_page(insp: Inspection, images: dict[PortRef, str], exacts: dict[PortRef, str], sheet_file: str | None) -> str:
    e = html.escape
    pipe = insp.pipeline
    out_names: dict[PortRef, list[str]] = {}
    for name, ref in insp.outputs.items():
        out_names.setdefault(ref, []).append(name)
    gens: dict[int, list[NodeView]] = {}
    for n in insp.nodes:
        gens.setdefault(insp.generation.get(n.node, 0), []).append(n)
    columns = []
    for g in sorted(gens):
        cards = []
        for n in gens[g]:
            ins = "".join(f'<li>{e(p)} ← <a href="#node-{e(src.split(".")[0])}">{e(src)}</a></li>'
                          for p, src in n.inputs.items())
            figs = []
            for p in n.ports:
                ref = (p.node, p.port)
                img = (f'<a href="{e(images[ref])}"><img src="{e(images[ref])}" alt="{e(p.node)}.{e(p.port)}"></a>'
                       if ref in images else "")
                exact = f' · <a href="{e(exacts[ref])}">exact</a>' if ref in exacts else ""
                named = f' <span class="badge">output {e(", ".join(out_names[ref]))}</span>' if ref in out_names else ""
                figs.append(f'<figure>{img}<figcaption><b>{e(p.port)}</b> · {e(p.fmt)}{named}{exact}<br>'
                            f'<span class="dim">{e(p.panel.kind)}: {e(p.panel.note)}</span></figcaption>'
                            f'{stats_table(p.stats)}</figure>')
            params = json.dumps(n.params, sort_keys=True)
            cards.append(
                f'<div class="card" id="node-{e(n.node)}"><h2>{e(n.node)} <span class="dim">({e(n.type)})</span></h2>'
                f'<div><span class="badge {e(n.status)}">{e(n.status)}</span> {n.ms:.1f} ms '
                f'<span class="dim">key {e(n.key[:12])}</span></div>'
                f'{"<ul class=inputs>" + ins + "</ul>" if ins else ""}'
                f'<details><summary>params</summary><pre>{e(params)}</pre></details>{"".join(figs)}</div>')
        columns.append(f'<div class="gen"><div class="label">step {g + 1}</div>{"".join(cards)}</div>')
    w, h = pipe.size
    skipped = (f'<p class="dim">not needed by the outputs (not run): {e(", ".join(insp.not_planned))}</p>'
               if insp.not_planned else "")
    sheet_html = (f'<details open class="sheet"><summary>contact sheet</summary>'
                  f'<a href="{e(sheet_file)}"><img src="{e(sheet_file)}" alt="contact sheet"></a></details>'
                  if sheet_file else "")
    body = (f'<h1>{e(pipe.name)}</h1><p class="dim">{e(pipe.file)} · {w}×{h} · scene {e(pipe.scene_spec)} · '
            f'seed {pipe.seed} · frame {insp.frame} · {len(insp.nodes)} nodes, {insp.total_ms:.1f} ms in nodes</p>'
            f'<div class="flow">{"".join(columns)}</div>{skipped}{sheet_html}')
    return page(f"{pipe.name}: intermediate buffers", body)


def inspect_all(pipe: Pipeline, out: Path, frame: int, cache: Any, exact: bool = True) -> tuple[Inspection, Path]:
    """What `inspect --all` does: run with every intermediate kept, write it all, return where the page is."""
    ex = debug_executor(pipe, cache, keep_host=True)
    try:
        insp = inspect_run(ex, frame)
        write_inspection(insp, out, exact=exact)
    finally:
        ex.close()
    return insp, out / "index.html"
