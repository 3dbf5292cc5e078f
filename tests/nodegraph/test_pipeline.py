"""Every load error is one line naming file:line:col, what was expected and what was found."""

from __future__ import annotations

from pathlib import Path

import pytest

from nodegraph import pipeline as pl
from nodegraph.errors import CycleError, PipelineError, PortTypeError

GOOD = """\
pipeline: t
size: [64, 64]
nodes:
  gbuf: {type: rasterize}
  edges:
    type: edge_detect
    in: {normal_depth: gbuf.normal_depth}
outputs:
  image: edges.out
"""


def load(text: str, **kw):
    return pl.loads(text, "p.yaml", load_scene=False, **kw)


def error(text: str, **kw) -> PipelineError:
    with pytest.raises(PipelineError) as info:
        load(text, **kw)
    msg = str(info.value)
    assert "\n" not in msg, "errors are one line"
    return info.value


def test_good_pipeline_loads():
    p = load(GOOD)
    assert p.connections["edges"] == {"normal_depth": ("gbuf", "normal_depth")}
    assert p.outputs == {"image": ("edges", "out")}


def test_unknown_node_type_suggests_nearest():
    e = error(GOOD.replace("type: edge_detect", "type: edge_detekt"))
    assert str(e).startswith("p.yaml:6:11: node 'edges': unknown node type 'edge_detekt'")
    assert "did you mean 'edge_detect'" in str(e)


def test_unknown_input_port():
    e = error(GOOD.replace("in: {normal_depth:", "in: {normaldepth:"))
    assert str(e).startswith("p.yaml:7:10: node 'edges' (edge_detect) has no input 'normaldepth'")
    assert "did you mean 'normal_depth'" in str(e)


def test_unknown_output_port():
    e = error(GOOD.replace("gbuf.normal_depth", "gbuf.normal_dept"))
    assert str(e).startswith("p.yaml:7:24: node 'edges' input 'normal_depth': node 'gbuf' (rasterize) has no "
                             "output 'normal_dept'")
    assert "did you mean 'normal_depth'" in str(e)


def test_type_mismatch():
    with pytest.raises(PortTypeError) as info:
        load(GOOD.replace("normal_depth: gbuf.normal_depth", "normal_depth: gbuf.color"))
    assert str(info.value) == ("p.yaml:7:24: node 'edges' input 'normal_depth': expected Texture[RGBA32F], "
                               "got Texture[RGBA8] from gbuf.color")


def test_precision_too_low_is_a_type_error():
    text = GOOD.replace("  edges:\n", "  e2:\n    type: edge_detect\n    in: {normal_depth: gbuf.normal}\n"
                                      "  edges:\n")
    with pytest.raises(PortTypeError, match="expected Texture\\[RGBA32F\\], got Texture\\[RGBA16F\\] from gbuf.normal"):
        load(text)


def test_cycle_lists_its_nodes():
    text = """\
pipeline: t
nodes:
  a: {type: sketch, in: {edges: e.out, shade: b.color, offset: n.out}}
  b: {type: sketch, in: {edges: e.out, shade: a.color, offset: n.out}}
  g: {type: rasterize}
  e: {type: edge_detect, in: {normal_depth: g.normal_depth}}
  n: {type: perlin_noise}
outputs: {x: a.color}
"""
    with pytest.raises(CycleError) as info:
        load(text)
    msg = str(info.value)
    assert msg.startswith("p.yaml:")
    assert "cycle in the node graph" in msg
    assert "a -> b -> a" in msg or "b -> a -> b" in msg


def test_missing_input():
    e = error(GOOD.replace("    in: {normal_depth: gbuf.normal_depth}\n", ""))
    assert str(e).startswith("p.yaml:5:3: node 'edges' (edge_detect) is missing input 'normal_depth' "
                             "(Texture[RGBA32F])")


def test_bad_parameter_value():
    e = error(GOOD.replace("    in: {normal", "    params: {width: 0}\n    in: {normal"))
    assert str(e).startswith("p.yaml:7:21: node 'edges' (edge_detect) field 'width': expected")
    assert "found 0" in str(e)


def test_unknown_parameter():
    e = error(GOOD.replace("    in: {normal", "    params: {widht: 2}\n    in: {normal"))
    assert str(e).startswith("p.yaml:7:14: node 'edges' (edge_detect) unknown field 'widht' (did you mean 'width'?)")


def test_bad_top_level_field():
    e = error(GOOD.replace("size: [64, 64]", "size: [64, big]"))
    assert str(e).startswith("p.yaml:2:12: field 'size.1': expected a valid integer")


def test_yaml_syntax_error():
    e = error(GOOD.replace("outputs:", "outputs: [oops"))
    assert str(e).startswith("p.yaml:") and "invalid YAML" in str(e)


def test_missing_pipeline_file(tmp_path: Path):
    with pytest.raises(PipelineError, match="file not found: .*nope.yaml"):
        pl.load(tmp_path / "nope.yaml")


def test_missing_scene_file(tmp_path: Path):
    p = tmp_path / "p.yaml"
    p.write_text(GOOD.replace("size: [64, 64]", "size: [64, 64]\nscene: missing.obj"))
    with pytest.raises(PipelineError) as info:
        pl.load(p)
    assert str(info.value).startswith(f"{p}:3:8: ")
    assert "missing.obj" in str(info.value)


def test_set_override_validated_like_the_file():
    p = load(GOOD, overrides=["edges.normal_threshold=0.6"])
    assert p.nodes["edges"].params.normal_threshold == 0.6
    with pytest.raises(PipelineError) as info:
        load(GOOD, overrides=["edges.normal_treshold=0.6"])
    assert str(info.value).startswith("--set edges.normal_treshold=0.6: node 'edges' (edge_detect) has no "
                                      "parameter 'normal_treshold' (did you mean 'normal_threshold'?)")
    with pytest.raises(PipelineError, match=r"^--set edges.width=-3: node 'edges' field 'width': expected"):
        load(GOOD, overrides=["edges.width=-3"])
    with pytest.raises(PipelineError, match=r"^--set edgs.width=2: unknown node 'edgs' \(did you mean 'edges'\?\)"):
        load(GOOD, overrides=["edgs.width=2"])


def test_size_override():
    assert load(GOOD, size=(120, 90)).size == (120, 90)
    assert pl.parse_size("1200x900") == (1200, 900)
    with pytest.raises(PipelineError, match="--size: expected WIDTHxHEIGHT"):
        pl.parse_size("1200")


def test_shipped_pipelines_validate():
    root = Path(__file__).resolve().parents[2] / "pipelines"
    files = sorted(root.glob("*.yaml"))
    assert files
    for f in files:
        pl.load(f, load_scene=False)
