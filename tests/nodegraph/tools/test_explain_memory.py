"""`run --explain` counts each buffer at its own size: tiles and texture arrays are not screen-sized."""

from __future__ import annotations

import re

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.tools.explain import explain
from tests.conftest import ROOT


def test_explain_memory_uses_each_outputs_shape() -> None:
    pipe = pl.load(str(ROOT / "pipelines" / "pencil.yaml"), size=(640, 480))
    text = explain(Executor(pipe, None), 0)
    paper = pipe.nodes["paper"].params.size
    tam = pipe.nodes["tam"].params
    layers = pipe.nodes["distortion"].params.layers
    assert f"out: RGBA16F {paper}x{paper} " in text
    assert f"tones: R8 {tam.size}x{tam.size}x{tam.tones} " in text
    assert f"out: RG16F 640x480x{layers} " in text
    # the total is the sum of the listed buffers, each width x height x layers x bytes per texel
    listed = [float(m) for m in re.findall(r" ([0-9.]+) MiB", text.split("texture memory")[0])]
    total = float(re.search(r"texture memory: ([0-9.]+) MiB", text).group(1))
    assert abs(sum(listed) - total) < 0.05 * len(listed)
    expected_tam = tam.size * tam.size * tam.tones * 1 / 1024**2
    assert f"{expected_tam:.1f} MiB" in text.split("tones:")[1].splitlines()[0]
