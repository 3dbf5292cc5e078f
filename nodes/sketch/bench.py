"""What `sketchgraph bench PIPELINE` times of this node on the CPU: its float64 reference on read-back inputs."""

from __future__ import annotations

from typing import Any

import numpy as np

from .reference import sketch


def _plane(a: Any) -> Any:
    """A single-channel image as (H, W) whether it came back from the GPU (H, W, 1) or a reference."""
    return a[..., 0] if a.ndim == 3 else a


def reference(node: Any, ins: dict[str, Any]) -> dict[str, Any]:
    """The float64 reference of `node` (a Sketch) on read-back inputs, by output port."""
    p = node.params
    layers = [(np.asarray(layer.matrix), layer.color) for layer in node.layers()]
    return sketch(_plane(ins["edges"]), ins["shade"], ins["offset"], np.asarray(p.shade_matrix), layers,
                  p.edge_strength, p.use_shade, p.paper)
