"""What `sketchgraph bench PIPELINE` times of this node on the CPU: its float64 reference on read-back inputs."""

from __future__ import annotations

from typing import Any

from .reference import depth_sprite


def _plane(a: Any) -> Any:
    """A single-channel image as (H, W) whether it came back from the GPU (H, W, 1) or a reference."""
    return a[..., 0] if a.ndim == 3 else a


def reference(node: Any, ins: dict[str, Any]) -> dict[str, Any]:
    """The float64 reference of `node` (a DepthSprite) on read-back inputs, by output port."""
    uc, ud = ins.get("under_color"), ins.get("under_depth")
    return depth_sprite(ins["color"], ins["offsets"], _plane(ins["depth"]), uc, None if ud is None else _plane(ud),
                        node.params.paper)
