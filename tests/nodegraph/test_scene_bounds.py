"""Numbers in a scene file are bounded where they are read (scene.MAX_MAGNITUDE), so a value such as 1e300
is one located line at load, not an overflow later (a light direction squared, a camera's near plane)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodegraph.errors import PipelineError
from nodegraph.scene.scene import MAX_MAGNITUDE, load_scene

CASES = {
    "objects: [{primitive: {type: sphere}, transform: {translate: [1e300, 0, 0]}}]": "objects.0.transform.translate",
    "objects: [{primitive: {type: sphere}}]\nlight: {direction: [1e300, 1, 1]}": "light.direction",
    "objects: [{primitive: {type: torus, R: 1e300, r: 0.3}}]": "field 'R'",
    "objects: [{primitive: {type: sphere}}]\ncamera: {eye: [1e300, 0, 0], target: [0, 0, 0]}": "camera.eye",
    "objects: [{primitive: {type: sphere}}]\norbit: {axis: [0, 1, 0], degrees_per_frame: 1e300}": "orbit",
    "objects: [{primitive: {type: box, size: [1e300, 1, 1]}}]": "field 'size'",
    "objects: [{primitive: {type: sphere}, transform: {rotate: [0, -1e13, 0]}}]": "transform.rotate",
}


@pytest.mark.parametrize("text, where", list(CASES.items()))
def test_huge_numbers_are_one_located_line(tmp_path: Path, text: str, where: str) -> None:
    p = tmp_path / "s.yaml"
    p.write_text(text + "\n")
    with pytest.raises(PipelineError) as err:
        load_scene(p)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"{p}:") and where in msg
    assert f"magnitude at most {MAX_MAGNITUDE:g}" in msg


def test_the_bound_admits_what_float64_holds(tmp_path: Path) -> None:
    p = tmp_path / "s.yaml"
    p.write_text("objects: [{primitive: {type: sphere, radius: 2}, transform: {translate: [1e11, 0, 0]}}]\n")
    scene = load_scene(p)
    assert np.isfinite(scene.objects[0].transform).all() and scene.objects[0].transform[0, 3] == 1e11
