"""Test helpers shared by test modules: paths, the shared meshes, running one node, the seed 004 kernels."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED_MESHES = ROOT.parent / "shared" / "meshes"
GOLDEN = Path(__file__).parent / "golden"
FAILURES = Path(__file__).parent / "_failures"


def shared_mesh(name: str) -> Path:
    """A mesh from ../shared/meshes, or a skip saying where it was looked for."""
    p = SHARED_MESHES / name
    if not p.exists():
        pytest.skip(f"shared test mesh {name} not found at {p} (the shared/ folder sits beside the repository)")
    return p


def run_node(gl, node, inputs: dict, size: tuple[int, int], frame: int = 0, scene: object = None, seed: int = 0,
             needed: frozenset[str] | None = None, reference_size: int | None = None) -> dict:
    """Compute one node outside a pipeline (declared output formats); without `reference_size` the image is
    its own reference (px_scale 1)."""
    from nodegraph.node import RunContext

    ctx = RunContext(node, gl=gl, size=size, frame=frame, pipeline_seed=seed, scene=scene,
                     reference_size=reference_size)
    return node.compute(ctx, inputs, frozenset(node.outputs) if needed is None else needed)


# The kernels of seed 004 (Curtis' loose and sketchy method) exactly as printed.
SEED_TENT = np.array([[1, 2, 1], [2, 4, 2], [1, 2, 1]], float)
SEED_GX = np.array([[-1, -2, -1], [0, 0, 0], [1, 2, 1]], float)
SEED_GY = np.array([[1, 0, -1], [2, 0, -2], [1, 0, -1]], float)


def seed_weights(k: np.ndarray) -> np.ndarray:
    """The seed's k[x][y] (y down the image) as a weight array over our [row (y up), col (x)]."""
    return np.flipud(k.T)


# A one-rasterize pipeline around extra nodes: `extra` adds node lines, `g_in` connects the rasterizer's inputs.
RASTER = """\
pipeline: t
size: [96, 80]
scene: {scene}
nodes:
{extra}
  g: {{type: rasterize{g_in}}}
outputs:
  image: g.normal_depth
"""


def render_normal_depth(gl, text: str) -> np.ndarray:
    """Run a pipeline given as YAML text (named t.yaml) without a cache; rasterize `g`'s normal_depth."""
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor

    pipe = pl.loads(text, "t.yaml")
    return Executor(pipe, None, gl=gl).run().values[("g", "normal_depth")].read()


def inspect_probe(tmp_path: Path, text: str, scene: Path, size: tuple[int, int],
                  wanted: list[tuple[str, int]]) -> list[np.ndarray]:
    """The pipeline `text` (written as tmp_path/probe.yaml) on `scene` at `size`, without a cache: each
    (NODE.PORT, frame) of `wanted` inspected."""
    import nodegraph as ng

    probe = tmp_path / "probe.yaml"
    probe.write_text(text)
    with ng.Session(cache=False) as session:
        pipe = session.load(probe, scene=str(scene), size=size)
        return [pipe.inspect(ref, frame=frame) for ref, frame in wanted]


# -- the per-node roster: a minimal pipeline, outputs as declared and planned, located errors ----------
def run_minimal(gl, nodes: str, outputs: dict[str, str], size: tuple[int, int] = (48, 40),
                scene: str = "builtin:box", seed: int = 5, requested: list | None = None, **load_kw):
    """Load and run (no cache) a pipeline of `nodes` (YAML lines, indented two spaces) named t.yaml;
    returns (executor, result)."""
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor

    outs = "".join(f"  {name}: {ref}\n" for name, ref in outputs.items())
    # the image is its own reference size (px_scale 1): params in pixels of this small image
    text = (f"pipeline: t\nsize: [{size[0]}, {size[1]}]\nreference_size: {min(size)}\nscene: {scene}\nseed: {seed}\n"
            f"nodes:\n{nodes}\noutputs:\n{outs}")
    ex = Executor(pl.loads(text, "t.yaml", **load_kw), None, requested=requested, gl=gl)
    return ex, ex.run()


def assert_outputs_as_planned(ex, res, nid: str) -> list[str]:
    """Every output of node `nid` that the run returned is a value of the declared port type; textures
    are in the planned format (never more precise than declared), at the size and layer count the node
    declares (`output_shape`), and read back as finite float32 (H, W, C). Returns the ports checked."""
    from nodegraph import types
    from nodegraph.values import Tex, TexArray

    node = ex.plan.pipeline.nodes[nid]
    size = tuple(ex.plan.pipeline.size)
    checked = []
    for (vid, port), value in res.values.items():
        if vid != nid:
            continue
        declared = node.outputs[port].type
        checked.append(port)
        if not declared.is_texture:
            assert type(value).__name__ == {"File": "PosixPath"}.get(declared.kind, declared.kind), (port, value)
            continue
        fmt = ex.plan.formats[(nid, port)]
        assert declared.fmt is None or types.precision(fmt) <= types.precision(declared.fmt), (port, fmt)
        assert value.fmt == fmt, (port, value.fmt, fmt)
        w, h, layers = node.output_shape(port, size)
        assert value.size == (w, h), (port, value.size, (w, h))
        arr = value.read()
        if declared.kind == "TextureArray":
            assert isinstance(value, TexArray) and value.layers == layers
            assert arr.shape == (layers, h, w, types.components(fmt)), (port, arr.shape)
        else:
            assert isinstance(value, Tex)
            assert arr.shape == (h, w, types.components(fmt)), (port, arr.shape)
        assert arr.dtype == np.float32 and np.isfinite(arr).all(), port
    assert checked, f"the run returned no output of {nid!r}"
    return sorted(checked)


def assert_one_line_located(exc: BaseException, where: str) -> None:
    """A load-time error is one line and starts with its location (`t.yaml:LINE:COL`)."""
    text = str(exc)
    assert "\n" not in text.strip(), text
    assert text.startswith(where), text


def yuv420_reference(rgb8: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """BT.601 limited-range 4:2:0 of 8-bit RGB (H, W, 3), rows top first, in float64 before rounding: the size
    padded to even by repeating the last column/row, Y = 16 + 219/255 (0.299 R + 0.587 G + 0.114 B), chroma
    from the mean RGB of each 2x2 block, Cb = 128 + 224/255 (B - Y') / 1.772, Cr = 128 + 224/255 (R - Y') / 1.402
    (Y' the unscaled luma of the mean)."""
    x = rgb8.astype(np.float64)
    h, w = x.shape[:2]
    x = np.pad(x, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")
    k = np.array([0.299, 0.587, 0.114])
    y = 16.0 + 219.0 / 255.0 * (x @ k)
    m = (x[0::2, 0::2] + x[0::2, 1::2] + x[1::2, 0::2] + x[1::2, 1::2]) / 4.0
    luma = m @ k
    cb = 128.0 + 224.0 / 255.0 * (m[..., 2] - luma) / 1.772
    cr = 128.0 + 224.0 / 255.0 * (m[..., 0] - luma) / 1.402
    return y, cb, cr


def assert_rounds_to(got: np.ndarray, ref: np.ndarray, what: str = "") -> None:
    """`got` (uint8) is `ref` (float64) rounded half to even and clamped to [0, 255]; where `ref` lies within
    1e-3 of a tie (x.5), where float32 arithmetic may round the other way, it may be 1 off."""
    want = np.clip(np.rint(ref), 0, 255)
    near_tie = np.abs(np.abs(ref - np.floor(ref)) - 0.5) < 1e-3
    diff = np.abs(got.astype(np.int64) - want.astype(np.int64))
    bad = (diff > 1) | ((diff == 1) & ~near_tie)
    assert not bad.any(), f"{what}: {int(bad.sum())} of {bad.size} values off, first at {np.argwhere(bad)[0]}"
