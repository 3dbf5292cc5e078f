"""The located YAML loader refuses what it cannot read sanely, each time with one located line."""

from __future__ import annotations

import builtins
import io
import os
from pathlib import Path

import pytest

from nodegraph import yamlio
from nodegraph.errors import PipelineError
from tests.nodegraph.faultkit import assert_one_line_error, cli, cli_subprocess
from tests.workcount import python_lines


def _err(path: Path) -> str:
    with pytest.raises(PipelineError) as info:
        yamlio.load(path)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


def test_valid_file_still_loads_with_marks(tmp_path: Path) -> None:
    p = tmp_path / "ok.yaml"
    p.write_text("a: &x [1, 2]\nb: *x\nc: {d: é}\n", encoding="utf-8")
    data = yamlio.load(p)
    assert data == {"a": [1, 2], "b": [1, 2], "c": {"d": "é"}}
    assert data.key_marks["c"] == (3, 1)


def test_not_utf8_names_line_column_and_byte(tmp_path: Path) -> None:
    p = tmp_path / "latin1.yaml"
    p.write_bytes("pipeline: x\nname: caf\xe9 secret\n".encode("latin-1"))
    msg = _err(p)
    assert msg.startswith(f"{p}:2:10: expected UTF-8 text, found byte 0xe9")
    assert "secret" not in msg


def test_nul_bytes_are_a_binary_file(tmp_path: Path) -> None:
    p = tmp_path / "bin.yaml"
    p.write_bytes(b"pipeline: x\nab\x00cd secret")
    msg = _err(p)
    assert msg.startswith(f"{p}:2:3: expected YAML text, found a NUL byte")
    assert "secret" not in msg


def test_control_character_is_one_located_line(tmp_path: Path) -> None:
    p = tmp_path / "ctl.yaml"
    p.write_bytes(b"a: 1\nb: x\x07y\n")
    msg = _err(p)
    assert msg.startswith(f"{p}:2:5: invalid YAML: unacceptable character #x0007")


@pytest.mark.parametrize("style", ["flow", "block"])
def test_deep_nesting_is_refused_before_recursion(tmp_path: Path, style: str) -> None:
    n = 20_000
    p = tmp_path / "deep.yaml"
    if style == "flow":
        p.write_text("a: " + "[" * n + "]" * n + "\n")
    else:
        p.write_text("".join("  " * i + f"k{i}:\n" for i in range(200)) + "  " * 200 + "v: 1\n")
    msg = _err(p)
    assert f"nested more than {yamlio.MAX_DEPTH} levels deep" in msg and msg.startswith(f"{p}:")


def test_nesting_at_the_limit_loads(tmp_path: Path) -> None:
    n = yamlio.MAX_DEPTH - 1  # the top mapping is one level
    p = tmp_path / "ok.yaml"
    p.write_text("a: " + "[" * n + "]" * n + "\n")
    assert yamlio.load(p)["a"] is not None


def test_nesting_through_aliases_counts(tmp_path: Path) -> None:
    inner = "[" * 40 + "]" * 40
    p = tmp_path / "alias_deep.yaml"
    p.write_text(f"a: &x {inner}\nb: " + "[" * 30 + "*x" + "]" * 30 + "\n")
    assert "once aliases are expanded" in _err(p)


def _bomb(levels: int, width: int = 10) -> str:
    lines = ["a0: &a0 [" + ", ".join(["lol"] * width) + "]"]
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]")
    return "\n".join(lines) + "\n"


def test_alias_bomb_is_refused_without_expanding_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    levels, width = 12, 10
    p = tmp_path / "bomb.yaml"
    p.write_text(_bomb(levels, width))  # 10^12 values once expanded
    measured = 0
    measure = yamlio._Marking._measure

    def counting(self, node):  # noqa: ANN001, ANN202
        nonlocal measured
        measured += 1
        return measure(self, node)

    monkeypatch.setattr(yamlio._Marking, "_measure", counting)
    lines, msg = python_lines(lambda: _err(p))
    assert f"aliases expand to more than {yamlio.MAX_VALUES} values" in msg
    assert msg.startswith(f"{p}:")
    # The work is bounded by the file, not by its expansion: each loader (libyaml's, then PyYAML's for the
    # message) measures every node written in the file at most once (the top mapping, a key, a sequence and
    # its `width` items per level), and the whole load executes fewer lines of Python than there are values under
    # the cap (about 33,000 here); walking the expanded tree up to the cap, in any Python loop, would take at
    # least a line a value.
    written = 1 + levels * (2 + width)
    assert measured <= 2 * written
    assert lines < yamlio.MAX_VALUES


def test_alias_bomb_through_the_cli_does_not_hang(tmp_path: Path) -> None:
    p = tmp_path / "bomb.yaml"
    p.write_text("pipeline: x\n" + _bomb(9) + "nodes: {n: {type: rasterize, params: {x: *a8}}}\noutputs: {}\n")
    out = cli_subprocess("run", p, "-o", tmp_path / "o.png", timeout=60)
    assert_one_line_error(out, "aliases expand")


def test_small_aliases_are_fine(tmp_path: Path) -> None:
    p = tmp_path / "a.yaml"
    p.write_text(_bomb(3))  # 1000 values
    assert len(yamlio.load(p)["a2"]) == 10


def test_recursive_alias_is_one_line(tmp_path: Path) -> None:
    p = tmp_path / "rec.yaml"
    p.write_text("a: &x [1, *x]\n")
    msg = _err(p)
    assert msg.startswith(f"{p}:1:") and "recursive" in msg


def test_huge_file_is_refused_before_reading(tmp_path: Path) -> None:
    p = tmp_path / "huge.yaml"
    with p.open("wb") as fh:  # sparse: no disk used
        fh.truncate(yamlio.MAX_BYTES + 1)
    msg = _err(p)
    assert "too large: expected at most 16.0 MiB" in msg


def test_fifo_is_not_opened(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    p = tmp_path / "pipe.yaml"
    os.mkfifo(p)
    # every way of opening it is watched: an open would block until a writer comes, so the watchers record
    # the attempt and refuse it instead of opening (the test fails, it does not hang)
    opened: list[str] = []

    def watch(real):  # noqa: ANN001, ANN202
        def guarded(file, *args, **kwargs):  # noqa: ANN001, ANN202
            if not isinstance(file, int) and os.path.abspath(os.fspath(file)) == str(p):
                opened.append(f"{real.__module__}.{real.__name__}")
                raise PermissionError(f"the test forbids opening {p}")
            return real(file, *args, **kwargs)
        return guarded

    monkeypatch.setattr(builtins, "open", watch(builtins.open))
    monkeypatch.setattr(io, "open", watch(io.open))
    monkeypatch.setattr(os, "open", watch(os.open))
    assert "expected a regular YAML file, found a FIFO" in _err(p)
    assert opened == []  # refused from its stat alone: never opened, so nothing could wait for a writer


def test_symlink_to_dev_zero_is_not_read(tmp_path: Path) -> None:
    p = tmp_path / "zero.yaml"
    p.symlink_to("/dev/zero")
    assert "found a character device" in _err(p)


def test_directory(tmp_path: Path) -> None:
    p = tmp_path / "dir.yaml"
    p.mkdir()
    assert "found a folder" in _err(p)


def test_over_long_path(tmp_path: Path) -> None:
    p = tmp_path / ("x" * 5000 + ".yaml")
    msg = _err(p)
    assert "File name too long" in msg and len(msg) < 400


def test_missing_file_keeps_its_message(tmp_path: Path) -> None:
    assert "file not found" in _err(tmp_path / "nope.yaml")


@pytest.mark.parametrize("make", ["fifo", "zero", "dir", "long", "latin", "nul", "deep"])
def test_cli_one_line_for_each(tmp_path: Path, make: str) -> None:
    p = tmp_path / "p.yaml"
    if make == "fifo":
        os.mkfifo(p)
    elif make == "zero":
        p.symlink_to("/dev/zero")
    elif make == "dir":
        p.mkdir()
    elif make == "long":
        p = tmp_path / ("y" * 4000 + ".yaml")
    elif make == "latin":
        p.write_bytes(b"pipeline: \xff\n")
    elif make == "nul":
        p.write_bytes(b"\x00\x01\x02")
    else:
        p.write_text("a: " + "{b: " * 5000 + "1" + "}" * 5000)
    assert_one_line_error(cli("run", p, "-o", tmp_path / "o.png"))


def test_load_memo_gives_own_copies_and_sees_edits(tmp_path) -> None:
    """Parsed files are remembered by path, inode, size and mtime: each caller gets its own copy (editing it
    changes nothing for the next), and an edited file is parsed again."""
    import os

    from nodegraph import yamlio

    f = tmp_path / "p.yaml"
    f.write_text("a: {b: [1, 2]}\n")
    first = yamlio.load(f)
    first["a"]["b"].append(3)
    second = yamlio.load(f)
    assert second == {"a": {"b": [1, 2]}}
    assert yamlio.locate(second, ["a", "b", 1], "p.yaml").line == 1  # marks survive the copy
    st = os.stat(f)
    f.write_text("a: {b: [7, 8]}\n")  # same size
    os.utime(f, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    assert yamlio.load(f) == {"a": {"b": [7, 8]}}


# --- the libyaml-backed loader: the same values and marks as the pure-Python one -------------------------

_fast = pytest.mark.skipif(yamlio._FastMarkedLoader is None, reason="this PyYAML was built without libyaml")


def _same_tree(a: object, b: object, where: str) -> None:
    assert type(a) is type(b) and a == b, where
    if isinstance(a, dict):
        assert (a.key_marks, a.value_marks, a.mark) == (b.key_marks, b.value_marks, b.mark), where  # type: ignore[attr-defined]
        for k in a:
            _same_tree(a[k], b[k], f"{where}.{k}")  # type: ignore[index]
    elif isinstance(a, list):
        assert (a.item_marks, a.mark) == (b.item_marks, b.mark), where  # type: ignore[attr-defined]
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same_tree(x, y, f"{where}[{i}]")


def _both(text: str) -> tuple[object, object]:
    import yaml

    return (yaml.load(text, Loader=yamlio._FastMarkedLoader),  # noqa: S506 - SafeConstructor subclasses
            yaml.load(text, Loader=yamlio._MarkedLoader))  # noqa: S506


@_fast
def test_libyaml_loader_matches_on_the_shipped_files() -> None:
    root = Path(__file__).resolve().parents[2]
    files = sorted([*root.glob("pipelines/*.yaml"), *root.glob("examples/**/*.yaml"), root / "gallery/gallery.yaml"])
    assert len(files) > 5
    import yaml

    for f in files:
        text = f.read_text(encoding="utf-8")
        fast, slow = _both(text)
        _same_tree(fast, slow, str(f))
        assert yamlio.safe_load(text) == yaml.safe_load(text), f


@pytest.mark.slow  # 2.2 s: Hypothesis
@_fast
def test_libyaml_loader_matches_on_generated_documents() -> None:
    import yaml
    from hypothesis import given, settings
    from hypothesis import strategies as st

    scalars = (st.none() | st.booleans() | st.integers(-10**12, 10**12)
               | st.floats(allow_nan=False, allow_infinity=True) | st.text(max_size=12))
    keys = st.text(min_size=1, max_size=8) | st.integers(-100, 100)
    tree = st.recursive(scalars, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(keys, inner, max_size=4),
                        max_leaves=20)

    @settings(max_examples=150, deadline=None)
    @given(doc=st.dictionaries(keys, tree, min_size=1, max_size=5), flow=st.booleans(), unicode=st.booleans())
    def check(doc: dict, flow: bool, unicode: bool) -> None:
        text = yaml.safe_dump(doc, default_flow_style=flow, allow_unicode=unicode, sort_keys=False)
        fast, slow = _both(text)
        _same_tree(fast, slow, text)
        assert yamlio.safe_load(text) == yaml.safe_load(text)  # (not always `doc`: PyYAML folds a lone NEL)

    check()


@_fast
def test_loads_parses_valid_text_once_with_libyaml(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*_: object) -> None:
        raise AssertionError("the pure-Python loader ran on valid text")

    monkeypatch.setattr(yamlio._MarkedLoader, "__init__", refuse)
    assert yamlio.loads("a: [1, {b: c}]\n") == {"a": [1, {"b": "c"}]}


@_fast
def test_text_libyaml_refuses_reads_as_the_pure_python_error() -> None:
    import yaml

    with pytest.raises(yaml.YAMLError, match="mapping values are not allowed here"):  # libyaml: "in this context"
        yamlio.safe_load("a: b: c\n")
    for text, expected in (("a: [1, 2\n", "<string>:2:1: invalid YAML: expected ',' or ']', but got '<stream end>'"),
                           ("a: b: c\n", "<string>:1:5: invalid YAML: mapping values are not allowed here")):
        with pytest.raises(PipelineError) as info:
            yamlio.loads(text)
        assert str(info.value) == expected
