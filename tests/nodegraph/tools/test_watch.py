"""`run --watch`: the watcher loop, driven directly for a bounded number of polls."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from nodegraph.tools.watch import Watcher, scene_files, watch

ROOT = Path(__file__).resolve().parents[3]


def touch_later(path: Path, text: str | None = None) -> None:
    """Rewrite (or just touch) a file with a modification time surely later than before."""
    if text is not None:
        path.write_text(text)
    st = path.stat()
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))


def drive(watcher: Watcher, edits: dict[int, callable], polls: int) -> list:
    """Run `polls` polls; before poll i (1-based, after the sleep) apply edits[i]."""
    state = {"poll": 1}

    def fake_sleep(_s: float) -> None:
        state["poll"] += 1
        if state["poll"] in edits:
            edits[state["poll"]]()

    lines: list[str] = []
    events = watch(watcher, interval=0.0, max_iterations=polls, echo=lines.append, sleep=fake_sleep)
    assert len(lines) == len(events)
    return events


@pytest.fixture
def nienhaus(tmp_path: Path) -> Path:
    p = tmp_path / "p.yaml"
    shutil.copy(ROOT / "pipelines" / "nienhaus_sketchy.yaml", p)
    return p


def test_only_changed_keys_recompute(gl, nienhaus, tmp_path):
    text = nienhaus.read_text()
    assert "normal_threshold: 0.4" in text
    edits = {
        3: lambda: touch_later(nienhaus, text.replace("normal_threshold: 0.4", "normal_threshold: 0.25")),
        5: lambda: touch_later(nienhaus, text.replace("normal_threshold: 0.4", "normal_threshold: [oops")),
        6: lambda: touch_later(nienhaus, text),
        7: lambda: touch_later(nienhaus),  # touched, same content: keys unchanged, nothing recomputes
    }
    w = Watcher(nienhaus, out=tmp_path / "o.png", size="40x32", cache=None)
    events = drive(w, edits, polls=8)
    assert [e.changed != [] for e in events] == [False, True, True, True, True]
    first, edit, broken, fixed, touched = events
    downstream = {"edges", "sketch", "sprite"}  # of edges.normal_threshold (sprite may be a pass-through)
    assert {"gbuf", "edges", "noise", "sketch"} <= set(first.computed) and first.error is None
    assert {"edges", "sketch"} <= set(edit.computed) <= downstream and edit.reused >= 2
    assert broken.error and "p.yaml" in broken.error and not broken.computed
    # back to 0.4: those outputs were let go after the edit (a watch keeps what its last run used)
    assert {"edges", "sketch"} <= set(fixed.computed) <= downstream
    assert touched.computed == [] and touched.reused >= 1  # the output from memory; nothing above it runs
    assert (tmp_path / "o.png").exists()
    assert "recomputed edges" in edit.describe() and "ms" in edit.describe()


def test_scene_file_changes_are_watched(gl, tmp_path):
    shutil.copy(ROOT / "pipelines" / "sketchy_composite.yaml", tmp_path / "c.yaml")
    (tmp_path / "scenes").mkdir()
    scene = tmp_path / "scenes" / "composite.yaml"
    shutil.copy(ROOT / "pipelines" / "scenes" / "composite.yaml", scene)
    text = scene.read_text()
    assert "color: [0.70, 0.74, 0.66]" in text  # the pillar, not sketchy
    edits = {2: lambda: touch_later(scene, text.replace("color: [0.70, 0.74, 0.66]", "color: [0.9, 0.1, 0.1]"))}
    w = Watcher(tmp_path / "c.yaml", out=tmp_path / "o.png", size="32x32", cache=None)
    events = drive(w, edits, polls=3)
    assert scene in w.files()
    assert len(events) == 2 and events[1].changed == [str(scene)]
    # the scene is hashed as a whole, so every node reading it recomputes; noise does not read it
    assert "noise" not in events[1].computed and "plain" in events[1].computed


def test_scene_files_lists_meshes(tmp_path):
    s = tmp_path / "s.yaml"
    s.write_text("objects:\n  - mesh: m/a.obj\n  - primitive: {type: box}\n")
    assert scene_files("s.yaml", tmp_path) == [s, tmp_path / "m" / "a.obj"]
    assert scene_files("builtin:cloister", tmp_path) == []
