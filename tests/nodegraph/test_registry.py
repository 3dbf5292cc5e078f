"""Node types come from the `nodegraph.nodes` entry-point group, built-ins included."""

from __future__ import annotations

import importlib.metadata
import sys
from pathlib import Path

from nodegraph import registry


def test_builtin_nodes_register_through_entry_points():
    eps = importlib.metadata.entry_points(group=registry.GROUP)
    assert any(ep.value == "nodegraph_nodes:register" for ep in eps)
    reg = registry.default()
    for name in ("rasterize", "edge_detect", "perlin_noise", "sketch", "depth_sprite", "write"):
        assert name in reg


def test_engine_never_imports_nodes_by_name():
    """The core (types, nodes, registry, pipelines, planning, execution, cache, GL) knows node types only
    through the registry. Benchmark and accuracy harnesses may call node references directly."""
    engine = Path(__file__).resolve().parents[2] / "nodegraph"
    core = ["__init__", "types", "node", "registry", "pipeline", "yamlio", "executor", "cache", "gl", "glsl",
            "values", "errors", "scene", "meshes", "primitives", "imageio", "cli", "render"]
    offenders = []
    for name in core:
        p = engine / f"{name}.py"
        for line in p.read_text().splitlines():
            s = line.strip()
            if s.startswith(("import nodes", "from nodes")):
                offenders.append(f"{p.name}: {s}")
    assert not offenders


def test_a_third_party_plugin_registers_through_the_same_group(tmp_path: Path, monkeypatch):
    pkg = tmp_path / "myplugin"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(
        "from nodegraph.node import Node, Output\nfrom nodegraph.types import Texture\n\n"
        "class Blank(Node):\n    outputs = {'out': Output(Texture('R8'))}\n\n"
        "def register(reg):\n    reg.add(Blank, 'blank_plugin')\n")
    dist = tmp_path / "myplugin-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: myplugin\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[nodegraph.nodes]\nmine = myplugin:register\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "_DEFAULT", None)
    try:
        reg = registry.default()
        assert "blank_plugin" in reg and "rasterize" in reg
    finally:
        registry._DEFAULT = None
        sys.modules.pop("myplugin", None)
