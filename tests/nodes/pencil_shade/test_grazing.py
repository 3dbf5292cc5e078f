"""pencil_shade on surfaces seen nearly edge-on (`grazing_floor`, `grazing_angle`): a flat sheet seen at 10
degrees from the side the light does not reach keeps a readable tone; the rule only ever lightens, and only near
edge-on; and the `blend` output asked for alone reads the G-buffer (it read zeros)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.executor import Executor

ROOT = Path(__file__).resolve().parents[3]
SIZE = (160, 160)


def sheet_scene(tmp_path: Path, side: str) -> Path:
    """A 3 x 3 plane (y = 0, facing +y) seen at 10 degrees above (`lit`: the default view-space light, from the
    upper left, reaches it) or below it (`unlit`: the camera sees its back, turned from the light)."""
    a = math.radians(10.0)
    y = 4.0 * math.sin(a) * (1.0 if side == "lit" else -1.0)
    path = tmp_path / f"sheet_{side}.yaml"
    path.write_text("scene: sheet\nobjects:\n  - primitive: {type: plane, size: 3, subdiv: 16}\n"
                    f"camera: {{eye: [0, {y:.9f}, {4.0 * math.cos(a):.9f}], target: [0, 0, 0], fov: 40}}\n")
    return path


def render(scene: Path, *overrides: str, ports: tuple[str, ...] = ("color", "blend")) -> dict[str, np.ndarray]:
    pipe = pl.load(ROOT / "pipelines" / "pencil.yaml", size=SIZE, scene=str(scene), overrides=list(overrides))
    res = Executor(pipe, None, requested=[("shade", p) for p in ports]).run()
    return {p: res.values[("shade", p)].read() for p in ports}


def luminance_on_sheet(out: dict[str, np.ndarray]) -> np.ndarray:
    covered = out["blend"][..., 3] >= 0
    assert covered.mean() > 0.15  # the sheet fills a band across the picture
    return out["color"][..., :3].mean(axis=2)[covered]


@pytest.mark.slow  # four renders, about 1 s each
def test_a_sheet_seen_at_10_degrees_from_its_unlit_side_stays_readable(gl, tmp_path):
    unlit = sheet_scene(tmp_path, "unlit")
    lum = luminance_on_sheet(render(unlit))
    plain = luminance_on_sheet(render(unlit, "shade.grazing_floor=0"))  # N.L alone: hatched nearly black
    assert (plain < 0.3).mean() > 0.08 and plain.mean() < 0.45, ((plain < 0.3).mean(), plain.mean())
    assert (lum < 0.3).mean() < 0.02 and lum.mean() > 0.55, ((lum < 0.3).mean(), lum.mean())
    # the side the light reaches is bright either way: the rule is a floor, never darker
    lit = sheet_scene(tmp_path, "lit")
    a, b = luminance_on_sheet(render(lit)), luminance_on_sheet(render(lit, "shade.grazing_floor=0"))
    np.testing.assert_array_equal(a, b)
    assert a.mean() > 0.75


def test_the_floor_is_a_lift_that_fades_at_the_grazing_angle():
    from nodegraph_nodes.pencil_shade import reference

    facing = np.linspace(0.0, 1.0, 101)
    end = math.sin(math.radians(20.0))
    b = reference.brightness(np.zeros_like(facing), facing, 0.5, 20.0)
    assert b[0] == 0.5 and np.all(np.diff(b) <= 0) and np.all(b[facing >= end] == 0.0)
    np.testing.assert_allclose(reference.brightness(np.full(5, 0.7), np.zeros(5), 0.5, 20.0), 0.7)  # lit: as lit
    np.testing.assert_allclose(reference.brightness(np.full(5, -0.3), np.full(5, 0.2), 0.0, 20.0), 0.0)  # off
    # a sheet seen at 10 degrees, at the centre of the view: darkness 0.5, not 1
    d = reference.darkness(reference.brightness(np.zeros(1), np.array([math.sin(math.radians(10.0))]), 0.5, 20.0))
    assert 0.45 < d[0] < 0.55


def test_blend_alone_reads_the_geometry_pass(gl, tmp_path):
    """With `blend` the only output asked for, the hatching pass does not read the tonal art map, so the G-buffer
    took texture unit 0 and with it the filtering sampler meant for the map: every weight and tone read 0."""
    scene = sheet_scene(tmp_path, "unlit")
    alone = render(scene, ports=("blend",))["blend"]
    both = render(scene, ports=("blend", "color"))["blend"]
    covered = both[..., 3] >= 0
    assert covered.any() and both[..., 3][covered].min() > 1.0  # a tone index, not 0
    np.testing.assert_array_equal(alone, both)
