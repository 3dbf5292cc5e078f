"""Image files through OpenImageIO. Arrays are float32 (H, W, C) with row 0 = bottom (GL order)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import fsio
from ..errors import SketchgraphError
from ..fsio import IncompleteWrite, atomic_output, clean
from ..values import to_uint8

WRITABLE = (".png", ".exr", ".tif", ".tiff", ".jpg", ".jpeg")


def write(path: str | Path, arr: np.ndarray, attributes: dict[str, str] | None = None, half: bool = True) -> Path:
    """Write a float image. PNG/JPEG/TIFF are 8-bit (values clipped to [0,1]); EXR keeps the values."""
    import OpenImageIO as oiio

    p = Path(path)
    ext = p.suffix.lower()
    if ext not in WRITABLE:
        raise SketchgraphError(f"{p}: cannot write '{ext or 'no extension'}' images; use one of {', '.join(WRITABLE)}")
    a = np.asarray(arr, dtype=np.float32)
    if a.ndim == 2:
        a = a[:, :, None]
    a = np.ascontiguousarray(a[::-1])
    h, w, c = a.shape
    if ext == ".exr":
        spec = oiio.ImageSpec(w, h, c, oiio.HALF if half else oiio.FLOAT)
        spec.attribute("compression", "zip")
        data = a
    else:
        if c == 2:  # two channels have no standard 8-bit layout: pad with a zero blue channel
            a = np.concatenate([a, np.zeros((h, w, 1), np.float32)], axis=2)
            c = 3
        spec = oiio.ImageSpec(w, h, c, oiio.UINT8)
        data = to_uint8(a)
    if c == 1:
        spec.channelnames = ("Y",)
    for k, v in (attributes or {}).items():
        spec.attribute(k, v)
    with atomic_output(p) as tmp:  # OIIO picks the format from the name: the temporary name keeps it
        out = oiio.ImageOutput.create(str(tmp))
        if out is None or not out.open(str(tmp), spec):
            raise IncompleteWrite(clean(oiio.geterror() or (out.geterror() if out else "")))
        ok = out.write_image(data)
        problem = out.geterror()  # some writers (PNG) report short writes only here and still return True
        closed = out.close()
        problem = problem or out.geterror()
        if not ok or not closed:
            raise IncompleteWrite(clean(problem or oiio.geterror()))
        _verify(oiio, tmp, w, h, c, problem)
    return p


PNG_LEVEL = 1
"""Default level of `write_png8` / `write_png_rows` (frame sequences). Levels 1-3 are ISA-L's deflate
(`isal`): an 800x800 spot frame in 0.33 ms of CPU at level 1 (43.7 KB) against 2.8 ms for zlib's level 1
(42.1 KB) and 20 ms for OIIO's default writer; 0 is stored (no compression), 4-9 are zlib's levels
(docs/performance.md "Frame output"). Without `isal` installed, every level is zlib's."""


def _deflate(data: memoryview, level: int) -> bytes:
    """A zlib stream of `data` at `level` (see `PNG_LEVEL`). Both compressors leave the interpreter lock free
    while they work, so writer threads overlap the render loop."""
    import zlib

    if 1 <= level <= 3:
        try:
            from isal import isal_zlib
        except ImportError:  # optional at run time: zlib gives the same pixels, a little slower
            pass
        else:
            return isal_zlib.compress(data, level)
    return zlib.compress(data, level)


def write_png8(path: str | Path, img: np.ndarray, level: int = PNG_LEVEL) -> Path:
    """Write 8-bit file values (H, W, C) uint8, row 0 at the top (file order), as a PNG: C = 1 grey, 3 RGB,
    4 RGBA. Deflated here at `level` (`PNG_LEVEL`; no row filters) without holding the interpreter, so writer
    threads overlap the render loop. Atomic, checked like `write`.

    Why not a library: OpenImageIO's PNG writer holds the interpreter lock while it encodes (the render loop
    stalls behind the writer threads), and Pillow always applies adaptive row filters: on the default
    pipeline's 800x800 image, Pillow level 1 took 17.6 ms (165,900 bytes) against 6.9 ms (140,377 bytes)
    here. ISA-L or zlib does the compression; this only frames its output in the PNG chunks (IHDR, IDAT,
    IEND)."""
    a = np.asarray(img)
    if a.dtype != np.uint8 or a.ndim != 3 or a.shape[2] not in (1, 3, 4):
        raise SketchgraphError(f"{Path(path)}: write_png8 takes (H, W, 1|3|4) uint8, got {a.dtype} {a.shape}")
    h, w, c = a.shape
    return write_png_rows(path, png_rows(a), w, h, c, level)


def png_rows(img: np.ndarray) -> np.ndarray:
    """The bytes a PNG's image data compresses, for (H, W, C) uint8 file values: each row top first, as the
    filter byte 0 ("none") and the row's bytes; 1-D, H * (1 + W * C) bytes."""
    h, w, c = img.shape
    rows = np.empty((h, 1 + w * c), np.uint8)
    rows[:, 0] = 0
    rows[:, 1:] = img.reshape(h, w * c)
    return rows.reshape(-1)


def write_png_rows(path: str | Path, rows: np.ndarray, w: int, h: int, c: int, level: int = PNG_LEVEL,
                   sync: bool = True) -> Path:
    """Write a PNG (8 bits a channel; C = 1 grey, 3 RGB, 4 RGBA) from its row bytes as `png_rows` gives them
    (or `GL.read_png_rows`, made on the GPU): they are deflated at `level` (`PNG_LEVEL`) without holding the
    interpreter lock, and the output is framed in the IHDR, IDAT and IEND chunks. Atomic; synced unless `sync`
    is False (`fsio.atomic_write_bytes`)."""
    from ..fsio import atomic_write_bytes

    p = Path(path)
    return atomic_write_bytes(p, png_bytes(rows, w, h, c, level, name=str(p)), sync)


def png_bytes(rows: np.ndarray, w: int, h: int, c: int, level: int = PNG_LEVEL, name: str = "png",
              palette: np.ndarray | None = None) -> bytes:
    """A PNG file's bytes (8 bits a channel; C = 1 grey, 3 RGB, 4 RGBA) from its row bytes, each row's filter
    byte first (`png_rows`), deflated at `level` without holding the interpreter lock and framed in the IHDR,
    IDAT and IEND chunks. With a `palette` ((N, 3) uint8, N <= 256; C = 1) the bytes are indices into it."""
    import struct
    import zlib

    data = memoryview(np.ascontiguousarray(rows, dtype=np.uint8)).cast("B")
    if c not in (1, 3, 4) or w < 1 or h < 1 or len(data) != h * (1 + w * c):
        raise SketchgraphError(f"{name}: expected {h} rows of 1 + {w} x {c} bytes, got {len(data)} bytes")

    def chunk(kind: bytes, payload: bytes) -> bytes:
        return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))

    colour = {1: 0, 3: 2, 4: 6}[c]
    plte = b""
    if palette is not None:
        entries = np.ascontiguousarray(palette, dtype=np.uint8)
        if c != 1 or entries.ndim != 2 or entries.shape[1] != 3 or not 1 <= len(entries) <= 256:
            raise SketchgraphError(f"{name}: a palette is (N <= 256, 3) uint8 for one channel of indices")
        colour, plte = 3, chunk(b"PLTE", entries.tobytes())
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour, 0, 0, 0)) + plte
            + chunk(b"IDAT", _deflate(data, level)) + chunk(b"IEND", b""))


def _verify(oiio: object, path: Path, w: int, h: int, c: int, problem: str = "") -> None:
    """Check the written file is whole: some writers (PNG) lose a failed final flush (a file size limit, a
    full disk) and report success. PNG and JPEG are checked by structure (chunks up to IEND, the end
    marker), without decoding (libpng would print to stderr); other formats are read back."""
    ext = path.suffix.lower()
    if ext == ".png":
        if not _png_complete(path.read_bytes()):
            raise IncompleteWrite(clean(problem) or "the written PNG is incomplete")
        return
    if ext in (".jpg", ".jpeg"):
        data = path.read_bytes()
        if not (data.startswith(b"\xff\xd8") and data.rstrip(b"\0").endswith(b"\xff\xd9")):
            raise IncompleteWrite(clean(problem) or "the written JPEG is incomplete")
        return
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise IncompleteWrite(clean(oiio.geterror()) or "the written file cannot be read back")
    try:
        spec = inp.spec()
        pixels = inp.read_image(oiio.FLOAT)
        read_problem = inp.geterror()
    finally:
        inp.close()
    if pixels is None or read_problem or (spec.width, spec.height, spec.nchannels) != (w, h, c):
        raise IncompleteWrite(clean(problem or read_problem) or "the written file is incomplete")


def _png_complete(data: bytes) -> bool:
    """A PNG signature, then chunks whose lengths and CRCs hold, ending with IEND at the end of the file."""
    import zlib

    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        return False
    pos = 8
    while pos + 12 <= len(data):
        n = int.from_bytes(data[pos:pos + 4], "big")
        kind = data[pos + 4:pos + 8]
        end = pos + 12 + n
        if end > len(data):
            return False
        if zlib.crc32(data[pos + 4:pos + 8 + n]) != int.from_bytes(data[pos + 8 + n:end], "big"):
            return False
        if kind == b"IEND":
            return end == len(data)
        pos = end
    return False


def read(path: str | Path) -> np.ndarray:
    """Read an image as float32 (H, W, C), row 0 = bottom. A file that does not decode is one
    `SketchgraphError` line; the decoder's own messages (libpng prints to stderr) never reach the terminal."""
    oiio = fsio.oiio()
    p = Path(path)
    if not p.exists():
        raise SketchgraphError(f"{p}: file not found")
    pixels, problem, spec = None, "", None
    with fsio.native_stderr() as printed:
        inp = oiio.ImageInput.open(str(p))
        if inp is None:
            problem = oiio.geterror()
        else:
            try:
                spec = inp.spec()
                pixels = inp.read_image(oiio.FLOAT)
                problem = inp.geterror() if pixels is None or inp.has_error else ""
            except Exception as exc:  # noqa: BLE001 - a broken file makes the decoder raise whatever it raises
                pixels, problem = None, str(exc)
            finally:
                inp.close()
            oiio.geterror()  # taken, so that OpenImageIO does not print it at exit
    if spec is None or pixels is None or problem or np.asarray(pixels).size != spec.height * spec.width \
            * spec.nchannels:
        why = clean(problem.splitlines()[0] if problem.strip() else printed[0] if printed else "")
        raise SketchgraphError(f"{p}: cannot read the image" + (f": {why}" if why else " (broken or truncated)"))
    arr = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    return np.ascontiguousarray(arr[::-1])
