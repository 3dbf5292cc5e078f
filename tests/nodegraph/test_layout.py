"""The layout rules of DESIGN.md ("Layout, turn 2"), checked on the import graph of nodegraph/ and nodes/.

The graph comes from the source with `ast`: every `import` and `from ... import` anywhere in a module
(function-level ones too), relative imports resolved, `nodegraph_nodes.X` (the installed name of the
repository's nodes/ folder) read as `nodes.X`. An import of a package a module lives in is not an edge (the
package is initialised first whatever the module does).
"""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("nodegraph", "nodes")
INSTALLED_AS = {"nodegraph_nodes": "nodes"}


def _modules() -> dict[str, Path]:
    mods: dict[str, Path] = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            mods[".".join(parts)] = path
    return mods


def _canonical(name: str) -> str:
    head, dot, rest = name.partition(".")
    return INSTALLED_AS.get(head, head) + dot + rest


def _imported_names(module: str, path: Path) -> list[str]:
    """Every dotted name `module` imports (for `from a import b`: both `a.b` and `a`)."""
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    names: list[str] = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names += [_canonical(a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                if node.level - 1 > len(package):
                    raise AssertionError(f"{path}: relative import beyond the top-level package")
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = _canonical(node.module or "")
            names += [f"{source}.{a.name}" for a in node.names if a.name != "*"] + [source]
    return names


def _resolve(name: str, mods: dict[str, Path]) -> str | None:
    """The module (of `mods`) that an imported dotted name lives in, or None for an outside import."""
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


@cache
def import_graph() -> nx.DiGraph:
    mods = _modules()
    g = nx.DiGraph()
    g.add_nodes_from(mods)
    for module, path in mods.items():
        for name in _imported_names(module, path):
            target = _resolve(name, mods)
            if target is None or target == module or module.startswith(target + "."):
                continue
            g.add_edge(module, target)
    return g


def _circles(within: str) -> list[list[str]]:
    g = import_graph()
    return sorted(c for c in nx.simple_cycles(g) if any(m.split(".")[0] == within for m in c))


def _is_node_package(m: str) -> bool:
    return m.startswith("nodes.")


def _node_of(m: str) -> str:
    return m.split(".")[1]


# -- the walker itself -------------------------------------------------------------------------------
def test_the_graph_sees_known_imports():
    g = import_graph()
    assert g.has_edge("nodegraph.executor", "nodegraph.cache")  # from .cache import Cache
    assert g.has_edge("nodegraph.tools.gallery.build", "nodegraph.tools.gallery.model")  # from .model import ...
    assert g.has_edge("nodegraph.tools.gallery.build", "nodegraph.executor")  # from ...executor import ...
    assert g.has_edge("nodegraph.tools.bench.accuracy", "nodegraph.tools.bench.stability")  # function-level import
    assert g.has_edge("nodes.curvature.stability", "nodes.curvature.principal")


def test_installed_names_and_relative_imports_resolve(tmp_path: Path):
    mods = {"nodes": tmp_path / "nodes" / "__init__.py", "nodes.a": tmp_path / "nodes" / "a" / "__init__.py",
            "nodes.a.core": tmp_path / "nodes" / "a" / "core.py", "nodes.b": tmp_path / "nodes" / "b" / "__init__.py"}
    src = tmp_path / "nodes" / "b" / "__init__.py"
    src.parent.mkdir(parents=True)
    src.write_text("def f():\n    from nodegraph_nodes.a import core\n    from ..a.core import x\n    import nodes.a\n")
    got = {_resolve(n, mods) for n in _imported_names("nodes.b", src)}
    assert got == {"nodes.a", "nodes.a.core"}


# -- the rules -----------------------------------------------------------------------------------------
def test_no_import_circle_in_the_engine():
    circles = _circles("nodegraph")
    assert not circles, "import circles: " + "; ".join(" -> ".join(c + c[:1]) for c in circles)


def test_no_import_circle_in_the_nodes():
    circles = _circles("nodes")
    assert not circles, "import circles: " + "; ".join(" -> ".join(c + c[:1]) for c in circles)


def test_nothing_in_the_engine_imports_the_nodes():
    bad = [(a, b) for a, b in import_graph().edges if a.startswith("nodegraph") and b.split(".")[0] == "nodes"]
    assert not bad, "nodegraph/ must find nodes through the registry: " + ", ".join(f"{a} -> {b}" for a, b in bad)


def test_no_node_imports_a_sibling():
    bad = [(a, b) for a, b in import_graph().edges if _is_node_package(a) and _is_node_package(b)
           and _node_of(a) != _node_of(b) and not _node_of(b).startswith("_")]
    assert not bad, "node imports sibling: " + ", ".join(f"{a} -> {b}" for a, b in sorted(bad))


def test_cli_is_imported_by_no_module():
    importers = sorted(a for a, b in import_graph().edges if b == "nodegraph.cli")
    assert not importers, f"nodegraph.cli is imported by {importers}"


def test_the_engine_and_library_face_do_not_import_the_tools():
    bad = sorted((a, b) for a, b in import_graph().edges if b.startswith("nodegraph.tools")
                 and not a.startswith(("nodegraph.tools", "nodegraph.cli")))
    assert not bad, "imports point down only (tools sit above the engine): " + ", ".join(f"{a} -> {b}" for a, b in bad)


# -- the wings (DESIGN.md, "Layout, turn 3") --------------------------------------------------------
# Lowest first. A module may import modules of its own layer and of layers below it, never above. The core
# is two layers: its leaves (which the wings use) below the wings, the engine (which runs nodes on the GPU
# and loads scenes) above them.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("leaves", ("nodegraph.errors", "nodegraph.types", "nodegraph.values", "nodegraph.fsio", "nodegraph.yamlio",
                "nodegraph.schemas", "nodegraph.cache", "nodegraph.blas")),
    ("scene", ("nodegraph.scene",)),
    ("gpu", ("nodegraph.gpu",)),
    ("output", ("nodegraph.output",)),
    ("engine", ("nodegraph.node", "nodegraph.registry", "nodegraph.shipped", "nodegraph.pipeline", "nodegraph.plan",
                "nodegraph.executor", "nodegraph.films")),
    ("face", ("nodegraph", "nodegraph.render", "nodegraph.api", "nodegraph.distributed")),
    ("tools", ("nodegraph.tools",)),
    ("cli", ("nodegraph.cli",)),
)
WINGS = ("scene", "gpu", "output")


def layer_of(module: str) -> int | None:
    """The index in LAYERS of a nodegraph module: a wing or tools holds its whole folder; other entries name
    single modules (the package itself, `nodegraph`, is its `__init__`)."""
    for i, (name, members) in enumerate(LAYERS):
        for m in members:
            if module == m or (name in (*WINGS, "tools") and module.startswith(m + ".")):
                return i
    return None


def test_every_engine_module_has_a_layer():
    loose = sorted(m for m in import_graph() if m.startswith("nodegraph") and layer_of(m) is None)
    assert not loose, f"modules in no layer (add them to LAYERS in tests/nodegraph/test_layout.py): {loose}"


def test_the_wings_are_folders():
    root = ROOT / "nodegraph"
    for wing in (*WINGS, "tools/bench"):
        assert (root / wing / "__init__.py").is_file(), wing
    flat = sorted(p.stem for p in root.glob("*.py"))
    assert len(flat) <= 20, f"nodegraph/ holds {len(flat)} flat modules: {flat}"
    assert not sorted(p.name for p in (root / "tools").glob("bench*.py")), "benchmarks live in nodegraph/tools/bench/"


def test_imports_point_down_the_layers():
    bad = sorted((a, b) for a, b in import_graph().edges if a.startswith("nodegraph") and b.startswith("nodegraph")
                 and layer_of(a) is not None and layer_of(b) is not None and layer_of(b) > layer_of(a))
    assert not bad, "imports point down only: " + ", ".join(
        f"{a} ({LAYERS[layer_of(a)][0]}) -> {b} ({LAYERS[layer_of(b)][0]})" for a, b in bad)


def test_the_layer_check_sees_an_upward_import(tmp_path: Path):
    """The check is not vacuous: an import from the scene wing up into the gpu wing is caught."""
    g = import_graph().copy()
    g.add_edge("nodegraph.scene.meshes", "nodegraph.gpu.gl")
    up = [(a, b) for a, b in g.edges if a.startswith("nodegraph") and b.startswith("nodegraph")
          and layer_of(b) is not None and layer_of(a) is not None and layer_of(b) > layer_of(a)]
    assert up == [("nodegraph.scene.meshes", "nodegraph.gpu.gl")]
