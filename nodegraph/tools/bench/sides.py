"""The side each shared test mesh is benchmarked from: `sketchgraph bench` fixes the front of the files in
../shared/meshes (as `--front` would), so that a benchmark's camera, and the figures measured through it, do
not move when the framing rules (nodegraph/scene/framing.py) change. Each is the front the rules found when the
figures in docs/ were first measured; spot's is its file's +Z, its back (the rules now find its face, -Z).
`sketchgraph run` and the Python API are not affected; `sketchgraph bench ... --front auto` (where a benchmark
takes `--front`) measures a mesh from the side the rules find."""

from __future__ import annotations

from pathlib import Path

SHARED_MESHES = Path(__file__).resolve().parents[4] / "shared" / "meshes"  # the benchmarks' test meshes

FRONTS = {"cow.obj": "x", "fandisk.obj": "-z", "ogre.obj": "z", "spot.obj": "z", "stanford-bunny.obj": "-x",
          "suzanne.obj": "z", "teapot.obj": "x"}


def fixed(meshes: Path = SHARED_MESHES) -> dict[str, str]:
    """{resolved path of each shared mesh: the file's axis its front faces} (views.FRONT's mapping form)."""
    return {str((Path(meshes) / name).resolve()): axis for name, axis in FRONTS.items()}
