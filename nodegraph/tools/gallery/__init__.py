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

Modules: `model` (the gallery file, entries, build results, the gallery's node cache), `build` (planning,
rendering, the manifest), `verify` (rebuild and compare) and `page` (index.html). This package re-exports
what the command line and the tests use.
"""

from __future__ import annotations

from .build import (
    BuildReport,
    EntryPlan,
    Variant,
    build,
    file_sha256,
    format_build,
    manifest_text,
    pixels_sha256,
    plan_entry,
    read_manifest,
    render_entry,
    versions,
)
from .model import (
    DEFAULT_TOLERANCE,
    FORMAT,
    REPO,
    SHARED,
    VERSIONED,
    Entry,
    EntryResult,
    Gallery,
    TemporaryCache,
    _inside,
    load,
    node_cache,
)
from .page import write_index
from .verify import EntryCheck, FileCheck, compare_images, format_verify, verify

__all__ = [
    "DEFAULT_TOLERANCE", "FORMAT", "REPO", "SHARED", "VERSIONED", "BuildReport", "Entry", "EntryCheck", "EntryPlan",
    "EntryResult", "FileCheck", "Gallery", "TemporaryCache", "Variant", "_inside", "build", "compare_images",
    "file_sha256", "format_build", "format_verify", "load", "manifest_text", "node_cache", "pixels_sha256",
    "plan_entry", "read_manifest", "render_entry", "verify", "versions", "write_index",
]
