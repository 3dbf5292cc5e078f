"""Files in and out: check an input path before opening it, and write outputs atomically.

Inputs: `check_input` stats a path (following symlinks) and refuses what is not a regular file of a
sane size (a folder, a FIFO, `/dev/zero`, an over-long name) with one line, before anything is read.

Outputs: `atomic_output(path)` yields a temporary path in the same folder (same extension, so
libraries that pick the format from the name still work); the file is synced and renamed onto `path`
only when the writer finished without error, so a failed write (a full disk, a size limit) leaves the
previous file as it was and no partial file behind. A frame sequence writes its frames with `sync=False`
and makes them durable together at its end (`sync_written`): a killed process still leaves each frame
whole or absent, and the command returns only once its frames are on disk.

Before anything renders, `check_output(path)` (a file) and `check_output_folder(path)` (a folder the output
goes into) refuse, with one line, what cannot be written: a part of the folder that is a file, a target that is
a folder or a device, a folder that takes no new files (tried by creating and removing a temporary file).

Temporary files are hidden and carry the writer's process id: `.NAME.tmp-PID-N.EXT` (`atomic_output`) and
`.NAME.partial-PID-N.EXT` (films). A killed writer leaves its file; `clean_stale_temps` (called by the next
run writing the same output) removes those whose process is gone, or which are older than `STALE_AGE` (the
pid may be reused), and never another live process's or this process's own.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import itertools
import os
import re
import stat
import threading
import time
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from .errors import SketchgraphError


class OutputError(SketchgraphError):
    """An output file could not be written; the previous file (if any) is unchanged."""


class OutputPathError(OutputError, ValueError):
    """An output path that cannot be written, found before anything renders (`check_output`): a part of its
    folder is a file, it is a folder or a device, or its folder takes no new files."""


class IncompleteWrite(OutputError):
    """Raised by a writer (inside `atomic_output`) whose library reported a failure without an OS error;
    `atomic_output` then looks for the OS reason itself."""


def show_path(path: str | os.PathLike[str], limit: int = 160) -> str:
    """A path for a message: whole when short, else its start and end around an ellipsis."""
    text = os.fspath(path)
    if len(text) <= limit:
        return text
    keep = (limit - 1) // 2
    return f"{text[:keep]}…{text[-keep:]} ({len(text)} characters)"


def clean(text: str, limit: int = 120) -> str:
    """A library's message fit for one line: printable ASCII only, whitespace collapsed, capped."""
    out = "".join(c if 32 <= ord(c) < 127 else " " for c in str(text))
    out = " ".join(out.split())
    return out if len(out) <= limit else out[: limit - 1] + "…"


# --- compiled kernels: optional, and one line where they cannot be used ---------------------------------------
_COMPILED_WARNED: set[str] = set()


def compiled(package: str, name: str, what: str, instead: str) -> Any:
    """The Numba-compiled module `package.name`, or None: silently where it cannot be imported (Numba is optional;
    the caller's NumPy or Python code gives the same results, slower), and with one RuntimeWarning per module
    where Numba, importing it, finds no writable folder for its cache of compiled code (a read-only install
    without NUMBA_CACHE_DIR). `what` names the compiled code and `instead` what runs in its place, for that line."""
    import importlib
    import warnings

    try:
        return importlib.import_module(f"{package}.{name}")
    except ImportError:
        return None
    except RuntimeError as exc:
        if f"{package}.{name}" not in _COMPILED_WARNED:
            _COMPILED_WARNED.add(f"{package}.{name}")
            warnings.warn(f"{what} unavailable ({exc}); running {instead}. Set NUMBA_CACHE_DIR to a writable "
                          "folder.", RuntimeWarning, stacklevel=3)
        return None


# --- image libraries, kept quiet: each problem becomes one line of ours --------------------------------------
_STDERR_LOCK = threading.RLock()


@functools.cache
def oiio() -> Any:
    """The OpenImageIO module, with its own printing turned off: an ImageBuf destroyed with an error nobody
    retrieved no longer prints it (`imagebuf:print_uncaught_errors`). Callers retrieve every error
    (`geterror()`, also the global one, which OpenImageIO otherwise prints at exit) and say it in one line."""
    import OpenImageIO

    OpenImageIO.attribute("imagebuf:print_uncaught_errors", 0)
    return OpenImageIO


@contextlib.contextmanager
def native_stderr() -> Iterator[list[str]]:
    """Capture what C libraries write straight to file descriptor 2 while the block runs (libpng prints
    "libpng error: ..." there, past OpenImageIO and Python); the lines fill the list yielded, for the caller's
    one-line message. One block at a time in the process; whatever the process writes to stderr meanwhile is
    captured too, so keep the block to the decoding call. Where descriptor 2 cannot be redirected, nothing
    is captured."""
    import sys
    import tempfile

    lines: list[str] = []
    with _STDERR_LOCK:
        with contextlib.suppress(AttributeError, OSError, ValueError):
            sys.stderr.flush()
        try:
            saved = os.dup(2)
        except OSError:
            yield lines
            return
        try:
            with tempfile.TemporaryFile() as sink:
                os.dup2(sink.fileno(), 2)
                try:
                    yield lines
                finally:
                    with contextlib.suppress(AttributeError, OSError, ValueError):
                        sys.stderr.flush()
                    os.dup2(saved, 2)
                    sink.seek(0)
                    text = sink.read(1 << 16).decode("utf-8", "replace")
                    lines += [ln for ln in text.splitlines() if ln.strip()]
        finally:
            os.close(saved)


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _os_reason(exc: OSError) -> str:
    if exc.errno == errno.ENAMETOOLONG:
        return "path too long for the filesystem (File name too long)"
    return exc.strerror or type(exc).__name__


def check_input(path: str | os.PathLike[str], what: str = "file", max_bytes: int | None = None,
                error: type[SketchgraphError] = SketchgraphError) -> os.stat_result:
    """`os.stat(path)`, refusing anything but a regular file of at most `max_bytes` with one line."""
    shown = show_path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise error(f"{shown}: {what} not found (check the path)") from None
    except NotADirectoryError:
        raise error(f"{shown}: {what} not found (a part of the path is not a folder)") from None
    except OSError as exc:
        raise error(f"{shown}: cannot access {what}: {_os_reason(exc)}") from None
    except ValueError:  # embedded NUL in the path
        raise error(f"{shown}: cannot access {what}: the path contains a NUL character") from None
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{shown}: expected a regular {what}, found {_kind(st.st_mode)}")
    if max_bytes is not None and st.st_size > max_bytes:
        raise error(f"{shown}: {what} too large: expected at most {_size(max_bytes)}, found {_size(st.st_size)}")
    return st


def read_input(path: str | os.PathLike[str], what: str = "file", max_bytes: int = 16 * 1024**2,
               error: type[SketchgraphError] = SketchgraphError) -> bytes:
    """The bytes of a regular file of at most `max_bytes` (checked before opening and while reading)."""
    check_input(path, what, max_bytes, error)
    try:
        with open(path, "rb") as fh:
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise error(f"{show_path(path)}: cannot read {what}: {_os_reason(exc)}") from None
    if len(data) > max_bytes:  # grew after the stat
        raise error(f"{show_path(path)}: {what} too large: expected at most {_size(max_bytes)}")
    return data


def _size(n: int) -> str:
    if n >= 1024**2:
        return f"{n / 1024**2:.1f} MiB"
    if n >= 1024:
        return f"{n / 1024:.1f} KiB"
    return f"{n} bytes"


def make_folder(folder: Path, for_path: Path) -> None:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{show_path(for_path)}: cannot create folder {show_path(folder)}: "
                          f"{_os_reason(exc)}") from None
    if not folder.is_dir():
        raise OutputError(f"{show_path(for_path)}: cannot write: {show_path(folder)} is not a folder")


def _kind_of(mode: int) -> str:
    return "a file" if stat.S_ISREG(mode) else _kind(mode)


def _existing_folder(folder: Path, for_path: Path) -> Path:
    """The deepest existing folder at or above `folder`; one line when one of them is a file (or a device)."""
    cur = folder if str(folder) else Path(".")
    while True:
        try:
            st = os.stat(cur)
        except (FileNotFoundError, NotADirectoryError):
            up = cur.parent
            if up == cur:
                raise OutputPathError(f"{show_path(for_path)}: cannot write: no part of its folder exists") from None
            cur = up
            continue
        except OSError as exc:
            raise OutputPathError(f"{show_path(for_path)}: cannot write: {show_path(cur)}: {_os_reason(exc)}") \
                from None
        except ValueError:
            raise OutputPathError(f"{show_path(for_path)}: cannot write: the path contains a NUL character") from None
        if stat.S_ISDIR(st.st_mode):
            return cur
        raise OutputPathError(f"{show_path(for_path)}: cannot write: {show_path(cur)} is {_kind_of(st.st_mode)}, "
                              "not a folder")


def _probe_folder(folder: Path, for_path: Path) -> None:
    """Create and remove a temporary file (named as `atomic_output` names them) in `folder`: one line when the
    folder takes no new files (read-only, no permission, no space for a file)."""
    name = for_path.name or "output"
    tmp = folder / f".{name}.tmp-{os.getpid()}-{next(_temp_numbers)}{for_path.suffix}"
    try:
        fd = os.open(tmp, _TEMP_FLAGS, 0o666)
    except OSError as exc:
        raise OutputPathError(f"{show_path(for_path)}: cannot write in {show_path(folder)}: {_os_reason(exc)}") \
            from None
    os.close(fd)
    _remove(tmp)


def _stat_output(p: Path) -> os.stat_result | None:
    """`os.stat(p)`, None where nothing is there yet; any other fault one line (`OutputPathError`)."""
    try:
        return os.stat(p)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:
        raise OutputPathError(f"{show_path(p)}: cannot write: {_os_reason(exc)}") from None
    except ValueError:
        raise OutputPathError(f"{show_path(p)}: cannot write: the path contains a NUL character") from None


def check_output(path: str | os.PathLike[str]) -> Path:
    """Before anything renders: `path` can be written as a file. One line (`OutputPathError`) when a part of its
    folder is a file, it is a folder or a device (`/dev/null`: replacing a device is never what was meant), or
    the deepest existing folder takes no new files. Creates nothing it leaves behind; returns `path`."""
    p = Path(path)
    st = _stat_output(p)
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise OutputPathError(f"{show_path(p)}: cannot write: it is a folder; give a file's name (inside it, or "
                              "beside it)")
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise OutputPathError(f"{show_path(p)}: cannot write: expected a regular file, found {_kind(st.st_mode)}")
    _probe_folder(_existing_folder(p.parent, p), p)
    return p


def check_output_folder(path: str | os.PathLike[str]) -> Path:
    """Before anything renders: `path` is a folder that takes new files, or can be made one. One line
    (`OutputPathError`) otherwise: it is a file or a device, a part above it is a file, files cannot be made."""
    p = Path(path)
    st = _stat_output(p)
    if st is not None and not stat.S_ISDIR(st.st_mode):
        raise OutputPathError(f"{show_path(p)}: cannot write into it: expected a folder, found {_kind_of(st.st_mode)}")
    folder = p if st is not None else _existing_folder(p.parent, p)
    _probe_folder(folder, p / "probe")
    return p


STALE_AGE = 24 * 3600.0
"""Seconds after which a temporary file counts as stale even when a process with its pid runs (pids are reused)."""

_TEMP_NAME = re.compile(r"\.(?P<target>.+)\.(?:tmp|partial)-(?P<pid>\d{1,10})(?:-\d{1,20})?(?P<ext>\.[^.]*)?")


def temp_target(name: str) -> tuple[str, int] | None:
    """(the output's name, the writer's pid) of one of our temporary files' names, else None."""
    m = _TEMP_NAME.fullmatch(name)
    if m is None:
        return None
    target = m.group("target")
    if (m.group("ext") or "") != os.path.splitext(target)[1]:
        return None
    return target, int(m.group("pid"))


def pid_alive(pid: int) -> bool:
    """Whether a process `pid` runs on this machine (a process of another user counts)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    except OverflowError:
        return False
    return True


def clean_stale_temps(folder: str | os.PathLike[str], target: str | re.Pattern[str]) -> list[Path]:
    """Remove our temporary files in `folder` for outputs named `target` (a name, or a pattern the whole name
    matches) whose writer is gone: its pid is not a live process here, or the file is older than `STALE_AGE`.
    Never this process's own files, never anything but regular files named as ours. Returns what was removed;
    a folder that cannot be listed is left alone."""
    matches = (lambda n: n == target) if isinstance(target, str) else (lambda n: target.fullmatch(n) is not None)
    removed: list[Path] = []
    now = time.time()
    try:
        entries = list(os.scandir(folder))
    except (OSError, ValueError):
        return removed
    for entry in entries:
        found = temp_target(entry.name)
        if found is None or not matches(found[0]) or found[1] == os.getpid():
            continue
        try:
            st = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        if not stat.S_ISREG(st.st_mode):
            continue
        if pid_alive(found[1]) and now - st.st_mtime < STALE_AGE:
            continue
        with contextlib.suppress(OSError):
            os.unlink(entry.path)
            removed.append(Path(entry.path))
    return removed


def new_temp_name(p: Path, kind: str = "tmp") -> Path:
    """A temporary path beside `p` named as ours (`.NAME.KIND-PID-N.EXT`), not yet created."""
    folder = p.parent if str(p.parent) else Path(".")
    return folder / f".{p.name}.{kind}-{os.getpid()}-{next(_temp_numbers)}{p.suffix}"


def _probe_reason(tmp: Path) -> str | None:
    """Why writing to `tmp`'s filesystem fails now, from the OS: append 64 KiB and see what happens."""
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_APPEND)
    except OSError as exc:
        return _os_reason(exc)
    try:
        os.write(fd, b"\0" * 65536)
        os.fsync(fd)
    except OSError as exc:
        return _os_reason(exc)
    finally:
        os.close(fd)
    return None


def _remove(path: Path) -> None:
    with contextlib.suppress(OSError):
        path.unlink()


_TEMP_FLAGS = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0)
_temp_numbers = itertools.count()


def _open_temp(p: Path) -> tuple[int, Path]:
    """Create `.NAME.tmp-PID-N.EXT` beside `p` (a new name each call, never an existing file), open for writing,
    with the mode any new file gets (0666 less the umask; the kernel applies it, so no thread flips the process's
    umask). The folder is made only when the first try finds it missing."""
    folder = p.parent if str(p.parent) else Path(".")
    made = False
    for _ in range(1000):
        tmp = folder / f".{p.name}.tmp-{os.getpid()}-{next(_temp_numbers)}{p.suffix}"
        try:
            return os.open(tmp, _TEMP_FLAGS, 0o666), tmp
        except FileExistsError:  # left by a process that had this pid: take the next number
            continue
        except (FileNotFoundError, NotADirectoryError):
            if made:
                raise
            make_folder(folder, p)  # raises the reason when the folder cannot be made
            made = True
    raise OutputError(f"{show_path(p)}: cannot write: no free temporary name beside it")


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str], nonempty: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside `path` (`.NAME.tmp-PID-N.EXT`); when the body returns, sync it and
    rename it onto `path`. Any failure removes the temporary file, leaves `path` untouched and raises
    one line naming `path` and the OS error. `nonempty`: an empty result counts as a failure."""
    p = Path(path)
    fd, tmp = _temp_for(p)
    os.close(fd)
    with _removed_on_failure(tmp, p):
        try:
            yield tmp
        except IncompleteWrite as exc:
            detail = _probe_reason(tmp) or clean(str(exc)) or "the writer failed"
            raise OutputError(f"{show_path(p)}: cannot write: {detail}") from None
        if nonempty and tmp.stat().st_size == 0:
            reason = _probe_reason(tmp)
            raise OutputError(f"{show_path(p)}: cannot write: {reason or 'the writer produced an empty file'}")
        with _opened(tmp) as fd:
            _sync_keeping_mode(fd, p)
        os.replace(tmp, p)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes, sync: bool = True) -> Path:
    """Write `data` to `path` atomically, as `atomic_output` does, in one open of the temporary file (a frame
    sequence's writer threads call this once a frame); returns `path`. With `sync` False the file is renamed
    into place unsynced: the caller syncs it later (`sync_written`)."""
    p = Path(path)
    fd, tmp = _temp_for(p)
    with _removed_on_failure(tmp, p):
        with open(fd, "wb", buffering=0) as fh:
            view = memoryview(data)
            while view:  # a raw write may take less than asked
                view = view[fh.write(view):]
            if sync:
                os.fsync(fd)
            _keep_mode(fd, p)
        os.replace(tmp, p)
    return p


def sync_written(paths: Iterable[str | os.PathLike[str]]) -> None:
    """Make files written with `sync=False` durable, with their folders (their renames). A frame sequence does
    this at its end instead of syncing every frame as it is written: on the project's VM the per-frame sync
    cost about 0.5 ms of kernel CPU a frame, beside llvmpipe's threads. Where the C library has `syncfs`
    (Linux), each file system holding them is synced once (60 new frames: 0.6-0.7 ms, against 7-20 ms for a
    sync of each file); elsewhere each file, then each folder, is synced. A failure raises one line naming
    the file or the folder."""
    files = [Path(p) for p in paths]
    folders = list(dict.fromkeys(p.parent for p in files))
    syncfs = _syncfs()
    if syncfs is not None:
        seen: set[int] = set()
        for folder in folders:
            try:
                with _opened(folder) as fd:
                    dev = os.fstat(fd).st_dev
                    if dev not in seen and syncfs(fd) != 0:
                        import ctypes

                        err = ctypes.get_errno()
                        raise OSError(err, os.strerror(err))
                    seen.add(dev)
            except OSError as exc:
                raise OutputError(f"{show_path(folder)}: cannot sync: {_os_reason(exc)}") from None
        return
    for p in files:
        try:
            with _opened(p) as fd:
                os.fsync(fd)
        except OSError as exc:
            raise OutputError(f"{show_path(p)}: cannot sync: {_os_reason(exc)}") from None
    for folder in folders:
        with contextlib.suppress(OSError), _opened(folder) as fd:  # some filesystems refuse to sync a folder
            os.fsync(fd)


@contextlib.contextmanager
def _opened(path: str | os.PathLike[str]) -> Iterator[int]:
    """A read-only descriptor of `path` (a file or a folder), closed on leaving."""
    fd = os.open(path, os.O_RDONLY)
    try:
        yield fd
    finally:
        os.close(fd)


@functools.cache
def _syncfs() -> Any:
    """The C library's syncfs(fd), or None where there is none (not Linux)."""
    import ctypes

    try:
        return ctypes.CDLL(None, use_errno=True).syncfs
    except (OSError, AttributeError):
        return None


@contextlib.contextmanager
def _removed_on_failure(tmp: Path, p: Path) -> Iterator[None]:
    """Inside: an OS error becomes one line naming `p`; any failure removes `tmp` and is raised."""
    try:
        try:
            yield
        except OSError as exc:
            raise _write_error(p, exc) from None
    except BaseException:
        _remove(tmp)
        raise


def _write_error(p: Path, exc: OSError) -> OutputError:
    return OutputError(f"{show_path(p)}: cannot write: {_os_reason(exc)}")


def _temp_for(p: Path) -> tuple[int, Path]:
    """`_open_temp`, its OS errors as one line naming `p`."""
    try:
        return _open_temp(p)
    except OSError as exc:
        raise _write_error(p, exc) from None


def _sync_keeping_mode(fd: int, p: Path) -> None:
    """Sync the temporary file open as `fd`, and give it `p`'s mode (`_keep_mode`)."""
    os.fsync(fd)
    _keep_mode(fd, p)


def _keep_mode(fd: int, p: Path) -> None:
    """Give the temporary file open as `fd` `p`'s mode where `p` exists (a rewrite keeps its permissions; a new
    file keeps the mode it was created with)."""
    try:
        mode = stat.S_IMODE(os.stat(p).st_mode)
    except OSError:
        return
    os.fchmod(fd, mode)


def atomic_write_text(path: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> Path:
    return atomic_write_bytes(path, text.encode(encoding))
