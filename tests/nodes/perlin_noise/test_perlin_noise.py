"""perlin_noise against its float64 CPU twin; white noise uncorrelated, Perlin noise correlated, seeds."""

from __future__ import annotations

import numpy as np
import pytest
from nodegraph_nodes.perlin_noise import PerlinNoise

from nodegraph import pipeline as pl
from nodegraph.errors import PipelineError
from nodegraph.node import derive_seed
from tests.helpers import assert_one_line_located, assert_outputs_as_planned, run_minimal, run_node


# -- noise ----------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["perlin", "white"])
def test_noise_node_matches_float64_cpu(gl, kind):
    size = (120, 72)
    node = PerlinNoise("noise", PerlinNoise.Params(kind=kind, scale=0.013, octaves=4))
    got = run_node(gl, node, {}, size, seed=99)["out"].read()
    from nodegraph.node import derive_seed

    ref = node.reference(size[0], size[1], derive_seed(99, "noise", 0))
    assert np.abs(got - ref).max() < (1e-5 if kind == "perlin" else 1e-6)


@pytest.mark.parametrize(("seed", "octaves", "mode"),
                         [(0, 1, "turbulence"), (7, 12, "fbm"), (2**31 - 7, 5, "turbulence")])
def test_perlin_noise_matches_float64_cpu_across_seeds_and_octaves(gl, seed, octaves, mode):
    # the gradient tables are built per octave from the seed's lattice z: other seeds, octave counts and modes
    size = (97, 61)
    node = PerlinNoise("noise", PerlinNoise.Params(scale=0.031, octaves=octaves, mode=mode))
    got = run_node(gl, node, {}, size, seed=seed)["out"].read()
    from nodegraph.node import derive_seed

    ref = node.reference(size[0], size[1], derive_seed(seed, "noise", 0))
    assert np.abs(got - ref).max() < 1e-5


def test_gradient_tables_give_the_permutation_lookups_bits(gl):
    # one fetch of noise.gradient_table per noise value instead of twelve permutation lookups: the same hashes, so
    # the pass gives the same bits as the lookups (the shader without NOISE_GRAD_TABLE)
    from nodegraph_nodes import perlin_noise as pn
    from nodegraph_nodes._shared import noise

    glsl = pn.PerlinNoise.source_dir() / "perlin_noise.glsl"
    size = (131, 67)
    for seed, octaves, mode in [(3, 4, 0), (123456, 9, 1)]:
        cell, frac = noise.seed_offset_parts(seed)
        uniforms = {"u_scale_split": noise.split_scale(0.029), "u_seed_cell": tuple(int(c) for c in cell),
                    "u_seed_frac": tuple(float(f) for f in frac), "u_octaves": octaves, "u_mode": mode,
                    "u_size": (float(size[0]), float(size[1]))}
        tables = pn.gradient_tables(gl, noise.screen_lattice_z(cell, frac, octaves))
        outs = []
        for defines, textures in [({"KIND": 0}, {}), ({"KIND": 0, "NOISE_GRAD_TABLE": 1}, {"t_noise_grad": tables})]:
            out = gl.texture(size, "RG32F")
            gl.fullscreen(gl.program(glsl, defines, node="test"), [out], textures=textures, uniforms=uniforms)
            outs.append(out.read())
            gl.release(out)
        assert outs[0].tobytes() == outs[1].tobytes()


# -- chalk: white vs Perlin noise ----------------------------------------------------------------
def _lag1(a: np.ndarray, axis: int) -> float:
    a = a - a.mean()
    x = np.moveaxis(a, axis, 0)
    return float((x[1:] * x[:-1]).mean() / (a * a).mean())


def test_white_noise_is_uncorrelated_and_perlin_correlated(gl):
    size = (256, 256)
    perlin = run_node(gl, PerlinNoise("n", PerlinNoise.Params(kind="perlin", scale=0.01)), {}, size, seed=3)
    white = run_node(gl, PerlinNoise("n", PerlinNoise.Params(kind="white")), {}, size, seed=3)
    p, wn = perlin["out"].read(), white["out"].read()
    for c in range(2):
        for axis in (0, 1):
            assert _lag1(p[..., c], axis) > 0.9
            # 65k samples: the estimate's standard deviation is ~0.004
            assert abs(_lag1(wn[..., c], axis)) < 0.02
    # the two channels of the white noise are independent too, and uniform on [0, 1)
    assert abs(np.corrcoef(wn[..., 0].ravel(), wn[..., 1].ravel())[0, 1]) < 0.02
    assert wn.min() >= 0.0 and wn.max() < 1.0 and abs(wn.mean() - 0.5) < 0.01


def test_white_noise_pattern_follows_the_seed(gl):
    size = (64, 64)
    node = PerlinNoise("n", PerlinNoise.Params(kind="white"))
    a = run_node(gl, node, {}, size, seed=1)["out"].read()
    b = run_node(gl, node, {}, size, seed=1)["out"].read()
    c = run_node(gl, node, {}, size, seed=2)["out"].read()
    assert np.array_equal(a, b)
    assert np.mean(a == c) < 0.01
    assert np.array_equal(a, node.reference(64, 64, derive_seed(1, "n", 0)).astype(np.float32))


@pytest.mark.parametrize("size, reference_size, block", [((160, 120), 60, 2), ((96, 90), 30, 3)])
def test_white_grain_is_a_pixel_of_the_reference_size(gl, size, reference_size, block):
    """Above the reference size a white-noise grain covers 1 / px_scale pixels (2x2 at twice the size, 3x3 at
    three times): the GPU equals the float64 CPU twin bit for bit, and that twin is the reference-size noise
    repeated block by block, so chalk frays alike at every size."""
    node = PerlinNoise("n", PerlinNoise.Params(kind="white"))
    seed = derive_seed(5, "n", 0)
    got = run_node(gl, node, {}, size, seed=5, reference_size=reference_size)["out"].read()
    ref = node.reference(size[0], size[1], seed, reference_size=reference_size)
    assert np.array_equal(got, ref.astype(np.float32))
    small = node.reference(-(-size[0] // block), -(-size[1] // block), seed)  # the noise at the reference size
    assert np.array_equal(ref, np.repeat(np.repeat(small, block, 0), block, 1)[:size[1], :size[0]])
    # below it each pixel reads a grain of its own (cells 0, 2, 4, ...: still uncorrelated)
    half = node.reference(40, 30, seed, reference_size=60)
    assert np.array_equal(half, node.reference(80, 60, seed)[::2, ::2])


# -- roster: smoke and shapes -----------------------------------------------------------------------
def test_smoke_in_a_minimal_pipeline_outputs_as_declared_and_planned(gl):
    nodes = """\
  n: {type: perlin_noise}
"""
    ex, res = run_minimal(gl, nodes, {"out": "n.out"})
    assert assert_outputs_as_planned(ex, res, "n") == ["out"]


def test_bad_params_are_located_load_errors():
    for bad, field in (("octaves: 0", "octaves"), ("kind: pink", "kind"), ("scale: 2", "scale")):
        text = (f"pipeline: t\nscene: builtin:box\nnodes:\n  n: {{type: perlin_noise, params: {{{bad}}}}}\n"
                "outputs: {a: n.out}\n")
        with pytest.raises(PipelineError) as e:
            pl.loads(text, "t.yaml")
        assert_one_line_located(e.value, "t.yaml:4:")
        assert field in str(e.value)


def test_scale_is_cycles_per_pixel_at_the_reference_size(gl):
    """At 200 px with reference 400 (px_scale 0.5) the noise is twice the frequency per pixel: the float64
    reference with scale / 0.5, and the same noise values at the same place in the picture as a 400 px
    render (its position 2i + 1 is pixel i's centre here)."""
    from nodegraph.node import derive_seed

    node = PerlinNoise("noise", PerlinNoise.Params(scale=0.013, octaves=3))
    seed = derive_seed(99, "noise", 0)
    got = run_node(gl, node, {}, (200, 120), seed=99, reference_size=240)["out"].read()
    ref = node.reference(200, 120, seed, px_scale=0.5)
    assert np.abs(got - ref).max() < 1e-5
    # independent of the node: Perlin's function at the picture's coordinates, 400 px wide at 0.013 per pixel
    from nodegraph_nodes._shared import noise

    xs = np.arange(200) * 2 + 1.0
    ys = np.arange(120) * 2 + 1.0
    o = noise.seed_offset(seed)
    sx, ty = np.meshgrid(xs, ys)
    fn = noise._octave_fn("turbulence")
    expect = fn(sx * 0.013 + o[0], ty * 0.013 + o[1], np.full(sx.shape, o[2]), 3)
    assert np.abs(ref[..., 0] - expect).max() < 1e-9


def test_white_noise_and_px_scale_in_the_key():
    from nodegraph.node import HashContext

    perlin = PerlinNoise("n", PerlinNoise.Params())
    white = PerlinNoise("n", PerlinNoise.Params(kind="white"))
    h = HashContext((400, 400), 0, 1, None, 800)
    assert h.values_for(perlin)["px_scale"] == 0.5
    assert h.values_for(white)["px_scale"] == 0.5  # its grain is a pixel of the reference size


@pytest.mark.parametrize("dtype", [np.float16, np.float32])
def test_channel_absmax_is_the_largest_magnitude_nan_included(dtype):
    # the half path compares sign-cleared bits as integers; the reference is float64 NumPy on the same values
    from nodegraph_nodes.perlin_noise import channel_absmax

    rng = np.random.default_rng(7)
    for case in range(60):
        a = (rng.standard_normal((9, 13, 2)) * 10.0 ** rng.uniform(-7, 4)).astype(dtype)  # subnormal halves too
        if case % 4 == 1:
            a[rng.integers(9), rng.integers(13), rng.integers(2)] = np.nan
        if case % 5 == 2:
            a[2, 3, 0] = -np.inf
        if case % 6 == 3:
            a[..., 1] = -0.0
        ref = [float(np.abs(a[..., k].astype(np.float64)).max()) for k in (0, 1)]
        got = channel_absmax(a)
        for r, g in zip(ref, got, strict=True):
            assert (np.isnan(r) and np.isnan(g)) or (r == g and not np.signbit(g)), (case, ref, got)
