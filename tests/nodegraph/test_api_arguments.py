"""Every documented Python API call checks its arguments (nodegraph/api.py): a wrong type or an out-of-range value
raises a SketchgraphError that is also the matching builtin (`ArgumentTypeError` a TypeError,
`ArgumentValueError` / `PipelineArgumentError` a ValueError), with a one-line message naming the argument as the
API spells it (`scene=`, not the command line's `--scene`). A table of the calls the issue found (raw TypeError,
KeyError, OverflowError from deep inside; `size=(True, True)` rendering 1x1; `frames(range(10**12))` building a
list), then Hypothesis-generated wrong calls of every argument. Nothing here renders: every check runs before
the GL context is used."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, note, settings
from hypothesis import strategies as st

import nodegraph as ng
from nodegraph import api
from nodegraph.errors import ArgumentTypeError, ArgumentValueError, PipelineArgumentError, SketchgraphError
from nodegraph.output.write import MAX_FRAME
from tests.conftest import ROOT

PIPE = str(ROOT / "pipelines" / "nienhaus_sketchy.yaml")


@pytest.fixture(scope="module")
def session() -> Any:
    with ng.Session(cache=False) as s:
        yield s


@pytest.fixture(scope="module")
def pipe(session: Any) -> Any:
    return session.load(PIPE, scene="builtin:torus", size=(16, 16))


@pytest.fixture(autouse=True)
def _no_rendering(monkeypatch: pytest.MonkeyPatch) -> None:
    """A bad argument is refused before anything runs: running an executor here fails the test."""

    def refuse(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("an executor was asked to run: the argument was not checked first")

    monkeypatch.setattr(api.Session, "executor", refuse)


def _call(fn: Callable[[], Any]) -> BaseException:
    """Call `fn` (iterating what it returns, for `frames`); the exception it raised."""
    try:
        out = fn()
        if hasattr(out, "__next__"):
            list(itertools.islice(out, 3))
    except BaseException as exc:  # noqa: BLE001 - what escapes is the point
        return exc
    raise AssertionError("no error raised")


def _assert_api_error(exc: BaseException, arg: str | tuple[str, ...], builtin: type[BaseException] | None = None
                      ) -> str:
    assert isinstance(exc, SketchgraphError), f"{type(exc).__name__} escaped: {exc!r}"
    assert isinstance(exc, (TypeError, ValueError)), f"{type(exc).__name__} is neither a TypeError nor a ValueError"
    if builtin is not None:
        assert isinstance(exc, builtin), f"{type(exc).__name__}: expected a {builtin.__name__}"
    text = str(exc)
    assert text and "\n" not in text and "\r" not in text, repr(text)
    names = (arg,) if isinstance(arg, str) else arg
    assert text.startswith(tuple(f"{a}{c}" for a in names for c in "=[")), \
        f"the message should name {' or '.join(names)}=: {text!r}"
    assert "--" not in text.split(":")[0], f"a command-line flag in an API error: {text!r}"
    assert len(text) < 600, text
    return text


# -- the calls the issue found ----------------------------------------------------------------------------
def _specific(pipe: Any, session: Any) -> list[tuple[str, Callable[[], Any], str, type[BaseException]]]:
    P = PIPE
    return [
        ("load(size=100)", lambda: ng.load(P, size=100), "size", TypeError),
        ("load(size=(True, True))", lambda: ng.load(P, size=(True, True)), "size", TypeError),
        ("load(size=(0, 10))", lambda: ng.load(P, size=(0, 10)), "size", ValueError),
        ("load(size=(1.5, 2))", lambda: ng.load(P, size=(1.5, 2)), "size", TypeError),
        ("load(size='abc')", lambda: ng.load(P, size="abc"), "size", ValueError),
        ("load(scene=missing)", lambda: ng.load(P, scene="no/such/scene.yaml"), "scene", ValueError),
        ("load(scene=5)", lambda: ng.load(P, scene=5), "scene", TypeError),
        ("load(set=5)", lambda: ng.load(P, set=5), "set", TypeError),
        ("load(set={1: 2})", lambda: ng.load(P, set={1: 2}), "set", TypeError),
        ("load(set=object value)", lambda: ng.load(P, set={"edges.width": object()}), "set", TypeError),
        ("load(set=nan)", lambda: ng.load(P, set={"edges.width": math.nan}), "set", ValueError),
        ("load(set=unknown param)", lambda: ng.load(P, set={"edges.normal_treshold": 0.6}), "set", ValueError),
        ("load(view='bogus')", lambda: ng.load(P, view="bogus"), "view", ValueError),
        ("load(up=3)", lambda: ng.load(P, up=3), "up", TypeError),
        ("load(reference_size='a')", lambda: ng.load(P, reference_size="a"), "reference_size", TypeError),
        ("load(reference_size=-1)", lambda: ng.load(P, reference_size=-1), "reference_size", ValueError),
        ("load(pipeline=5)", lambda: ng.load(5), "pipeline", TypeError),
        ("load(pipeline='a\\0b')", lambda: ng.load("a\0b"), "pipeline", ValueError),
        ("load(pipeline=missing)", lambda: ng.load("no_such_pipeline"), "pipeline", ValueError),
        ("load(session=5)", lambda: ng.load(P, session=5), "session", TypeError),
        ("load(fill=0)", lambda: ng.load(P, fill=0), "fill", ValueError),
        ("load(fill=nan)", lambda: ng.load(P, fill=math.nan), "fill", ValueError),
        ("load(fill=True)", lambda: ng.load(P, fill=True), "fill", TypeError),
        ("load(allow_outside='yes')", lambda: ng.load(P, allow_outside="yes"), "allow_outside", TypeError),
        ("load(film='yes')", lambda: ng.load(P, film="yes"), "film", TypeError),
        ("Session(memory_limit='a')", lambda: ng.Session(memory_limit="a"), "memory_limit", TypeError),
        ("Session(memory_limit=-1)", lambda: ng.Session(memory_limit=-1), "memory_limit", ValueError),
        ("Session(memory_limit=2**64)", lambda: ng.Session(memory_limit=2**64), "memory_limit", ValueError),
        ("Session(cache=5)", lambda: ng.Session(cache=5), "cache", TypeError),
        ("render(frame='a')", lambda: pipe.render(frame="a"), "frame", TypeError),
        ("render(frame=True)", lambda: pipe.render(frame=True), "frame", TypeError),
        ("render(frame=1.5)", lambda: pipe.render(frame=1.5), "frame", TypeError),
        ("render(frame=2**40)", lambda: pipe.render(frame=2**40), "frame", ValueError),
        ("render(frame=-2**31)", lambda: pipe.render(frame=-(2**31)), "frame", ValueError),
        ("render(output=5)", lambda: pipe.render(output=5), "output", TypeError),
        ("render(output='nope')", lambda: pipe.render(output="nope"), "output", ValueError),
        ("render(dtype='float16')", lambda: pipe.render(dtype="float16"), "dtype", ValueError),
        ("render(dtype=np.float32)", lambda: pipe.render(dtype=np.float32), "dtype", TypeError),
        ("inspect(5)", lambda: pipe.inspect(5), "port", TypeError),
        ("inspect('edgez.out')", lambda: pipe.inspect("edgez.out"), "port", ValueError),
        ("value(frame=None)", lambda: pipe.value(frame=None), "frame", TypeError),
        ("frames(5)", lambda: pipe.frames(5), "frames", TypeError),
        ("frames(b'ab')", lambda: pipe.frames(b"ab"), "frames", TypeError),
        ("frames(['a'])", lambda: pipe.frames(["a"]), "frames", TypeError),
        ("frames([True])", lambda: pipe.frames([True]), "frames", TypeError),
        ("frames([2**40])", lambda: pipe.frames([2**40]), "frames", ValueError),
        ("frames(range(2**40, 2**41))", lambda: pipe.frames(range(2**40, 2**41)), "frames", ValueError),
        ("frames('abc')", lambda: pipe.frames("abc"), "frames", ValueError),
        ("frames('0:2000000')", lambda: pipe.frames("0:2000000"), "frames", ValueError),
        ("frames(dtype=1)", lambda: pipe.frames([0], dtype=1), "dtype", TypeError),
        ("frames(chunk=0)", lambda: pipe.frames([0], chunk=0), "chunk", ValueError),
        ("frames(chunk=2) alone", lambda: pipe.frames([0], chunk=2), "chunk", ValueError),
        ("frames(scheduler=5)", lambda: pipe.frames([0], scheduler=5), "scheduler", TypeError),
        ("write(5)", lambda: pipe.write(5), "path", TypeError),
        ("write('')", lambda: pipe.write(""), "path", ValueError),
        ("write(frame='0')", lambda: pipe.write("x.png", frame="0"), "frame", TypeError),
        ("set(5)", lambda: pipe.set(5), "values", TypeError),
        ("set([5])", lambda: pipe.set([5]), "values", TypeError),
        ("set(edges__width=object())", lambda: pipe.set(edges__width=object()), "set", TypeError),
        ("params(5)", lambda: pipe.params(5), "node", TypeError),
        ("params('nope')", lambda: pipe.params("nope"), "node", ValueError),
        ("to_array(5)", lambda: api.to_array(5), "value", TypeError),
        ("to_array(1-D array)", lambda: api.to_array(np.zeros(4)), "value", ValueError),
        ("to_array(dtype='int8')", lambda: api.to_array(np.zeros((2, 2, 1)), "int8"), "dtype", ValueError),
    ]


def test_the_calls_the_issue_found_raise_one_line_api_errors(pipe: Any, session: Any) -> None:
    for name, fn, arg, builtin in _specific(pipe, session):
        exc = _call(fn)
        try:
            _assert_api_error(exc, arg, builtin)
        except AssertionError as err:
            raise AssertionError(f"{name}: {err}") from exc


def test_a_missing_scene_names_the_api_argument_not_the_cli_flag() -> None:
    with pytest.raises(PipelineArgumentError) as info:
        ng.load(PIPE, scene="no/such/scene.yaml")
    text = str(info.value)
    assert text.startswith("scene='no/such/scene.yaml': scene file not found") and "--scene" not in text
    assert isinstance(info.value, ng.PipelineError) and isinstance(info.value, ValueError)
    with pytest.raises(PipelineArgumentError, match=r"^set=\{'edges.normal_treshold': 0.6\}: .*normal_threshold"):
        ng.load(PIPE, set={"edges.normal_treshold": 0.6})


def test_bool_is_not_a_size_or_a_frame(pipe: Any) -> None:
    for size in [(True, True), (np.True_, 4), [True, 2]]:
        with pytest.raises(ArgumentTypeError, match="not bools"):
            ng.load(PIPE, size=size)
    with pytest.raises(ArgumentTypeError, match="not a bool"):
        pipe.render(frame=np.True_)
    assert ng.load(PIPE, size=(np.int64(20), 10), scene="builtin:torus").size == (20, 10)  # numpy ints are ints


def test_frames_is_lazy_over_huge_ranges_and_checks_each_frame(pipe: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    """`frames(range(10**12))` builds nothing: the first frames come without the rest being looked at (the
    executor is stubbed: nothing renders); a bad frame in an iterable raises when it is reached."""
    seen: list[int] = []

    class FakeExecutor:
        def run(self, frame: int) -> Any:
            seen.append(frame)
            return type("R", (), {"values": {ref: np.zeros((2, 2, 4), np.float32)}, "computed": lambda s: []})()

    ref = pipe._ref(None)
    monkeypatch.setattr(api.Session, "executor", lambda self, *a, **k: FakeExecutor())
    got = [f for f, _ in itertools.islice(pipe.frames(range(10**12)), 3)]
    assert got == [0, 1, 2] and seen == [0, 1, 2]
    it = pipe.frames(iter([5, 6, "7", 8]))
    assert [f for f, _ in itertools.islice(it, 2)] == [5, 6]
    with pytest.raises(ArgumentTypeError, match=r"^frames\[2\]='7'"):
        next(it)
    with pytest.raises(ArgumentValueError, match="between"):
        list(pipe.frames([MAX_FRAME, MAX_FRAME + 1]))
    assert seen[-1] == MAX_FRAME  # the good frame before the bad one was rendered


# -- generated wrong calls --------------------------------------------------------------------------------
class _Opaque:
    def __repr__(self) -> str:
        return "<opaque\nobject>"  # a repr with a line break: the message must stay one line


_ANY: list[tuple[type, st.SearchStrategy[Any]]] = [  # (the exact type of every value drawn, values)
    (type(None), st.none()), (bool, st.booleans()), (int, st.integers()),
    (int, st.integers(min_value=10**20, max_value=10**60)), (int, st.just(10**5000)),
    (float, st.floats(allow_nan=True, allow_infinity=True)), (complex, st.complex_numbers()),
    (str, st.text(max_size=20)), (bytes, st.binary(max_size=8)), (list, st.lists(st.integers(), max_size=3)),
    (dict, st.dictionaries(st.text(max_size=4), st.integers(), max_size=2)), (tuple, st.tuples(st.integers())),
    (object, st.just(object())), (_Opaque, st.builds(_Opaque)), (np.float32, st.just(np.float32(1.5))),
    (np.ndarray, st.just(np.array([1, 2, 3]))),
]


def _not(*types: type) -> st.SearchStrategy[Any]:
    """Values of none of `types` (exact types: a bool is not an int here). Chosen when the strategy is built, so
    nothing is drawn and thrown away."""
    return st.one_of([strategy for t, strategy in _ANY if t not in types])


def _bad_int(lo: int, hi: int, none: bool = True) -> st.SearchStrategy[Any]:
    """Out of [lo, hi], or not an int (None too, where None is not a valid value)."""
    return st.one_of(st.integers(max_value=lo - 1), st.integers(min_value=hi + 1), st.booleans(),
                     st.floats(), st.text(max_size=5), st.none() if none else st.just("0"))


_NAME = st.text(st.characters(codec="utf-8"), max_size=12).map(lambda t: "nope\n" + t)  # never a real name
_BAD_SIZE = st.one_of(
    _not(str, tuple, list, type(None)),
    st.tuples(st.integers(1, 64)),  # one number
    st.tuples(st.integers(1, 64), st.integers(1, 64), st.integers(1, 64)),
    st.tuples(_bad_int(1, 16384), st.integers(1, 64)),
    st.tuples(st.integers(1, 64), _bad_int(1, 16384)),
    st.text(max_size=12).filter(lambda t: "x" not in t.lower() and "×" not in t),
)
_BAD_FRAMES = st.one_of(
    _not(str, list, tuple, dict, bytes, np.ndarray),
    st.binary(min_size=1, max_size=4),
    st.lists(_bad_int(-MAX_FRAME, MAX_FRAME, none=True), min_size=1, max_size=3),
    st.builds(lambda a, b: range(a, b), st.integers(MAX_FRAME + 1, 2**80), st.integers(2**80 + 1, 2**90)),
    st.text(max_size=12).filter(lambda t: ":" not in t and not t.strip().lstrip("-").isdigit()),
)
_BAD_SET = st.one_of(
    _not(str, list, tuple, dict, type(None)),
    st.dictionaries(st.integers(), st.integers(), min_size=1, max_size=2),
    st.dictionaries(st.just("edges.width"), st.one_of(st.just(object()), st.just({1, 2}), st.just(math.inf),
                                                       st.just(math.nan), st.builds(_Opaque)), min_size=1),
    st.lists(_not(str), min_size=1, max_size=3),
    st.just({"edges.no_such_param": 1}), _NAME.map(lambda t: {t: 1}), _NAME.map(lambda t: [t]),
)
_BAD_PATH = st.one_of(_not(str, Path), st.just(""), st.text(max_size=8).map(lambda t: t + "\0" + t))
_BAD_OPTIONAL_PATH = st.one_of(_not(str, Path, type(None)), st.just(""), st.text(max_size=8).map(lambda t: t + "\0"))
_HOLD: dict[str, Any] = {}  # the module's pipe, for the strategies below (built once, at import)


def _wrong_calls() -> st.SearchStrategy[tuple[str, Any, Callable[[], Any]]]:
    P = PIPE

    class _Pipe:  # the module's pipe, looked up when a call is made
        def __getattr__(self, name: str) -> Any:
            return getattr(_HOLD["pipe"], name)

    pipe = _Pipe()

    def call(arg: str, values: st.SearchStrategy[Any], fn: Callable[[Any], Any]) -> st.SearchStrategy[Any]:
        return values.map(lambda v: (arg, v, lambda: fn(v)))

    return st.one_of(
        call("pipeline", st.one_of(_BAD_PATH, _NAME), lambda v: ng.load(v)),
        call("scene", st.one_of(_BAD_OPTIONAL_PATH, _NAME.map(lambda t: t + ".yaml")),
             lambda v: ng.load(P, scene=v)),
        call("size", _BAD_SIZE, lambda v: ng.load(P, size=v)),
        call("set", _BAD_SET, lambda v: ng.load(P, set=v)),
        call("out_dir", _not(str, Path, type(None)), lambda v: ng.load(P, out_dir=v)),
        call("allow_outside", _not(bool), lambda v: ng.load(P, allow_outside=v)),
        call("film", _not(bool), lambda v: ng.load(P, film=v)),
        call("view", st.one_of(_not(str, type(None)), _NAME), lambda v: ng.load(P, view=v)),
        call("up", st.one_of(_not(str, type(None)), _NAME), lambda v: ng.load(P, up=v)),
        call("reference_size", _bad_int(1, 16384, none=False),
             lambda v: ng.load(P, reference_size=v)),
        call("session", _not(type(None)), lambda v: ng.load(P, session=v)),
        call("fill", st.one_of(_not(float, int, np.float32, type(None)), st.floats().filter(lambda x: not 0 < x <= 4)),
             lambda v: ng.load(P, fill=v)),
        call("cache", _not(bool, str, Path), lambda v: ng.Session(cache=v)),
        call("memory_limit", _bad_int(0, 2**63 - 1), lambda v: ng.Session(memory_limit=v)),
        call("output", st.one_of(_not(str, type(None)), _NAME), lambda v: pipe.render(output=v)),
        call("frame", _bad_int(-MAX_FRAME, MAX_FRAME), lambda v: pipe.render(frame=v)),
        call("dtype", st.one_of(_not(str), _NAME), lambda v: pipe.render(dtype=v)),
        call("port", st.one_of(_not(str), _NAME), lambda v: pipe.inspect(v)),
        call("frame", _bad_int(-MAX_FRAME, MAX_FRAME), lambda v: pipe.inspect("edges.out", frame=v)),
        call("frame", _bad_int(-MAX_FRAME, MAX_FRAME), lambda v: pipe.value(frame=v)),
        call("frames", _BAD_FRAMES, lambda v: pipe.frames(v)),
        call("dtype", st.one_of(_not(str), _NAME), lambda v: pipe.frames([0], dtype=v)),
        call("chunk", _bad_int(1, 10**6, none=False), lambda v: pipe.frames([0], chunk=v, scheduler="local:1")),
        call("path", _BAD_PATH, lambda v: pipe.write(v)),
        call("frame", _bad_int(-MAX_FRAME, MAX_FRAME), lambda v: pipe.write("never.png", frame=v)),
        call("values", _BAD_SET, lambda v: pipe.set(v)),
        call("node", st.one_of(_not(str), _NAME), lambda v: pipe.params(v)),
        call("value", _not(np.ndarray), lambda v: api.to_array(v)),
        call("dtype", st.one_of(_not(str), _NAME), lambda v: api.to_array(np.zeros((2, 2, 1), np.float32), v)),
    )


@pytest.mark.slow  # Hypothesis, 400 calls
@settings(max_examples=400, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow,
                                 HealthCheck.function_scoped_fixture])
@given(wrong=_wrong_calls())
def test_generated_wrong_calls_raise_only_one_line_api_errors(pipe: Any, wrong: tuple[str, Any, Any]) -> None:
    _HOLD["pipe"] = pipe
    arg, value, fn = wrong
    note(f"{arg}={api._shown(value)}")
    event(arg)
    exc = _call(fn)
    # pipe.set(values): a value of the wrong type is `values=`; an override the pipeline refuses is named as
    # load's `set=` (the new Pipe loads with it)
    _assert_api_error(exc, ("values", "set") if arg == "values" else arg)
