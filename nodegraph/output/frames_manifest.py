"""A sidecar manifest per output pattern: frame -> the digest of what it was rendered from and the SHA-256 of
the file written, so that `--resume` skips the frames a killed run already finished.

The manifest of `out/f_####.png` is `out/.f_####.png.frames.json`. A frame counts as done only when its
record's digest equals the one planned now (the output node's content key, the port and the file type)
and the file on disk still has the recorded SHA-256; anything else is rendered again. Serial and
distributed runs share this module; writes are atomic (`fsio.atomic_write_text`).
"""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path
from typing import Any

from ..fsio import atomic_write_text

FORMAT = 1


def manifest_path(pattern: str | Path) -> Path:
    p = Path(pattern)
    return p.with_name(f".{p.name}.frames.json")


def frame_digest(key: str, port: str, suffix: str) -> str:
    """What a frame file is made from: the output node's key, its port and the file type."""
    text = json.dumps({"key": key, "port": port, "suffix": suffix.lower()}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def file_sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


class FramesManifest:
    def __init__(self, pattern: str | Path) -> None:
        self.pattern = str(pattern)
        self.path = manifest_path(pattern)
        self.frames: dict[int, dict[str, str]] = {}
        self._dirty = False
        self._saved = 0.0

    @classmethod
    def load(cls, pattern: str | Path) -> FramesManifest:
        """The manifest beside `pattern`; an absent or unreadable one is empty (every frame renders)."""
        m = cls(pattern)
        try:
            data: Any = json.loads(m.path.read_text())
        except (OSError, ValueError):
            return m
        if isinstance(data, dict) and data.get("format") == FORMAT and isinstance(data.get("frames"), dict):
            for k, rec in data["frames"].items():
                if isinstance(rec, dict) and isinstance(rec.get("key"), str) and isinstance(rec.get("sha256"), str):
                    try:
                        m.frames[int(k)] = {"key": rec["key"], "sha256": rec["sha256"]}
                    except ValueError:
                        continue
        return m

    def done(self, frame: int, digest: str, path: str | Path) -> bool:
        rec = self.frames.get(frame)
        if rec is None or rec["key"] != digest:
            return False
        p = Path(path)
        try:
            return p.is_file() and file_sha256(p) == rec["sha256"]
        except OSError:
            return False

    def record(self, frame: int, digest: str, sha256: str) -> None:
        self.frames[int(frame)] = {"key": digest, "sha256": sha256}
        self._dirty = True

    def forget(self, frame: int) -> None:
        if self.frames.pop(int(frame), None) is not None:
            self._dirty = True

    def save(self, every: float = 0.0) -> bool:
        """Write the manifest if it changed and `every` seconds passed since the last write."""
        now = time.monotonic()
        if not self._dirty or (every and now - self._saved < every):
            return False
        body = {"format": FORMAT, "pattern": Path(self.pattern).name,
                "frames": {str(f): self.frames[f] for f in sorted(self.frames)}}
        atomic_write_text(self.path, json.dumps(body, indent=0, sort_keys=True) + "\n")
        self._dirty = False
        self._saved = now
        return True
