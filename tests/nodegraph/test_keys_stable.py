"""Moving code must not change a cache key: every shipped pipeline's node keys, at two frames, equal the
keys recorded before the turn-2 layout move (tests/golden/pipeline_keys.json).

A change that is meant to invalidate entries (a node's version, its GLSL, its params) updates the file in
the same commit and says why."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from nodegraph import pipeline as pl
from nodegraph.executor import Executor

ROOT = Path(__file__).resolve().parents[2]
RECORDED = json.loads((ROOT / "tests" / "golden" / "pipeline_keys.json").read_text())


@pytest.mark.parametrize("name", sorted(RECORDED))
def test_pipeline_keys_unchanged(name: str) -> None:
    pipe = pl.load(str(ROOT / "pipelines" / f"{name}.yaml"))
    for frame, keys in RECORDED[name].items():
        assert Executor(pipe, None).keys(int(frame)) == keys, f"{name} frame {frame}"


def test_every_shipped_pipeline_is_recorded() -> None:
    assert sorted(p.stem for p in (ROOT / "pipelines").glob("*.yaml")) == sorted(RECORDED)
