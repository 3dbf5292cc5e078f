"""Node types come from the `nodegraph.nodes` entry-point group, built-ins included."""

from __future__ import annotations

import importlib.metadata
import sys
from pathlib import Path

import pytest

from nodegraph import registry
from nodegraph.errors import PluginError


def test_builtin_nodes_register_through_entry_points():
    eps = importlib.metadata.entry_points(group=registry.GROUP)
    assert any(ep.value == "nodegraph_nodes:register" for ep in eps)
    reg = registry.default()
    for name in ("rasterize", "edge_detect", "perlin_noise", "sketch", "depth_sprite", "write"):
        assert name in reg


def test_engine_never_imports_nodes_by_name():
    """The core (types, nodes, registry, pipelines, planning, execution, cache, GL) knows node types only
    through the registry (test_layout.py checks every module of nodegraph/, the tools included)."""
    engine = Path(__file__).resolve().parents[2] / "nodegraph"
    core = ["__init__", "types", "node", "registry", "pipeline", "yamlio", "executor", "cache", "gpu/gl", "gpu/glsl",
            "values", "errors", "scene/scene", "scene/meshes", "scene/primitives", "output/imageio", "cli", "render"]
    offenders = []
    for name in core:
        p = engine / f"{name}.py"
        for line in p.read_text().splitlines():
            s = line.strip()
            if s.startswith(("import nodes", "from nodes")):
                offenders.append(f"{name}.py: {s}")
    assert not offenders


def test_a_node_types_package_module_is_found_through_the_registry():
    reg = registry.default()
    assert reg.module("edge_detect") == "nodegraph_nodes.edge_detect" == registry.module_of("edge_detect")
    assert reg.submodule("edge_detect", "reference").__name__ == "nodegraph_nodes.edge_detect.reference"
    assert registry.node_module("curvature", "accuracy").__name__ == "nodegraph_nodes.curvature.accuracy"
    try:
        reg.module("no_such_node")
    except KeyError as exc:
        assert "no_such_node" in str(exc)
    else:
        raise AssertionError("an unknown type must raise KeyError")


def test_the_module_of_a_node_class_defined_in_a_submodule_is_its_package(tmp_path: Path, monkeypatch):
    pkg = tmp_path / "deepplugin"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("from .impl import Deep\n")
    (pkg / "impl.py").write_text(
        "from nodegraph.node import Node, Output\nfrom nodegraph.types import Texture\n\n"
        "class Deep(Node):\n    outputs = {'out': Output(Texture('R8'))}\n\n"
        "    def compute(self, ctx, inputs, needed):\n        return {}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        from deepplugin import Deep

        reg = registry.Registry()
        reg.add(Deep, "deep")
        assert reg.module("deep") == "deepplugin"
    finally:
        for m in ("deepplugin", "deepplugin.impl"):
            sys.modules.pop(m, None)


def test_a_third_party_plugin_registers_through_the_same_group(tmp_path: Path, monkeypatch):
    pkg = tmp_path / "myplugin"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(
        "from nodegraph.node import Node, Output\nfrom nodegraph.types import Texture\n\n"
        "class Blank(Node):\n    outputs = {'out': Output(Texture('R8'))}\n\n"
        "    def compute(self, ctx, inputs, needed):\n        return {}\n\n"
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


def test_lazy_types_are_imported_on_first_use_and_checked(tmp_path: Path, monkeypatch):
    """add_lazy registers a type without importing it; get() imports and checks it; module() needs no import."""
    pkg = tmp_path / "lazyplugin"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(
        "from nodegraph.node import Node, Output\nfrom nodegraph.types import Texture\n\n"
        "class Lazy(Node):\n    outputs = {'out': Output(Texture('R8'))}\n\n"
        "    def compute(self, ctx, inputs, needed):\n        return {}\n\n"
        "class NotANode:\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        reg = registry.Registry()
        reg.add_lazy("lazy", "lazyplugin:Lazy")
        reg.add_lazy("broken", "lazyplugin:NotANode")
        reg.add_lazy("missing", "lazyplugin_missing:X")
        assert "lazyplugin" not in sys.modules
        assert reg.names() == ["broken", "lazy", "missing"] and "lazy" in reg
        assert reg.module("lazy") == "lazyplugin" and "lazyplugin" not in sys.modules
        cls = reg.get("lazy")
        assert cls.__name__ == "Lazy" and cls.type_name == "lazy"
        with pytest.raises(PluginError, match="not a subclass of nodegraph.node.Node"):
            reg.get("broken")
        with pytest.raises(PluginError, match="cannot be loaded: ModuleNotFoundError"):
            reg.get("missing")
        with pytest.raises(PluginError, match="already registered"):
            reg.add_lazy("lazy", "lazyplugin:Lazy")
    finally:
        sys.modules.pop("lazyplugin", None)


@pytest.mark.slow  # CLI processes, about 2 s each
def test_a_pipeline_imports_only_the_node_packages_it_uses():
    """In a fresh process: loading the default pipeline imports its five node packages and no other."""
    import subprocess

    code = ("import sys\nfrom nodegraph import pipeline as pl\n"
            "pl.load(sys.argv[1], load_scene=False)\n"
            "print(sorted(m.split('.')[1] for m in sys.modules if m.startswith('nodegraph_nodes.')"
            " and not m.startswith('nodegraph_nodes._')"
            " and m.count('.') == 1))")
    pipe = Path(__file__).resolve().parents[2] / "pipelines" / "nienhaus_sketchy.yaml"
    out = subprocess.run([sys.executable, "-c", code, str(pipe)], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == str(sorted(["rasterize", "edge_detect", "perlin_noise", "sketch", "depth_sprite"]))


@pytest.mark.slow  # CLI processes, about 2 s each
@pytest.mark.parametrize("args", [["--help"], ["nodes"], ["nodes", "edge_detect"]])
def test_help_and_nodes_import_no_gl_numba_scipy(args):
    """`sketchgraph --help` and `sketchgraph nodes` import none of moderngl, numba, scipy, libigl, OpenImageIO;
    `nodes TYPE` imports that one node package."""
    import subprocess

    code = ("import sys\nsys.argv = ['sketchgraph', *sys.argv[1:]]\nfrom nodegraph.cli import main\n"
            "try:\n    main()\nexcept SystemExit:\n    pass\n"
            "heavy = ['moderngl', 'numba', 'scipy', 'igl', 'OpenImageIO', 'matplotlib', 'glcontext']\n"
            "print('HEAVY', [m for m in heavy if m in sys.modules], file=sys.stderr)\n"
            "print('NODES', len([m for m in sys.modules if m.startswith('nodegraph_nodes.') and m.count('.') == 1]),"
            " file=sys.stderr)\n"
            "print('NUMPY', 'numpy' in sys.modules, file=sys.stderr)\n")
    out = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, check=True)
    assert "HEAVY []" in out.stderr, out.stderr
    if args == ["--help"]:
        assert "NODES 0" in out.stderr
        assert "NUMPY False" in out.stderr, "sketchgraph --help imported NumPy (0.05 s of CPU becomes 0.2 s)"
    if args == ["nodes", "edge_detect"]:
        assert "NODES 1" in out.stderr
