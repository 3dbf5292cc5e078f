"""The framing choices (`--up`, `--view`, `--fill`, scene `up:`/`view:`) and the lens (`--camera-type`, `--fov`,
`--zoom`), without NumPy: the command line builds its options from them before anything heavy is imported
(`sketchgraph --help`). The geometry that uses them is `nodegraph.scene.framing` and `Camera.with_lens`."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping
from contextvars import ContextVar
from pathlib import Path

from .timeline import ANIMATION_ENDS

UP_AXES = ("x", "y", "z", "-x", "-y", "-z")
VIEWS = ("three-quarter", "front", "back", "left", "right", "top", "widest")
CAMERA_TYPES = ("perspective", "orthographic")


def _trust_scene_files(ctx: object, param: object, value: bool) -> None:
    """--allow-outside-scene-dir: for this process, glTF URIs may leave the file's folder (gltf.OUTSIDE_ALLOWED)."""
    if value:
        from .gltf import OUTSIDE_ALLOWED

        OUTSIDE_ALLOWED.set(True)


ANIMATION: ContextVar[str | None] = ContextVar("scene_animation", default=None)
"""`--animation`: the clips glTF files play (NAME, INDEX or all; None: all), for every scene this process loads."""
ANIMATION_END: ContextVar[str | None] = ContextVar("scene_animation_end", default=None)
"""`--animation-end`: hold or loop (None: hold, or what a scene YAML object says)."""


def _scoped(var: ContextVar[str | None]) -> object:
    """A click callback that sets `var` for the command's run: it runs whether or not the option is given, and
    the value before it comes back when the command's context closes (tests and tools run many commands)."""

    def callback(ctx: object, param: object, value: str | None) -> None:
        token = var.set(value)
        ctx.call_on_close(lambda: var.reset(token))  # type: ignore[attr-defined]

    return callback


_set_animation = _scoped(ANIMATION)
_set_animation_end = _scoped(ANIMATION_END)


@contextlib.contextmanager
def playing(animation: str | int | None, end: str | None) -> Iterator[None]:
    """`--animation` and `--animation-end` in effect inside the block (for the Python API)."""
    a = ANIMATION.set(None if animation is None else str(animation))
    e = ANIMATION_END.set(end)
    try:
        yield
    finally:
        ANIMATION_END.reset(e)
        ANIMATION.reset(a)


FRONT: ContextVar[str | Mapping[str, str] | None] = ContextVar("scene_front", default=None)
"""`--front`: the axis of a mesh file (x, y, z, -x, -y, -z, in the file's own axes) its front faces, for every mesh
file this process loads (None: found by the rules of nodegraph/scene/framing.py); or a mapping from mesh files'
resolved paths to that axis, files not in it found (the benchmarks' fixed sides, nodegraph/tools/bench/sides.py)."""


def _set_front(ctx: object, param: object, value: str | None) -> None:
    if value is None:  # not given: a side fixed around the command (the benchmarks') stands
        return
    token = FRONT.set(None if value == "auto" else value)
    ctx.call_on_close(lambda: FRONT.reset(token))  # type: ignore[attr-defined]


@contextlib.contextmanager
def facing(front: str | Mapping[str, str] | None) -> Iterator[None]:
    """`--front` in effect inside the block (for the Python API, the distributed workers and the benchmarks):
    an axis, "auto" (found, whatever is in effect around the block) or a mapping (FRONT); None changes nothing."""
    if front is None:
        yield
        return
    token = FRONT.set(None if front == "auto" else front)
    try:
        yield
    finally:
        FRONT.reset(token)


def front_of(source: str | Path | None) -> str | None:
    """The front axis `--front` gives the mesh file `source` (FRONT), or None: found."""
    given = FRONT.get()
    if given is None or isinstance(given, str):
        return given
    if source is None:
        return None
    try:
        return given.get(str(Path(source).resolve()))
    except (OSError, ValueError):
        return None


LENS: ContextVar[tuple[str | None, float | None, float | None]] = ContextVar("scene_lens",
                                                                          default=(None, None, None))
"""`--camera-type`, `--fov`, `--zoom` (None: not given), applied by `scene.load_scene` to every scene this process
loads (`Camera.with_lens`)."""


def _set_lens(index: int) -> object:
    def callback(ctx: object, param: object, value: object) -> None:
        lens = list(LENS.get())
        lens[index] = value  # runs whether or not the option is given: an earlier value never leaks
        token = LENS.set((lens[0], lens[1], lens[2]))
        ctx.call_on_close(lambda: LENS.reset(token))  # type: ignore[attr-defined]  # and none outlives the command

    return callback


@contextlib.contextmanager
def lens(camera_type: str | None = None, fov: float | None = None, zoom: float | None = None) -> Iterator[None]:
    """`--camera-type`, `--fov` and `--zoom` in effect inside the block (for the Python API)."""
    token = LENS.set((camera_type, fov, zoom))
    try:
        yield
    finally:
        LENS.reset(token)


def click_options(f: object) -> object:
    """`--view`, `--up` and `--fill` for a click command (run, inspect, bench, ...): keyword args `view`, `up`,
    `fill`; and `--front`, `--allow-outside-scene-dir`, `--animation`, `--animation-end`, `--camera-type`, `--fov`
    and `--zoom`, which take effect as they are parsed (no keyword arg; `FRONT`, `ANIMATION`, `ANIMATION_END`,
    `LENS`)."""
    import click

    f = click.option("--zoom", type=click.FloatRange(0.0, 1e6, min_open=True), default=None, metavar="F",
                     expose_value=False, callback=_set_lens(2),
                     help="Magnify the view by F (2: the subject twice as large, 0.5: half), perspective or "
                     "orthographic, framed or a file's own camera.")(f)
    f = click.option("--fov", type=click.FloatRange(0.0, 180.0, min_open=True, max_open=True), default=None,
                     metavar="DEG", expose_value=False, callback=_set_lens(1),
                     help="Perspective field of view in degrees (across the picture's shorter side; a glTF "
                     "camera's: its height); the camera moves along its axis so the subject keeps its size.")(f)
    f = click.option("--camera-type", type=click.Choice(CAMERA_TYPES), default=None, expose_value=False,
                     callback=_set_lens(0), help="Perspective or orthographic (parallel lines stay parallel); "
                     "the view keeps what it shows in the plane through the camera's target.")(f)
    f = click.option("--animation-end", type=click.Choice(ANIMATION_ENDS), default=None, expose_value=False,
                     callback=_set_animation_end, help="What a glTF clip shorter than the longest does after its "
                     "last key: hold its last pose or loop (default hold).")(f)
    f = click.option("--animation", metavar="NAME|INDEX|all", default=None, expose_value=False,
                     callback=_set_animation, help="Which animations of a glTF file play (default all, together, "
                     "as glTF viewers play them; NAME or INDEX: that clip alone).")(f)
    f = click.option("--allow-outside-scene-dir", is_flag=True, expose_value=False, callback=_trust_scene_files,
                     help="Let glTF files read buffers and images outside their own folder (trusted files only; "
                     "by default such a URI is refused).")(f)
    f = click.option("--fill", type=click.FloatRange(0.0, 4.0, min_open=True), default=None, metavar="F",
                     help="Share of the picture's shorter side a mesh file's projected bounding box spans "
                     "(default 0.85).")(f)
    f = click.option("--front", type=click.Choice(UP_AXES + ("auto",)), default=None, expose_value=False,
                     callback=_set_front, help="The axis a mesh file's front faces, in the file's own axes (default "
                     "auto: +Z, -Y for STL, unless its shape says otherwise); the views are taken from it.")(f)
    f = click.option("--up", type=click.Choice(UP_AXES + ("auto",)), default=None,
                     help="The mesh file's up axis (default auto: the format's convention unless the shape "
                     "clearly says otherwise; -y: upside down).")(f)
    f = click.option("--view", type=click.Choice(VIEWS), default=None,
                     help="Side a mesh file (or a scene file without a camera) is seen from (default "
                     "three-quarter: front and a little to the right, from above).")(f)
    return f
