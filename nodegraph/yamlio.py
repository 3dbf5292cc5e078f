"""YAML with `yaml.safe_load` semantics that remembers where every value came from.

Mappings load as `MarkedDict` and sequences as `MarkedList`; both carry the (line, col) of each
key/item (1-based), so a pydantic error path can be turned into `file:line:col`.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from .errors import Location, PipelineError

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


class _MarkedLoader(yaml.SafeLoader):
    pass


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


_MarkedLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_MarkedLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)


def loads(text: str, file: str = "<string>") -> Any:
    """Parse YAML text; syntax errors become a one-line PipelineError with the position."""
    try:
        return yaml.load(text, Loader=_MarkedLoader)  # noqa: S506 - SafeLoader subclass
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        loc = Location(file, mark.line + 1, mark.column + 1) if mark else Location(file)
        what = (exc.problem or exc.context or "invalid YAML").strip()
        raise PipelineError(f"invalid YAML: {what}", loc) from None
    except yaml.YAMLError as exc:  # pragma: no cover - non-marked yaml errors are rare
        raise PipelineError(f"invalid YAML: {exc}", Location(file)) from None


def load(path: str | Path) -> Any:
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise PipelineError(f"file not found: {p} (check the path; relative paths start at the current "
                            "directory)") from None
    except OSError as exc:
        raise PipelineError(f"cannot read {p}: {exc.strerror}") from None
    return loads(text, str(path))


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
