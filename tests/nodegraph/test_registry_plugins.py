"""Broken plugins: each becomes one warning line naming its entry point, and everything else keeps working.

Each test installs a fake distribution (a package plus a `.dist-info` folder with `entry_points.txt`) on
sys.path, so the entry points are found by importlib.metadata exactly as installed plugins are.
"""

from __future__ import annotations

import itertools
import sys
import textwrap
import warnings
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest
from click.testing import CliRunner

from nodegraph import registry
from nodegraph.cli import main
from nodegraph.errors import PluginError

BUILTINS = ("rasterize", "edge_detect", "composite", "sketch", "write")
_serial = itertools.count()

GOOD = """
from typing import Any
from pydantic import Field
from nodegraph.node import Input, Node, NodeParams, Output
from nodegraph.types import Texture

class Good(Node):
    \"\"\"A valid node.\"\"\"
    inputs = {"color": Input(Texture("RGBA8"), "in")}
    outputs = {"out": Output(Texture("RGBA8"), "out")}

    class Params(NodeParams):
        gain: float = Field(1.0, description="gain")

    def compute(self, ctx: Any, inputs: dict, needed: frozenset) -> dict:
        return {"out": inputs["color"]}
"""


@pytest.fixture
def plugins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """install(source, register_body) -> (package name, dist name): a fake installed plugin."""
    made: list[str] = []
    monkeypatch.setattr(registry, "_DEFAULT", None)

    def install(source: str, entry: str = "register", files: dict[str, str] | None = None) -> tuple[str, str]:
        n = next(_serial)
        pkg, dist_name = f"fakeplugin_{n}", f"fake-plugin-{n}"
        root = tmp_path / f"site{n}"
        (root / pkg).mkdir(parents=True)
        (root / pkg / "__init__.py").write_text(textwrap.dedent(source))
        for name, text in (files or {}).items():
            (root / pkg / name).write_text(text)
        info = root / f"{dist_name.replace('-', '_')}-1.0.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist_name}\nVersion: 1.0\n")
        (info / "entry_points.txt").write_text(f"[{registry.GROUP}]\nplug{n} = {pkg}:{entry}\n")
        monkeypatch.syspath_prepend(str(root))
        made.append(pkg)
        return pkg, dist_name

    yield install
    for pkg in made:
        for mod in [m for m in sys.modules if m == pkg or m.startswith(pkg + ".")]:
            del sys.modules[mod]


def cli_nodes(*args: str):
    result = CliRunner().invoke(main, ["nodes", *args], catch_exceptions=False)
    warned = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    return result, warned


def assert_one_warning(pkg: str, dist: str, *phrases: str) -> str:
    result, warned = cli_nodes()
    assert result.exit_code == 0, result.output
    for name in BUILTINS:
        assert f"\n{name}  (version" in "\n" + result.stdout
    assert len(warned) == 1, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr  # no traceback
    line = warned[0]
    assert f"= {pkg}:register'" in line and f"({dist} 1.0)" in line, line
    for phrase in phrases:
        assert phrase in line, line
    return line


def test_a_plugin_that_fails_to_import(plugins):
    pkg, dist = plugins("import not_a_module_anywhere\n")
    assert_one_warning(pkg, dist, "cannot be loaded", "ModuleNotFoundError", "not_a_module_anywhere")


def test_a_plugin_whose_register_raises(plugins):
    pkg, dist = plugins(GOOD + "\ndef register(reg):\n    reg.add(Good, 'half_done')\n    raise RuntimeError('boom')\n")
    assert_one_warning(pkg, dist, "register() raised RuntimeError: boom")
    assert "half_done" not in registry.default()  # nothing of a failed register is kept


def test_an_entry_point_that_names_no_function(plugins):
    pkg, dist = plugins("register = 42\n")
    assert_one_warning(pkg, dist, "not a function")


def test_a_plugin_cannot_replace_a_builtin(plugins):
    from nodegraph_nodes.composite import Composite

    pkg, dist = plugins(GOOD + "\ndef register(reg):\n    reg.add(Good, 'composite')\n")
    assert_one_warning(pkg, dist, "node type 'composite' is already registered by entry point 'builtin")
    assert registry.default().get("composite") is Composite


def test_a_plugin_cannot_rename_a_builtin_class(plugins):
    from nodegraph_nodes.composite import Composite

    pkg, dist = plugins("from nodegraph_nodes.composite import Composite\n\n"
                        "def register(reg):\n    reg.add(Composite, 'my_composite')\n")
    assert_one_warning(pkg, dist, "already registered as 'composite'")
    assert Composite.type_name == "composite" and "my_composite" not in registry.default()


def test_two_plugins_with_one_name_the_first_by_entry_point_name_wins(plugins):
    body = GOOD + "\ndef register(reg):\n    reg.add(Good, 'shared_name')\n"
    first, _ = plugins(body)
    second, dist = plugins(body)
    line = assert_one_warning(second, dist, "node type 'shared_name' is already registered by entry point")
    assert f"{first}:register" in line
    assert registry.default().get("shared_name").__module__ == first


@pytest.mark.parametrize("source, phrase", [
    ("class NotANode:\n    pass\n", "is not a subclass of nodegraph.node.Node"),
    ("from pydantic import BaseModel\n" + GOOD.replace("class Params(NodeParams):", "class Params(BaseModel):"),
     "Params must subclass nodegraph.node.NodeParams, found a pydantic model"),
    (GOOD.replace('{"out": Output(Texture("RGBA8"), "out")}', '{"out": Texture("RGBA8")}'),
     "outputs['out'] must be a nodegraph.node.Output, found PortType"),
    (GOOD.replace('Input(Texture("RGBA8"), "in")', '"RGBA8"'), "inputs['color'] must be a nodegraph.node.Input"),
    (GOOD.replace('Output(Texture("RGBA8"), "out")', 'Output("RGBA8", "out")'), "must be a port type"),
    (GOOD.split("    def compute")[0], "does not define compute(ctx, inputs, needed)"),
    (GOOD.replace("class Good(Node):", "class Good(Node):\n    shaders = ('missing.glsl',)"),
     "shader 'missing.glsl' not found"),
    (GOOD.replace("class Good(Node):", "class Good(Node):\n    persist = 'sometimes'"), "persist must be one of"),
    (GOOD.replace("class Good(Node):", "class Good(Node):\n    context_keys = frozenset({'time'})"),
     "context_keys has unknown ['time']"),
], ids=["not-a-node", "params-not-nodeparams", "output-not-Output", "input-not-Input", "port-type", "no-compute",
        "missing-shader", "persist", "context-keys"])
def test_an_invalid_node_class_is_skipped_and_its_valid_sibling_kept(plugins, source, phrase):
    cls = "NotANode" if "NotANode" in source else "Good"
    body = source + GOOD.replace("class Good(", "class Sibling(") + (
        f"\ndef register(reg):\n    reg.add({cls}, 'broken_one')\n    reg.add(Sibling, 'fine_one')\n")
    pkg, dist = plugins(body)
    assert_one_warning(pkg, dist, "node type skipped", phrase)
    reg = registry.default()
    assert "broken_one" not in reg and "fine_one" in reg
    assert reg.origin("fine_one").startswith("entry point 'plug")


def test_a_good_plugin_with_glsl_registers_and_warns_nothing(plugins):
    source = GOOD.replace("class Good(Node):", "class Good(Node):\n    shaders = ('good.glsl',)")
    pkg, _ = plugins(source + "\ndef register(reg):\n    reg.add(Good, 'good_plugin_node')\n",
                     files={"good.glsl": "#version 330\n"})
    result, warned = cli_nodes("good_plugin_node")
    assert result.exit_code == 0 and not warned, result.output
    assert "good_plugin_node  (version 1)" in result.stdout
    assert registry.default().get("good_plugin_node").__module__ == pkg


def test_warnings_are_plugin_warnings_and_recorded(plugins):
    pkg, _ = plugins("raise ValueError('first line\\nsecond line')\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        reg = registry.default()
    assert [w.category for w in caught] == [registry.PluginWarning]
    assert "ValueError: first line" in str(caught[0].message) and "second line" not in str(caught[0].message)
    assert reg.problems == [str(caught[0].message)]
    assert "rasterize" in reg


def _builtin(value: str = "nodegraph_nodes:register") -> EntryPoint:
    return EntryPoint("builtin", value, registry.GROUP)


def test_the_builtin_entry_point_failing_is_an_error(monkeypatch):
    monkeypatch.setattr(registry, "_DEFAULT", None)
    monkeypatch.setattr(registry, "entry_points", lambda group: [_builtin("nodegraph_nodes:no_such_function")])
    with pytest.raises(PluginError, match="nothing can run without the built-in node types"):
        registry.default()
    result = CliRunner().invoke(main, ["nodes"])
    assert result.exit_code == 2
    assert result.stderr.startswith("error: entry point 'builtin = nodegraph_nodes:no_such_function': cannot be "
                                    "loaded: AttributeError")
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_no_builtin_entry_point_is_an_error(monkeypatch):
    monkeypatch.setattr(registry, "entry_points", lambda group: [])
    with pytest.raises(PluginError, match="no built-in node types"):
        registry.load()


def test_the_builtin_loads_first_whatever_the_order(monkeypatch, plugins):
    pkg, _ = plugins(GOOD + "\ndef register(reg):\n    reg.add(Good, 'rasterize')\n")
    from nodegraph_nodes.rasterize import Rasterize

    plugin_ep = EntryPoint("aaa", f"{pkg}:register", registry.GROUP)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        reg = registry.load([plugin_ep, _builtin()])
    assert reg.get("rasterize") is Rasterize
    assert len(caught) == 1 and "already registered" in str(caught[0].message)


def test_direct_add_raises_plugin_error():
    reg = registry.Registry()
    with pytest.raises(PluginError, match="is not a subclass"):
        reg.add(int, "x")  # type: ignore[arg-type]
