"""Every file the project writes goes through nodegraph.fsio (temporary file in the same folder, checked,
renamed) or the cache's own atomic writer: no module writes a file in place."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
ALLOWED = {"nodegraph/fsio.py", "nodegraph/cache.py"}  # the two atomic writers themselves
IN_PLACE = re.compile(r"\.write_text\(|\.write_bytes\(|\bopen\([^)]*['\"][wax]b?['\"]")
NEEDS_TEMP = re.compile(r"\b(savefig|imsave|np\.savez|np\.save)\(")


def test_no_module_writes_a_file_in_place() -> None:
    offenders = []
    for p in sorted([*ROOT.glob("nodegraph/**/*.py"), *ROOT.glob("nodes/**/*.py")]):
        rel = p.relative_to(ROOT).as_posix()
        if rel in ALLOWED:
            continue
        lines = p.read_text().splitlines()
        for i, line in enumerate(lines):
            if line.lstrip().startswith("#"):
                continue
            unguarded = NEEDS_TEMP.search(line) and "atomic_output" not in lines[i - 1] and "tmp" not in line
            if IN_PLACE.search(line) or unguarded:
                offenders.append(f"{rel}:{i + 1}: {line.strip()}")
    assert not offenders, "write through nodegraph.fsio (atomic_output / atomic_write_text):\n" + "\n".join(offenders)


def test_a_failed_manifest_write_keeps_the_previous_file(tmp_path: Path, monkeypatch) -> None:
    """The gallery writes its manifest through atomic_write_text: a write that fails midway (here the
    rename is refused) leaves the previous manifest byte for byte and no temporary file behind."""
    import os

    import pytest

    from nodegraph import fsio
    from nodegraph.errors import SketchgraphError

    target = tmp_path / "manifest.json"
    target.write_bytes(b'{"old": true}\n')

    def refuse(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", refuse)
    with pytest.raises(SketchgraphError, match="No space left on device"):
        fsio.atomic_write_text(target, '{"new": true}\n')
    assert target.read_bytes() == b'{"old": true}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["manifest.json"]


def test_clean_stale_temps_removes_only_our_files_whose_writer_is_gone(tmp_path: Path) -> None:
    """`fsio.clean_stale_temps`: a file named as ours (`.NAME.tmp-PID-N.EXT`, `.NAME.partial-PID-N.EXT`) for the
    output asked about goes when its pid is no live process here, or when it is older than STALE_AGE; this
    process's own files, a live process's recent files, other outputs' files, folders and links named as ours,
    and names that only look alike stay."""
    import os
    import subprocess
    import sys

    from nodegraph import fsio

    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    dead, live, me = child.pid, os.getppid(), os.getpid()
    gone = [f".a.png.tmp-{dead}-0.png", f".a.png.partial-{dead}-3.png", f".a.png.tmp-{live}-1.png"]
    stay = [f".a.png.tmp-{me}-0.png", f".a.png.tmp-{live}-0.png", f".b.png.tmp-{dead}-0.png", f"a.png.tmp-{dead}-0.png",
            f".a.png.tmp-{dead}-0.exr", ".a.png.tmp-x-0.png", "a.png"]
    for name in gone + stay:
        (tmp_path / name).write_bytes(b"x")
    old = tmp_path / gone[2]
    os.utime(old, (0, old.stat().st_mtime - fsio.STALE_AGE - 60))
    (tmp_path / f".a.png.tmp-{dead}-9.png").mkdir()
    (tmp_path / f".a.png.tmp-{dead}-8.png").symlink_to(tmp_path / "a.png")
    stay += [f".a.png.tmp-{dead}-9.png", f".a.png.tmp-{dead}-8.png"]
    removed = fsio.clean_stale_temps(tmp_path, "a.png")
    assert sorted(p.name for p in removed) == sorted(gone)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(stay)
    assert fsio.clean_stale_temps(tmp_path / "missing", "a.png") == []
