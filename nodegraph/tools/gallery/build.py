"""`sketchgraph gallery build`: plan every entry's keys without rendering, render what is out of date, write
the images, manifest.json, timings.json and the page."""

from __future__ import annotations

import hashlib
import json
import platform
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import SketchgraphError
from ...executor import Executor
from ...fsio import atomic_write_text
from ...node import digest
from ...pipeline import Pipeline
from .. import viz
from .. import wedge as wedgemod
from .model import FORMAT, VERSIONED, Entry, EntryResult, Gallery, _rel
from .page import write_index
from .views import Views


# -- planning: keys without rendering --------------------------------------------------------------------
@dataclass
class Variant:
    kind: str  # main | frame | cell
    pipe: Pipeline
    frame: int
    overrides: list[str] = field(default_factory=list)
    label: str = ""
    row: int = 0
    col: int = 0
    keys: dict[str, str] = field(default_factory=dict)  # content key of every node its outputs need


@dataclass
class EntryPlan:
    entry: Entry
    main: Pipeline
    variants: list[Variant]
    outputs: list[str]
    build_key: str
    record: dict[str, Any]  # the manifest record, without files


def _open(entry: Entry, extra: list[str] = (), scene_from: Pipeline | None = None) -> Pipeline:
    from ... import pipeline as pl

    overrides = entry.overrides + list(extra)
    if scene_from is None:
        return pl.load(entry.pipeline, overrides=overrides, size=entry.size, scene=entry.scene)
    pipe = pl.load(entry.pipeline, overrides=overrides, size=entry.size, scene=entry.scene, load_scene=False)
    pipe.scene = scene_from.scene
    return pipe


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def plan_entry(entry: Entry, renderer: str, cell: int, root: Path) -> EntryPlan:
    main = _open(entry)
    outputs = entry.outputs or list(main.outputs)
    for name in outputs:
        if name not in main.outputs:
            raise SketchgraphError(f"entry '{entry.name}': pipeline has no output '{name}'; outputs: "
                                   + ", ".join(main.outputs))
    frames = entry.frames or [0]
    variants = [Variant("main", main, frames[0])]
    variants += [Variant("frame", main, f, label=f"frame {f}") for f in frames[1:]]
    if entry.wedge:
        for r, c, overrides, text in wedgemod.combinations(entry.wedge):
            variants.append(Variant("cell", _open(entry, overrides, main), frames[0], overrides, text, r, c))
    keys = []
    for v in variants:
        ex = Executor(v.pipe, None, requested=[v.pipe.outputs[o] for o in outputs])
        v.keys = ex.keys(v.frame)
        keys.append({"kind": v.kind, "frame": v.frame, "overrides": v.overrides, "keys": v.keys})
    scene_files = [p for p in entry.scene_files() if p.exists()]
    record = {
        "pipeline": entry.pipeline_rel,
        "pipeline_sha256": file_sha256(entry.pipeline),
        "scene": entry.scene_rel or main.scene_spec,
        "scene_sha256": main.scene.content_hash() if main.scene is not None else None,
        "scene_files": {_rel(p, root): file_sha256(p) for p in scene_files},
        "size": list(main.size),
        "seed": main.seed,
        "overrides": entry.overrides,
        "params": {nid: node.recorded_params() for nid, node in main.nodes.items()},
        "frames": frames,
        "wedge": {a.param: list(a.values) for a in entry.wedge} if entry.wedge else None,
        "outputs": {o: ".".join(main.outputs[o]) for o in outputs},
        "shared": entry.uses_shared(),
        "keys": keys[0]["keys"],  # content keys of the main render's nodes (verify names the ones that changed)
    }
    from ..inspect_all import PNG_LEVEL, VIEW_VERSION

    build_key = digest({"format": FORMAT, "viz": viz.VERSION, "view": VIEW_VERSION, "png": f"zlib{PNG_LEVEL}",
                        "renderer": renderer, "cell": cell, "variants": keys, "record": record})
    return EntryPlan(entry, main, variants, outputs, build_key, record)


# -- rendering -------------------------------------------------------------------------------------------
def pixels_sha256(img8: np.ndarray) -> str:
    h = hashlib.sha256(f"{img8.shape}".encode())
    h.update(np.ascontiguousarray(img8).tobytes())
    return h.hexdigest()


def sheet_key(args: dict[str, Any]) -> str:
    """The name of a contact sheet's record: everything `viz.contact_sheet(**args)` draws from (each cell's
    picture by its SHA-256, its label lines, the title, labels and layout; the drawing code's version is in
    the record's name, `views._suffix`)."""
    parts = {k: v for k, v in args.items() if k != "cells"}
    parts["cells"] = [[None if c.image is None else [c.image.dtype.str, pixels_sha256(c.image)], list(c.lines)]
                      for c in args["cells"]]
    return digest({"contact_sheet": parts})


def _sheet(views: Views, args: dict[str, Any], dest: Path, rel: str, what: str,
           files: dict[str, dict[str, Any]]) -> None:
    """Write the contact sheet `viz.contact_sheet(**args)` as `rel`: its PNG bytes from the view cache where the
    same sheet was drawn before (`sheet_key`), otherwise drawn, written and kept there."""
    key = sheet_key(args)
    png = views.png(key, "sheet", None)
    if png is None:
        png = _draw_png(viz.contact_sheet(**args), (dest / rel).parent)
        views.put_png(key, "sheet", None, *png)
    _record(*png, dest, rel, what, files)


def _record(data: bytes, pixels: str, size: list[int], dest: Path, rel: str, what: str,
            files: dict[str, dict[str, Any]]) -> None:
    """Write a picture's PNG bytes (drawn now or kept in the view cache) and describe the file."""
    from ...fsio import atomic_write_bytes

    path = dest / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, data)
    files[rel] = {"sha256": hashlib.sha256(data).hexdigest(), "pixels_sha256": pixels, "size": size, "what": what}


def _draw_png(panel_image: np.ndarray, folder: Path) -> tuple[bytes, str, list[int]]:
    """A full-size picture as the gallery's PNG bytes, with its pixels' SHA-256 and size."""
    from ..inspect_all import write_png

    folder.mkdir(parents=True, exist_ok=True)
    tmp = folder / ".draw.png"
    img8 = write_png(tmp, panel_image)
    data = tmp.read_bytes()
    tmp.unlink()
    return data, pixels_sha256(img8), [int(img8.shape[1]), int(img8.shape[0])]


class _Pictures:
    """The pictures of some ports of one render (one variant): the contact-sheet view of each and the PNG of
    each output, from the view cache where it has them; the rest is rendered (with the node cache) and drawn
    once, and the view cache keeps it."""

    def __init__(self, views: Views, pipe: Pipeline, keys: dict[str, str], formats: dict[Any, str],
                 refs: list[Any], outputs: set[Any], cell: int):
        self.views, self.pipe, self.keys, self.formats = views, pipe, keys, formats
        self.refs, self.outputs, self.cell = refs, outputs, cell
        self.view: dict[Any, Any] = {}
        self.png: dict[Any, tuple[bytes, str, list[int]] | None] = {}
        for ref in refs:
            v = views.view(keys[ref[0]], ref[1], formats.get(ref))
            if v is not None:
                self.view[ref] = v
            if ref in outputs and (v is None or v.panel.image is not None):
                self.png[ref] = views.png(keys[ref[0]], ref[1], formats.get(ref))

    def missing(self) -> list[Any]:
        return [r for r in self.refs if r not in self.view or (r in self.png and self.png[r] is None)]

    def draw(self, ex: Executor, result: Any, folder: Path) -> None:
        from ...executor import describe
        from ..inspect_all import read_once, shown
        from .views import View

        for ref in self.missing():
            value = result.values[ref]
            host = read_once(ex, value)
            doc = self.pipe.nodes[ref[0]].outputs[ref[1]].doc
            key, fmt = self.keys[ref[0]], self.formats.get(ref)
            if ref not in self.view:
                got = result.stats[ref[0]].outputs.get(ref[1]) if ref[0] in result.stats else None
                self.view[ref] = View(shown(value, host, ref[1], doc, self.cell), got or describe(value))
                self.views.put_view(key, ref[1], fmt, self.view[ref])
            if ref in self.outputs and self.png.get(ref) is None:
                full = viz.visualize(host if host is not None else value, ref[1], doc)
                self.png[ref] = _draw_png(full.image, folder) if full.image is not None else None
                if self.png[ref] is not None:
                    self.views.put_png(key, ref[1], fmt, *self.png[ref])


def render_entry(ep: EntryPlan, cache: Any, dest: Path, cell: int, inspect_dir: Path | None = None) -> EntryResult:
    """Render every variant of an entry into `dest`/images/<entry>/ and describe the files written.

    Each buffer is read back (or loaded) once and drawn at the size its contact-sheet cell shows it; outputs are
    drawn at full size too. Pictures of outputs whose node keys the view cache holds (`views`) are not drawn
    again, and where it holds every picture of a variant, nothing is rendered or loaded for it."""
    from ...plan import plan
    from ..inspect_all import all_ports, inspect_run, write_inspection
    from ..watch import adopt_memory
    from .views import View

    entry = ep.entry
    res = EntryResult(entry.name, "rendered")
    t0 = time.perf_counter()
    base = f"images/{entry.name}"
    folder = dest / base
    if folder.exists():
        shutil.rmtree(folder)
    many = len(ep.variants) > 1 and any(v.kind == "frame" for v in ep.variants)
    main = ep.variants[0]
    views = Views(cache if inspect_dir is None else None, cell)
    base_plan = plan(main.pipe)
    formats = dict(base_plan.formats)
    prev: Executor | None = None
    try:
        refs = all_ports(main.pipe)
        out_refs = [main.pipe.outputs[o] for o in ep.outputs]
        if cache is not None:  # the view records live in the renderer's folder of the node cache
            Executor(main.pipe, cache).cache  # noqa: B018 - binds the cache to the GL renderer
        keys = Executor(main.pipe, None, requested=refs, like=base_plan).keys(main.frame)
        pics = _Pictures(views, main.pipe, keys, formats, refs, set(out_refs), cell)
        need = pics.missing()
        passing = {n for n, _ in base_plan.aliases}
        for nid in base_plan.order:
            res.node_status[nid], res.node_ms[nid] = "pass-through" if nid in passing else "view", 0.0
        if inspect_dir is not None:  # every buffer at full size too, with statistics and exact values
            from ..inspect_all import debug_executor

            prev = debug_executor(main.pipe, cache, keep_host=True)
            insp = inspect_run(prev, main.frame, stats=True, full=True, box=cell)
            write_inspection(insp, inspect_dir / entry.name, exact=True)
            for p in insp.ports():
                pics.view[(p.node, p.port)] = View(p.thumb, p.fmt)
                if (p.node, p.port) in pics.png and p.panel.image is not None:
                    pics.png[(p.node, p.port)] = _draw_png(p.panel.image, folder)
            for n in insp.nodes:
                res.node_status[n.node], res.node_ms[n.node] = n.status, round(n.ms, 3)
        elif need:
            prev = Executor(main.pipe, cache, requested=need, like=base_plan, keep_host=True)
            result = prev.run(main.frame)
            pics.draw(prev, result, folder)
            for nid, st in result.stats.items():
                if st.status != "skipped":  # skipped: its pictures came from the view cache
                    res.node_status[nid], res.node_ms[nid] = st.status, round(st.ms, 3)
        frame_cells: list[viz.Cell] = []
        for o, ref in zip(ep.outputs, out_refs, strict=True):
            png = pics.png.get(ref)
            if png is None:
                continue
            suffix = f"_f{main.frame:04d}" if many else ""
            _record(*png, dest, f"{base}/{o}{suffix}.png", f"output {o}, frame {main.frame}", res.files)
            if o == ep.outputs[0]:
                frame_cells.append(viz.Cell(pics.view[ref].panel.image, [f"frame {main.frame}"]))
        w, h = main.pipe.size
        sheet_cells = [viz.Cell(pics.view[r].panel.image, [f"{r[0]}.{r[1]}", f"{pics.view[r].fmt} "
                                                           f"{pics.view[r].panel.kind}"]) for r in refs]
        _sheet(views, {"cells": sheet_cells, "cell": cell,
                       "title": f"{entry.name}: intermediates, {w}x{h}, frame {main.frame}"},
               dest, f"{base}/intermediates.png", "contact sheet of intermediates", res.files)
        cells: list[wedgemod.Cell] = []
        for v in ep.variants[1:]:
            vrefs = [v.pipe.outputs[o] for o in ep.outputs]
            vplan = plan(v.pipe, vrefs)
            vpics = _Pictures(views, v.pipe, v.keys, dict(vplan.formats), vrefs, set(vrefs), cell)
            vneed = vpics.missing()
            computed: list[str] = []
            if vneed:
                vex = Executor(v.pipe, cache, requested=vneed, keep_host=True)
                if prev is not None:
                    adopt_memory(vex, prev, v.frame)
                    prev.close()
                prev = vex
                result = vex.run(v.frame)
                vpics.draw(vex, result, folder)
                computed = result.computed()
            for o, ref in zip(ep.outputs, vrefs, strict=True):
                png = vpics.png.get(ref)
                if png is None:
                    continue
                thumb = vpics.view[ref].panel.image
                if v.kind == "frame":
                    _record(*png, dest, f"{base}/{o}_f{v.frame:04d}.png", f"output {o}, frame {v.frame}", res.files)
                    if o == ep.outputs[0]:
                        frame_cells.append(viz.Cell(thumb, [f"frame {v.frame}"]))
                elif o == ep.outputs[0]:
                    _record(*png, dest, f"{base}/wedge_r{v.row}c{v.col}.png", f"wedge cell {v.label}", res.files)
                    cells.append(wedgemod.Cell(v.row, v.col, v.overrides, v.label, thumb, computed, 0.0))
        if len(frame_cells) > 1:
            _sheet(views, {"cells": frame_cells, "cell": cell, "columns": min(len(frame_cells), 6),
                           "title": f"{entry.name}: {ep.outputs[0]} by frame"},
                   dest, f"{base}/frames.png", "contact sheet of frames", res.files)
        if cells and entry.wedge:
            _sheet(views, wedgemod.sheet_args(cells, entry.wedge, entry.name, cell), dest, f"{base}/wedge.png",
                   "wedge contact sheet", res.files)
    finally:
        if prev is not None:
            prev.close()
            prev.clear_memory()  # give the textures back to the pool for the next entry
        if cache is not None:
            cache.flush()
    res.ms = (time.perf_counter() - t0) * 1000
    return res


# -- build -----------------------------------------------------------------------------------------------
def versions() -> dict[str, str]:
    from ... import __version__

    out = {"sketchgraph": __version__, "python": platform.python_version()}
    for dist in VERSIONED:
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            continue
    return out


def read_manifest(path: Path) -> dict[str, Any]:
    if not path.exists():
        return {}
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise SketchgraphError(f"{path}: unreadable manifest ({exc}); delete it and build again") from None


def manifest_text(manifest: dict[str, Any]) -> str:
    return json.dumps(manifest, indent=1, sort_keys=True, ensure_ascii=False) + "\n"


def _up_to_date(old: dict[str, Any] | None, ep: EntryPlan, root: Path) -> bool:
    if not old or old.get("build_key") != ep.build_key or not old.get("files"):
        return False
    return all((root / rel).exists() and file_sha256(root / rel) == rec.get("sha256")
               for rel, rec in old["files"].items())


@dataclass
class BuildReport:
    results: list[EntryResult]
    total_s: float
    manifest: dict[str, Any]
    kind: str  # cold (fresh, empty node cache; every entry rendered) | warm
    failed: list[str] = field(default_factory=list)
    previous_cold_s: float | None = None


def _renderer() -> str:
    from ...gpu import gl as glmod

    return glmod.get().renderer


def _cluster_renderer(client: Any, cache: Any) -> str:
    """The workers' GL renderer (the manifest has one; a cluster of mixed renderers cannot build it)."""
    from ... import distributed as dist

    dist.ensure_plugin(client, cache.root if cache is not None else False)
    found = set(dist.worker_renderers(client).values())
    if len(found) != 1:
        raise SketchgraphError("gallery build --scheduler: expected workers with one GL renderer, found "
                               + (" and ".join(sorted(found)) if found else "no workers"))
    return found.pop()


def render_entry_task(entry: Entry, renderer: str, cell: int, root: str, inspect_dir: str | None,
                      cache_root: Any) -> dict[str, Any]:
    """On a worker: plan and render one entry into the (shared) gallery folder; the result is small."""
    from ... import distributed as dist

    try:
        state = dist.worker_state()
        if state.renderer != renderer:
            raise SketchgraphError(f"entry '{entry.name}': worker renders with {state.renderer}, the build plans "
                                   f"{renderer}")
        ep = plan_entry(entry, renderer, cell, Path(root))
        res = render_entry(ep, state.cache_for(cache_root), Path(root), cell,
                           Path(inspect_dir) if inspect_dir else None)
    except SketchgraphError as exc:
        return {"error": dist.TaskFailure.of(exc)}
    return {"result": res}


def _submit_entry(client: Any, entry: Entry, renderer: str, gallery: Gallery, cache: Any, inspect: bool) -> Any:
    from ... import distributed as dist

    return client.submit(render_entry_task, entry, renderer, gallery.cell, str(gallery.root),
                         str(gallery.out / "inspect") if inspect else None,
                         str(cache.root) if cache is not None else False, pure=False, retries=dist.RETRIES)


def _entry_result(client: Any, fut: Any) -> EntryResult:
    from ... import distributed as dist

    try:
        res = dist.result(client, fut)  # one line when the cluster has no live worker
    except SketchgraphError:
        raise
    except Exception as exc:  # noqa: BLE001
        raise dist.remote_error(exc) from None
    dist._raise_failure(res)
    return res["result"]


def _progress(items: list[Any], disable: bool) -> Any:
    import sys

    from tqdm import tqdm

    return tqdm(items, disable=disable or not sys.stderr.isatty(), unit="entry", file=sys.stderr, leave=False,
                dynamic_ncols=True)


def build(gallery: Gallery, cache: Any, *, only: list[str] | None = None, force: bool = False,
          inspect: bool = False, echo: Callable[[str], None] = print, progress: bool = True,
          cold: bool = False, scheduler: Any = None) -> BuildReport:
    """Render every entry that is not up to date (every entry with `force`); write manifest.json,
    timings.json and index.html. `cold` says the cache is fresh and empty (for the build history).
    `scheduler`: a `distributed.Client`; entries render as tasks on its workers (one renderer for all),
    which write the images into the gallery folder (shared) and return their records."""
    t0 = time.perf_counter()
    renderer = _renderer() if scheduler is None else _cluster_renderer(scheduler, cache)
    remote: dict[str, tuple[Any, EntryPlan]] = {}
    old = read_manifest(gallery.manifest_path)
    old_entries: dict[str, Any] = old.get("entries", {}) if old.get("renderer") == renderer else {}
    entries = [gallery.entry(n) for n in only] if only else gallery.entries
    results: list[EntryResult] = []
    records: dict[str, Any] = {}
    failed: list[str] = []
    bar = _progress(entries, not progress)
    for entry in bar:
        if hasattr(bar, "set_postfix_str"):
            bar.set_postfix_str(entry.name)
        t1 = time.perf_counter()
        missing = entry.missing_shared()
        if missing:
            res = EntryResult(entry.name, "skipped", note=f"needs {', '.join(_rel(p, Path.cwd()) for p in missing)} "
                                                          "(../shared is absent here); kept its manifest record")
            if entry.name in old.get("entries", {}):
                records[entry.name] = old["entries"][entry.name]
            results.append(res)
            _echo_line(echo, bar, res)
            continue
        try:
            ep = plan_entry(entry, renderer, gallery.cell, gallery.root)
            prev = old_entries.get(entry.name)
            if not force and _up_to_date(prev, ep, gallery.root):
                res = EntryResult(entry.name, "up to date", dict(prev["files"]))
                records[entry.name] = prev
            elif scheduler is not None:  # rendered on the cluster; its result is filled in below
                remote[entry.name] = (_submit_entry(scheduler, entry, renderer, gallery, cache, inspect), ep)
                res = EntryResult(entry.name, "submitted")
            else:
                res = render_entry(ep, cache, gallery.root, gallery.cell,
                                   gallery.out / "inspect" if inspect else None)
                records[entry.name] = {**ep.record, "build_key": ep.build_key, "files": res.files}
        except Exception as exc:  # noqa: BLE001 - one broken entry must not stop the others
            res = _failed(entry.name, exc, old, records, failed)
        res.ms = (time.perf_counter() - t1) * 1000
        results.append(res)
        if res.status != "submitted":
            _echo_line(echo, bar, res)
    for i, res in enumerate(results):
        if res.name not in remote:
            continue
        fut, ep = remote[res.name]
        t1 = time.perf_counter()
        try:
            res = _entry_result(scheduler, fut)
            records[res.name] = {**ep.record, "build_key": ep.build_key, "files": res.files}
        except Exception as exc:  # noqa: BLE001 - one broken entry must not stop the others
            res = _failed(res.name, exc, old, records, failed)
        results[i] = res
        _echo_line(echo, bar, res)
    if remote:
        from ... import distributed as dist

        dist.prune_shared(cache.root if cache is not None else False, {renderer})
    if only:  # a partial build keeps the other entries' records
        for name, rec in old.get("entries", {}).items():
            records.setdefault(name, rec)
    else:  # images of entries that no longer exist
        images = gallery.root / "images"
        known = {e.name for e in gallery.entries}
        for folder in sorted(images.iterdir()) if images.is_dir() else []:
            if folder.is_dir() and folder.name not in known:
                shutil.rmtree(folder)
    manifest = {
        "format": FORMAT,
        "gallery": _rel(gallery.file, gallery.root),
        "renderer": renderer,
        "versions": versions(),
        "tolerance": gallery.tolerance,
        "entries": {k: records[k] for k in sorted(records)},
    }
    atomic_write_text(gallery.manifest_path, manifest_text(manifest))
    total = time.perf_counter() - t0
    kind = "cold" if cold else "warm"
    report = BuildReport(results, total, manifest, kind, failed)
    _write_timings(gallery, results)
    report.previous_cold_s = _history(gallery, report, bool(only))
    write_index(gallery, manifest, results)
    return report


def _echo_line(echo: Callable[[str], None], bar: Any, res: EntryResult) -> None:
    """Live feedback beside the progress bar (the table at the end says it all again)."""
    if hasattr(bar, "write") and not getattr(bar, "disable", True):
        bar.write(f"{res.status:<10} {res.name:<28} {res.ms / 1000:7.2f} s" + (f"  {res.note}" if res.note else ""))


def _write_timings(gallery: Gallery, results: list[EntryResult]) -> None:
    path = gallery.root / "timings.json"
    try:
        timings = json.loads(path.read_text()) if path.exists() else {}
    except json.JSONDecodeError:
        timings = {}
    for r in results:
        if r.status == "rendered":
            timings[r.name] = {"ms": round(r.ms, 1), "nodes_ms": r.node_ms, "nodes": r.node_status}
    known = {e.name for e in gallery.entries}
    timings = {k: v for k, v in sorted(timings.items()) if k in known}
    atomic_write_text(path, json.dumps(timings, indent=1, sort_keys=True) + "\n")


def _history(gallery: Gallery, report: BuildReport, partial: bool) -> float | None:
    """Append this build to out/builds.json; return the total of the last full cold build before it."""
    path = gallery.out / "builds.json"
    try:
        history = json.loads(path.read_text()) if path.exists() else []
    except json.JSONDecodeError:
        history = []
    colds = [h["total_s"] for h in history if h.get("kind") == "cold" and not h.get("partial")]
    history.append({"when": time.strftime("%Y-%m-%dT%H:%M:%S"), "kind": report.kind, "partial": partial,
                    "total_s": round(report.total_s, 3),
                    "entries": {r.name: {"status": r.status, "s": round(r.ms / 1000, 3)} for r in report.results}})
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(history[-50:], indent=1) + "\n")
    return colds[-1] if colds else None


def format_build(report: BuildReport) -> str:
    lines = [f"{'entry':<28} {'status':<10} {'seconds':>8}"]
    for r in report.results:
        lines.append(f"{r.name:<28} {r.status:<10} {r.ms / 1000:8.2f}" + (f"  {r.note}" if r.note else ""))
    counts: dict[str, int] = {}
    for r in report.results:
        counts[r.status] = counts.get(r.status, 0) + 1
    hits = sum(1 for r in report.results for s in r.node_status.values() if s in ("disk", "memory", "view"))
    nodes = sum(1 for r in report.results for s in r.node_status.values() if s != "pass-through")
    lines.append(f"total {report.total_s:.2f} s ({report.kind} build: "
                 + ", ".join(f"{n} {s}" for s, n in counts.items())
                 + (f"; {hits} of {nodes} nodes of rendered entries came from the cache" if nodes else "") + ")")
    if report.kind == "cold":
        lines.append("cold build (empty node cache): the baseline later builds are compared with")
    elif report.previous_cold_s:
        ratio = report.previous_cold_s / max(report.total_s, 1e-9)
        lines.append(f"vs the last cold build ({report.previous_cold_s:.2f} s): {ratio:.1f}x faster")
    if report.failed:
        lines.append(f"failed: {', '.join(report.failed)}")
    return "\n".join(lines)


def _failed(name: str, exc: BaseException, old: dict[str, Any], records: dict[str, Any],
            failed: list[str]) -> EntryResult:
    """A failed entry: one line of why, and its old manifest record kept."""
    if not isinstance(exc, SketchgraphError):
        exc = SketchgraphError(f"{type(exc).__name__}: {exc}")
    failed.append(name)
    if name in old.get("entries", {}):
        records[name] = old["entries"][name]
    return EntryResult(name, "failed", note=str(exc))
