"""What `sketchgraph bench PIPELINE` times of this node on the CPU: its float64 reference on read-back inputs."""

from __future__ import annotations

from typing import Any

from .reference import edge_detect


def reference(node: Any, ins: dict[str, Any]) -> dict[str, Any]:
    """The float64 reference of `node` (an EdgeDetect) on read-back inputs, by output port."""
    return edge_detect(ins["normal_depth"], **node.params.model_dump())
