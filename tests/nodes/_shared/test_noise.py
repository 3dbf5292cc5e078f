"""Noise core of the `perlin_noise` node: float64 reference, published values, statistics, GPU vs CPU."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

if TYPE_CHECKING:
    import moderngl

ROOT = Path(__file__).resolve().parents[3]
if str(ROOT) not in sys.path:  # until the project configures pytest's pythonpath
    sys.path.insert(0, str(ROOT))

from nodegraph_nodes._shared import noise as ref  # noqa: E402

GLSL_INCLUDE = ROOT / "nodes" / "perlin_noise" / "improved_noise.glsl"

# Ken Perlin's Java ImprovedNoise.noise(3.14, 42, 7), the value quoted wherever his reference
# implementation is ported (e.g. the Rosetta Code "Perlin noise" task); reproduced to the last bit by
# ref._scalar_reference_noise. The second pair is quoted next to it by several ports and also agrees.
PUBLISHED = [((3.14, 42.0, 7.0), 0.13691995878400012),
             ((-4.20, 10.0, 6.0), 0.14208000000000043)]


def _neighbour_r(a: np.ndarray) -> tuple[float, float]:
    """Pearson correlation of horizontally and vertically adjacent values of a 2D array."""
    h = np.corrcoef(a[:, :-1].ravel(), a[:, 1:].ravel())[0, 1]
    v = np.corrcoef(a[:-1, :].ravel(), a[1:, :].ravel())[0, 1]
    return float(h), float(v)


# --- reference --------------------------------------------------------------------------------------

def test_perm_is_perlins_table():
    assert ref.PERM.dtype == np.uint8 and ref.PERM.shape == (256,)
    assert sorted(ref.PERM.tolist()) == list(range(256))
    assert ref.PERM[:6].tolist() == [151, 160, 137, 91, 90, 15]
    assert ref.PERM[-6:].tolist() == [78, 66, 215, 61, 156, 180]
    assert ref.perm_texture_bytes() == bytes(ref.PERM.tolist())


def test_published_reference_values():
    for (x, y, z), want in PUBLISHED:
        assert ref._scalar_reference_noise(x, y, z) == want
        assert float(ref.improved_noise(x, y, z)) == pytest.approx(want, abs=1e-15)


def test_vectorised_equals_scalar_transcription():
    rng = np.random.default_rng(1234)
    pts = np.concatenate([
        rng.uniform(-300.0, 300.0, (2000, 3)),
        rng.uniform(-2.0, 2.0, (1000, 3)),
        np.round(rng.uniform(-50, 50, (500, 3))) + rng.choice([0.0, 1e-9, -1e-9, 0.5], (500, 3)),
    ])
    got = ref.improved_noise(pts[:, 0], pts[:, 1], pts[:, 2])
    want = np.array([ref._scalar_reference_noise(*p) for p in pts.tolist()])
    assert got.dtype == np.float64 and got.shape == (len(pts),)
    assert np.max(np.abs(got - want)) <= 1e-12


def test_noise_zero_on_lattice_bounded_and_broadcasts():
    rng = np.random.default_rng(5)
    lattice = rng.integers(-1000, 1000, (500, 3)).astype(np.float64)
    assert np.all(ref.improved_noise(*lattice.T) == 0.0)
    pts = rng.uniform(-100, 100, (200_000, 3))
    n = ref.improved_noise(*pts.T)
    assert np.all(np.abs(n) <= 1.0)
    assert 0.3 < np.abs(n).max() <= 1.0 and abs(n.mean()) < 0.01
    assert ref.improved_noise(np.zeros((4, 1)), np.zeros(5), 0.5).shape == (4, 5)
    # the lattice index wraps every 256 units, also for coordinates far beyond int64
    assert ref.improved_noise(0.25 + 256 * 7, -0.75 - 256 * 3, 1e20) == ref.improved_noise(0.25, -0.75, 1e20)


def test_turbulence_and_fbm_are_octave_sums():
    rng = np.random.default_rng(6)
    x, y, z = rng.uniform(-20, 20, (3, 10_000))
    t = ref.turbulence(x, y, z, 4)
    assert np.all(t >= 0.0)
    want_t = sum(np.abs(ref.improved_noise(2**i * x, 2**i * y, 2**i * z)) / 2**i for i in range(4))
    want_f = sum(ref.improved_noise(2**i * x, 2**i * y, 2**i * z) / 2**i for i in range(4))
    np.testing.assert_allclose(t, want_t, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ref.fbm(x, y, z, 4), want_f, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(ref.turbulence(x, y, z, 1), np.abs(ref.improved_noise(x, y, z)))
    np.testing.assert_array_equal(ref.turbulence(x, y, z, 0), np.zeros_like(x))
    assert np.abs(ref.fbm(x, y, z, 4)).max() <= 2.0


def test_seed_offset():
    for seed in (0, 1, 7, 12345, 2**31, -1):
        o = ref.seed_offset(seed)
        cell, frac = ref.seed_offset_parts(seed)
        assert o.shape == (3,) and o.dtype == np.float64
        np.testing.assert_array_equal(o, ref.seed_offset(seed))
        assert np.all((o >= 0) & (o < 256))
        assert np.all((frac > 0) & (frac < 1)), "fraction never 0: pixel grids stay off the lattice"
        np.testing.assert_array_equal(cell + frac.astype(np.float64), o)
        np.testing.assert_array_equal(o.astype(np.float32).astype(np.float64), o)
    np.testing.assert_array_equal(ref.seed_offset(-1), ref.seed_offset(2**32 - 1))
    assert len({tuple(ref.seed_offset(s)) for s in range(200)}) == 200


@pytest.mark.slow  # 1.4 s
def test_different_seeds_give_unrelated_patterns():
    a = ref.screen_offsets(256, 256, 0.2, 4, seed=1)
    b = ref.screen_offsets(256, 256, 0.2, 4, seed=2)
    r = np.corrcoef(a[..., 0].ravel(), b[..., 0].ravel())[0, 1]
    assert abs(r) < 0.1
    np.testing.assert_array_equal(a, ref.screen_offsets(256, 256, 0.2, 4, seed=1))


def test_screen_offsets_mapping():
    w, h, scale, oct_, seed = 40, 30, 0.05, 3, 9
    off = ref.screen_offsets(w, h, scale, oct_, seed)
    assert off.shape == (h, w, 2) and off.dtype == np.float64
    o = ref.seed_offset(seed)
    for x, y in [(0, 0), (39, 0), (0, 29), (17, 11)]:
        s, t = (x + 0.5) / w, (y + 0.5) / h  # row 0 = bottom row
        want_s = ref.turbulence(s * w * scale + o[0], t * h * scale + o[1], o[2], oct_)
        want_t = ref.turbulence((1 - s) * w * scale + o[0], (1 - t) * h * scale + o[1], o[2], oct_)
        assert off[y, x, 0] == pytest.approx(float(want_s), abs=1e-13)
        assert off[y, x, 1] == pytest.approx(float(want_t), abs=1e-13)
    # the paper's off_t is off_s turned by 180 degrees
    np.testing.assert_allclose(off[..., 1], off[::-1, ::-1, 0], rtol=0, atol=1e-13)
    assert np.all(off >= 0)
    f = ref.screen_offsets(w, h, scale, oct_, seed, mode="fbm")
    assert f.min() < 0 < f.max()


def test_noise3_at():
    rng = np.random.default_rng(3)
    pts = rng.uniform(-5, 5, (1000, 3))
    v = ref.noise3_at(pts, 4, seed=11)
    assert v.shape == (1000, 2) and v.dtype == np.float64 and np.all(v >= 0)
    q = pts + ref.seed_offset(11)
    np.testing.assert_array_equal(v[:, 0], ref.turbulence(*q.T, 4))
    np.testing.assert_array_equal(v[:, 1], ref.turbulence(*(q + ref.CHANNEL1_OFFSET).T, 4))
    assert abs(np.corrcoef(v[:, 0], v[:, 1])[0, 1]) < 0.15
    assert ref.noise3_at(pts.reshape(10, 100, 3), 2, 0, "fbm", scale=0.5).shape == (10, 100, 2)
    np.testing.assert_array_equal(ref.noise3_at(pts, 2, 0, "fbm", scale=2.0)[:, 0],
                                  ref.fbm(*(2.0 * pts + ref.seed_offset(0)).T, 2))


def test_hash_u32_is_pcg_hash():
    def pcg(v: int) -> int:  # plain-int transcription of the formula in the module docstring
        m = 0xFFFFFFFF
        state = (v * 747796405 + 2891336453) & m
        word = (((state >> ((state >> 28) + 4)) ^ state) * 277803737) & m
        return ((word >> 22) ^ word) & m

    keys = np.array([0, 1, 2, 255, 2**31, 2**32 - 1, 123456789], dtype=np.uint32)
    got = ref.hash_u32(keys)
    assert got.dtype == np.uint32
    assert got.tolist() == [pcg(int(k)) for k in keys]
    assert ref.hash_u32(np.array([-1])).tolist() == [pcg(2**32 - 1)]


def test_white_offsets():
    w = ref.white_offsets(256, 256, seed=5)
    assert w.shape == (256, 256, 2) and w.dtype == np.float64
    assert w.min() >= 0.0 and w.max() < 1.0
    assert abs(w.mean() - 0.5) < 0.01 and abs(w.var() - 1 / 12) < 0.005
    np.testing.assert_array_equal(w * 2**24, np.floor(w * 2**24))  # 24-bit values, exact in float32
    np.testing.assert_array_equal(w, ref.white_offsets(256, 256, seed=5))
    assert not np.array_equal(w, ref.white_offsets(256, 256, seed=6))
    assert not np.array_equal(w, ref.white_offsets(256, 256, seed=5, frame=1))
    assert abs(np.corrcoef(w[..., 0].ravel(), w[..., 1].ravel())[0, 1]) < 0.02


def test_white_is_uncorrelated_perlin_is_coherent():
    white = ref.white_offsets(256, 256, seed=3)
    perlin = ref.screen_offsets(256, 256, 0.02, 4, seed=3)
    for c in (0, 1):
        rw = _neighbour_r(white[..., c])
        rp = _neighbour_r(perlin[..., c])
        assert max(abs(r) for r in rw) < 0.05, rw
        assert min(rp) > 0.9, rp


def test_errors():
    with pytest.raises(ValueError, match="mode"):
        ref.screen_offsets(8, 8, 0.1, 2, 0, mode="simplex")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="octaves"):
        ref.turbulence(0.5, 0.5, 0.5, -1)
    with pytest.raises(ValueError, match="octaves"):
        ref.fbm(0.5, 0.5, 0.5, 2.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="size"):
        ref.white_offsets(0, 8, 1)
    with pytest.raises(ValueError, match="points"):
        ref.noise3_at(np.zeros((4, 2)), 2, 0)
    with pytest.raises(TypeError):
        ref.hash_u32(np.array([0.5]))


def test_split_scale():
    for scale in (0.02, 0.37, 1.0, 3.0e-4, 12.345, 1 / 3):
        hi, lo = ref.split_scale(scale)
        assert abs((hi + lo) - scale) <= 2.0**-33 * scale
        assert np.float32(hi) == hi and np.float32(lo) == lo
        x = np.arange(8192, dtype=np.float64) + 0.5
        np.testing.assert_array_equal((x.astype(np.float32) * np.float32(hi)).astype(np.float64), x * hi)


# --- GPU (llvmpipe through EGL) vs CPU ------------------------------------------------------------

_VS = """#version 330
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""

_FS = """#version 330
#include "improved_noise.glsl"
uniform int u_what;
uniform vec2 u_size;
uniform vec2 u_scale_split;
uniform ivec3 u_seed_cell;
uniform vec3 u_seed_frac;
uniform int u_octaves;
uniform int u_mode;
uniform uint u_seed;
uniform uint u_frame;
uniform float u_scale;
uniform sampler2D t_points;
out vec2 f_out;
void main() {
    vec3 point = texelFetch(t_points, ivec2(gl_FragCoord.xy), 0).xyz;
    if (u_what == 0) {
        f_out = screen_offset(gl_FragCoord.xy, u_size, u_scale_split, u_seed_cell, u_seed_frac,
                              u_octaves, u_mode);
    } else if (u_what == 1) {
        f_out = white_offset(uvec2(gl_FragCoord.xy), u_seed, u_frame);
    } else if (u_what == 2) {
        f_out = noise3_at(point, u_scale, u_seed_cell, u_seed_frac, u_octaves, u_mode);
    } else {
        f_out = vec2(improved_noise(point), u_mode == NOISE_FBM ? fbm(point, u_octaves)
                                                                : turbulence(point, u_octaves));
    }
}
"""


class _Gpu:
    def __init__(self, gl) -> None:
        import moderngl

        self.mgl = moderngl
        self.ctx = gl.ctx  # the one test context (tests/conftest.py)
        fs = _FS.replace('#include "improved_noise.glsl"', GLSL_INCLUDE.read_text())
        self.prog = self.ctx.program(vertex_shader=_VS, fragment_shader=fs)
        self.perm = self.ctx.texture((256, 1), 1, ref.perm_texture_bytes(), dtype="u1")
        self.perm.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.vao = self.ctx.vertex_array(self.prog, [])
        self._fbos: dict[tuple[int, int], moderngl.Framebuffer] = {}
        self._set("t_perm", 0)
        self._set("t_points", 1)

    def _set(self, name: str, value: object) -> None:
        if name in self.prog:  # the compiler drops uniforms a branch does not need
            self.prog[name].value = value

    def render(self, width: int, height: int, points: np.ndarray | None = None,
               **uniforms: object) -> np.ndarray:
        ctx, mgl = self.ctx, self.mgl
        pts = np.zeros((height, width, 3), np.float32) if points is None else points.astype(np.float32)
        t_points = ctx.texture((width, height), 3, np.ascontiguousarray(pts).tobytes(), dtype="f4")
        t_points.filter = (mgl.NEAREST, mgl.NEAREST)
        fbo = self._framebuffer(width, height)
        try:
            fbo.use()
            fbo.viewport = (0, 0, width, height)
            self.perm.use(0)
            t_points.use(1)
            for name, value in uniforms.items():
                self._set(name, value)
            self.vao.render(mgl.TRIANGLES, vertices=3)
            out = np.frombuffer(fbo.read(components=2, dtype="f4"), np.float32).reshape(height, width, 2)
            assert ctx.error == "GL_NO_ERROR"
            return out.astype(np.float64)
        finally:
            t_points.release()

    def _framebuffer(self, width: int, height: int) -> moderngl.Framebuffer:
        # kept until the context goes: moderngl rebinds the last bound framebuffer when it creates
        # one, which is GL_INVALID_OPERATION if that one was released
        key = (width, height)
        if key not in self._fbos:
            self._fbos[key] = self.ctx.framebuffer(
                color_attachments=[self.ctx.texture((width, height), 2, dtype="f4")])
        return self._fbos[key]

    def seed_uniforms(self, seed: int) -> dict[str, object]:
        cell, frac = ref.seed_offset_parts(seed)
        return {"u_seed_cell": tuple(int(c) for c in cell), "u_seed_frac": tuple(float(f) for f in frac)}


@pytest.fixture(scope="module")
def gpu(gl):
    g = _Gpu(gl)
    assert g.ctx.error == "GL_NO_ERROR"
    return g


MODE_ID = {"turbulence": 0, "fbm": 1}
# Measured on llvmpipe: <= 1.7e-6 everywhere. A naive float32 mapping (offset added as a float, one
# float32 scale) gives 3e-5 at 64x48 and up to 8e-4 at coordinates of a few thousand; 1e-5 catches that.
GPU_TOL = 1e-5


@pytest.mark.slow  # 4.9 s (turbulence)
@pytest.mark.parametrize("mode", ["turbulence", "fbm"])
def test_gpu_screen_offsets_match_reference(gpu, mode):
    w, h, scale, octaves, seed = 64, 48, 0.05, 4, 7
    got = gpu.render(w, h, u_what=0, u_size=(w, h), u_scale_split=ref.split_scale(scale),
                     u_octaves=octaves, u_mode=MODE_ID[mode], **gpu.seed_uniforms(seed))
    want = ref.screen_offsets(w, h, scale, octaves, seed, mode)
    err = np.abs(got - want).max()
    print(f"screen {mode} {w}x{h}: max |GPU - CPU| = {err:.3g}")
    assert err <= GPU_TOL


@pytest.mark.slow  # 3.4 s
def test_gpu_screen_offsets_wide_image_large_coordinates(gpu):
    """4096 px wide at 0.37 cycles/px: noise coordinates up to ~1500 before the seed offset."""
    w, h, scale, octaves, seed = 4096, 8, 0.37, 4, 2024
    got = gpu.render(w, h, u_what=0, u_size=(w, h), u_scale_split=ref.split_scale(scale),
                     u_octaves=octaves, u_mode=0, **gpu.seed_uniforms(seed))
    err = np.abs(got - ref.screen_offsets(w, h, scale, octaves, seed)).max()
    print(f"screen turbulence {w}x{h} scale {scale}: max |GPU - CPU| = {err:.3g}")
    assert err <= GPU_TOL


@pytest.mark.parametrize("seed,frame", [(0, 0), (7, 3), (2**32 - 5, 2**31 + 1)])
def test_gpu_white_offsets_exact(gpu, seed, frame):
    w, h = 64, 48
    got = gpu.render(w, h, u_what=1, u_seed=seed & 0xFFFFFFFF, u_frame=frame & 0xFFFFFFFF)
    want = ref.white_offsets(w, h, seed, frame)
    assert np.abs(got - want).max() <= 1e-6
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("extent", [4.0, 3000.0])
@pytest.mark.parametrize("mode", ["turbulence", "fbm"])
def test_gpu_noise3_at_points(gpu, mode, extent):
    w, h, octaves, seed = 64, 48, 4, 99
    rng = np.random.default_rng(int(extent) + MODE_ID[mode])
    pts = rng.uniform(-extent, extent, (h, w, 3)).astype(np.float32)
    got = gpu.render(w, h, pts, u_what=2, u_scale=1.0, u_octaves=octaves, u_mode=MODE_ID[mode],
                     **gpu.seed_uniforms(seed))
    want = ref.noise3_at(pts.astype(np.float64), octaves, seed, mode)
    err = np.abs(got - want).max()
    print(f"noise3_at {mode} |p| <= {extent}: max |GPU - CPU| = {err:.3g}")
    assert err <= GPU_TOL


def test_gpu_plain_noise_and_turbulence(gpu):
    """improved_noise / turbulence without offsets, negative coordinates included (floor of negatives)."""
    w, h, octaves = 64, 48, 4
    rng = np.random.default_rng(17)
    pts = rng.uniform(-40, 40, (h, w, 3)).astype(np.float32)
    pts[0, :8] = [[-1, -2, -3], [0, 0, 0], [-0.5, -0.5, -0.5], [255, 256, -256], [-1e-3, 2, 3],
                  [3.14, 42, 7], [-4.2, 10, 6], [1, 1, 1]]
    got = gpu.render(w, h, pts, u_what=3, u_octaves=octaves, u_mode=0)
    p = pts.astype(np.float64)
    want = np.stack([ref.improved_noise(*np.moveaxis(p, -1, 0)),
                     ref.turbulence(*np.moveaxis(p, -1, 0), octaves)], axis=-1)
    err = np.abs(got - want).max(axis=(0, 1))
    print(f"plain noise / turbulence: max |GPU - CPU| = {err[0]:.3g} / {err[1]:.3g}")
    assert err.max() <= GPU_TOL
    assert got[0, 0, 0] == 0.0 and got[0, 1, 0] == 0.0
