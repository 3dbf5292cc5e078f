"""YAML with `yaml.safe_load` semantics that remembers where every value came from.

Mappings load as `MarkedDict` and sequences as `MarkedList`; both carry the (line, col) of each
key/item (1-based), so a pydantic error path can be turned into `file:line:col`.
"""

from __future__ import annotations

import contextlib
import copy
import difflib
import os
import stat
from collections import OrderedDict
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from .errors import Location, PipelineError
from .fsio import clean, read_input, show_path

T = TypeVar("T", bound=BaseModel)


class MarkedDict(dict):
    """A dict that knows where its keys and values are in the source file."""

    key_marks: dict[Any, tuple[int, int]]
    value_marks: dict[Any, tuple[int, int]]
    mark: tuple[int, int]


class MarkedList(list):
    item_marks: list[tuple[int, int]]
    mark: tuple[int, int]


def _pos(node: yaml.Node) -> tuple[int, int]:
    return (node.start_mark.line + 1, node.start_mark.column + 1)


MAX_BYTES = 16 * 1024**2
"""Largest YAML file read (pipelines and scenes are a few KiB)."""
MAX_DEPTH = 64
"""Deepest nesting of mappings and sequences, counted through aliases."""
MAX_VALUES = 100_000
"""Most values (scalars, mappings, sequences) a document may hold once its aliases are expanded:
aliases are shared when loading, but every consumer (validation, hashing) walks the expanded tree."""


class _LimitError(yaml.MarkedYAMLError):
    pass


class _Marking:
    """What both loaders add to PyYAML's composer: containers are measured as they are composed, so deep
    nesting and alias bombs are refused before anything recurses (every node's expanded size and height
    are known once it is composed)."""

    def _start_marking(self) -> None:
        self._depth = 0
        self._expanded: dict[int, tuple[int, int]] = {}  # id(node) -> (values when expanded, height)

    def compose_node(self, parent: Any, index: Any) -> Any:
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                mark = self.peek_event().start_mark  # type: ignore[attr-defined]
                raise _LimitError(None, None, f"nested more than {MAX_DEPTH} levels deep; expected at most "
                                  f"{MAX_DEPTH} levels of mappings and sequences", mark)
            node = super().compose_node(parent, index)  # type: ignore[misc]  # PyYAML's Composer, next in both MROs
            self._measure(node)
            return node
        finally:
            self._depth -= 1

    def _measure(self, node: yaml.Node) -> None:
        key = id(node)
        if key in self._expanded:
            size, height = self._expanded[key]  # an alias: its target was measured when composed
        elif isinstance(node, yaml.SequenceNode):
            parts = [self._expanded.get(id(c), (1, 1)) for c in node.value]
            size, height = 1 + sum(p[0] for p in parts), 1 + max((p[1] for p in parts), default=0)
        elif isinstance(node, yaml.MappingNode):
            parts = [self._expanded.get(id(c), (1, 1)) for kv in node.value for c in kv]
            size, height = 1 + sum(p[0] for p in parts), 1 + max((p[1] for p in parts), default=0)
        else:
            size, height = 1, 1
        self._expanded[key] = (size, height)
        if height + self._depth - 1 > MAX_DEPTH:
            raise _LimitError(None, None, f"nested more than {MAX_DEPTH} levels deep once aliases are expanded; "
                              f"expected at most {MAX_DEPTH} levels", node.start_mark)
        if size > MAX_VALUES:
            raise _LimitError(None, None, f"aliases expand to more than {MAX_VALUES} values (found {size} so "
                              f"far); expected at most {MAX_VALUES} (an alias bomb?)", node.start_mark)


class _MarkedLoader(_Marking, yaml.SafeLoader):
    """SafeLoader (PyYAML's pure-Python reader, scanner and parser) that builds marked containers. Its
    error messages are the ones `loads` reports."""

    def __init__(self, stream: Any):
        super().__init__(stream)
        self._start_marking()


_FastMarkedLoader: type | None = None
if yaml.__with_libyaml__:
    class _FastMarkedLoader(_Marking, yaml.composer.Composer, yaml.cyaml.CParser,  # type: ignore[no-redef]
                            yaml.constructor.SafeConstructor, yaml.resolver.Resolver):
        """The same loader on libyaml's scanner and parser (PyYAML's composer, constructors and resolver on
        its events: the same values and marks). Parsing the shipped pipelines takes a fifth of the time
        (6.2 against 30 ms for all of them, one run); a document it refuses is parsed again by
        `_MarkedLoader`, so errors read as before."""

        def __init__(self, stream: Any):
            yaml.cyaml.CParser.__init__(self, stream)
            yaml.composer.Composer.__init__(self)
            yaml.constructor.SafeConstructor.__init__(self)
            yaml.resolver.Resolver.__init__(self)
            self._start_marking()


def _construct_mapping(loader: _MarkedLoader, node: yaml.MappingNode) -> MarkedDict:
    loader.flatten_mapping(node)
    out = MarkedDict()
    out.key_marks, out.value_marks, out.mark = {}, {}, _pos(node)
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        try:
            hash(key)
        except TypeError:
            raise yaml.constructor.ConstructorError(
                "while constructing a mapping", node.start_mark, "found unhashable key", key_node.start_mark
            ) from None
        if key in out:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark
            )
        out[key] = loader.construct_object(value_node, deep=True)
        out.key_marks[key] = _pos(key_node)
        out.value_marks[key] = _pos(value_node)
    return out


def _construct_sequence(loader: _MarkedLoader, node: yaml.SequenceNode) -> MarkedList:
    out = MarkedList(loader.construct_object(child, deep=True) for child in node.value)
    out.item_marks = [_pos(child) for child in node.value]
    out.mark = _pos(node)
    return out


for _loader in (_MarkedLoader, _FastMarkedLoader):
    if _loader is not None:
        _loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
        _loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)


def safe_load(text: str) -> Any:
    """`yaml.safe_load` on libyaml's parser where PyYAML has it (the same values, several times faster); a
    document libyaml refuses is parsed again by PyYAML's own loader, so the error raised is PyYAML's."""
    if yaml.__with_libyaml__:
        with contextlib.suppress(yaml.YAMLError):
            return yaml.load(text, Loader=yaml.CSafeLoader)  # noqa: S506 - the C twin of SafeLoader
    return yaml.safe_load(text)


def plain(value: Any) -> Any:
    """A parsed value with its marked mappings and lists turned into plain dicts and lists (for YAML or JSON
    writers, which do not know the subclasses)."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


class YamlLimitError(PipelineError):
    """YAML refused for its shape, not its syntax: a NUL byte, nesting deeper than `MAX_DEPTH`, aliases
    expanding past `MAX_VALUES`."""


def value(text: str, where: Location) -> Any:
    """A YAML value given on the command line (`--set NODE.PARAM=VALUE`): parsed with the limits of `loads`
    (one located line when refused), while text that is not valid YAML stays the plain string it is."""
    try:
        return loads(text, where.file)
    except YamlLimitError as exc:
        raise YamlLimitError(exc.message, where) from None
    except PipelineError:
        return text


def loads(text: str, file: str = "<string>") -> Any:
    """Parse YAML text; syntax errors and refused input (NUL bytes, nesting deeper than `MAX_DEPTH`,
    aliases expanding past `MAX_VALUES`) become a one-line PipelineError with the position."""
    nul = text.find("\0")
    if nul >= 0:
        line, col = _line_col(text, nul)
        raise YamlLimitError("expected YAML text, found a NUL byte (a binary file?)", Location(file, line, col))
    if _FastMarkedLoader is not None:
        # anything libyaml or the limits refuse falls through to the pure-Python loader, whose messages are kept
        with contextlib.suppress(yaml.YAMLError):
            return yaml.load(text, Loader=_FastMarkedLoader)  # noqa: S506 - SafeConstructor, no Python tags
    try:
        return yaml.load(text, Loader=_MarkedLoader)  # noqa: S506 - SafeLoader subclass
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        loc = Location(file, mark.line + 1, mark.column + 1) if mark else Location(file)
        what = clean((exc.problem or exc.context or "invalid YAML").strip(), 200)
        if isinstance(exc, _LimitError):
            raise YamlLimitError(f"YAML {what}", loc) from None
        raise PipelineError(f"invalid YAML: {what}", loc) from None
    except yaml.reader.ReaderError as exc:
        line, col = _line_col(text, exc.position)
        raise PipelineError(f"invalid YAML: unacceptable character #x{exc.character:04x} (control characters "
                            "are not allowed)" if isinstance(exc.character, int) else "invalid YAML: bad character",
                            Location(file, line, col)) from None
    except yaml.YAMLError as exc:  # pragma: no cover - non-marked yaml errors are rare
        raise PipelineError(f"invalid YAML: {clean(str(exc))}", Location(file)) from None
    except RecursionError:  # PyYAML's parser recurses once per flow bracket, before the composer counts depth
        raise YamlLimitError(f"YAML nested too deeply; expected at most {MAX_DEPTH} levels", Location(file)) from None


def _line_col(text: str, offset: int) -> tuple[int, int]:
    line_start = text.rfind("\n", 0, offset) + 1
    return text.count("\n", 0, offset) + 1, offset - line_start + 1


def load(path: str | Path) -> Any:
    """Read and parse a YAML file: a regular file of at most `MAX_BYTES`, UTF-8 text, checked before
    it is opened (a FIFO, a device or a folder is refused, not read)."""
    p = Path(path)
    try:
        os.stat(p)
    except FileNotFoundError:
        raise PipelineError(f"file not found: {show_path(p)} (check the path; relative paths start at the current "
                            "directory)") from None
    except (OSError, ValueError):
        pass  # read_input says what is wrong
    memo_key = _memo_key(p)
    if memo_key is not None and memo_key in _PARSED:
        _PARSED.move_to_end(memo_key)
        return copy.deepcopy(_PARSED[memo_key])
    data = read_input(p, "YAML file", MAX_BYTES, PipelineError)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        col = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
        raise PipelineError(f"expected UTF-8 text, found byte 0x{data[exc.start]:02x} (save the file as UTF-8)",
                            Location(show_path(path), line, col)) from None
    parsed = loads(text, str(path))
    if memo_key is not None:
        _PARSED[memo_key] = copy.deepcopy(parsed)
        while len(_PARSED) > _MEMO_SIZE:
            _PARSED.popitem(last=False)
    return parsed


# Parsed files by (real path, inode, size, mtime): a gallery build or a wedge loads the same pipeline and scene
# files dozens of times, and PyYAML's pure-Python parser costs ~8 ms a file where a deep copy costs ~0.5 ms.
# A changed file has a new size or mtime and is parsed again (`watch` keeps working); callers get their own
# copy, so a caller that edits its data changes nothing here.
_MEMO_SIZE = 64
_PARSED: OrderedDict[tuple[str, int, int, int], Any] = OrderedDict()


def _memo_key(p: Path) -> tuple[str, int, int, int] | None:
    try:
        st = os.stat(p)
    except (OSError, ValueError):
        return None
    if not stat.S_ISREG(st.st_mode):
        return None
    return (os.path.realpath(p), st.st_ino, st.st_size, st.st_mtime_ns)


def locate(root: Any, path: Sequence[Any], file: str | None, key: bool = False) -> Location:
    """The deepest known position of `path` (a pydantic `loc` or our own key path) inside `root`."""
    best = getattr(root, "mark", None)
    node = root
    for i, part in enumerate(path):
        last = i == len(path) - 1
        if isinstance(node, MarkedDict) and part in node:
            marks = node.key_marks if (key and last) else node.value_marks
            best = marks.get(part, best)
            node = node[part]
        elif isinstance(node, MarkedList) and isinstance(part, int) and 0 <= part < len(node):
            best = node.item_marks[part]
            node = node[part]
        else:
            break
    if best is None:
        return Location(file)
    return Location(file, best[0], best[1])


def describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def suggest(word: str, choices: Iterable[str]) -> str:
    """' (did you mean 'x'?)' for the nearest choice, or ''."""
    match = difflib.get_close_matches(str(word), list(choices), n=1, cutoff=0.5)
    return f" (did you mean '{match[0]}'?)" if match else ""


def _fields_at(model: Any, loc: Sequence[Any]) -> list[str]:
    """Field names of the (nested) pydantic model reached by following `loc` from `model`."""
    import typing

    current = model
    for part in loc:
        if not (isinstance(current, type) and issubclass(current, BaseModel)):
            return []
        if isinstance(part, str) and part in current.model_fields:
            ann = current.model_fields[part].annotation
        elif isinstance(part, (str, int)):
            ann = current  # an element of a container: keep looking for a model below
        else:
            return []
        candidates = [ann, *typing.get_args(ann)]
        for args in list(candidates):
            candidates.extend(typing.get_args(args))
        current = next((c for c in candidates if isinstance(c, type) and issubclass(c, BaseModel)), None)
    if isinstance(current, type) and issubclass(current, BaseModel):
        return list(current.model_fields)
    return []


def validation_error(exc: ValidationError, root: Any, file: str | None, prefix: Sequence[Any] = (),
                     what: str = "", model: Any = None) -> PipelineError:
    """The first pydantic error as a one-line PipelineError located in the YAML source."""
    err = exc.errors()[0]
    loc = list(prefix) + [p for p in err["loc"] if not (isinstance(p, str) and p.startswith("function-"))]
    etype = err["type"]
    field = ".".join(str(p) for p in err["loc"]) or "value"
    label = f"{what} " if what else ""
    if etype == "extra_forbidden":
        parent_model_fields = _fields_at(model, err["loc"][:-1]) if model is not None else []
        msg = f"{label}unknown field '{err['loc'][-1]}'" + suggest(str(err["loc"][-1]), parent_model_fields)
        return PipelineError(msg, locate(root, loc, file, key=True))
    if etype == "missing":
        return PipelineError(f"{label}missing required field '{field}'", locate(root, loc[:-1], file))
    found = describe(err.get("input"))
    msg = f"{label}field '{field}': expected {err['msg'].removeprefix('Input should be ')}, found {found}"
    if etype in ("value_error", "assertion_error"):
        msg = f"{label}field '{field}': {err['msg'].removeprefix('Value error, ')}, found {found}"
    return PipelineError(msg, locate(root, loc, file))


def validate(model: type[T], data: Any, file: str | None, prefix: Sequence[Any] = (), root: Any = None,
             what: str = "") -> T:
    """`model.model_validate(data)` with errors turned into located one-line PipelineErrors."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise validation_error(exc, root if root is not None else data, file, prefix, what, model) from None


def load_model(path: str | Path, model: type[T]) -> T:
    """Load a YAML file into a pydantic model; every error is one line with file:line:col."""
    data = load(path)
    return validate(model, data, str(path))
