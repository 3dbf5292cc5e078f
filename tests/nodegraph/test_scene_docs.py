"""docs/scenes.md: every ```yaml block is a scene file that the real loader takes and the scene schema
accepts, so the page cannot drift from the code."""

from __future__ import annotations

import re
from pathlib import Path

import jsonschema
import pytest
import yaml

from nodegraph.scene import scene as sc

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "scenes.md"
BLOCKS = re.findall(r"^```yaml\n(.*?)^```", DOC.read_text(), re.MULTILINE | re.DOTALL)
TETRAHEDRON = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def test_the_page_has_examples():
    assert len(BLOCKS) >= 6


@pytest.mark.parametrize("i", range(len(BLOCKS)))
def test_each_example_loads_and_validates(i, tmp_path):
    text = BLOCKS[i]
    data = yaml.safe_load(text)
    jsonschema.validate(data, sc.json_schema())
    for obj in data["objects"]:  # mesh files the example names: a small stand-in beside the scene file
        if "mesh" in obj:
            p = tmp_path / obj["mesh"]
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_text(TETRAHEDRON)
    path = tmp_path / "example.yaml"
    path.write_text(text)
    scene = sc.load_scene(str(path))
    assert len(scene.objects) == len(data["objects"])
    if "orbit" in data:
        assert scene.orbit is not None and scene.orbit.degrees_per_frame == data["orbit"]["degrees_per_frame"]
    else:
        assert scene.orbit is None
