"""The gallery: `gallery/gallery.yaml` lists entries (a pipeline, a scene, overrides, optional frames or a
wedge); `sketchgraph gallery build` renders them, `sketchgraph gallery verify` renders them again and
compares with `gallery/manifest.json`.

What is committed and what is not:
- committed: gallery.yaml, manifest.json (the contract: a SHA-256 per image, pipeline and scene
  hashes, params, seeds, package versions and the GL renderer), images/ (every image the manifest
  lists: outputs, frames, wedge cells and the contact sheets; the references a build on another
  renderer is compared with), index.html and timings.json (measurements, kept out of the manifest so
  that the manifest of a build is always the same bytes);
- ignored (gallery/out/): verify's rebuilds and difference images, `--inspect` dumps, build history.

A build is incremental: an entry whose build key (every planned node's content key for every frame and
wedge cell, the renderer, the visualisation version) and files match the manifest is up to date. The
node cache makes re-rendering an entry cheap as well.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import re
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ...errors import SketchgraphError
from ...executor import Executor
from ...node import digest
from ...pipeline import Pipeline
from .. import viz
from .. import wedge as wedgemod

FORMAT = 1
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_\-]*$")
DEFAULT_TOLERANCE = {"per_pixel": 0.1, "outliers": 0.005, "mean": 0.01}
VERSIONED = ("numpy", "moderngl", "glcontext", "OpenImageIO", "pydantic", "PyYAML", "libigl", "networkx", "scipy")
REPO = Path(__file__).resolve().parents[3]  # the checkout this module runs from (installed: not a repository)
SHARED = REPO.parent / "shared"


# -- the gallery file ------------------------------------------------------------------------------------
@dataclass
class Entry:
    name: str
    pipeline: Path  # absolute
    pipeline_rel: str  # as the manifest records it: relative to the gallery folder, '/' separated
    scene: str | None = None  # loader spec (builtin:NAME or an absolute path); None: the pipeline's own
    scene_rel: str | None = None
    overrides: list[str] = field(default_factory=list)
    size: tuple[int, int] | None = None
    frames: list[int] | None = None
    wedge: list[wedgemod.Axis] | None = None
    outputs: list[str] | None = None
    doc: str = ""
    auto: bool = False  # made for a pipeline that no entry names
    shared: bool = False  # uses ../shared (marked in gallery.yaml, or found from the scene's files)
    spec: dict[str, Any] = field(default_factory=dict)

    def scene_files(self) -> list[Path]:
        from ..watch import scene_files

        if self.scene is not None:
            return scene_files(self.scene, Path.cwd())
        try:
            data = yaml.safe_load(self.pipeline.read_text())
        except (OSError, yaml.YAMLError):
            return []
        spec = data.get("scene", "builtin:cloister") if isinstance(data, dict) else "builtin:cloister"
        return scene_files(str(spec), self.pipeline.parent)

    def uses_shared(self) -> bool:
        return self.shared or any(_inside(p, SHARED) for p in self.scene_files())

    def missing_shared(self) -> list[Path]:
        """Scene files from ../shared that are absent here (also for a `shared: true` entry whose files are
        elsewhere, as when the gallery file is used with an installed package)."""
        return [p for p in self.scene_files() if (self.shared or _inside(p, SHARED)) and not p.exists()]


def _inside(path: Path, folder: Path) -> bool:
    try:
        Path(os.path.normpath(path.absolute())).relative_to(os.path.normpath(folder.absolute()))
    except ValueError:
        return False
    return True


@dataclass
class Gallery:
    file: Path
    root: Path
    entries: list[Entry]
    tolerance: dict[str, float]
    cell: int = 160

    @property
    def out(self) -> Path:
        return self.root / "out"

    @property
    def manifest_path(self) -> Path:
        return self.root / "manifest.json"

    def entry(self, name: str) -> Entry:
        for e in self.entries:
            if e.name == name:
                return e
        raise SketchgraphError(f"{self.file}: no entry '{name}'; entries: {', '.join(e.name for e in self.entries)}")


def _rel(path: Path, root: Path) -> str:
    return Path(os.path.relpath(path.absolute(), root.absolute())).as_posix()


def _frames(value: Any, where: str) -> list[int] | None:
    if value is None:
        return None
    if isinstance(value, int):
        return [value]
    if isinstance(value, str):
        from ...render import parse_frames

        return parse_frames(value)
    if isinstance(value, list) and value and all(isinstance(v, int) for v in value):
        return list(value)
    raise SketchgraphError(f"{where}: frames: expected N, 'START:END[:STEP]' or a list of frame numbers")


def _overrides(value: Any, where: str) -> list[str]:
    if value is None:
        return []
    if isinstance(value, dict):
        return [f"{k}={json.dumps(v)}" for k, v in value.items()]
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return list(value)
    raise SketchgraphError(f"{where}: set: expected {{NODE.PARAM: VALUE}} or a list of NODE.PARAM=VALUE")


_ENTRY_KEYS = {"name", "pipeline", "scene", "set", "size", "frames", "wedge", "outputs", "doc", "shared"}


def load(path: str | Path) -> Gallery:
    """Read gallery.yaml: its entries, plus a default entry (the pipeline as it is) for every pipeline
    matched by `pipelines:` (a glob relative to the file), named after the file, unless an entry has
    that name already."""
    file = Path(path)
    if not file.exists():
        raise SketchgraphError(f"gallery file not found: {file}; the gallery lives in the repository "
                               "(gallery/gallery.yaml): run from the repository's root or pass --gallery FILE")
    try:
        data = yaml.safe_load(file.read_text()) or {}
    except yaml.YAMLError as exc:
        raise SketchgraphError(f"{file}: not valid YAML: {str(exc).splitlines()[0]}") from None
    if not isinstance(data, dict):
        raise SketchgraphError(f"{file}: expected a mapping with 'entries'")
    unknown = set(data) - {"pipelines", "entries", "tolerance", "cell", "doc"}
    if unknown:
        raise SketchgraphError(f"{file}: unknown keys {sorted(unknown)}; known: cell, doc, entries, pipelines, "
                               "tolerance")
    root = file.parent
    tolerance = {**DEFAULT_TOLERANCE, **(data.get("tolerance") or {})}
    entries: list[Entry] = []
    for i, raw in enumerate(data.get("entries") or []):
        where = f"{file}: entries[{i}]"
        if not isinstance(raw, dict) or "name" not in raw or "pipeline" not in raw:
            raise SketchgraphError(f"{where}: expected a mapping with at least name and pipeline")
        bad = set(raw) - _ENTRY_KEYS
        if bad:
            raise SketchgraphError(f"{where} ({raw['name']}): unknown keys {sorted(bad)}; known: "
                                   + ", ".join(sorted(_ENTRY_KEYS)))
        entries.append(_entry(raw, root, where))
    names = {e.name for e in entries}
    pipelines_glob = data.get("pipelines")
    if pipelines_glob:
        for p in sorted(root.glob(pipelines_glob)):
            if p.stem in names:
                continue
            entries.append(_entry({"name": p.stem, "pipeline": _rel(p, root)}, root, f"{file}: {p.name}", auto=True))
            names.add(p.stem)
    seen: set[str] = set()
    for e in entries:
        if e.name in seen:
            raise SketchgraphError(f"{file}: two entries are named '{e.name}'")
        seen.add(e.name)
    return Gallery(file, root, entries, tolerance, int(data.get("cell", 160)))


def _entry(raw: dict[str, Any], root: Path, where: str, auto: bool = False) -> Entry:
    name = str(raw["name"])
    if not _NAME.match(name):
        raise SketchgraphError(f"{where}: name '{name}': letters, digits, '_' and '-' only")
    pipeline = (root / str(raw["pipeline"])).absolute()
    pipeline_rel = _rel(pipeline, root)
    if not pipeline.exists():  # not a file beside the gallery: a shipped pipeline by name, if it is one
        from ...shipped import resolve

        try:
            pipeline, pipeline_rel = resolve(str(raw["pipeline"])).absolute(), str(raw["pipeline"])
        except SketchgraphError as exc:
            raise SketchgraphError(f"{where} ({name}): pipeline: {exc}") from None
    scene = raw.get("scene")
    scene_spec = None
    if scene is not None:
        scene = str(scene)
        scene_spec = scene if scene.startswith("builtin:") else str((root / scene).absolute())
    size = raw.get("size")
    if size is not None and not (isinstance(size, list) and len(size) == 2 and all(isinstance(v, int) for v in size)):
        raise SketchgraphError(f"{where}: size: expected [width, height]")
    outputs = raw.get("outputs")
    if isinstance(outputs, str):
        outputs = [outputs]
    return Entry(name=name, pipeline=pipeline, pipeline_rel=pipeline_rel, scene=scene_spec,
                 scene_rel=scene, overrides=_overrides(raw.get("set"), where),
                 size=tuple(size) if size else None, frames=_frames(raw.get("frames"), where),
                 wedge=wedgemod.axes_from(raw["wedge"]) if raw.get("wedge") else None, outputs=outputs,
                 doc=str(raw.get("doc", "")).strip(), auto=auto, shared=bool(raw.get("shared", False)),
                 spec=dict(raw))


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
        keys.append({"kind": v.kind, "frame": v.frame, "overrides": v.overrides, "keys": ex.keys(v.frame)})
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
        "params": {nid: node.params.model_dump(mode="json") for nid, node in main.nodes.items()},
        "frames": frames,
        "wedge": {a.param: list(a.values) for a in entry.wedge} if entry.wedge else None,
        "outputs": {o: ".".join(main.outputs[o]) for o in outputs},
        "shared": entry.uses_shared(),
        "keys": keys[0]["keys"],  # content keys of the main render's nodes (verify names the ones that changed)
    }
    build_key = digest({"format": FORMAT, "viz": viz.VERSION, "renderer": renderer, "cell": cell,
                        "variants": keys, "record": record})
    return EntryPlan(entry, main, variants, outputs, build_key, record)


# -- rendering -------------------------------------------------------------------------------------------
@dataclass
class EntryResult:
    name: str
    status: str  # rendered | up to date | skipped | failed
    files: dict[str, dict[str, Any]] = field(default_factory=dict)
    ms: float = 0.0
    node_ms: dict[str, float] = field(default_factory=dict)
    node_status: dict[str, str] = field(default_factory=dict)
    note: str = ""


def pixels_sha256(img8: np.ndarray) -> str:
    h = hashlib.sha256(f"{img8.shape}".encode())
    h.update(np.ascontiguousarray(img8).tobytes())
    return h.hexdigest()


def _write(img: np.ndarray, dest: Path, rel: str, what: str, files: dict[str, dict[str, Any]]) -> None:
    path = dest / rel
    viz.write_png(path, img)
    img8 = viz.to_uint8(img)
    files[rel] = {"sha256": file_sha256(path), "pixels_sha256": pixels_sha256(img8),
                  "size": [int(img8.shape[1]), int(img8.shape[0])], "what": what}


def render_entry(ep: EntryPlan, cache: Any, dest: Path, cell: int, inspect_dir: Path | None = None) -> EntryResult:
    """Render every variant of an entry into `dest`/images/<entry>/ and describe the files written."""
    from ..inspect_all import debug_executor, inspect_run, sheet, write_inspection
    from ..watch import adopt_memory

    entry = ep.entry
    res = EntryResult(entry.name, "rendered")
    t0 = time.perf_counter()
    base = f"images/{entry.name}"
    folder = dest / base
    if folder.exists():
        shutil.rmtree(folder)
    many = len(ep.variants) > 1 and any(v.kind == "frame" for v in ep.variants)
    main = ep.variants[0]
    ex = debug_executor(main.pipe, cache)
    prev: Executor = ex
    try:
        insp = inspect_run(ex, main.frame)
        for n in insp.nodes:
            res.node_ms[n.node] = round(n.ms, 3)
            res.node_status[n.node] = n.status
        by_ref = {(p.node, p.port): p for p in insp.ports()}
        frame_cells: list[viz.Cell] = []
        for o in ep.outputs:
            panel = by_ref[main.pipe.outputs[o]].panel
            if panel.image is None:
                continue
            suffix = f"_f{main.frame:04d}" if many else ""
            _write(panel.image, dest, f"{base}/{o}{suffix}.png", f"output {o}, frame {main.frame}", res.files)
            if o == ep.outputs[0]:
                frame_cells.append(viz.Cell(panel.image, [f"frame {main.frame}"]))
        w, h = main.pipe.size
        _write(sheet(insp, cell, f"{entry.name}: intermediates, {w}x{h}, frame {main.frame}"), dest,
               f"{base}/intermediates.png", "contact sheet of intermediates", res.files)
        if inspect_dir is not None:
            write_inspection(insp, inspect_dir / entry.name, exact=True)
        cells: list[wedgemod.Cell] = []
        for v in ep.variants[1:]:
            refs = [v.pipe.outputs[o] for o in ep.outputs]
            vex = Executor(v.pipe, cache, requested=refs)
            adopt_memory(vex, prev, v.frame)
            prev.close()
            prev = vex
            result = vex.run(v.frame)
            for o, ref in zip(ep.outputs, refs, strict=True):
                panel = viz.visualize(result.values[ref], ref[1], v.pipe.nodes[ref[0]].outputs[ref[1]].doc)
                if panel.image is None:
                    continue
                if v.kind == "frame":
                    _write(panel.image, dest, f"{base}/{o}_f{v.frame:04d}.png", f"output {o}, frame {v.frame}",
                           res.files)
                    if o == ep.outputs[0]:
                        frame_cells.append(viz.Cell(panel.image, [f"frame {v.frame}"]))
                elif o == ep.outputs[0]:
                    _write(panel.image, dest, f"{base}/wedge_r{v.row}c{v.col}.png", f"wedge cell {v.label}",
                           res.files)
                    cells.append(wedgemod.Cell(v.row, v.col, v.overrides, v.label, panel.image,
                                               result.computed(), 0.0))
        if len(frame_cells) > 1:
            _write(viz.contact_sheet(frame_cells, cell=cell, columns=min(len(frame_cells), 6),
                                     title=f"{entry.name}: {ep.outputs[0]} by frame"),
                   dest, f"{base}/frames.png", "contact sheet of frames", res.files)
        if cells and entry.wedge:
            _write(wedgemod.sheet(cells, entry.wedge, entry.name, cell), dest, f"{base}/wedge.png",
                   "wedge contact sheet", res.files)
    finally:
        prev.close()
        prev.clear_memory()  # give the textures back to the pool for the next entry
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
    from ... import gl as glmod

    return glmod.get().renderer


def _progress(items: list[Any], disable: bool) -> Any:
    import sys

    from tqdm import tqdm

    return tqdm(items, disable=disable, unit="entry", file=sys.stderr, leave=False, dynamic_ncols=True)


def build(gallery: Gallery, cache: Any, *, only: list[str] | None = None, force: bool = False,
          inspect: bool = False, echo: Callable[[str], None] = print, progress: bool = True,
          cold: bool = False) -> BuildReport:
    """Render every entry that is not up to date (every entry with `force`); write manifest.json,
    timings.json and index.html. `cold` says the cache is fresh and empty (for the build history)."""
    t0 = time.perf_counter()
    renderer = _renderer()
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
            else:
                res = render_entry(ep, cache, gallery.root, gallery.cell,
                                   gallery.out / "inspect" if inspect else None)
                records[entry.name] = {**ep.record, "build_key": ep.build_key, "files": res.files}
        except Exception as exc:  # noqa: BLE001 - one broken entry must not stop the others
            if not isinstance(exc, SketchgraphError):
                exc = SketchgraphError(f"{type(exc).__name__}: {exc}")
            res = EntryResult(entry.name, "failed", note=str(exc))
            failed.append(entry.name)
            if entry.name in old.get("entries", {}):
                records[entry.name] = old["entries"][entry.name]
        res.ms = (time.perf_counter() - t1) * 1000
        results.append(res)
        _echo_line(echo, bar, res)
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
    gallery.manifest_path.write_text(manifest_text(manifest))
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
    path.write_text(json.dumps(timings, indent=1, sort_keys=True) + "\n")


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
    path.write_text(json.dumps(history[-50:], indent=1) + "\n")
    return colds[-1] if colds else None


def format_build(report: BuildReport) -> str:
    lines = [f"{'entry':<28} {'status':<10} {'seconds':>8}"]
    for r in report.results:
        lines.append(f"{r.name:<28} {r.status:<10} {r.ms / 1000:8.2f}" + (f"  {r.note}" if r.note else ""))
    counts: dict[str, int] = {}
    for r in report.results:
        counts[r.status] = counts.get(r.status, 0) + 1
    hits = sum(1 for r in report.results for s in r.node_status.values() if s in ("disk", "memory"))
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


# -- verify ----------------------------------------------------------------------------------------------
@dataclass
class FileCheck:
    file: str
    ok: bool
    how: str  # identical | within tolerance | differs | missing | extra | new
    max_abs: float | None = None
    mean_abs: float | None = None
    outliers: float | None = None


@dataclass
class EntryCheck:
    name: str
    status: str  # ok | differs | skipped | failed
    files: list[FileCheck] = field(default_factory=list)
    note: str = ""


def compare_images(ref: np.ndarray, new: np.ndarray, tol: dict[str, float]) -> tuple[bool, float, float, float]:
    """(within tolerance, max abs, mean abs, fraction of pixels beyond the per-pixel tolerance) of two
    images in [0, 1]; a pixel's difference is its largest channel difference."""
    d = np.abs(ref.astype(np.float64) - new.astype(np.float64)).max(axis=-1)
    max_abs, mean_abs = float(d.max()), float(d.mean())
    outliers = float((d > tol["per_pixel"] + 1e-9).mean())
    return (outliers <= tol["outliers"] and mean_abs <= tol["mean"]), max_abs, mean_abs, outliers


def verify(gallery: Gallery, cache: Any, *, only: list[str] | None = None, echo: Callable[[str], None] = print,
           progress: bool = True, dest: Path | None = None) -> tuple[list[EntryCheck], dict[str, Any]]:
    """Render every entry again (into gallery/out/verify) and compare with the manifest."""
    manifest = read_manifest(gallery.manifest_path)
    if not manifest:
        raise SketchgraphError(f"{gallery.manifest_path}: no manifest; run `sketchgraph gallery build` first")
    renderer = _renderer()
    same_renderer = manifest.get("renderer") == renderer
    tol = {**DEFAULT_TOLERANCE, **manifest.get("tolerance", {})}
    dest = dest or gallery.out / "verify"
    entries = [gallery.entry(n) for n in only] if only else gallery.entries
    checks: list[EntryCheck] = []
    recorded = manifest.get("entries", {})
    bar = _progress(entries, not progress)
    for entry in bar:
        missing = entry.missing_shared()
        if missing:
            needs = ", ".join(_rel(p, Path.cwd()) for p in missing)
            checks.append(EntryCheck(entry.name, "skipped", note=f"needs {needs}"))
            continue
        rec = recorded.get(entry.name)
        if rec is None:
            checks.append(EntryCheck(entry.name, "differs", note="not in the manifest (run gallery build)"))
            continue
        try:
            ep = plan_entry(entry, manifest.get("renderer", renderer), gallery.cell, gallery.root)
            res = render_entry(ep, cache, dest, gallery.cell)
        except Exception as exc:  # noqa: BLE001
            checks.append(EntryCheck(entry.name, "failed", note=f"{type(exc).__name__}: {exc}"))
            continue
        check = EntryCheck(entry.name, "ok")
        if ep.build_key != rec.get("build_key"):
            changed = [k for k in ep.record if k != "keys" and ep.record[k] != rec.get(k)]
            old_keys, new_keys = rec.get("keys", {}), ep.record["keys"]
            nodes = [n for n in new_keys if old_keys.get(n) != new_keys[n]]
            what = changed + ([f"keys of {', '.join(nodes)}"] if nodes else [])
            check.note = "inputs changed since the manifest was built: " + (", ".join(what) or "frames or wedge cells")
        for rel in sorted(set(rec.get("files", {})) | set(res.files)):
            want, got = rec.get("files", {}).get(rel), res.files.get(rel)
            committed = gallery.root / rel
            if want is not None and (not committed.exists() or file_sha256(committed) != want["sha256"]):
                check.files.append(FileCheck(rel, False, "the committed image is missing" if not committed.exists()
                                             else "the committed image does not match the manifest"))
            if want is None:
                check.files.append(FileCheck(rel, False, "new (not in the manifest)"))
            elif got is None:
                check.files.append(FileCheck(rel, False, "missing (the manifest lists it)"))
            elif got["sha256"] == want["sha256"]:
                check.files.append(FileCheck(rel, True, "identical"))
            elif same_renderer:
                fc = FileCheck(rel, False, "differs" if got["pixels_sha256"] != want.get("pixels_sha256")
                               else "differs in file bytes only (same pixels: another PNG encoder?)")
                _measure(fc, gallery.root / rel, dest / rel, tol)
                check.files.append(fc)
            else:
                fc = FileCheck(rel, False, "differs")
                _measure(fc, gallery.root / rel, dest / rel, tol)
                if fc.max_abs is not None:
                    ok = (fc.outliers or 0) <= tol["outliers"] and (fc.mean_abs or 0) <= tol["mean"]
                    fc.ok, fc.how = ok, "within tolerance" if ok else "beyond tolerance"
                check.files.append(fc)
        if not all(f.ok for f in check.files) or check.note:
            check.status = "differs"
        checks.append(check)
    for name in sorted(set(recorded) - {e.name for e in gallery.entries}):
        if not only:
            checks.append(EntryCheck(name, "differs", note="in the manifest but not in gallery.yaml"))
    info = {"renderer": renderer, "manifest_renderer": manifest.get("renderer"), "same_renderer": same_renderer,
            "tolerance": tol, "versions": versions(), "manifest_versions": manifest.get("versions", {})}
    return checks, info


def _measure(fc: FileCheck, ref_path: Path, new_path: Path, tol: dict[str, float]) -> None:
    """Pixel differences against the committed reference image; a difference image beside the rebuild."""
    if not ref_path.exists():
        fc.how += " (no reference image to measure against)"
        return
    ref, new = viz.read_png(ref_path), viz.read_png(new_path)
    if ref.shape != new.shape:
        fc.how += f" (size {ref.shape[1]}x{ref.shape[0]} -> {new.shape[1]}x{new.shape[0]})"
        return
    _, fc.max_abs, fc.mean_abs, fc.outliers = compare_images(ref[..., :3], new[..., :3], tol)
    d = np.abs(ref[..., :3].astype(np.float64) - new[..., :3]).max(axis=-1)
    viz.write_png(new_path.with_name(new_path.stem + ".diff.png"), viz.heat(d, max(fc.max_abs, 1e-6)))


def format_verify(checks: list[EntryCheck], info: dict[str, Any]) -> str:
    lines = []
    if info["same_renderer"]:
        lines.append(f"renderer: {info['renderer']} (as in the manifest): every file must be byte-identical")
    else:
        t = info["tolerance"]
        lines.append(f"renderer: {info['renderer']}; the manifest was built on {info['manifest_renderer']}: "
                     f"images must agree within {t['per_pixel']} per pixel (largest channel, 0..1) on all but "
                     f"{100 * t['outliers']:.2g}% of pixels, mean difference at most {t['mean']}")
    drift = {k: (info["manifest_versions"].get(k), v) for k, v in info["versions"].items()
             if info["manifest_versions"].get(k) != v}
    if drift:
        lines.append("package versions differ from the manifest: "
                     + ", ".join(f"{k} {a} -> {b}" for k, (a, b) in sorted(drift.items())))
    for c in checks:
        n_ok = sum(1 for f in c.files if f.ok)
        head = f"{c.status.upper():<8} {c.name}"
        if c.status == "ok":
            kinds = sorted({f.how for f in c.files})
            lines.append(f"{head}: {n_ok} files {', '.join(kinds)}" + (f"; {c.note}" if c.note else ""))
            continue
        lines.append(head + (f": {c.note}" if c.note else ""))
        for f in c.files:
            if f.ok:
                continue
            m = (f"  max {f.max_abs:.4g}, mean {f.mean_abs:.4g}, {100 * (f.outliers or 0):.3g}% of pixels beyond "
                 f"{info['tolerance']['per_pixel']}" if f.max_abs is not None else "")
            lines.append(f"    {f.file}: {f.how}{m}")
    bad = [c.name for c in checks if c.status in ("differs", "failed")]
    skipped = [c.name for c in checks if c.status == "skipped"]
    lines.append(f"{len(checks) - len(bad) - len(skipped)} ok, {len(bad)} differ"
                 + (f" ({', '.join(bad)})" if bad else "") + (f", {len(skipped)} skipped" if skipped else ""))
    return "\n".join(lines)


# -- the page --------------------------------------------------------------------------------------------
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
        outs = [rel for rel, f in present.items() if f["what"].startswith("output")
                and f["what"].endswith(f", frame {first}")]
        sheets = [rel for rel, f in present.items() if "contact sheet" in f["what"]]
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
    path.write_text(text)
    return path


# -- node caches -----------------------------------------------------------------------------------------
def node_cache(gallery: Gallery, no_cache: bool = False, cache_dir: Path | None = None, cold: bool = False) -> Any:
    """The gallery's own node cache (gallery/out/cache unless `cache_dir`), so that gallery builds neither
    depend on nor evict what other runs cached. `cold` empties it first."""
    from ...cache import Cache

    if no_cache:
        if cold:
            raise SketchgraphError("--cold builds fill the node cache; drop --no-cache")
        return None
    root = Path(cache_dir) if cache_dir else gallery.out / "cache"
    if cold:
        if cache_dir and root.exists() and any(p.suffix not in (".exr", ".npz") for p in root.glob("*/*")):
            raise SketchgraphError(f"--cold would empty {root}, which holds files that are not cache entries")
        shutil.rmtree(root, ignore_errors=True)
    return Cache(root)


class TemporaryCache:
    """A fresh, empty node cache for a cold build (removed afterwards)."""

    def __enter__(self) -> Any:
        from ...cache import Cache

        self._dir = tempfile.mkdtemp(prefix="sketchgraph-cold-")
        return Cache(Path(self._dir))

    def __exit__(self, *exc: Any) -> None:
        shutil.rmtree(self._dir, ignore_errors=True)
