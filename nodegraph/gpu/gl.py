"""The one headless OpenGL context (EGL), texture allocation with reuse, and full-screen passes."""

from __future__ import annotations

import os
import struct
from collections import OrderedDict, defaultdict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import types
from ..errors import GLUnavailableError, SketchgraphError
from ..values import Footprint, Tex, TexArray
from . import footprint
from .glsl import ProgramCache

_INSTALL_HINT = ("install Mesa's EGL and OpenGL drivers (Debian/Ubuntu: apt-get install libegl1 libgl1-mesa-dri; "
                 "Fedora: dnf install mesa-libEGL mesa-dri-drivers)")
_CONTEXT: GL | None = None


class GL:
    """Wraps the moderngl context: programs, pooled textures, framebuffers, full-screen draws."""

    def __init__(self, ctx: Any):
        self.ctx = ctx
        self.programs = ProgramCache(ctx)
        self._pool: dict[tuple[int, int, str], list[Any]] = defaultdict(list)
        # framebuffers by the ids of their attachments; each entry keeps its attachments alive, so an id
        # cannot be reused while the entry exists, and releasing a texture drops its framebuffers
        self._fbos: dict[tuple[int, ...], tuple[Any, tuple[Any, ...]]] = {}
        self._empty_vao: dict[int, Any] = {}
        self._scratch: Any = None
        self.resources: dict[Any, Any] = {}  # per-context caches of nodes (samplers, lookup textures)
        self._meshes: OrderedDict[Any, MeshBuffers] = OrderedDict()  # vertex/index buffers, least recent first
        self._slots: dict[Any, Any] = {}  # `mesh_buffers` slot -> the key of the buffers last built for it
        self.draws = DrawCount()  # full-screen passes and geometry draws issued through this wrapper

    @property
    def renderer(self) -> str:
        info = self.ctx.info
        return f"{info.get('GL_RENDERER', '?')} | {info.get('GL_VERSION', '?')}"

    @property
    def max_texture_size(self) -> int:
        """The largest texture width or height this context allocates (GL_MAX_TEXTURE_SIZE, capped by
        GL_MAX_VIEWPORT_DIMS: a texture is drawn into through a viewport of its size)."""
        info = self.ctx.info
        limit = int(info.get("GL_MAX_TEXTURE_SIZE", 0) or 0)
        dims = info.get("GL_MAX_VIEWPORT_DIMS")
        if dims:
            limit = min(limit, *(int(d) for d in dims)) if limit else min(int(d) for d in dims)
        return limit

    def check_size(self, size: tuple[int, int], what: str = "size") -> None:
        """Refuse a render size this context cannot allocate, naming both numbers."""
        limit = self.max_texture_size
        if limit and (int(size[0]) > limit or int(size[1]) > limit):
            raise SketchgraphError(f"{what} {int(size[0])}x{int(size[1])}: expected width and height at most "
                                     f"{limit}, the largest texture this OpenGL context allocates "
                                     f"(GL_MAX_TEXTURE_SIZE; {self.renderer})")

    # -- textures --------------------------------------------------------------------------
    def texture(self, size: tuple[int, int], fmt: str, data: np.ndarray | None = None,
                filter: str = "linear", repeat: bool = False) -> Tex:
        """A texture of `fmt`, from the pool when one of the same shape is free."""
        w, h = int(size[0]), int(size[1])
        pool = self._pool[(w, h, fmt)]
        if pool:  # allocation costs more than a full-screen pass on llvmpipe: reuse, and write if needed
            tex = pool.pop()
            if data is not None:
                tex.write(_to_bytes(data, fmt), alignment=1)
        else:
            comps, _, dtype, _ = types.FORMATS[fmt]
            payload = None if data is None else _to_bytes(data, fmt)
            tex = self.ctx.texture((w, h), comps, payload, dtype=dtype, alignment=1)
        f = self.ctx.LINEAR if filter == "linear" else self.ctx.NEAREST
        tex.filter = (f, f)
        tex.repeat_x = tex.repeat_y = repeat
        return Tex(tex, fmt)

    def texture_array(self, size: tuple[int, int], layers: int, fmt: str, data: np.ndarray,
                      repeat: bool = True, mipmaps: bool = True) -> TexArray:
        comps, _, dtype, _ = types.FORMATS[fmt]
        tex = self.ctx.texture_array((size[0], size[1], layers), comps, _to_bytes(data, fmt), dtype=dtype,
                                     alignment=1)
        tex.repeat_x = tex.repeat_y = repeat
        if mipmaps:
            tex.build_mipmaps()
            tex.filter = (self.ctx.LINEAR_MIPMAP_LINEAR, self.ctx.LINEAR)
            tex.anisotropy = 8.0
        return TexArray(tex, fmt)

    def release(self, value: Any) -> None:
        """Return a texture to the pool (only the engine calls this, when nothing refers to it)."""
        if isinstance(value, Tex):
            w, h = value.size
            pool = self._pool[(w, h, value.fmt)]
            if len(pool) < 16:
                pool.append(value.texture)
            else:
                self._drop_framebuffers(value.texture)
                value.texture.release()  # type: ignore[attr-defined]
        elif isinstance(value, TexArray):
            self._drop_framebuffers(value.texture)
            value.texture.release()  # type: ignore[attr-defined]

    def _drop_framebuffers(self, texture: Any) -> None:
        tid = id(texture)
        for key in [k for k in self._fbos if tid in k]:
            fbo, _ = self._fbos.pop(key)
            self._release_fbo(fbo)

    def _release_fbo(self, fbo: Any) -> None:
        # moderngl restores the last bound framebuffer when it creates one: never leave a deleted one bound
        if self._scratch is None:
            self._scratch = self.ctx.framebuffer(color_attachments=[self.ctx.renderbuffer((1, 1))])
        self._scratch.use()
        fbo.release()

    def framebuffer(self, colors: list[Tex], depth: Any = None) -> Any:
        attachments = tuple(c.texture for c in colors) + ((depth,) if depth is not None else ())
        key = tuple(id(a) for a in attachments)
        entry = self._fbos.get(key)
        if entry is None:
            if len(self._fbos) >= 512:  # drop the oldest half; never the one bound last
                for old in list(self._fbos)[:256]:
                    old_fbo, _ = self._fbos.pop(old)
                    self._release_fbo(old_fbo)
            fbo = self.ctx.framebuffer(color_attachments=[c.texture for c in colors], depth_attachment=depth)
            self._fbos[key] = (fbo, attachments)
            return fbo
        return entry[0]

    def clear_each(self, fbo: Any, values: list[tuple[float, ...]], depth: float | None = None) -> None:
        """Clear colour attachment i of `fbo` to `values[i]` (padded with zeros to RGBA) and the depth attachment
        to `depth` (kept when None), on `fbo` itself: one clear per distinct value, the others masked off.

        On llvmpipe a clear on the framebuffer about to be drawn is applied tile by tile as the draw is
        rasterised; a clear through a framebuffer of its own is a pass of its own, which the draw then reads
        back (ogre's G-buffer with its `depth` output: 24.9-28.6 -> 23.8-24.2 ms, three processes each)."""
        padded = [tuple(float(c) for c in v) + (0.0,) * (4 - len(v)) for v in values]
        bits = [struct.pack("4f", *v) for v in padded]  # by bits: -0.0 is a value of its own (a gradient's blank)
        distinct = list(dict.fromkeys(bits))
        keep_depth = depth is None and fbo.depth_attachment is not None
        if keep_depth:
            fbo.depth_mask = False
        try:
            if len(distinct) == 1:
                fbo.clear(*padded[0], depth=1.0 if depth is None else depth)
                return
            on, off = (True,) * 4, (False,) * 4
            try:
                for key in distinct:
                    fbo.color_mask = [on if b == key else off for b in bits]
                    fbo.clear(*padded[bits.index(key)], depth=1.0 if depth is None else depth)
            finally:
                fbo.color_mask = [on] * len(padded)
        finally:
            if keep_depth:
                fbo.depth_mask = True

    def depth_buffer(self, size: tuple[int, int]) -> Any:
        """A depth renderbuffer of `size`, shared by the passes that need one (each clears or overwrites it)."""
        key = ("depth_renderbuffer", (int(size[0]), int(size[1])))
        rb = self.resources.get(key)
        if rb is None:
            rb = self.resources[key] = self.ctx.depth_renderbuffer(key[1])
        return rb

    def upload(self, arr: np.ndarray, fmt: str, filter: str = "linear") -> Tex:
        """(H, W[, C]) array, row 0 = bottom, into a new texture of `fmt`."""
        h, w = arr.shape[:2]
        return self.texture((w, h), fmt, data=arr, filter=filter)

    # -- passes ----------------------------------------------------------------------------
    def program(self, path: Path, defines: dict[str, Any] | None = None, node: str = "?") -> Any:
        return self.programs.get(path, defines, node)

    def fullscreen(self, program: Any, targets: list[Tex], textures: dict[str, Any] | None = None,
                   uniforms: dict[str, Any] | None = None, fbo: Any = None,
                   rect: tuple[int, int, int, int] | None = None,
                   blanks: list[tuple[float, ...]] | None = None) -> None:
        """Draw the full-screen triangle with `program` into `targets` (MRT in the listed order). `rect` and
        `blanks` (one value for each target): the caller knows the pass gives `blanks[i]` in target i everywhere
        outside `rect` ((x, y, w, h)); then each target is cleared to its blank value, the pass draws inside
        `rect` only, and the targets get that footprint (`nodegraph.gpu.footprint`). A `rect` holding the whole
        image, or footprints switched off, draws the whole image as without one."""
        fbo = fbo or self.framebuffer(targets)
        w, h = targets[0].size if targets else fbo.size
        scissor = rect if footprint.ENABLED and not footprint.covers_image(rect, (w, h)) else None
        if scissor is not None:
            if blanks is None or len(blanks) != len(targets):
                raise SketchgraphError("fullscreen: a rect needs one blank value for each target")
            self.clear_each(fbo, blanks)
            for tex, blank in zip(targets, blanks, strict=True):
                tex.footprint = Footprint(scissor, tuple(float(b) for b in blank))
            fbo.scissor = scissor
        fbo.use()
        self.ctx.viewport = (0, 0, w, h)
        bind(program, textures or {}, uniforms or {})
        vao = self._empty_vao.get(id(program))
        if vao is None:
            vao = self.ctx.vertex_array(program, [])
            self._empty_vao[id(program)] = vao
        try:
            vao.render(mode=self.ctx.TRIANGLES, vertices=3)
        finally:
            if scissor is not None:
                fbo.scissor = None  # framebuffers are shared: leave it as the others expect
        self.draws.fullscreen += 1

    def read_uint8(self, tex: Tex) -> np.ndarray:
        """A texture as 8-bit file values (H, W, 4) uint8, row 0 at the top: exactly
        `imageio.to_uint8(tex.read())` flipped to file order, padded to four channels as GL samples a texture
        (missing colour channels 0, missing alpha 255). 8-bit textures are read as they are; others go
        through one full-screen pass into an 8-bit integer texture, so the read-back is 1 byte a channel."""
        w, h = tex.size
        c = types.components(tex.fmt)
        if types.numpy_dtype(tex.fmt) == np.uint8:
            raw = tex.read_native()[::-1]
            if c == 4:
                return np.ascontiguousarray(raw)
            out = np.zeros((h, w, 4), np.uint8)
            out[:, :, 3] = 255
            out[:, :, :c] = raw
            return out
        target, fbo = self._pack_target((w, h))
        from .glsl import ENGINE_GLSL

        prog = self.program(ENGINE_GLSL / "pack8.glsl", node="engine")
        self.fullscreen(prog, [], {"t_src": tex}, {"u_height": h}, fbo=fbo)
        out = np.empty((h, w, 4), np.uint8)
        target.read_into(out, alignment=1)
        return out

    def read_png_rows(self, tex: Tex) -> tuple[np.ndarray, int]:
        """A texture as the bytes a PNG's image data compresses, and their channels (1: grey, 3: RGB):
        every row top first, a filter byte 0 ("none"), then the row's 8-bit values, exactly as
        `imageio.png_rows(read_uint8(tex)[..., :channels])` would give them (values as `read_uint8`; one
        channel is grey, anything else RGB with missing colour channels 0). `read_png_block` read back, laid
        out as one stream."""
        block = self.read_png_block(tex)
        return block.rows(), block.channels

    def read_png_block(self, tex: Tex) -> PngBlock:
        """A texture's PNG row bytes (`read_png_rows`) as read back from the GPU, before they are laid out as
        one stream (`PngBlock.rows`, which a writer thread calls, so the render thread only packs and reads):
        `pack_png(tex).read()`."""
        return self.pack_png(tex).read()

    def pack_png(self, tex: Tex, slot: int = 0) -> PackedPng:
        """Issue the pass that lays `tex` out as PNG row bytes, into pack target `slot`; `.read()` reads them
        back as a `PngBlock`. The read is a texture read of the whole target: on llvmpipe a framebuffer read
        waits for every queued pass, a texture read only for the passes writing it. So, read after the
        passes that follow it have waited for it (a frame later in a sequence, before the slot is packed
        again), the read does not wait for the GPU at all. Two slots let a caller keep two packs outstanding.

        Where a row's bytes are a multiple of 16, one full-screen pass writes the rows 16 bytes a fragment and
        the filter bytes are added by `PngBlock.rows`; where the texture is blank outside its footprint, only
        the fragments over the footprint are packed, into a target of about the footprint's size (rounded up,
        so an animated footprint seldom needs a new one), the rest of each row being the blank pixel's bytes
        repeated (the default image on spot: 38% of the image). Otherwise the pass writes the stream 4 bytes a
        texel, so the read-back is the stream itself."""
        w, h = tex.size
        c = 1 if types.components(tex.fmt) == 1 else 3
        from .glsl import ENGINE_GLSL

        if (c * w) % 16 == 0:
            # rows 16 bytes a fragment (PNG_WIDE): spot's 800x800 RGB frame 3.2-3.4 ms of CPU (pass, read-back,
            # layout) against 6.2-6.3 for the 4-byte stream pass below
            prog = self.program(ENGINE_GLSL / "pack8.glsl", {"PNG_WIDE": 1, "PNG_CHANNELS": c}, node="engine")
            full = (c * w // 16, h)
            fp = footprint.of(tex)
            if fp is None or footprint.covers_image(fp.rect, (w, h)):
                target, fbo = self._pack_target(full, "u4", slot)
                self.fullscreen(prog, [], {"t_src": tex}, {"u_height": h, "u_width": w, "u_offset": (0, 0)}, fbo=fbo)
                return PackedPng(PngBlock((w, h), c, None, 0, 0, None), target, (0, 0, *full))
            x, y, pw, ph = fp.rect
            f0, f1 = (c * x) // 16, -(-(c * (x + pw)) // 16)
            r0, r1 = h - (y + ph), h - y  # the stream's rows run top first, the texture's from the bottom
            block = PngBlock((w, h), c, None, r0, 16 * f0, self._blank_bytes(tex, fp, c))
            if f1 <= f0 or r1 <= r0:
                return PackedPng(block, None, (0, 0, 0, 0))
            size, origin = _block_target_place((f0, r0, f1, r1), full)
            (target,), fbo = self._targets(("pack8-block", slot), size, ((4, "u4"),))
            self.fullscreen(prog, [], {"t_src": tex}, {"u_height": h, "u_width": w, "u_offset": origin}, fbo=fbo)
            return PackedPng(block, target, (f0 - origin[0], r0 - origin[1], f1 - f0, r1 - r0))
        total = h * (1 + c * w)
        rows = -(-total // (4 * w))  # at most h: 1 + 3w <= 4w bytes a row
        target, fbo = self._pack_target((w, rows), "u1", slot)

        prog = self.program(ENGINE_GLSL / "pack8.glsl", {"PNG_ROWS": 1, "PNG_CHANNELS": c}, node="engine")
        self.fullscreen(prog, [], {"t_src": tex},
                        {"u_height": h, "u_width": w, "u_target_width": w, "u_total": total}, fbo=fbo)
        return PackedPng(PngBlock((w, h), c, None, 0, 0, None), target, (0, 0, w, rows), stream_bytes=total)

    def _blank_bytes(self, tex: Tex, fp: Footprint, channels: int) -> np.ndarray:
        """The 8-bit file values (`channels` of them) of a texel of `tex` outside its footprint: read once from the
        texture, at a corner outside the rectangle, and kept per format and blank value (the stored blank is the
        format's rounding of `fp.blank`, which the read takes as it is)."""
        key = ("blank8", tex.fmt, fp.blank, channels)
        hit = self.resources.get(key)
        if hit is None:
            x, y, rw, rh = fp.rect
            corner = _corner_outside((x, y, x + rw, y + rh), tex.size)
            comps = types.components(tex.fmt)
            texel = np.empty(comps, np.float32)  # the value the pack pass fetches, as a float
            self.framebuffer([tex]).read_into(texel, viewport=(*corner, 1, 1), components=comps, alignment=1,
                                              dtype="f4")
            from ..values import to_uint8

            px = to_uint8(np.concatenate([texel, np.zeros(3, np.float32)]))
            hit = self.resources[key] = px[:1] if channels == 1 else px[:3]
        return hit

    def read_yuv420(self, tex: Tex) -> Yuv420Planes:
        """A texture as a film frame's planes: BT.601 limited-range 4:2:0 (the conversion swscale applies to
        rgb24 -> yuv420p by default) of the 8-bit values `read_uint8` gives (one channel is grey; otherwise
        RGB, alpha dropped), the size rounded up to even by repeating the last column/row. Chroma is each 2x2
        block's mean RGB converted (swscale filters rows [1 3 3 1] / 8 instead); every value rounded half to
        even (pack8.glsl). One full-screen pass of a fragment per 4 x 2 pixels, each fetched once, 1.5 bytes a
        pixel read back (rows padded to 4 bytes): `pack_yuv420(tex).read()`."""
        return self.pack_yuv420(tex).read()

    def pack_yuv420(self, tex: Tex, slot: int = 0) -> PackedYuv420:
        """Issue `read_yuv420`'s pass into the targets of `slot`; `.read()` reads them back as `Yuv420Planes`
        by texture reads, which wait only for the passes writing them (see `pack_png`: read a frame later,
        the read does not wait). Where the texture is blank outside its footprint, only
        the fragments over it are converted, into targets of about the block's size (rounded up to 8 x 16
        fragments), and the rest of each plane is the blank pixel's Y, U and V (made once by the pass on a
        fragment outside)."""
        w, h = tex.size
        ew, eh = w + w % 2, h + h % 2
        line = -(-ew // 4) * 4  # bytes of a Y row as the pass writes it; chroma rows are half
        c = 1 if types.components(tex.fmt) == 1 else 3
        full = (line // 4, eh // 2)
        from .glsl import ENGINE_GLSL

        prog = self.program(ENGINE_GLSL / "pack8.glsl", {"YUV420": 1, "YUV420_CHANNELS": c}, node="engine")
        widths = (line, line, line // 2, line // 2)
        part = self._yuv_part(tex, line, prog)
        if part is None:
            targets, fbo = self._yuv_targets(full, slot)
            self.fullscreen(prog, [], {"t_src": tex}, {"u_src": (w, h), "u_offset": (0, 0)}, fbo=fbo)
            return PackedYuv420((ew, eh), widths, None, targets, (0, 0, *full), (0, 0))
        (f0, g0, f1, g1), blank = part
        if f1 <= f0 or g1 <= g0:
            return PackedYuv420((ew, eh), widths, blank, None, (0, 0, 0, 0), (0, 0))
        size, origin = _block_target_place((f0, g0, f1, g1), full)
        targets, fbo = self._yuv_targets(size, slot, block=True)
        self.fullscreen(prog, [], {"t_src": tex}, {"u_src": (w, h), "u_offset": origin}, fbo=fbo)
        return PackedYuv420((ew, eh), widths, blank, targets, (f0 - origin[0], g0 - origin[1], f1 - f0, g1 - g0),
                            (f0, g0))

    def _yuv_part(self, tex: Tex, line: int, prog: Any) -> tuple[tuple[int, int, int, int], tuple[int, ...]] | None:
        """For `pack_yuv420` of a texture with a footprint (even size, rows a multiple of 4 pixels): the fragments
        (x0, y0, x1, y1) of the pass (`prog`) that touch the footprint, and the blank pixel's
        (Y, Y, U, V), found by the pass on a corner fragment outside and kept per format and blank value; None:
        convert the whole frame."""
        fp = footprint.of(tex)
        w, h = tex.size
        if fp is None or footprint.covers_image(fp.rect, (w, h)) or w % 4 or h % 2 or line != w:
            return None
        x, y, pw, ph = fp.rect
        nx, ny = w // 4, h // 2  # fragment (i, j): pixels 4i..4i+3 of the image rows 2j, 2j+1 counted from the top
        frags = (x // 4, (h - y - ph) // 2, -(-(x + pw) // 4), -(-(h - y) // 2))
        if pw <= 0 or ph <= 0:
            frags = (0, 0, 0, 0)
        key = ("blank_yuv", tex.fmt, fp.blank)
        blank = self.resources.get(key)
        if blank is None:
            corner = _corner_outside(frags, (nx, ny))
            if corner is None:
                return None
            # the corner fragment alone, into targets of one fragment (no frame's targets are touched)
            targets, fbo = self._targets(("yuv420-blank",), (1, 1), _YUV_TARGETS)
            self.fullscreen(prog, [], {"t_src": tex}, {"u_src": (w, h), "u_offset": corner}, fbo=fbo)
            values = []
            for t, comps in zip(targets, (4, 4, 2, 2), strict=True):
                texel = np.empty(comps, np.uint8)
                t.read_into(texel, alignment=1)
                values.append(int(texel[0]))
            blank = self.resources[key] = tuple(values)
        return frags, blank

    def _yuv_targets(self, size: tuple[int, int], slot: int = 0, block: bool = False
                     ) -> tuple[tuple[Any, ...], Any]:
        """`pack_yuv420`'s four integer textures (Y even rows, Y odd rows: RGBA8UI; U, V: RG8UI) of `size`
        and their framebuffer: kept per size and slot for whole frames; for a footprint's block (`block`), one
        set per slot, replaced when the size changes."""
        key = ("yuv420-block", slot) if block else ("yuv420", size, slot)
        return self._targets(key, size, _YUV_TARGETS)

    def _targets(self, key: Any, size: tuple[int, int], specs: tuple[tuple[int, str], ...]
                 ) -> tuple[tuple[Any, ...], Any]:
        """Textures of `size` (one per (components, dtype) in `specs`) and their framebuffer, kept under `key`;
        an entry of another size under the same key is released and replaced (a footprint's block targets,
        one set per slot)."""
        entry = self.resources.get(key)
        if entry is not None and entry[0][0].size == size:
            return entry
        if entry is not None:
            entry[1].release()
            for t in entry[0]:
                t.release()
        targets = tuple(self.ctx.texture(size, n, dtype=dtype) for n, dtype in specs)
        entry = self.resources[key] = (targets, self.ctx.framebuffer(color_attachments=list(targets)))
        return entry

    def _pack_target(self, size: tuple[int, int], dtype: str = "u1", slot: int = 0) -> tuple[Any, Any]:
        """The integer texture (and its framebuffer) of `size` that the pack passes draw into, kept per size,
        type and slot (`pack_png`): RGBA8UI (`u1`), or RGBA32UI (`u4`) for `pack_png`'s wide pass."""
        (target,), fbo = self._targets(("pack8", size, dtype, slot), size, ((4, dtype),))
        return target, fbo

    # -- geometry ---------------------------------------------------------------------------
    def mesh_buffers(self, key: Any, build: Callable[[], MeshArrays], slot: Any = None) -> MeshBuffers:
        """Vertex and index buffers of one mesh, cached by `key` (say the node, the mesh's content hash and
        whatever else shaped the arrays); `build` runs only on a miss. The least recently used entries are
        released beyond `MESH_CACHE_ENTRIES`. `.vao(program)` gives the program's vertex array over them.
        `slot`: what stays the same from frame to frame (a posed part: its rest pose): on a miss, the buffers
        last built for the slot take the new vertices in place when the layout and indices are the same
        (no new buffers, vertex arrays kept); the entry then answers to `key` alone."""
        entry = self._meshes.get(key)
        if entry is not None:
            self._meshes.move_to_end(key)
            return entry
        arrays = build()
        old_key = self._slots.get(slot) if slot is not None else None
        old = self._meshes.get(old_key) if old_key is not None else None
        if old is not None and old.rewrite(arrays):
            del self._meshes[old_key]
            self._meshes[key] = old
            self._slots[slot] = key
            return old
        entry = self._meshes[key] = MeshBuffers(self.ctx, arrays, self.draws)
        if slot is not None:
            if len(self._slots) > 4 * MESH_CACHE_ENTRIES:
                self._slots.clear()
            self._slots[slot] = key
        while len(self._meshes) > MESH_CACHE_ENTRIES:
            _, old = self._meshes.popitem(last=False)
            old.release()
        return entry

    def image_texture(self, key: Any, pixels: np.ndarray, srgb: bool = True, filters: tuple[int, int] = (9987, 9729),
                      repeat: tuple[bool, bool] = (True, True)) -> Any:
        """A moderngl texture of an (h, w, 4) uint8 image (row 0 at t = 0), kept by `key` (say the image's digest and
        how it is sampled; the least recently used beyond IMAGE_CACHE_ENTRIES are released). `srgb`: stored as
        SRGB8_ALPHA8, so samples (and their filtering) come out linear; `filters`: GL's (min, mag) enums, mipmaps
        built where the min filter uses them; `repeat`: REPEAT (else CLAMP_TO_EDGE) along s and t."""
        cache = self.resources.setdefault("gl.image_textures", OrderedDict())
        tex = cache.get(key)
        if tex is not None:
            cache.move_to_end(key)
            return tex
        h, w = pixels.shape[:2]
        tex = self.ctx.texture((w, h), 4, np.ascontiguousarray(pixels, dtype=np.uint8).tobytes(), alignment=1,
                               internal_format=0x8C43 if srgb else None)  # GL_SRGB8_ALPHA8
        if filters[0] in (9984, 9985, 9986, 9987):
            tex.build_mipmaps()
        tex.filter = filters
        tex.repeat_x, tex.repeat_y = repeat
        cache[key] = tex
        while len(cache) > IMAGE_CACHE_ENTRIES:
            cache.popitem(last=False)[1].release()
        return tex

    def release_meshes(self) -> None:
        """Release every cached mesh's buffers and vertex arrays (the next draw uploads them again)."""
        while self._meshes:
            _, entry = self._meshes.popitem()
            entry.release()

    @contextmanager
    def depth_test(self, func: str = "<") -> Iterator[DepthState]:
        """Depth-tested drawing (`func` as moderngl spells it: "<", "<=", "1", ...) with culling under the
        caller's control (`state.cull(...)`, `state.depth_func(...)`). On exit the engine's baseline state is
        restored whatever happened: no depth test, no culling, cull face "back", depth function "<", front faces
        counter-clockwise."""
        mgl = self.ctx
        mgl.enable(mgl.DEPTH_TEST)
        mgl.depth_func = func
        try:
            yield DepthState(mgl)
        finally:
            mgl.depth_func = "<"
            mgl.disable(mgl.DEPTH_TEST)
            mgl.disable(mgl.CULL_FACE)
            mgl.cull_face = "back"
            mgl.front_face = "ccw"

    def finish(self) -> None:
        self.ctx.finish()

    def check(self) -> None:
        err = self.ctx.error
        if err != "GL_NO_ERROR":
            raise RuntimeError(f"OpenGL error: {err}")


def _corner_outside(cells: tuple[int, int, int, int], size: tuple[int, int]) -> tuple[int, int] | None:
    """A corner cell of a (w, h) grid outside cells [x0, x1) x [y0, y1), or None (they hold every corner)."""
    x0, y0, x1, y1 = cells
    w, h = size
    return next(((i, j) for i in (0, w - 1) for j in (0, h - 1) if not (x0 <= i < x1 and y0 <= j < y1)), None)


@dataclass
class Yuv420Planes:
    """`GL.read_yuv420`'s read-back: the frame's (even) size and its planes, rows top first, each row padded
    to a multiple of 4 bytes (Y) or 2 (U, V): the even Y rows, the odd ones, U and V, each (height / 2, ...)."""

    size: tuple[int, int]
    y_even: np.ndarray
    y_odd: np.ndarray
    u: np.ndarray
    v: np.ndarray


@dataclass
class PngBlock:
    """`GL.read_png_block`'s read-back: a frame's PNG row bytes in the pieces the GPU made. `block`: the rows'
    8-bit values (no filter bytes), rows `row0`.. top first, bytes `byte0`.. of each row; every other byte is
    `blank` (the `channels` bytes of a pixel outside the footprint) repeated; `blank` None: `block` covers
    every byte. `stream`: the whole stream as the GPU wrote it, where the pass wrote it 4 bytes a texel."""

    size: tuple[int, int]
    channels: int
    block: np.ndarray | None
    row0: int
    byte0: int
    blank: np.ndarray | None
    stream: np.ndarray | None = None

    def rows(self, into: PngRowsBuffer | None = None) -> np.ndarray:
        """The stream a PNG's image data compresses (`GL.read_png_rows`): 1-D, h * (1 + w * channels) bytes.
        `into`: laid out in that buffer (a frame sequence's writer thread keeps one), valid until its next use."""
        if self.stream is not None:
            return self.stream
        return (into or PngRowsBuffer()).lay_out(self)

    @property
    def rect(self) -> tuple[int, int, int, int] | None:
        """Where `block` lies in the rows (first row, row past the last, first column, column past the last;
        column 0 is the filter byte), None without a block."""
        if self.block is None:
            return None
        bh, bw = self.block.shape
        return self.row0, self.row0 + bh, 1 + self.byte0, 1 + self.byte0 + bw


class PngRowsBuffer:
    """The rows of one frame after another (`PngBlock.rows`), in one buffer: the filter bytes and the blank
    around a footprint's block are laid out once, and each next frame restores the blank only where the last
    block lay and the new one does not, then copies its block. An animated footprint moves a little from frame
    to frame, so a frame writes about its block's bytes instead of the whole image's (spot at 800x800: about
    0.6 MB instead of 1.9)."""

    def __init__(self) -> None:
        self._out: np.ndarray | None = None
        self._key: Any = None
        self._blank_row: np.ndarray | None = None
        self._rect: tuple[int, int, int, int] | None = None  # the block copied last: every other byte is blank

    def lay_out(self, b: PngBlock) -> np.ndarray:
        w, h = b.size
        key = (w, h, b.channels, None if b.blank is None else bytes(b.blank))
        out = self._out
        if out is None or key != self._key:
            out = self._out = np.empty((h, 1 + b.channels * w), np.uint8)
            out[:, 0] = 0
            self._key, self._rect = key, None
            self._blank_row = None if b.blank is None else np.tile(b.blank, w)
            if self._blank_row is not None:
                out[:, 1:] = self._blank_row
        new = b.rect
        if self._rect is not None and self._blank_row is not None:
            for r0, r1, c0, c1 in _outside(self._rect, new):
                out[r0:r1, c0:c1] = self._blank_row[c0 - 1:c1 - 1]
        if new is not None:
            r0, r1, c0, c1 = new
            out[r0:r1, c0:c1] = b.block
        self._rect = new
        return out.reshape(-1)


def _outside(old: tuple[int, int, int, int], new: tuple[int, int, int, int] | None
             ) -> list[tuple[int, int, int, int]]:
    """The parts of rectangle `old` (rows r0..r1, columns c0..c1, ends excluded) outside `new`, as at most four
    rectangles (the empty ones dropped)."""
    r0, r1, c0, c1 = old
    if new is None:
        parts = [old]
    else:
        n0, n1, m0, m1 = new
        a, b = max(r0, n0), min(r1, n1)  # the rows both cover
        parts = [(r0, min(r1, n0), c0, c1), (max(r0, n1), r1, c0, c1)]
        if a < b:
            parts += [(a, b, c0, min(c1, m0)), (a, b, max(c0, m1), c1)]
    return [p for p in parts if p[0] < p[1] and p[2] < p[3]]


class PackedPng:
    """`GL.pack_png`'s pass, issued: `read()` reads its target back (a texture read, see `pack_png`) as a
    `PngBlock`. `place`: where the block lies in the target, in texels (x, y, width, height); `stream_bytes`:
    the target holds the whole stream, 4 bytes a texel, this many of them."""

    def __init__(self, block: PngBlock, target: Any, place: tuple[int, int, int, int],
                 stream_bytes: int | None = None):
        self._block, self._target, self._place, self._stream_bytes = block, target, place, stream_bytes

    def read(self) -> PngBlock:
        b = self._block
        if self._target is None:  # nothing over the footprint to pack: every byte is blank
            return b
        tw, th = self._target.size
        if self._stream_bytes is not None:  # the stream pass: 4 bytes a texel, the stream itself
            out = np.empty(tw * th * 4, np.uint8)
            self._target.read_into(out, alignment=1)
            return PngBlock(b.size, b.channels, None, 0, 0, None, stream=out[:self._stream_bytes])
        whole = np.empty((th, tw * 16), np.uint8)
        self._target.read_into(whole, alignment=1)
        x, y, w, h = self._place
        packed = whole if (x, y, w, h) == (0, 0, tw, th) else whole[y:y + h, 16 * x:16 * (x + w)]
        return PngBlock(b.size, b.channels, packed, b.row0, b.byte0, b.blank)


class PackedYuv420:
    """`GL.pack_yuv420`'s pass, issued: `read()` reads its targets back (texture reads) as `Yuv420Planes`.
    `blank`: the planes' values outside the block (None: the targets hold the whole frame); `place`: the block
    in the targets, in fragments (x, y, width, height); `at`: its first fragment in the frame."""

    def __init__(self, size: tuple[int, int], widths: tuple[int, ...], blank: tuple[int, ...] | None,
                 targets: tuple[Any, ...] | None, place: tuple[int, int, int, int], at: tuple[int, int]):
        self._size, self._widths, self._blank, self._targets = size, widths, blank, targets
        self._place, self._at = place, at

    def read(self) -> Yuv420Planes:
        ew, eh = self._size
        if self._blank is None:
            planes = []
            for t, width in zip(self._targets or (), self._widths, strict=True):
                a = np.empty((eh // 2, width), np.uint8)
                t.read_into(a, alignment=1)
                planes.append(a)
            return Yuv420Planes(self._size, *planes)
        planes = [np.full((eh // 2, width), b, np.uint8) for width, b in zip(self._widths, self._blank, strict=True)]
        if self._targets is not None:
            x, y, w, h = self._place
            f0, g0 = self._at
            for t, plane, comps in zip(self._targets, planes, (4, 4, 2, 2), strict=True):
                tw, th = t.size
                whole = np.empty((th, comps * tw), np.uint8)
                t.read_into(whole, alignment=1)
                plane[g0:g0 + h, comps * f0:comps * (f0 + w)] = whole[y:y + h, comps * x:comps * (x + w)]
        return Yuv420Planes(self._size, *planes)


_YUV_TARGETS = ((4, "u1"), (4, "u1"), (2, "u1"), (2, "u1"))
"""`pack_yuv420`'s targets: Y even rows, Y odd rows (RGBA8UI), U, V (RG8UI)."""


def _block_target_place(block: tuple[int, int, int, int], full: tuple[int, int]
                        ) -> tuple[tuple[int, int], tuple[int, int]]:
    """For a footprint's block of a pack pass, (x0, y0, x1, y1) in fragments of the whole layout `full`: the
    size of its target, the block rounded up to 8 x 16 fragments (so an animated footprint seldom needs a new
    one) and no bigger than the layout, and the layout's fragment at the target's (0, 0), placed so that the
    target holds the block inside the layout; the pass covers the whole target."""
    x0, y0, x1, y1 = block
    size = (min(full[0], -(-(x1 - x0) // 8) * 8), min(full[1], -(-(y1 - y0) // 16) * 16))
    return size, (min(x0, full[0] - size[0]), min(y0, full[1] - size[1]))


MESH_CACHE_ENTRIES = 64
IMAGE_CACHE_ENTRIES = 64  # textures of `GL.image_texture` kept on the GPU
_ATTRIBUTE_DTYPES = {"f": np.float32, "i": np.int32, "u": np.uint32}


@dataclass
class MeshArrays:
    """What `GL.mesh_buffers` uploads: per-vertex attributes {shader input: (array, moderngl format such as
    "3f")}, triangle indices, and anything the caller wants kept beside the buffers (`meta`)."""

    attributes: dict[str, tuple[np.ndarray, str]]
    indices: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)


class MeshBuffers:
    """A mesh's vertex buffers and index buffer on the GPU, with one vertex array per program using them."""

    def __init__(self, ctx: Any, arrays: MeshArrays, draws: DrawCount | None = None):
        self.ctx = ctx
        self._draws = draws if draws is not None else DrawCount()
        self.meta = arrays.meta
        self.buffers = {name: (ctx.buffer(np.ascontiguousarray(a, dtype=_ATTRIBUTE_DTYPES[fmt[-1]]).tobytes()), fmt)
                        for name, (a, fmt) in arrays.attributes.items()}
        # 16-bit indices where every vertex fits (ogre's 64,540 do): 0.3-0.7 ms less of its 12.5 ms draw on
        # llvmpipe, same triangles
        indices = np.asarray(arrays.indices)
        self.index_size = 2 if indices.size == 0 or int(indices.max()) < 65536 else 4
        self.index_buffer = ctx.buffer(np.ascontiguousarray(indices, dtype=np.uint16 if self.index_size == 2
                                                            else np.uint32).tobytes())
        # by program id; each entry keeps its program alive, so the id cannot be reused while it exists
        self._vaos: dict[int, tuple[Any, Any]] = {}
        self._indices = indices
        self._layout = {name: (fmt, np.asarray(a).shape) for name, (a, fmt) in arrays.attributes.items()}

    def rewrite(self, arrays: MeshArrays) -> bool:
        """Take `arrays` in place (vertex buffers written, index buffer and vertex arrays kept) if they have this
        entry's attributes, formats, shapes and indices; False (nothing changed) otherwise."""
        layout = {name: (fmt, np.asarray(a).shape) for name, (a, fmt) in arrays.attributes.items()}
        indices = np.asarray(arrays.indices)
        if layout != self._layout or not (indices is self._indices or np.array_equal(indices, self._indices)):
            return False
        for name, (a, fmt) in arrays.attributes.items():
            self.buffers[name][0].write(np.ascontiguousarray(a, dtype=_ATTRIBUTE_DTYPES[fmt[-1]]))
        self.meta = arrays.meta
        return True

    def vao(self, program: Any) -> Any:
        """The vertex array of `program` over the attributes it reads (16-bit indices where they fit)."""
        entry = self._vaos.get(id(program))
        if entry is None:
            content = [(buf, fmt, name) for name, (buf, fmt) in self.buffers.items() if name in program]
            vao = _CountedVertexArray(self.ctx.vertex_array(program, content, index_buffer=self.index_buffer,
                                                            index_element_size=self.index_size), self._draws)
            entry = self._vaos[id(program)] = (program, vao)
        return entry[1]

    def release(self) -> None:
        for _, vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
        for buf, _ in self.buffers.values():
            buf.release()
        self.buffers = {}
        self.index_buffer.release()


@dataclass
class DrawCount:
    """Draws issued through the wrapper (`GL.fullscreen` and vertex arrays of `GL.mesh_buffers`)."""

    fullscreen: int = 0
    geometry: int = 0

    @property
    def total(self) -> int:
        return self.fullscreen + self.geometry


class _CountedVertexArray:
    """A moderngl vertex array whose `render` calls are counted as geometry draws."""

    def __init__(self, vao: Any, draws: DrawCount):
        self._vao = vao
        self._draws = draws

    def render(self, *args: Any, **kwargs: Any) -> None:
        self._vao.render(*args, **kwargs)
        self._draws.geometry += 1

    def release(self) -> None:
        self._vao.release()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._vao, name)


class DepthState:
    """Inside `GL.depth_test`: face culling and the depth function, set per draw."""

    def __init__(self, mgl: Any):
        self._mgl = mgl

    def cull(self, face: str | None) -> None:
        """Cull "back" or "front" faces, or none (None: both sides drawn)."""
        mgl = self._mgl
        if face is None:
            mgl.disable(mgl.CULL_FACE)
        else:
            mgl.cull_face = face
            mgl.enable(mgl.CULL_FACE)

    def depth_func(self, func: str) -> None:
        self._mgl.depth_func = func

    def front_face(self, clockwise: bool) -> None:
        """Which winding faces the viewer: counter-clockwise (GL's default), or clockwise for a mirrored object,
        whose transform flips its triangles' screen winding, so that `gl_FrontFacing` still means outside."""
        self._mgl.front_face = "cw" if clockwise else "ccw"


def bind(program: Any, textures: dict[str, Any], uniforms: dict[str, Any]) -> None:
    """Bind textures to units 0.. and set uniforms; names the program does not use are skipped.

    NumPy arrays for matrix uniforms (mat2..mat4, or arrays of them) are given row-major, as NumPy writes
    them (m[row, col]); this is the one place they are transposed to GLSL's column-major order."""
    unit = 0
    for name, tex in textures.items():
        if name not in program:
            continue
        obj = tex.texture if isinstance(tex, (Tex, TexArray)) else tex
        obj.use(location=unit)
        program[name].value = unit
        unit += 1
    for name, value in uniforms.items():
        if name not in program:
            continue
        member = program[name]
        if isinstance(value, np.ndarray):
            if getattr(member, "matrix", False) and value.ndim >= 2:
                value = np.swapaxes(value, -1, -2)  # row-major NumPy -> column-major GLSL
            member.write(np.ascontiguousarray(value, dtype=np.float32).tobytes())
        else:
            member.value = value


def _to_bytes(data: np.ndarray, fmt: str) -> bytes:
    dt = types.numpy_dtype(fmt)
    arr = np.asarray(data)
    if dt == np.uint8 and arr.dtype != np.uint8:
        arr = np.clip(np.rint(np.asarray(arr, np.float32) * 255.0), 0, 255)  # half entries scaled in float32
    return np.ascontiguousarray(arr.astype(dt, copy=False)).tobytes()


def get() -> GL:
    """The process's GL context, created on first use (headless EGL)."""
    global _CONTEXT
    if _CONTEXT is None:
        _CONTEXT = GL(_create())
    return _CONTEXT


def create() -> GL:
    """A GL context of its own (not the process's), current on the calling thread: for a thread that renders
    apart from the rest of the process (`serve`'s render thread). EGL lets a context be current on one thread
    at a time, so such a thread cannot share the process's context with the thread that made it."""
    return GL(_create())


def _create() -> Any:
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - a dependency of the package
        raise GLUnavailableError(f"moderngl is not installed ({exc}); pip install moderngl") from None
    backend = os.environ.get("SKETCHGRAPH_GL_BACKEND", "egl")
    kwargs = {"backend": backend} if backend else {}
    try:
        return moderngl.create_standalone_context(require=330, **kwargs)
    except Exception as exc:  # noqa: BLE001 - any failure here means no usable GL
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise GLUnavailableError(
            f"cannot create a headless OpenGL 3.3 context through {backend.upper()} ({reason}); {_INSTALL_HINT}"
        ) from None
