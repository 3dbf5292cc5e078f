"""Writes tests/golden/pencil_shade_gs/*.exr: pencil.yaml's `shade` node as the geometry-shader
implementation drew it (commit d7fa746, before the deferred shading pass), so the implementation that
replaced it is compared with those pixels (test_pencil_shade.py::test_same_pixels_as_the_geometry_shader).

Channels: shade, blend (r, g, b, a), color (r, g, b), all half floats as the node's outputs are.
Run from the repository root at that commit: `python tests/nodes/pencil_shade/make_gs_reference.py OUT`.
Kept for the record; running it at a later commit draws the later implementation.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.output import imageio

# name -> (scene, size, frame): closed meshes (torus, spot: back faces culled), an open one drawn two-sided
# (teapot) and the dense one (ogre: 124k triangles, most of them a few pixels)
# (mesh files from ../shared/meshes)
CASES = {"torus": ("builtin:torus", (160, 120), 0), "spot": ("spot.obj", (192, 192), 5),
         "teapot": ("teapot.obj", (192, 160), 9), "ogre": ("ogre.obj", (256, 256), 2)}
ROOT = Path(__file__).resolve().parents[3]


def load(scene: str, size: tuple[int, int]) -> pl.Pipeline:
    """pencil.yaml as it was when the references were drawn."""
    if not scene.startswith("builtin:"):
        scene = str(ROOT.parent / "shared" / "meshes" / scene)
    # the references were drawn before pipelines had a reference size, i.e. with every param per pixel (the
    # reference size equal to the image's shorter side gives that: px_scale 1), and before curvature's smooth
    # field became the default (the spread field at its smoothing then), and before the tone of surfaces seen
    # nearly edge-on was lifted (shade.grazing_floor; the geometry shader never had it), and before tone took the
    # surface colour's lightness (shade.albedo_weight)
    pipe = pl.load(ROOT / "pipelines" / "pencil.yaml", size=size, scene=scene, reference_size=min(size),
                   overrides=["curv.field=spread", "curv.smoothing=0.05", "shade.grazing_floor=0",
                              "shade.albedo_weight=0", "contour.albedo_weight=0"])
    return pipe


def render(scene: str, size: tuple[int, int], frame: int) -> np.ndarray:
    """(H, W, 8): shade, blend rgba, color rgb of pencil.yaml's `shade` node."""
    pipe = load(scene, size)
    res = Executor(pipe, None, requested=[("shade", "shade"), ("shade", "blend"), ("shade", "color")]).run(frame)
    shade, blend, color = (res.values[("shade", port)].read() for port in ("shade", "blend", "color"))
    return np.concatenate([shade[..., :1], blend, color[..., :3]], axis=2)


if __name__ == "__main__":
    out = Path(sys.argv[1])
    for name, case in CASES.items():
        imageio.write(out / f"{name}.exr", render(*case))
        print(f"wrote {out / name}.exr")
