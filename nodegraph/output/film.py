"""Films and frame sequences: `-o` decides. `.mp4` (H.264, yuv420p), `.webm` (VP9), `.gif`, or an image
pattern with `####` (PNG, EXR; one file per frame).

Encoding and file writing run beside rendering: the render loop reads each frame back and hands it to a
worker thread through a bounded queue, so a film costs little more than its frames. A film is encoded to
a hidden temporary file in the output's folder (`.NAME.partial-PID-N.EXT`) and renamed when the container is
finalised; if the run fails or is interrupted the temporary file is removed, so the output is either a
complete, playable film or absent. A killed run cannot remove it: the next film written to the same output
(or an image sequence's next run, for its frames' `.tmp-` files) removes the temporary files whose process is
gone (`fsio.clean_stale_temps`). A failed write (a full disk, the file-size limit) is one line naming the
output. With `resume`, image sequences keep the frames manifest of `nodegraph.output.frames_manifest` (beside the
pattern: frame -> the digest of what it was rendered from and the file's SHA-256, shared with distributed
runs) and skip frames already written from the same keys whose files are intact; `render_frames` reports the
frames it wrote and those it skipped apart.
"""

from __future__ import annotations

import contextlib
import os
import queue
import re
import threading
from collections.abc import Callable, Iterable
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import SketchgraphError
from ..fsio import OutputError, clean_stale_temps, make_folder, new_temp_name, show_path
from .write import Bytes8, PngRows

if TYPE_CHECKING:
    from ..gpu.gl import Yuv420Planes

# extension -> (container format, codec, pixel format, default quality as CRF; None: not applicable)
FILM_FORMATS: dict[str, tuple[str, str, str, int | None]] = {
    ".mp4": ("mp4", "libx264", "yuv420p", 18),
    ".webm": ("webm", "libvpx-vp9", "yuv420p", 32),
    ".gif": ("gif", "gif", "pal8", None),  # GIF: one palette for the film, ordered dithering (`gif`)
}


YUV_TAGS = {"colorspace": 6, "color_range": 1}
"""What the yuv420p films' frames are, tagged on the stream and every frame: BT.601 (AVCOL_SPC_SMPTE170M) at
limited range (AVCOL_RANGE_MPEG), the conversion swscale applies to rgb24 -> yuv420p by default and the one
`GL.read_yuv420` makes on the GPU; before they were tagged, these films said "unspecified"."""

CODEC_OPTIONS: dict[str, dict[str, str]] = {"libx264": {"preset": "veryfast", "threads": "1", "bf": "0"}}
"""Encoder options beside the quality. H.264 at `veryfast`: 30 spot frames at 800x800, CRF 18, took 7.6 ms of
CPU a frame against 12.3 at x264's default `medium`, at the same size (217 KB against 219 KB) and 0.5 dB less
PSNR (38.8 against 39.3 dB; docs/performance.md "Frame output"): encoding competes with llvmpipe for the
same two cores. One x264 thread (frames stay on the writer thread, no frame-parallel copies): 60 frames
6.7 ms of CPU a frame against 8.2 with x264's own threads, 434 KB against 439 KB at the same Y-PSNR (47.9 dB);
`bench film` MP4/frames 0.735, 0.742 against 0.710, 0.721 in the same two runs. No B-frames (`bf` 0): 60 frames
5.2-6.2 ms of CPU a frame against 6.5-6.8 with veryfast's three (four alternations), 447 KB against 434 KB,
Y-PSNR 47.98 against 47.92 dB (the noise that changes every frame leaves B-frames little to predict);
`bench film` extra CPU 12.4-13.5 against 14.4-14.5 ms a frame (three interleaved runs; the rates in the noise)."""


GIF_MAX_FPS = 100.0
"""A GIF's frame delays are whole centiseconds (`gif.centiseconds`): above 100 frames/s some would be 0."""

MIN_FPS = 0.01
MAX_FPS = 1000.0
"""Frames per second `--fps` may give, and any film's rate (`FilmWriter`): a finite number in [MIN_FPS, MAX_FPS].
A film's frame rate is a fraction with a denominator of at most 1001."""


def is_film(path: str | Path) -> bool:
    return Path(str(path)).suffix.lower() in FILM_FORMATS


def check_target(pattern: str, frames: list[int] | range | None = None, writers: bool = True) -> None:
    """Before anything renders: the files `pattern` names for `frames` (one image, a sequence or a film) can be
    written: its extension one the writers take (an image, `.svg` for strokes, a film; not checked with
    `writers=False`, for `inspect`, which also writes other values' files), then as
    `fsio.check_output` checks (no part of the folder is a file, no target is a folder or a device, the folder
    takes new files), each fault one line (`fsio.OutputPathError`); then temporary files that killed
    runs left for these outputs are removed (`fsio.clean_stale_temps`: ours by name, their process gone)."""
    import os
    import stat

    from ..fsio import OutputPathError, check_output, clean_stale_temps, show_path
    from .imageio import WRITABLE
    from .write import frame_name_re, frame_path

    ext = Path(str(pattern)).suffix.lower()
    kinds = (*WRITABLE, ".svg", *FILM_FORMATS)
    if writers and ext not in kinds:
        raise OutputPathError(f"{pattern}: cannot write '{ext or 'no extension'}' files; use one of "
                              f"{', '.join(kinds)}")
    frames = frames if frames else [0]
    many = len(frames) > 1 and not is_film(pattern)
    first = frame_path(pattern, frames[0], many)
    check_output(first)
    names = frame_name_re(pattern)
    if names is None:
        return
    folder = first.parent if str(first.parent) else Path(".")
    wanted = None
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        m = names.fullmatch(entry.name)
        if m is None or entry.name == first.name:
            continue
        try:
            mode = entry.stat().st_mode
        except OSError:
            continue
        if stat.S_ISREG(mode):
            continue
        if wanted is None:
            wanted = set(frames) if many else set()
        number = m.group(1) if m.groups() else None
        if (number is None and not many) or (number is not None and int(number) in wanted):
            kind = "a folder" if stat.S_ISDIR(mode) else "not a regular file"
            raise OutputPathError(f"{show_path(entry.path)}: cannot write: it is {kind} (a frame of {pattern})")
    clean_stale_temps(folder, re.compile(names.pattern + "|" + re.escape(f".{Path(pattern).name}.frames.json")))


def check_folder(folder: str | Path) -> Path:
    """Before anything renders: `folder` is (or can be made) a folder that takes new files; one line if not."""
    from ..fsio import check_output_folder

    return check_output_folder(folder)


def check_fps(fps: Any, what: str = "--fps") -> float:
    """`fps` as a float, or one line saying what a frame rate must be."""
    import math

    try:
        rate = float(fps)
    except (TypeError, ValueError, OverflowError):
        rate = math.nan
    if not (math.isfinite(rate) and MIN_FPS <= rate <= MAX_FPS):
        raise SketchgraphError(f"{what}: expected frames per second between {MIN_FPS:g} and {MAX_FPS:g}, found "
                               f"{str(fps)[:40]!r}")
    return rate


def _film_error(path: Path, exc: BaseException) -> OutputError:
    """A failure of the film's encoder or file (PyAV's errors, OS errors) as one line naming the film."""
    from ..fsio import _os_reason, clean

    if isinstance(exc, OSError) and exc.errno is not None:
        reason = _os_reason(exc)
    else:
        reason = clean(getattr(exc, "strerror", None) or str(exc) or type(exc).__name__)
    return OutputError(f"{show_path(path)}: cannot write: {reason}")


class _Worker:
    """Threads consuming a bounded queue (one by default: a film's frames must stay in order); an exception
    there is raised in the caller at the next put."""

    def __init__(self, consume: Callable[[Any], None], depth: int = 8, threads: int = 1):
        self._q: queue.Queue[Any] = queue.Queue(maxsize=depth)
        self._consume = consume
        self.error: BaseException | None = None
        self._threads = [threading.Thread(target=self._run, name=f"sketchgraph-film-{i}", daemon=True)
                         for i in range(threads)]
        for t in self._threads:
            t.start()

    def _run(self) -> None:
        while True:
            item = self._q.get()
            if item is None:
                return
            if self.error is None:
                try:
                    self._consume(item)
                except BaseException as exc:  # handed to the render thread
                    self.error = exc

    def put(self, item: Any) -> None:
        self._check()
        self._q.put(item)

    def finish(self) -> None:
        for _ in self._threads:
            self._q.put(None)
        for t in self._threads:
            t.join()
        self._check()

    def _check(self) -> None:
        if self.error is not None:
            cls = OutputError if isinstance(self.error, OutputError) else SketchgraphError
            text = " ".join(str(self.error).split()) or type(self.error).__name__
            raise cls(f"writing frames failed: {text}") from self.error


class FilmWriter:
    """Frames (uint8 RGB with row 0 at the top, `Bytes8`, or for yuv420p films `GL.read_yuv420`'s planes) into
    a film, encoded on a worker thread."""

    def __init__(self, path: str | Path, fps: float, size: tuple[int, int], crf: int | None = None):
        import av

        self.path = Path(path)
        fmt, codec, pix, default_crf = FILM_FORMATS[self.path.suffix.lower()]
        fps = check_fps(fps, "fps")
        if pix == "pal8" and fps > GIF_MAX_FPS:
            raise SketchgraphError(f"{show_path(self.path)}: a GIF times frames in whole hundredths of a second: at "
                                   f"most {GIF_MAX_FPS:g} frames/s, found {fps:g}; write .mp4 or .webm instead")
        folder = self.path.parent if str(self.path.parent) else Path(".")
        make_folder(folder, self.path)
        clean_stale_temps(folder, self.path.name)  # what killed runs left for this film
        legacy = folder / f".{self.path.stem}.partial{self.path.suffix}"  # the name before pids were in it
        if legacy.is_file():
            legacy.unlink(missing_ok=True)
        self.tmp = new_temp_name(self.path, "partial")
        try:
            self.container = av.open(str(self.tmp), "w", format=fmt)
        except Exception as exc:
            self.tmp.unlink(missing_ok=True)
            raise _film_error(self.path, exc) from None
        try:
            self.rate = Fraction(fps).limit_denominator(1001)
            self.stream = self.container.add_stream(codec, rate=self.rate)
            w, h = size
            if pix == "yuv420p":  # chroma subsampling needs even sizes: the last row/column is repeated
                w, h = w + w % 2, h + h % 2
            self.stream.width, self.stream.height, self.stream.pix_fmt = w, h, pix
            self.pix = pix
            if pix == "yuv420p":
                for name, value in YUV_TAGS.items():
                    setattr(self.stream.codec_context, name, value)
            quality = default_crf if crf is None else crf
            options = dict(CODEC_OPTIONS.get(codec, {}))
            if quality is not None:
                options.update({"crf": str(quality), **({"b:v": "0"} if codec == "libvpx-vp9" else {})})
            if options:
                self.stream.options = options
        except Exception as exc:
            with contextlib.suppress(Exception):
                self.container.close()
            self.tmp.unlink(missing_ok=True)
            if isinstance(exc, (OSError, av.error.FFmpegError)):
                raise _film_error(self.path, exc) from None
            raise
        self.frames = 0
        self._palette: Any = None  # GIF: the film's palette (`gif.GifPalette`), from its first frame
        self._muxed = 0  # GIF: packets muxed, each timed by `gif.centiseconds`
        self._worker = _Worker(self._encode)

    def _encode(self, rgb: Any) -> None:
        import av

        try:
            self._encode_frame(rgb)
        except (OSError, av.error.FFmpegError) as exc:  # a full disk, the file-size limit (EFBIG), ...
            raise _film_error(self.path, exc) from None

    def _encode_frame(self, rgb: Any) -> None:
        import av

        from ..gpu.gl import Yuv420Planes

        h, w = self.stream.height, self.stream.width
        if isinstance(rgb, Yuv420Planes):  # converted on the GPU: the planes go to the encoder as they are
            frame = _yuv_frame(rgb)
        else:
            rgb = _rgb(rgb)
            if rgb.shape[0] != h or rgb.shape[1] != w:
                rgb = np.pad(rgb, ((0, h - rgb.shape[0]), (0, w - rgb.shape[1]), (0, 0)), mode="edge")
            if self.pix == "pal8":
                frame = self._gif_frame(rgb)
            else:
                frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb), format="rgb24")
        if self.pix == "yuv420p":
            for name, value in YUV_TAGS.items():
                setattr(frame, name, value)
        self._mux(self.stream.encode(frame))

    def _gif_frame(self, rgb: np.ndarray) -> Any:
        """A pal8 frame: `rgb` in the film's one palette (made from the first frame), ordered-dithered."""
        import av

        from .gif import GifPalette

        if self._palette is None:
            self._palette = GifPalette.for_frame(rgb)
        return av.VideoFrame.from_ndarray((self._palette.indices(rgb), self._palette.argb()), format="pal8")

    def _mux(self, packets: Iterable[Any]) -> None:
        """Mux `packets`; a GIF's are timed in centiseconds, each frame's delay the difference of the rounded
        exact times (`gif.centiseconds`), so they add up to the exact times without drift."""
        for packet in packets:
            if self.pix == "pal8":
                from .gif import centiseconds

                start, end = centiseconds(self._muxed, self.rate), centiseconds(self._muxed + 1, self.rate)
                packet.time_base = Fraction(1, 100)
                packet.pts = packet.dts = start
                packet.duration = end - start
                self._muxed += 1
            self.container.mux(packet)

    def write(self, rgb: np.ndarray) -> None:
        self._worker.put(rgb)
        self.frames += 1

    def close(self) -> Path:
        """Finish encoding, finalise the container, move it into place. A failure (a full disk, the file-size
        limit, the output turned into a folder meanwhile) is one line naming the film; the caller's `abort`
        removes the temporary file."""
        import av

        self._worker.finish()
        try:
            self._mux(self.stream.encode())
            self.container.close()
            os.replace(self.tmp, self.path)
        except (OSError, av.error.FFmpegError) as exc:
            raise _film_error(self.path, exc) from None
        return self.path

    def abort(self) -> None:
        """Stop and remove the temporary file: no partial film is left."""
        with contextlib.suppress(SketchgraphError):
            self._worker.finish()
        with contextlib.suppress(Exception):  # a container that never got a frame may refuse to finalise
            self.container.close()
        self.tmp.unlink(missing_ok=True)


WRITER_THREADS = 2
"""Writer threads of an image sequence: PNG frames are compressed by zlib, which frees the interpreter, so
two threads keep up with the render loop where one falls behind on a slow frame."""


class SequenceWriter:
    """One image file per frame (PNG, EXR, ...), written on worker threads; with `resume`, the frames
    manifest (`nodegraph.output.frames_manifest`, shared with distributed runs) records each frame's digest and
    file hash as it is written, so a later `--resume` skips what is done. PNG frames read back as PNG rows
    (`PngRows`, laid out on the GPU) are compressed at `png_level`."""

    def __init__(self, pattern: str, resume: bool, png_level: int | None = None, page: Any = None):
        from .frames_manifest import FramesManifest
        from .imageio import PNG_LEVEL
        from .write import frame_name_re

        names = frame_name_re(pattern)
        if names is not None:  # temporary files killed runs left for these frames (and their manifest)
            clean_stale_temps(Path(pattern).parent if str(Path(pattern).parent) else Path("."), re.compile(
                names.pattern + "|" + re.escape(f".{Path(pattern).name}.frames.json")))
        self.manifest = FramesManifest.load(pattern) if resume else None
        self.png_level = PNG_LEVEL if png_level is None else png_level
        self.page = page  # svg.Page for SVG frames (physical size), or None
        self._lock = threading.Lock()
        self._unsynced: list[Path] = []  # PNG frames written unsynced, synced together at `close`
        self._rows = threading.local()  # each writer thread's `gl.PngRowsBuffer`
        self._worker = _Worker(self._write, threads=WRITER_THREADS)

    def _write(self, item: tuple[Path, Any, int, str]) -> None:
        from .frames_manifest import file_sha256
        from .write import write_value

        path, value, frame, digest = item
        if isinstance(value, PngRows):
            buffer = getattr(self._rows, "buffer", None)
            if buffer is None:
                from ..gpu.gl import PngRowsBuffer

                buffer = self._rows.buffer = PngRowsBuffer()
            written = value.write(path, self.png_level, sync=False, rows_buffer=buffer)
            with self._lock:
                self._unsynced.append(written)
        else:
            written = write_value(value, path, page=self.page)
        if self.manifest is not None:
            # a frame the manifest records may still be unsynced: after a machine crash `--resume` finds its
            # file's hash changed (empty, cut short) and renders it again
            sha = file_sha256(written)
            with self._lock:
                self.manifest.record(frame, digest, sha)
                self.manifest.save(every=1.0)

    def up_to_date(self, frame: int, digest: str, path: Path) -> bool:
        return self.manifest is not None and self.manifest.done(frame, digest, path)

    def write(self, path: Path, value: Any, frame: int, digest: str) -> None:
        self._worker.put((path, value, frame, digest))

    def close(self) -> None:
        try:
            self._worker.finish()
        except BaseException:
            with contextlib.suppress(Exception):  # the frames written before the failure, synced if they can be
                self._sync()
            raise
        else:
            self._sync()
        finally:
            if self.manifest is not None:
                self.manifest.save()

    def _sync(self) -> None:
        from ..fsio import sync_written

        with self._lock:
            unsynced, self._unsynced = self._unsynced, []
        sync_written(unsynced)


def render_frames(ex: Any, ref: tuple[str, str], frames: Iterable[int], pattern: str, *, fps: float = 24.0,
                  crf: int | None = None, resume: bool = False, bar: Callable[[list[int]], Any] | None = None,
                  png_level: int | None = None, page: Any = None) -> dict[str, Any]:
    """Render `frames` of `ref` with executor `ex` into a film or an image sequence (by `pattern`'s extension).
    Returns {"path", "frames", "skipped", "total"}: `frames` the frames this call wrote, `skipped` those an
    earlier run had written (`resume`), `total` the frames asked for. The output key per frame is the node's key
    and the port.
    Textures bound for 8-bit files are converted on the GPU: MP4 and WebM frames to their yuv420p planes
    (`GL.read_yuv420`, 1.5 bytes a pixel, handed to the encoder without swscale), GIF frames to `Bytes8`, PNG
    frames to the PNG's row bytes (`PngRows`, which zlib compresses as they are); everything else about the
    file happens on the writer threads. Each frame is converted and read back during the next frame's run,
    once that frame's first pass is issued (`Executor.run`'s `before_wait`), so the GPU finishes one frame
    while the next is set up; a PNG or yuv420p frame's pass is issued then and read back a run later still
    (`GL.pack_png`, `GL.pack_yuv420`: the read then does not wait for the GPU). The last frames, and those
    before a failing one, are read back at the end."""
    from ..values import Tex
    from .write import frame_path

    frame_list = list(frames)
    loop = bar(frame_list) if bar is not None else frame_list
    if is_film(pattern):
        film = FilmWriter(pattern, fps, ex.pipeline.size, crf)
        held: list[Any] = []  # the last frame's value, until the next run hands it over
        converted: list[Any] = []  # the frame converted at the last hand-over (`GL.pack_yuv420`), to read

        def hand_over_film(last: bool = False) -> None:
            # as hand_over below: the frame converted at the last hand-over is read (without waiting) and
            # written first, so the film's frames stay in order
            while converted:
                film.write(converted.pop(0).read())
            while held:
                value = held.pop(0)
                if film.pix == "yuv420p" and isinstance(value, Tex):
                    converted.append(ex.gl.pack_yuv420(value))
                else:
                    film.write(_film_frame(ex, value))
            while last and converted:
                film.write(converted.pop(0).read())

        try:
            for frame in loop:
                value = ex.run(frame, before_wait=hand_over_film).values[ref]  # hands the last frame over
                held.append(value)
            hand_over_film(last=True)
            path = film.close()
        except BaseException:
            film.abort()
            raise
        return {"path": path, "frames": len(frame_list), "skipped": 0, "total": len(frame_list)}
    many = len(frame_list) > 1
    from .frames_manifest import frame_digest

    seq = SequenceWriter(pattern, resume and many, png_level, page)
    skipped = 0
    pending: list[tuple[Path, Any, int, str]] = []  # the last frame rendered, until the next run hands it over
    packed: list[tuple[Path, Any, int, str]] = []  # PNG frames whose pack pass is issued, until the next hand-over

    def write_packed() -> None:
        path, pack, frame, key = packed.pop(0)
        seq.write(path, PngRows(pack.read()), frame, key)

    def hand_over(last: bool = False) -> None:
        # the frame packed at the last hand-over is read back first: the passes since have waited for its pass,
        # so the read does not wait (GL.pack_png); then the frame rendered since is packed, to be read at the next
        # hand-over (or now, after the last frame). Every run hands over once (`Executor.run`), so at most one
        # frame is pending here, and the pack target is read before it is packed again.
        while packed:
            write_packed()
        while pending:
            path, value, frame, key = pending.pop(0)
            if path.suffix.lower() == ".png" and isinstance(value, Tex):
                packed.append((path, ex.gl.pack_png(value), frame, key))
            else:
                seq.write(path, _host(value), frame, key)
        while last and packed:
            write_packed()

    try:
        try:
            for frame in loop:
                path = frame_path(pattern, frame, many)
                # the resume digest needs this frame's keys; without a manifest the run computes them once, itself
                key = frame_digest(ex.keys(frame)[ref[0]], ref[1], path.suffix) if seq.manifest is not None else ""
                if seq.up_to_date(frame, key, path):
                    skipped += 1
                    continue
                value = ex.run(frame, before_wait=hand_over).values[ref]  # hands the last frame over
                pending.append((path, value, frame, key))
        except BaseException:
            # nothing rendered is lost: the frames before the failing one are still written (then the error)
            with contextlib.suppress(Exception):
                hand_over(last=True)
            raise
        hand_over(last=True)
    finally:
        seq.close()
    return {"path": frame_path(pattern, frame_list[0], many) if frame_list else Path(pattern),
            "frames": len(frame_list) - skipped, "skipped": skipped, "total": len(frame_list)}


def _host(value: Any) -> Any:
    """A value the writer thread can write without the GL context: textures are read back here."""
    from ..values import Tex, TexArray

    if isinstance(value, (Tex, TexArray)):
        from .write import to_image

        return to_image(value)
    return value


def _film_frame(ex: Any, value: Any) -> Any:
    """A texture as `Bytes8` (converted on the GPU) for a film that is not yuv420p (GIF); anything else read
    back as `_host` does. (yuv420p films take `GL.pack_yuv420`'s planes.)"""
    from .. import types
    from ..values import Tex

    if isinstance(value, Tex):
        return Bytes8(ex.gl.read_uint8(value), types.components(value.fmt))
    return _host(value)


def _yuv_frame(p: Yuv420Planes) -> Any:
    """A yuv420p `av.VideoFrame` of `p`'s planes (copied once into the frame's own, padded rows)."""
    import av

    w, h = p.size
    frame = av.VideoFrame(w, h, "yuv420p")
    y, u, v = (np.frombuffer(plane, np.uint8).reshape(-1, plane.line_size) for plane in frame.planes)
    y[0:h:2, :w] = p.y_even[:, :w]
    y[1:h:2, :w] = p.y_odd[:, :w]
    u[:h // 2, :w // 2] = p.u[:, :w // 2]
    v[:h // 2, :w // 2] = p.v[:, :w // 2]
    return frame


def _rgb(frame: Any) -> np.ndarray:
    """A frame (`Bytes8`, or uint8 RGB with row 0 at the top) as contiguous uint8 RGB (on the writer thread)."""
    if isinstance(frame, Bytes8):
        a = frame.data
        return np.ascontiguousarray(np.repeat(a[:, :, :1], 3, axis=2) if frame.channels == 1 else a[:, :, :3])
    return np.ascontiguousarray(frame)


def prepare(pipe: Any, out: str | None, frames: str | None, fps: float | None, camera: str | None
            ) -> tuple[list[int], float]:
    """The command line's animation options applied to a loaded pipeline: `--camera` (a glTF camera), `--fps`;
    returns (frames, fps). Without `--frames`, a film or a `####` pattern of an animated scene covers the
    whole animation; anything else renders frame 0."""
    from ..scene.animation import DEFAULT_FPS, default_frames, with_fps
    from ..scene.scene import select_camera
    from .write import parse_frames

    if fps is not None:
        fps = check_fps(fps)
    if pipe.scene is not None:
        pipe.scene = with_fps(select_camera(pipe.scene, camera), fps)
    anim = getattr(pipe.scene, "animation", None)
    rate = float(fps) if fps is not None else (anim.fps if anim is not None else DEFAULT_FPS)
    if frames is None and out is not None and (is_film(out) or "#" in out):
        whole = default_frames(pipe.scene)  # at most MAX_FRAMES, or one line suggesting --frames
        if whole is not None:
            return whole, rate
        if is_film(out):
            raise SketchgraphError(f"{out}: the scene does not move; give --frames START:END for a film")
    return parse_frames(frames), rate
