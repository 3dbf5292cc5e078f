"""Time principal curvature on a mesh: ``python -m nodes.curvature.bench [mesh.obj] [radius ...]``.

Prints libigl alone and the full ``compute_curvature`` (with fallbacks) side by side, best of 3.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import igl
import numpy as np

from nodes.curvature.principal import DEFAULT_RADIUS, compute_curvature

DEFAULT_MESH = Path("/work/shared/meshes/ogre.obj")


def _best(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv: list[str]) -> None:
    path = Path(argv[0]) if argv else DEFAULT_MESH
    radii = [int(a) for a in argv[1:]] or [DEFAULT_RADIUS, 5]
    V, F = igl.read_triangle_mesh(str(path))
    V, F = np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64)
    print(f"{path.name}: {len(V)} vertices, {len(F)} faces")
    for radius in radii:
        t_igl = _best(lambda radius=radius: igl.principal_curvature(V, F, radius))
        t_all = _best(lambda radius=radius: compute_curvature(V, F, radius))
        res = compute_curvature(V, F, radius)
        print(f"radius {radius}: libigl {t_igl:.3f} s, compute_curvature {t_all:.3f} s; fallbacks {res.counts}")


if __name__ == "__main__":
    main(sys.argv[1:])
