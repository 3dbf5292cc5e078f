"""`sketchgraph gallery verify`: render every entry again and compare with `gallery/manifest.json` (bit for
bit on the manifest's renderer, within a tolerance on another)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import SketchgraphError
from .. import viz
from .build import _progress, _renderer, file_sha256, plan_entry, read_manifest, render_entry, versions
from .model import DEFAULT_TOLERANCE, Gallery, _rel


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
            check.note = "inputs changed since the manifest was built: " + (", ".join(what) or "frames, wedge cells or "
                                                                             "the visualisation and PNG versions")
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
