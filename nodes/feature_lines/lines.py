"""feature_lines' CPU code (suggestive contours, ridges, valleys as segments on the mesh) lives in
nodes/_shared/feature_lines.py, where mesh_lines uses it too; this module keeps its name for feature_lines."""

from __future__ import annotations

from .._shared.feature_lines import *  # noqa: F403
from .._shared.feature_lines import _edge_vertices, _interp, _smoothstep  # noqa: F401
