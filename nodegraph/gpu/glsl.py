"""GLSL program loader: stage guards, injected defines, `#include`, `#line`, located errors.

A node's `.glsl` file starts with `#version`. Stages are selected by guards
(`#if defined VERTEX_SHADER` / `FRAGMENT_SHADER` / `COMPUTE_SHADER`); a file with a fragment stage
but no vertex stage gets the engine's full-screen triangle (`shaders/fullscreen.glsl`). After the
injected defines a `#line` directive restores the file's own numbering, and every included file gets
its own source-string number, so a compiler message maps back to `file:line`.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import ShaderError

ENGINE_GLSL = Path(__file__).parent / "shaders"
MAX_INCLUDE_DEPTH = 16
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')
_VERSION = re.compile(r"^\s*#\s*version\b")
# Mesa: "0:12(5): error: ..."; NVIDIA: "0(12) : error C...: ..."; others: "ERROR: 0:12: ..."
_MSG = [re.compile(r"(?P<file>\d+):(?P<line>\d+)\(\d+\):\s*(?P<msg>.*)"),
        re.compile(r"(?P<file>\d+)\((?P<line>\d+)\)\s*:\s*(?P<msg>.*)"),
        re.compile(r"ERROR:\s*(?P<file>\d+):(?P<line>\d+):\s*(?P<msg>.*)")]


@dataclass
class Assembled:
    source: str
    files: list[Path]  # index = GLSL source-string number used in #line


def _resolve(name: str, including: Path) -> Path:
    for base in (including.parent, ENGINE_GLSL):
        cand = (base / name).resolve()
        if cand.is_file():
            return cand
    raise ShaderError(f"{including}: #include \"{name}\" not found (looked beside it and in {ENGINE_GLSL})")


def assemble(path: Path, stage: str, defines: dict[str, Any] | None = None) -> Assembled:
    """Expand `path` for one stage: `#version`, stage + user defines, `#line`, includes (once each)."""
    files: list[Path] = [path]
    seen: set[Path] = {path.resolve()}
    lines = path.read_text().splitlines()
    if not lines or not _VERSION.match(lines[0]):
        raise ShaderError(f"{path}:1: the first line must be a #version directive")
    out = [lines[0], f"#define {stage}"]
    for name, value in sorted((defines or {}).items()):
        out.append(f"#define {name} {_define_value(value)}")
    out.append("#line 2 0")

    def expand(src_lines: list[str], file_no: int, file: Path, depth: int, first_line: int = 1) -> None:
        for lineno, line in enumerate(src_lines, start=first_line):
            m = _INCLUDE.match(line)
            if not m:
                out.append(line)
                continue
            if depth >= MAX_INCLUDE_DEPTH:
                raise ShaderError(f"{file}:{lineno}: #include nested deeper than {MAX_INCLUDE_DEPTH} (a cycle?)")
            inc = _resolve(m.group(1), file)
            if inc in seen:
                out.append(f"// {m.group(1)} already included")
                continue
            seen.add(inc)
            files.append(inc)
            n = len(files) - 1
            out.append(f"#line 1 {n}")
            inc_lines = inc.read_text().splitlines()
            if inc_lines and _VERSION.match(inc_lines[0]):
                raise ShaderError(f"{inc}:1: an included file must not have a #version line")
            expand(inc_lines, n, inc, depth + 1)
            out.append(f"#line {lineno + 1} {file_no}")

    expand(lines[1:], 0, path, 0, first_line=2)
    return Assembled("\n".join(out) + "\n", files)


def _define_value(value: Any) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    return str(value)


def stages_in(path: Path) -> set[str]:
    text = path.read_text()
    return {s for s in ("VERTEX_SHADER", "FRAGMENT_SHADER", "COMPUTE_SHADER", "GEOMETRY_SHADER") if s in text}


def _stamp(path: Path) -> tuple[float, int]:
    st = path.stat()
    return st.st_mtime, st.st_size


_DIGESTS: dict[str, tuple[str, tuple[tuple[Path, tuple[float, int]], ...]]] = {}
_RESOLVED: dict[Path, Path] = {}  # a shader path as nodes name it -> its resolved path (resolving stats every part)


def _digest(p: Path) -> tuple[str, tuple[Path, ...]]:
    """(digest, every file it read): an include file's own text, or a shader's assembled stages."""
    text = p.read_text()
    if not _VERSION.match(text.split("\n", 1)[0]):  # an include file: its text is its source
        return hashlib.sha256(text.encode()).hexdigest(), (p,)
    h = hashlib.sha256()
    files: dict[Path, None] = {p: None}
    # includes are part of the source: hash each stage's assembled text
    for stage in sorted(stages_in(p)) or ["FRAGMENT_SHADER"]:
        asm = assemble(p, stage)
        h.update(asm.source.encode())
        files.update(dict.fromkeys(f.resolve() for f in asm.files))
    return h.hexdigest(), tuple(files)


def source_digest(path: Path) -> str:
    """SHA-256 of a shader with its includes, cached while neither it nor any file it includes changes
    (checked by modification time and size, so editing only an include invalidates it too)."""
    p = _RESOLVED.get(path)
    if p is None:
        if len(_RESOLVED) >= 512:
            _RESOLVED.clear()
        p = _RESOLVED[path] = path.resolve()
    hit = _DIGESTS.get(str(p))
    if hit is not None and all(_stamp(f) == stamp for f, stamp in hit[1]):
        return hit[0]
    digest, files = _digest(p)
    if len(_DIGESTS) >= 512:
        _DIGESTS.clear()
    _DIGESTS[str(p)] = (digest, tuple((f, _stamp(f)) for f in files))
    return digest


def map_errors(log: str, files: list[Path]) -> str:
    """Rewrite compiler messages so they name our files: `file.glsl:12: error: ...`."""
    lines = []
    for raw in log.strip().splitlines():
        for pat in _MSG:
            m = pat.search(raw)
            if m and int(m.group("file")) < len(files):
                lines.append(f"{files[int(m.group('file'))]}:{m.group('line')}: {m.group('msg').strip()}")
                break
        else:
            if raw.strip():
                lines.append(raw.strip())
    return "; ".join(lines) if lines else log.strip()


class ProgramCache:
    """Compiles and caches programs per (file, defines) for one GL context."""

    def __init__(self, ctx: Any):
        self.ctx = ctx
        self._programs: dict[tuple, Any] = {}

    def get(self, path: Path, defines: dict[str, Any] | None = None, node: str = "?") -> Any:
        key = (str(path), tuple(sorted((defines or {}).items())), path.stat().st_mtime)
        prog = self._programs.get(key)
        if prog is None:
            prog = self._build(path, defines or {}, node)
            self._programs[key] = prog
        return prog

    def _build(self, path: Path, defines: dict[str, Any], node: str) -> Any:
        import moderngl

        stages = stages_in(path)
        parts: dict[str, Assembled] = {}
        try:
            if "COMPUTE_SHADER" in stages:
                parts["compute_shader"] = assemble(path, "COMPUTE_SHADER", defines)
                asm = parts["compute_shader"]
                return self.ctx.compute_shader(asm.source)
            vs_path = path if "VERTEX_SHADER" in stages else ENGINE_GLSL / "fullscreen.glsl"
            parts["vertex_shader"] = assemble(vs_path, "VERTEX_SHADER", defines)
            parts["fragment_shader"] = assemble(path, "FRAGMENT_SHADER", defines)
            if "GEOMETRY_SHADER" in stages:
                parts["geometry_shader"] = assemble(path, "GEOMETRY_SHADER", defines)
            return self.ctx.program(**{k: v.source for k, v in parts.items()})
        except moderngl.Error as exc:
            text = str(exc)
            stage = next((k for k in parts if k in text), None)
            files = parts[stage].files if stage else next(iter(parts.values())).files if parts else [path]
            raise ShaderError(f"node '{node}': {path.name}: GLSL compile/link failed: {map_errors(text, files)}") \
                from None
