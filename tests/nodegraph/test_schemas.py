"""`sketchgraph schema [--scene]`: the JSON Schemas accept every shipped pipeline and scene and reject
broken documents (checked with the jsonschema package, as an editor would)."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest
import yaml
from click.testing import CliRunner

from nodegraph import pipeline as pl
from nodegraph.cli import main
from nodegraph.scene import scene as sc
from nodegraph.schemas import unresolved_refs

ROOT = Path(__file__).resolve().parents[2]
PIPELINES = sorted((ROOT / "pipelines").glob("*.yaml"))
SCENES = sorted((ROOT / "pipelines" / "scenes").glob("*.yaml"))


def _validator(args: list[str]) -> jsonschema.Draft202012Validator:
    r = CliRunner().invoke(main, ["schema", *args])
    assert r.exit_code == 0, r.output
    schema = json.loads(r.output)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert unresolved_refs(schema) == []
    return jsonschema.Draft202012Validator(schema)


@pytest.fixture(scope="module")
def pipeline_schema() -> jsonschema.Draft202012Validator:
    return _validator([])


@pytest.fixture(scope="module")
def scene_schema() -> jsonschema.Draft202012Validator:
    return _validator(["--scene"])


def _errors(v: jsonschema.Draft202012Validator, doc: object) -> list[str]:
    return [e.message for e in v.iter_errors(doc)]


@pytest.mark.parametrize("path", PIPELINES, ids=lambda p: p.stem)
def test_every_shipped_pipeline_validates(pipeline_schema, path):
    assert _errors(pipeline_schema, yaml.safe_load(path.read_text())) == []


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_every_shipped_scene_validates(scene_schema, path):
    assert _errors(scene_schema, yaml.safe_load(path.read_text())) == []


def test_nested_definitions_are_hoisted_to_the_root():
    schema = pl.json_schema()
    assert "sketch.EdgeLayer" in schema["$defs"]
    assert unresolved_refs(schema) == []


GOOD_PIPELINE = (ROOT / "pipelines" / "nienhaus_sketchy.yaml").read_text()


@pytest.mark.parametrize("edit", [
    lambda d: d.pop("nodes"),
    lambda d: d.update(sizes=[1, 2]),
    lambda d: d["nodes"]["edges"].update(type="edge_detekt"),
    lambda d: d["nodes"]["edges"]["params"].update(normal_treshold=0.4),
    lambda d: d["nodes"]["edges"]["in"].update(nope="gbuf.color"),
    lambda d: d["nodes"]["noise"]["params"].update(octaves="four"),
])
def test_broken_pipelines_are_rejected(pipeline_schema, edit):
    doc = yaml.safe_load(GOOD_PIPELINE)
    assert _errors(pipeline_schema, doc) == []
    edit(doc)
    assert _errors(pipeline_schema, doc)


def test_a_broken_edge_layer_is_rejected(pipeline_schema):
    doc = yaml.safe_load((ROOT / "pipelines" / "repeated_edges.yaml").read_text())
    layers = next(n["params"]["edge_layers"] for n in doc["nodes"].values() if "edge_layers" in n.get("params", {}))
    layers[0]["colour"] = [0, 0, 0]
    assert _errors(pipeline_schema, doc)


@pytest.mark.parametrize("text", [
    "objects: []",
    "camera: {eye: [0, 0, 1], target: [0, 0, 0]}",
    "objects: [{mesh: a.obj, primitive: {type: box}}]",
    "objects: [{name: nothing}]",
    "objects: [{primitive: {type: boxx}}]",
    "objects: [{primitive: {type: torus, R: 1, q: 2}}]",
    "objects: [{primitive: {type: sphere, subdiv: 9}}]",
    "objects: [{mesh: a.obj, transform: {scale: -1}}]",
    "objects: [{mesh: a.obj, transform: {rotate: [1, 2]}}]",
    "objects: [{mesh: a.obj, color: [2, 0, 0]}]",
    "objects: [{mesh: a.obj}]\ncamera: {eye: [0, 0, 1]}",
    "objects: [{mesh: a.obj}]\nlight: {space: object}",
    "objects: [{mesh: a.obj}]\nfog: true",
])
def test_broken_scenes_are_rejected(scene_schema, text):
    assert _errors(scene_schema, yaml.safe_load(text))


def test_scene_schema_knows_every_primitive():
    prim = sc.json_schema()["$defs"]["ObjectSpec"]["properties"]["primitive"]
    assert sorted(v["properties"]["type"]["const"] for v in prim["oneOf"]) == sorted(sc.PRIMITIVE_SPECS)


def test_scale_and_size_take_one_number_as_the_loader_does(scene_schema):
    doc = yaml.safe_load("objects: [{primitive: {type: box, size: 2}, transform: {scale: 0.5}}]")
    assert _errors(scene_schema, doc) == []
