"""The pipelines that ship with the package, found by name.

The repository's `pipelines/` folder installs as the data package `nodegraph_pipelines` (setup.py maps
it; an editable install maps it to the checkout), read through `importlib.resources`. `resolve` is what
`pipeline.load` calls: an existing path wins, then a shipped name (with or without `.yaml`).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import yaml

from . import yamlio
from .errors import PipelineError
from .fsio import check_input, show_path

PACKAGE = "nodegraph_pipelines"
SUFFIXES = (".yaml", ".yml")


def folder() -> Path | None:
    """The folder holding the shipped pipelines, or None when the data package is not installed."""
    try:
        root = resources.files(PACKAGE)
    except ModuleNotFoundError:
        return None
    # installed from a wheel or editable: a real folder (the engine reads scenes relative to the file)
    return root if isinstance(root, Path) and root.is_dir() else None


def paths() -> dict[str, Path]:
    """Shipped pipelines by name (the file stem), sorted."""
    root = folder()
    if root is None:
        return {}
    return {p.stem: p for p in sorted(root.iterdir()) if p.suffix in SUFFIXES and p.is_file()}


def names() -> list[str]:
    return list(paths())


def resolve(spec: str | Path) -> Path:
    """An existing file as it is; else the shipped pipeline `spec` names ('nienhaus_sketchy' or
    'nienhaus_sketchy.yaml'). Anything else is a one-line PipelineError naming the shipped pipelines."""
    path = Path(spec).expanduser()
    try:
        exists, is_dir = path.is_file(), path.is_dir()
    except (OSError, ValueError):  # a name too long for the filesystem, a NUL byte: say so in one line
        check_input(path, "pipeline file", error=PipelineError)
        raise  # check_input raised already; never reached
    if exists:
        return path
    if is_dir:
        raise PipelineError(f"{show_path(path)} is a folder; expected a pipeline file or a shipped pipeline's name")
    text = str(spec)
    shipped = paths()
    looks_like_name = len(path.parts) == 1 and not text.startswith(".")
    name = path.stem if path.suffix in SUFFIXES else path.name
    if looks_like_name and name in shipped:
        return shipped[name]
    listing = f"shipped pipelines: {', '.join(shipped)}" if shipped else "no shipped pipelines are installed"
    if looks_like_name:
        raise PipelineError(f"no pipeline file or shipped pipeline named '{text}'"
                            f"{yamlio.suggest(name, shipped)}; {listing} (`sketchgraph pipelines` lists them)")
    hint = f" (the shipped pipeline '{name}' runs by name: give '{name}')" if name in shipped else ""
    raise PipelineError(f"pipeline file not found: {show_path(path)}{hint}; relative paths start at the current "
                        "directory; "
                        f"{listing}")


def describe(path: Path) -> str:
    """One line about a pipeline: its `doc` field's first line, else the first clause of its leading comment."""
    try:
        text = path.read_text(encoding="utf-8")
        data = yamlio.safe_load(text)
    except (OSError, yaml.YAMLError):
        return ""
    doc = data.get("doc") if isinstance(data, dict) else None
    if isinstance(doc, str) and doc.strip():
        return " ".join(doc.strip().splitlines()[0].split())
    comment = []
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        comment.append(line.lstrip("#").strip())
    return first_clause(" ".join(comment))


def first_clause(text: str) -> str:
    """Up to the first ': ' or the first '. ' that ends a sentence ('Fig. 8', 'et al. 2006' do not),
    outside parentheses and quotes."""
    depth, quoted = 0, False
    for i, ch in enumerate(text):
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth = max(depth - 1, 0)
        elif ch == '"':
            quoted = not quoted
        elif depth or quoted or text[i + 1:i + 2] not in (" ", ""):
            continue
        elif ch == ":" or (ch == "." and not text[i + 2:i + 3].islower() and not text[i + 2:i + 3].isdigit()):
            return text[:i].strip()
    return text.strip()
