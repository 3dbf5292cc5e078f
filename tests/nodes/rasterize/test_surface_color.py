"""glTF colour in `rasterize`'s colour output: base colour textures through TEXCOORD_n (KHR_texture_transform,
wrap modes, NEAREST filtering), alpha MASK cut-outs, vertex colours and the factor, read back against texel
values and a float64 reference of the glTF spec's formulas. The quad (tests/gltf_files.py) fills the square image
exactly, its top-left corner at uv (0, 0)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from nodegraph import pipeline as pl
from nodegraph.executor import Executor
from nodegraph.scene import gltf
from tests import gltf_files as gf

N = 64  # image size: a 4x4 texture's texel is 16x16 pixels


def _checker() -> np.ndarray:
    tex = np.zeros((4, 4, 3), np.uint8)
    for r in range(4):
        for c in range(4):
            tex[r, c] = (30 + 60 * c, 30 + 60 * r, 220 - 25 * (r + c))
    return tex


def _render(gl, path: Path, port: str = "color") -> np.ndarray:
    """`port` of a rasterize node over the file's scene, rows from the image's top."""
    text = (f"pipeline: t\nsize: [{N}, {N}]\nscene: {path}\nnodes:\n  g: {{type: rasterize}}\n"
            f"outputs:\n  image: g.{port}\n")
    res = Executor(pl.loads(text, str(path.with_suffix(".yaml"))), None, gl=gl).run()
    return np.flipud(res.values[("g", port)].read())


def _srgb(c: np.ndarray) -> np.ndarray:
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def _linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _reference(tex: np.ndarray, matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel centre: the texel NEAREST sampling with REPEAT reads through uv' = matrix (u, v, 1), and whether
    the pixel lies at least 1/4 pixel (in uv') away from a texel border (only those are compared)."""
    px = (np.arange(N) + 0.5) / N
    u, v = np.meshgrid(px, px)  # rows from the top: v grows downwards, as glTF's does
    uv = np.stack([u, v, np.ones_like(u)], -1) @ matrix[:2].T
    h, w = tex.shape[:2]
    s, t = uv[..., 0] * w, uv[..., 1] * h
    step = np.abs(matrix[:2, :2]).sum() * max(w, h) / N  # uv' change across a pixel, in texels (upper bound)
    clear = (np.abs(s - np.rint(s)) > step / 4) & (np.abs(t - np.rint(t)) > step / 4)
    texel = tex[np.floor(t).astype(int) % h, np.floor(s).astype(int) % w]
    return texel, clear


def test_a_checker_texture_shows_each_texel_at_its_pixels(gl, tmp_path: Path) -> None:
    tex = _checker()
    img = _render(gl, gf.textured_quad(tmp_path / "q.gltf", tex))
    for r in range(4):
        for c in range(4):
            block = img[16 * r + 1:16 * r + 15, 16 * c + 1:16 * c + 15]  # inside texel (r, c), away from its edges
            assert np.abs(block[..., :3] * 255 - tex[r, c]).max() <= 1.0, (r, c)
            assert np.all(block[..., 3] == 1.0)


@pytest.mark.parametrize("name,required", [("webp.glb", False), ("webp.gltf", True)])
def test_a_webp_texture_is_drawn_over_its_png_fallback(gl, tmp_path: Path, name: str, required: bool) -> None:
    """EXT_texture_webp: the texture's WebP image is drawn, not the PNG `source` beside it (here another image:
    the checker turned over), and a file that requires the extension is read."""
    tex = _checker()
    img = _render(gl, gf.textured_quad(tmp_path / name, tex[::-1, ::-1], webp=tex, webp_required=required))
    for r in range(4):
        for c in range(4):
            block = img[16 * r + 1:16 * r + 15, 16 * c + 1:16 * c + 15]
            assert np.abs(block[..., :3] * 255 - tex[r, c]).max() <= 1.0, (r, c)


def test_the_factor_multiplies_the_decoded_texture_in_linear_values(gl, tmp_path: Path) -> None:
    tex = _checker()
    factor = (0.5, 1.0, 0.25, 1.0)
    img = _render(gl, gf.textured_quad(tmp_path / "q.gltf", tex, factor=factor))
    want = 255 * _srgb(_linear(tex / 255.0) * np.array(factor[:3]))  # float64, from the spec
    assert np.abs(img[8::16, 8::16, :3] * 255 - want).max() <= 1.0


@pytest.mark.parametrize("transform", [
    {"offset": [0.25, 0.0]},
    {"offset": [0.5, 0.0], "scale": [0.5, 0.5]},
    {"rotation": math.pi / 2},
    {"offset": [0.1, 0.3], "rotation": 0.4, "scale": [1.5, 0.75]},
])
def test_khr_texture_transform_moves_the_texture(gl, tmp_path: Path, transform: dict) -> None:
    tex = _checker()
    img = _render(gl, gf.textured_quad(tmp_path / "q.gltf", tex, transform=transform))
    ox, oy = transform.get("offset", (0.0, 0.0))
    sx, sy = transform.get("scale", (1.0, 1.0))
    r = transform.get("rotation", 0.0)
    # the extension's reference: translation x rotation x scale, the rotation [[cos, sin], [-sin, cos]]
    m = (np.array([[1, 0, ox], [0, 1, oy], [0, 0, 1]]) @ np.array([[math.cos(r), math.sin(r), 0],
                                                                   [-math.sin(r), math.cos(r), 0], [0, 0, 1]])
         @ np.diag([sx, sy, 1.0]))
    want, clear = _reference(tex, m)
    assert clear.mean() > 0.5
    assert np.abs(img[..., :3][clear] * 255 - want[clear]).max() <= 1.0


def test_mirrored_repeat_and_clamp_wrap_modes(gl, tmp_path: Path) -> None:
    tex = _checker()
    shift = {"offset": [0.5, 0.0]}  # the right half of the quad reads u in 1..1.5
    mirror = _render(gl, gf.textured_quad(tmp_path / "m.gltf", tex, transform=shift, wrap=33648))
    clamp = _render(gl, gf.textured_quad(tmp_path / "c.gltf", tex, transform=shift, wrap=33071))
    for c in range(4):  # screen column block c reads texel column 2 + c: mirrored 2, 3, 3, 2; clamped 2, 3, 3, 3
        for r in range(4):
            centre = (16 * r + 8, 16 * c + 8)
            assert np.abs(mirror[centre][:3] * 255 - tex[r, (2, 3, 3, 2)[c]]).max() <= 1.0
            assert np.abs(clamp[centre][:3] * 255 - tex[r, (2, 3, 3, 3)[c]]).max() <= 1.0


def test_alpha_mask_cuts_out_texels_below_the_cutoff(gl, tmp_path: Path) -> None:
    tex = np.concatenate([_checker(), np.zeros((4, 4, 1), np.uint8)], axis=2)
    alpha = np.array([[255, 0, 200, 100]] * 4, np.uint8)  # cutoff 0.5: kept, cut, kept (0.78), cut (0.39)
    tex[..., 3] = alpha
    path = gf.textured_quad(tmp_path / "mask.gltf", tex, alpha_mode="MASK", cutoff=0.5)
    img = _render(gl, path)
    depth = _render(gl, path, "depth")
    for c, kept in enumerate((True, False, True, False)):
        block = (slice(2, N - 2), slice(16 * c + 2, 16 * c + 14))
        if kept:
            assert np.all(img[block][..., 3] == 1.0) and np.all(depth[block] < 1.0)
            assert np.abs(img[block][..., :3] * 255 - np.repeat(tex[:, c, :3], 16, 0)[2:N - 2, None]).max() <= 1.0
        else:  # background: the clear values, in every output
            assert np.all(img[block] == 0.0) and np.all(depth[block] == 1.0)
    blend = _render(gl, gf.textured_quad(tmp_path / "blend.gltf", tex, alpha_mode="BLEND"))
    assert np.all(blend[..., 3] == 1.0)  # BLEND is drawn opaque


def _barycentric_reference(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel centre (rows from the top), float64: the corner colours (linear) interpolated over the quad's
    triangles (0, 1, 2) and (0, 2, 3) in object space (the view is straight on: screen-affine), shown as display
    values; and whether the pixel lies over half a pixel from the shared diagonal."""
    c = (np.arange(N) + 0.5) / N * 2 - 1
    x, y = np.meshgrid(c, -c)
    v = gf.QUAD_V[:, :2].astype(np.float64)
    out = np.zeros((N, N, 3))
    for tri, inside in (((0, 1, 2), x >= y), ((0, 2, 3), x < y)):
        a, b, d = v[list(tri)]
        m = np.array([[b[0] - a[0], d[0] - a[0]], [b[1] - a[1], d[1] - a[1]]])
        l1, l2 = np.einsum("ij,...j->i...", np.linalg.inv(m), np.stack([x - a[0], y - a[1]], -1))
        w = np.stack([1 - l1 - l2, l1, l2], -1)
        out[inside] = (w @ corners[list(tri), :3])[inside]
    return _srgb(out), np.abs(x - y) / math.sqrt(2) > 1.0 / N


@pytest.mark.parametrize("ctype,n", [(gf.FLOAT, 3), (gf.FLOAT, 4), (gf.UBYTE, 4), (gf.USHORT, 4)])
def test_vertex_colours_interpolate_to_the_hand_computed_centre(gl, tmp_path: Path, ctype: int, n: int) -> None:
    corners = np.array([[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], [1.0, 1.0, 0.0, 1.0]])
    img = _render(gl, gf.vertex_color_quad(tmp_path / "vc.gltf", corners[:, :n], ctype))
    # the centre lies on the diagonal 0-2 both triangles share: half of corner 0 and half of corner 2 (linear
    # values, as glTF's COLOR_0 is), shown as display values (0.735, 0, 0.735); no material: white
    want, clear = _barycentric_reference(corners)
    assert np.abs(want[N // 2 - 1, N // 2] - _srgb(np.array([0.5, 0.0, 0.5]))).max() < 0.15  # beside the centre
    assert np.abs(img[..., :3][clear] - want[clear]).max() <= 1.5 / 255


def test_a_texture_is_decoded_once_per_content(tmp_path: Path, monkeypatch) -> None:
    calls = []
    decode = gltf._Reader._decode_pixels

    def counted(self, data, head):
        calls.append(len(data))
        return decode(self, data, head)

    monkeypatch.setattr(gltf._Reader, "_decode_pixels", counted)
    monkeypatch.setattr(gltf, "_DECODED", {})
    tex = _checker()
    gltf._ASSETS.clear()
    a = gltf.load_asset(gf.textured_quad(tmp_path / "a.gltf", tex))
    b = gltf.load_asset(gf.textured_quad(tmp_path / "b.gltf", tex, factor=(0.5, 0.5, 0.5, 1.0)))  # same image
    assert len(calls) == 1
    ta, tb = a.meshes[0][0].surface.material.texture, b.meshes[0][0].surface.material.texture
    assert ta.pixels is tb.pixels and ta.digest == tb.digest
    # the object's one flat colour: the factor times the texture's mean, in linear values (float64 reference)
    mean = _linear(tex / 255.0).reshape(-1, 3).mean(axis=0)
    assert a.meshes[0][0].color == pytest.approx(tuple(_srgb(mean)), abs=1e-9)
