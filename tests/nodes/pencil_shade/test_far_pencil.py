"""pencil.yaml on a mesh file far from the origin draws what it draws at the origin (nodegraph/scene/origin.py,
meshes.py): a torus 0.26 across written as OBJ text with every digit, at the origin and moved by 1e5 and 1e6,
gives the same 8-bit picture within 1/255. Before, the file at 1e6 was refused (coordinates over 2^20 times
the mesh's size), and `Mesh.signed_volume`, summed about the world origin, came out with the wrong sign there,
so pencil_shade culled the torus's front faces."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.scene.meshes import Mesh, MeshWarning
from nodegraph.scene.primitives import torus

ROOT = Path(__file__).resolve().parents[3]
DIRECTION = np.array([1.0, 0.6, -0.8])


def small_torus() -> Mesh:
    return torus(0.1, 0.03, 48, 24)


def write_obj(path: Path, v: np.ndarray, f: np.ndarray) -> Path:
    path.write_text("".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in v)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))
    return path


def test_signed_volume_keeps_its_sign_far_away():
    m = small_torus()
    want = m.signed_volume()
    assert want > 0
    for offset in (1e5, 1e6, 1e8):
        far = Mesh("far", m.vertices + DIRECTION * offset, m.faces)
        assert far.signed_volume() == pytest.approx(want, rel=1e-4), offset


@pytest.mark.slow  # three pencil renders, about 1 s each
def test_pencil_far_away_matches_the_origin(gl, tmp_path):
    m = small_torus()
    pictures = {}
    for offset in (0.0, 1e5, 1e6):
        path = write_obj(tmp_path / f"torus_{offset:g}.obj", m.vertices + DIRECTION * offset, m.faces)
        with warnings.catch_warnings():
            warnings.simplefilter("error", MeshWarning)  # read without a repair or a health note
            pipe = pl.load(ROOT / "pipelines" / "pencil.yaml", size=(128, 128), scene=str(path))
        img = Executor(pipe, None, gl=gl).run().values[("shade", "color")].read()
        pictures[offset] = np.rint(np.clip(img[..., :3], 0.0, 1.0) * 255.0)
    covered = (pictures[0.0] < 200).any(axis=2)
    assert covered.mean() > 0.05  # graphite: the torus is drawn
    for offset in (1e5, 1e6):
        diff = np.abs(pictures[offset] - pictures[0.0])
        assert diff.max() <= 1.0, (offset, diff.max(), int((diff > 1).sum()))
