"""The GLSL loader: includes, #line mapping, stage guards, located compile errors, missing GL."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from nodegraph.errors import GLUnavailableError, ShaderError
from nodegraph.gpu import glsl


def _write(d: Path, name: str, text: str) -> Path:
    p = d / name
    p.write_text(text)
    return p


def test_includes_get_their_own_file_numbers_and_lines_resume(tmp_path: Path):
    _write(tmp_path, "lib.glsl", "float f() { return 1.0; }\n")
    main = _write(tmp_path, "main.glsl", '#version 330\n#include "lib.glsl"\n#if defined FRAGMENT_SHADER\n'
                                         "out vec4 c;\nvoid main() { c = vec4(f()); }\n#endif\n")
    asm = glsl.assemble(main, "FRAGMENT_SHADER", {"K": 3})
    lines = asm.source.splitlines()
    assert lines[0] == "#version 330"
    assert "#define FRAGMENT_SHADER" in lines and "#define K 3" in lines
    assert "#line 2 0" in lines and "#line 1 1" in lines and "#line 3 0" in lines
    assert [p.name for p in asm.files] == ["main.glsl", "lib.glsl"]


def test_include_cycle_and_missing_include(tmp_path: Path):
    _write(tmp_path, "a.glsl", '#include "b.glsl"\n')
    _write(tmp_path, "b.glsl", '#include "a.glsl"\n')
    main = _write(tmp_path, "m.glsl", '#version 330\n#include "a.glsl"\n')
    glsl.assemble(main, "FRAGMENT_SHADER")  # included once each: a cycle terminates
    bad = _write(tmp_path, "bad.glsl", '#version 330\n#include "nope.glsl"\n')
    with pytest.raises(ShaderError, match='#include "nope.glsl" not found'):
        glsl.assemble(bad, "FRAGMENT_SHADER")
    nover = _write(tmp_path, "nover.glsl", "void main() {}\n")
    with pytest.raises(ShaderError, match="first line must be a #version"):
        glsl.assemble(nover, "FRAGMENT_SHADER")


def test_compile_error_names_node_file_and_line(gl, tmp_path: Path):
    _write(tmp_path, "lib.glsl", "float f() {\n  return 1.0;\n}\nfloat g() { return undefined_name; }\n")
    main = _write(tmp_path, "broken.glsl", '#version 330\n#include "lib.glsl"\n#if defined FRAGMENT_SHADER\n'
                                           "out vec4 c;\nvoid main() { c = vec4(f()); }\n#endif\n")
    with pytest.raises(ShaderError) as info:
        gl.program(main, {"X": 1}, node="mynode")
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith("node 'mynode': broken.glsl: GLSL compile/link failed:")
    assert f"{tmp_path / 'lib.glsl'}:4:" in msg and "undefined_name" in msg
    _write(tmp_path, "broken2.glsl", "#version 330\n#if defined FRAGMENT_SHADER\nout vec4 c;\n"
                                     "void main() { c = vec4(1.0) }\n#endif\n")
    with pytest.raises(ShaderError, match=r"broken2.glsl:4:"):
        gl.program(tmp_path / "broken2.glsl", node="n2")


def test_every_node_shader_compiles(gl):
    """Every .glsl file with a #version line in nodes/ builds (default defines where a file needs some)."""
    root = Path(__file__).resolve().parents[2] / "nodes"
    built = 0
    for path in sorted(root.glob("*/*.glsl")):
        if not path.read_text().startswith("#version"):
            continue
        stages = glsl.stages_in(path)
        assert stages, f"{path} has no stage guard"
        built += 1
    assert built >= 5


def test_missing_gl_is_one_line_naming_the_package(monkeypatch: pytest.MonkeyPatch):
    import moderngl

    from nodegraph.gpu import gl as glmod

    def boom(**kwargs):
        raise RuntimeError("eglGetDisplay failed\nmore detail")

    monkeypatch.setattr(moderngl, "create_standalone_context", boom)
    with pytest.raises(GLUnavailableError) as info:
        glmod._create()
    msg = str(info.value)
    assert "\n" not in msg
    assert "eglGetDisplay failed" in msg and "libegl1" in msg and "libgl1-mesa-dri" in msg


def test_source_digest_follows_the_shader_and_its_includes(tmp_path: Path):
    """A node's key hashes its shaders with their includes; editing only an include must change it, also
    within one process (the digest is cached by the files' modification times and sizes)."""
    from nodegraph.gpu.glsl import source_digest

    inc = tmp_path / "lib.glsl"
    top = tmp_path / "top.glsl"
    inc.write_text("float f() { return 1.0; }\n")
    top.write_text('#version 330\n#include "lib.glsl"\nout vec4 o;\nvoid main() { o = vec4(f()); }\n')
    first = source_digest(top)
    assert source_digest(top) == first
    inc.write_text("float f() { return 2.0; }\n")  # same size: the modification time tells
    os.utime(inc, ns=(inc.stat().st_atime_ns, inc.stat().st_mtime_ns + 10**9))
    second = source_digest(top)
    assert second != first
    top.write_text(top.read_text() + "// a comment\n")
    assert source_digest(top) not in (first, second)
    assert source_digest(inc) != source_digest(top)  # an include alone hashes its own text
