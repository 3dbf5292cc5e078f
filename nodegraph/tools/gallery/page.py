"""The gallery page: `gallery/index.html` from the manifest, the timings and the last build's results."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

from ...fsio import atomic_write_text
from .model import EntryResult, Gallery

# -- the page --------------------------------------------------------------------------------------------
_SHEETS = ("contact sheet of intermediates", "contact sheet of frames", "wedge contact sheet")  # in this order


def write_index(gallery: Gallery, manifest: dict[str, Any], results: list[EntryResult]) -> Path:
    import html

    from ..inspect_all import page

    e = html.escape
    timings_path = gallery.root / "timings.json"
    timings = json.loads(timings_path.read_text()) if timings_path.exists() else {}
    status = {r.name: r for r in results}
    sections = []
    toc = []
    for entry in gallery.entries:
        rec = manifest["entries"].get(entry.name)
        r = status.get(entry.name)
        toc.append(f'<a href="#{e(entry.name)}">{e(entry.name)}</a>')
        note = ""
        if r is not None and r.status in ("skipped", "failed"):
            note = f'<p class="bad">{e(r.status)}: {e(r.note)}</p>'
        if rec is None:
            sections.append(f'<section id="{e(entry.name)}"><h2>{e(entry.name)}</h2>{note}'
                            f'<p class="dim">not built</p></section>')
            continue
        files = rec.get("files", {})
        present = {rel: f for rel, f in files.items() if (gallery.root / rel).exists()}
        first = rec.get("frames", [0])[0]  # other frames are on the frames sheet
        # in an order of their own, not the record's: a record read from manifest.json has its files sorted, one
        # just built has them in the order they were drawn, and the page is the same either way
        outs = sorted(rel for rel, f in present.items() if f["what"].startswith("output")
                      and f["what"].endswith(f", frame {first}"))
        sheets = sorted((rel for rel, f in present.items() if "contact sheet" in f["what"]),
                        key=lambda rel: (_SHEETS.index(present[rel]["what"]) if present[rel]["what"] in _SHEETS
                                         else len(_SHEETS), rel))
        imgs = "".join(f'<figure><a href="{e(rel)}"><img class="out" src="{e(rel)}" alt="{e(rel)}"></a>'
                       f'<figcaption>{e(present[rel]["what"])}</figcaption></figure>' for rel in outs)
        sheet_html = "".join(f'<figure><a href="{e(rel)}"><img class="sheet" src="{e(rel)}" alt="{e(rel)}"></a>'
                             f'<figcaption>{e(present[rel]["what"])}</figcaption></figure>' for rel in sheets)
        t = timings.get(entry.name)
        timing = ""
        if t:
            nodes = ", ".join(f"{k} {v:.0f} ms ({t['nodes'].get(k, '')})" for k, v in t["nodes_ms"].items())
            timing = f'<p><b>render</b> {t["ms"] / 1000:.2f} s <span class="dim">· {e(nodes)}</span></p>'
        hashes = "".join(f"<tr><td>{e(rel)}</td><td>{f['size'][0]}×{f['size'][1]}</td>"
                         f"<td><code>{f['sha256'][:16]}</code></td></tr>" for rel, f in sorted(files.items()))
        params = yaml.safe_dump(rec.get("params", {}), sort_keys=True, default_flow_style=None, width=100)
        entry_yaml = yaml.safe_dump(entry.spec, sort_keys=False, default_flow_style=None, width=100)
        try:
            pipeline_text = entry.pipeline.read_text()
        except OSError:
            pipeline_text = ""
        auto = ' <span class="badge">default entry for the pipeline</span>' if entry.auto else ""
        shared = ' <span class="badge">uses ../shared</span>' if rec.get("shared") else ""
        sections.append(
            f'<section id="{e(entry.name)}"><h2>{e(entry.name)}{auto}{shared}</h2>'
            f'{f"<p>{e(entry.doc)}</p>" if entry.doc else ""}{note}'
            f'<p class="dim"><a href="{e(rec["pipeline"])}">{e(rec["pipeline"])}</a> · scene {e(str(rec["scene"]))}'
            f' · {rec["size"][0]}×{rec["size"][1]} · seed {rec["seed"]}'
            f'{" · frames " + e(str(rec["frames"])) if len(rec.get("frames", [])) > 1 else ""}'
            f'{" · set " + e(" ".join(rec["overrides"])) if rec.get("overrides") else ""}</p>'
            f'<div class="row">{imgs}</div><div class="row">{sheet_html}</div>{timing}'
            f'<details><summary>entry (gallery.yaml)</summary><pre>{e(entry_yaml)}</pre></details>'
            f'<details><summary>pipeline YAML</summary><pre>{e(pipeline_text)}</pre></details>'
            f'<details><summary>params of every node</summary><pre>{e(params)}</pre></details>'
            f'<details><summary>files and SHA-256</summary><table>{hashes}</table></details></section>')
    versions_text = ", ".join(f"{k} {v}" for k, v in manifest.get("versions", {}).items())
    body = (f'<h1>sketchgraph gallery</h1><p class="dim">{len(gallery.entries)} entries · renderer '
            f'{e(manifest.get("renderer", "?"))}<br>{e(versions_text)}<br>rebuild: <code>sketchgraph gallery build'
            f'</code> · check: <code>sketchgraph gallery verify</code> · <a href="manifest.json">manifest.json</a>'
            f'</p><nav>{" · ".join(toc)}</nav>{"".join(sections)}')
    css = ("<style>section { border-top: 1px solid var(--line); padding: 12px 0; } .row { display: flex; "
           "flex-wrap: wrap; gap: 12px; align-items: flex-start; } img.out { width: 360px; max-width: 100%; } "
           "img.sheet { max-width: 100%; max-height: 520px; } nav { margin: 8px 0 12px; } "
           "figure img { max-height: none; }</style>")
    text = page("sketchgraph gallery", body).replace("</head>", css + "\n</head>")
    path = gallery.root / "index.html"
    atomic_write_text(path, text)
    return path
