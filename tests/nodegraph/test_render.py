"""Frame sequences: a frame rendered alone is byte-identical to the same frame inside a sequence."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
from click.testing import CliRunner

ROOT = Path(__file__).resolve().parents[2]


def _run(args: list[str]) -> None:
    from nodegraph.cli import main

    res = CliRunner().invoke(main, ["run", *args, "--size", "64x64", "--no-cache", "-q"])
    assert res.exit_code == 0, res.output


@pytest.mark.slow  # 4 pipelines, up to 2.8 s each
@pytest.mark.parametrize("name", ["nienhaus_sketchy", "repeated_edges", "chalk", "object_space_uncertainty"])
def test_frame_alone_equals_frame_in_sequence(gl, tmp_path, monkeypatch, name):
    monkeypatch.setattr(warnings, "showwarning", warnings.showwarning)  # the CLI installs its own
    pipeline = str(ROOT / "pipelines" / f"{name}.yaml")
    seq, alone = tmp_path / "seq", tmp_path / "alone"
    _run([pipeline, "--frames", "0:4", "-o", str(seq / "frame_####.png")])
    assert sorted(p.name for p in seq.iterdir()) == [f"frame_{i:04d}.png" for i in range(4)]
    for frame in (2, 3):
        _run([pipeline, "--frames", f"{frame}:{frame + 1}", "-o", str(alone / "frame_####.png")])
        assert (alone / f"frame_{frame:04d}.png").read_bytes() == (seq / f"frame_{frame:04d}.png").read_bytes()
    # the orbit moves the camera: consecutive frames differ
    assert (seq / "frame_0000.png").read_bytes() != (seq / "frame_0001.png").read_bytes()
