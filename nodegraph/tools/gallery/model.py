"""The gallery file: `gallery/gallery.yaml` loaded and checked into a `Gallery` of `Entry`s; what a build
reports per entry; the gallery's own node cache."""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ... import yamlio
from ...errors import SketchgraphError
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
    _files: tuple[Any, list[Path]] | None = field(default=None, repr=False, compare=False)

    def scene_files(self) -> list[Path]:
        """The scene's files (the scene YAML and its meshes); remembered while the pipeline file and the scene
        file stay as they are (a build asks several times per entry)."""
        from ..watch import scene_files

        stamp = (self.scene, self.pipeline, Path.cwd(), _stamp(self.pipeline),
                 _stamp(Path(self.scene)) if self.scene is not None and not self.scene.startswith("builtin:") else None)
        if self._files is not None and self._files[0] == stamp:
            return list(self._files[1])
        if self.scene is not None:
            files = scene_files(self.scene, Path.cwd())
        else:
            try:
                data = yamlio.load(self.pipeline)
            except SketchgraphError:
                return []
            spec = data.get("scene", "builtin:cloister") if isinstance(data, dict) else "builtin:cloister"
            files = scene_files(str(spec), self.pipeline.parent)
        self._files = (stamp, files)
        return list(files)

    def uses_shared(self) -> bool:
        return self.shared or any(_inside(p, SHARED) for p in self.scene_files())

    def missing_shared(self) -> list[Path]:
        """Scene files from ../shared that are absent here (also for a `shared: true` entry whose files are
        elsewhere, as when the gallery file is used with an installed package)."""
        return [p for p in self.scene_files() if (self.shared or _inside(p, SHARED)) and not p.exists()]


def _stamp(path: Path) -> tuple[int, int] | None:
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size


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
        from ...output.write import parse_frames

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
    data = yamlio.plain(yamlio.load(file)) or {}  # a regular file of bounded size (not /dev/zero), nesting limited
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


@dataclass
class EntryResult:
    name: str
    status: str  # rendered | up to date | skipped | failed
    files: dict[str, dict[str, Any]] = field(default_factory=dict)
    ms: float = 0.0
    node_ms: dict[str, float] = field(default_factory=dict)
    node_status: dict[str, str] = field(default_factory=dict)
    note: str = ""


# -- node caches -----------------------------------------------------------------------------------------
def node_cache(gallery: Gallery, no_cache: bool = False, cache_dir: Path | None = None, cold: bool = False) -> Any:
    """The gallery's own node cache (gallery/out/cache unless `cache_dir`), so that gallery builds neither
    depend on nor evict what other runs cached. `cold` empties it first."""
    from ...cache import Cache
    from ...scene import meshstore

    if no_cache:
        if cold:
            raise SketchgraphError("--cold builds fill the node cache; drop --no-cache")
        meshstore.use_cache(None)
        return None
    root = Path(cache_dir) if cache_dir else gallery.out / "cache"
    if cold:
        if cache_dir and root.exists() and not _only_entries(root):
            raise SketchgraphError(f"--cold would empty {root}, which holds files that are not cache entries")
        shutil.rmtree(root, ignore_errors=True)
    cache = Cache(root)
    meshstore.use_cache(cache)  # mesh files parsed by an earlier build (emptied with the rest by --cold)
    return cache


def _only_entries(root: Path) -> bool:
    """Whether a folder holds nothing but node cache entries (`KEY[:2]/ENTRY.exr|npz`, also within the
    renderers' folders `renderer-*/`), so that --cold may empty it."""
    from ...cache import NAMESPACE_PREFIX

    for p in root.iterdir():
        if p.is_dir() and p.name.startswith(NAMESPACE_PREFIX):
            if not _only_entries(p):
                return False
        elif not p.is_dir() or any(f.suffix not in (".exr", ".npz") and not f.name.startswith(".")
                                   for f in p.iterdir()):
            return False
    return True


class TemporaryCache:
    """A fresh, empty node cache for a cold build (removed afterwards)."""

    def __enter__(self) -> Any:
        from ...cache import Cache
        from ...scene import meshstore

        self._dir = tempfile.mkdtemp(prefix="sketchgraph-cold-")
        cache = Cache(Path(self._dir))
        meshstore.use_cache(cache)  # cold for mesh files too
        return cache

    def __exit__(self, *exc: Any) -> None:
        from ...scene import meshstore

        meshstore.use_cache(None)
        shutil.rmtree(self._dir, ignore_errors=True)
