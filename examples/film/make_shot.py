"""Builds the README's short film: a skinned tentacle (a tapered tube on a chain of four joints) waving for two
seconds on a floor, with a ball rolling past, as a glTF file and a scene YAML that places it.

    python examples/film/make_shot.py out/shot          # writes out/shot/tentacle.glb and out/shot/shot.yaml
    sketchgraph run pencil --scene out/shot/shot.yaml --fps 12 --size 288x288 \\
        --set distortion.hold=2 --set contour.hold=2 -o docs/images/film_pencil.gif
    sketchgraph run object_space_uncertainty --scene out/shot/shot.yaml --frames 0:48:4 --size 240x240 \\
        -o out/shot/osu/f_####.png
    python examples/film/make_shot.py sheet docs/images/film_object_space.png out/shot/osu/f_*.png

Everything is generated here (pygltflib and NumPy); nothing binary is committed but the rendered film.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pygltflib as g

FLOAT, UBYTE = 5126, 5121
HEIGHT, JOINTS, SECONDS = 2.4, 4, 2.0
SEGMENT = 0.6  # joint spacing along +y


def tentacle_mesh(rings: int = 48, segments: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """A tube along +y from 0 to HEIGHT tapering from radius 0.3 to 0.07, closed at the base and by a tip."""
    ys = np.linspace(0.0, HEIGHT, rings)
    ang = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    r = 0.3 - 0.23 * ys / HEIGHT
    v = [[rr * math.cos(a), y, -rr * math.sin(a)] for y, rr in zip(ys, r, strict=True) for a in ang]
    v += [[0.0, 0.0, 0.0], [0.0, HEIGHT + 0.08, 0.0]]
    f = []
    for i in range(rings - 1):
        for k in range(segments):
            k1 = (k + 1) % segments
            a, b, c, d = i * segments + k, i * segments + k1, (i + 1) * segments + k1, (i + 1) * segments + k
            f += [[a, b, c], [a, c, d]]
    base, tip, last = rings * segments, rings * segments + 1, (rings - 1) * segments
    f += [[base, (k + 1) % segments, k] for k in range(segments)]
    f += [[tip, last + k, last + (k + 1) % segments] for k in range(segments)]
    return np.array(v, np.float32), np.array(f, np.uint32)


def skin_weights(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each vertex blends the two joints around its height linearly (the top one alone above the last)."""
    s = np.clip(v[:, 1] / SEGMENT, 0.0, JOINTS - 1)
    i = np.minimum(np.floor(s).astype(np.int64), JOINTS - 2)
    frac = s - i
    joints = np.zeros((len(v), 4), np.uint8)
    weights = np.zeros((len(v), 4), np.float32)
    joints[:, 0], joints[:, 1] = i, i + 1
    weights[:, 0], weights[:, 1] = 1.0 - frac, frac
    return joints, weights


def quat(axis: tuple[float, float, float], degrees: float) -> np.ndarray:
    h = math.radians(degrees) / 2
    return np.array([*(np.asarray(axis) * math.sin(h)), math.cos(h)])


def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    (ax, ay, az, aw), (bx, by, bz, bw) = a, b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


class Doc:
    def __init__(self) -> None:
        self.gltf = g.GLTF2(scene=0, scenes=[g.Scene(nodes=[])])
        self.blob = bytearray()

    def accessor(self, data: np.ndarray, kind: str, ctype: int = FLOAT, minmax: bool = False) -> int:
        arr = np.ascontiguousarray(data)
        while len(self.blob) % 4:
            self.blob += b"\0"
        self.gltf.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=arr.nbytes))
        self.blob += arr.tobytes()
        acc = g.Accessor(bufferView=len(self.gltf.bufferViews) - 1, componentType=ctype, count=arr.shape[0],
                         type=kind)
        if minmax:
            flat = arr.reshape(arr.shape[0], -1).astype(np.float64)
            acc.min, acc.max = flat.min(axis=0).tolist(), flat.max(axis=0).tolist()
        self.gltf.accessors.append(acc)
        return len(self.gltf.accessors) - 1

    def save(self, path: Path) -> None:
        self.gltf.buffers = [g.Buffer(byteLength=len(self.blob))]
        self.gltf.set_binary_blob(bytes(self.blob))
        self.gltf.save_binary(str(path))


def tentacle(path: Path) -> None:
    d = Doc()
    v, f = tentacle_mesh()
    joints, weights = skin_weights(v)
    attrs = g.Attributes(POSITION=d.accessor(v, "VEC3", minmax=True), JOINTS_0=d.accessor(joints, "VEC4", UBYTE),
                         WEIGHTS_0=d.accessor(weights, "VEC4"))
    d.gltf.materials.append(g.Material(pbrMetallicRoughness=g.PbrMetallicRoughness(
        baseColorFactor=[0.45, 0.55, 0.35, 1.0])))
    d.gltf.meshes.append(g.Mesh(primitives=[g.Primitive(attributes=attrs, material=0,
                                                        indices=d.accessor(f.reshape(-1), "SCALAR", 5125))]))
    # the joint chain: j0 at the base, each next one SEGMENT higher, a child of the one below
    for i in range(JOINTS):
        children = [i + 1] if i + 1 < JOINTS else []
        d.gltf.nodes.append(g.Node(name=f"j{i}", children=children,
                                   translation=[0.0, 0.0 if i == 0 else SEGMENT, 0.0]))
    d.gltf.scenes[0].nodes.append(0)
    ibm = np.stack([np.eye(4) for _ in range(JOINTS)])
    ibm[:, 1, 3] = -SEGMENT * np.arange(JOINTS)
    d.gltf.skins.append(g.Skin(joints=list(range(JOINTS)), inverseBindMatrices=d.accessor(
        ibm.transpose(0, 2, 1).astype(np.float32).reshape(JOINTS, 16), "MAT4")))
    d.gltf.nodes.append(g.Node(name="tentacle", mesh=0, skin=0))
    d.gltf.scenes[0].nodes.append(JOINTS)
    # a wave running up the chain: every joint sways about z and nods about x, later the higher it is
    times = np.linspace(0.0, SECONDS, 49)
    an = g.Animation(name="wave")
    t_acc = d.accessor(times.astype(np.float32), "SCALAR", minmax=True)
    for i in range(JOINTS):
        sway, nod = (8.0, 16.0, 22.0, 26.0)[i], (4.0, 8.0, 10.0, 12.0)[i]
        ph = 2 * math.pi * times / SECONDS
        q = np.stack([qmul(quat((0, 0, 1), sway * math.sin(p - 0.9 * i)), quat((1, 0, 0), nod * math.sin(p + 0.6 * i)))
                      for p in ph])
        an.samplers.append(g.AnimationSampler(input=t_acc, output=d.accessor(q.astype(np.float32), "VEC4")))
        an.channels.append(g.AnimationChannel(sampler=len(an.samplers) - 1,
                                              target=g.AnimationChannelTarget(node=i, path="rotation")))
    d.gltf.animations.append(an)
    d.save(path)


SHOT = """\
# The README's film (examples/film/make_shot.py writes this file and tentacle.glb beside it)
scene: tentacle-shot
fps: 24
objects:
  - name: tentacle
    gltf: tentacle.glb
  - name: floor
    primitive: {type: box, size: [4.0, 0.1, 2.4]}
    color: [0.85, 0.8, 0.7]
    transform: {translate: [0, -0.05, 0]}
  - name: ball
    primitive: {type: sphere, radius: 0.3, subdiv: 3}
    color: [0.8, 0.45, 0.3]
    animate:
      translate:
        - {time: 0, value: [-1.4, 0.3, 0.6], interpolation: smooth}
        - {time: 2, value: [1.4, 0.3, 0.6]}
      rotate:
        - {time: 0, value: [0, 0, 0]}
        - {time: 2, value: [0, 0, -573]}
camera:
  eye: [0.3, 2.2, 6.4]
  target: [0, 0.95, 0]
  fov: 38
"""


def sheet(out: str, frames: list[str], columns: int = 6) -> None:
    """A contact sheet of rendered frames (PNG files named ..._NNNN.png), labelled with their frame numbers."""
    from PIL import Image

    from nodegraph.tools.viz import Cell, contact_sheet

    cells = [Cell(np.asarray(Image.open(f).convert("RGB"), np.float32) / 255.0, [f"frame {int(Path(f).stem[-4:])}"])
             for f in sorted(frames)]
    img = contact_sheet(cells, cell=200, columns=columns)
    Image.fromarray((np.clip(img, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)).save(out, optimize=True)
    print(f"wrote {out} ({len(cells)} frames)")


def main(out: str) -> None:
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    tentacle(folder / "tentacle.glb")
    (folder / "shot.yaml").write_text(SHOT)
    print(f"wrote {folder / 'tentacle.glb'} and {folder / 'shot.yaml'}")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "sheet":
        sheet(sys.argv[2], sys.argv[3:])
    else:
        main(sys.argv[1] if len(sys.argv) > 1 else "out/shot")
