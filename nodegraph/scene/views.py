"""The framing choices (`--up`, `--view`, `--fill`, scene `up:`/`view:`), without NumPy: the command line
builds its options from them before anything heavy is imported (`sketchgraph --help`). The geometry that
uses them is `nodegraph.scene.framing`."""

from __future__ import annotations

UP_AXES = ("x", "y", "z", "-x", "-y", "-z")
VIEWS = ("three-quarter", "front", "back", "left", "right", "top", "widest")


def _trust_scene_files(ctx: object, param: object, value: bool) -> None:
    """--allow-outside-scene-dir: for this process, glTF URIs may leave the file's folder (gltf.OUTSIDE_ALLOWED)."""
    if value:
        from .gltf import OUTSIDE_ALLOWED

        OUTSIDE_ALLOWED.set(True)


def click_options(f: object) -> object:
    """`--view`, `--up` and `--fill` for a click command (run, inspect, bench, ...): keyword args `view`, `up`,
    `fill`; and `--allow-outside-scene-dir`, which takes effect as it is parsed (no keyword arg)."""
    import click

    f = click.option("--allow-outside-scene-dir", is_flag=True, expose_value=False, callback=_trust_scene_files,
                     help="Let glTF files read buffers and images outside their own folder (trusted files only; "
                     "by default such a URI is refused).")(f)
    f = click.option("--fill", type=click.FloatRange(0.0, 4.0, min_open=True), default=None, metavar="F",
                     help="Share of the picture's shorter side a mesh file's projected bounding box spans "
                     "(default 0.85).")(f)
    f = click.option("--up", type=click.Choice(UP_AXES + ("auto",)), default=None,
                     help="The mesh file's up axis (default auto: the format's convention unless the shape "
                     "clearly says otherwise; -y: upside down).")(f)
    f = click.option("--view", type=click.Choice(VIEWS), default=None,
                     help="Side a mesh file (or a scene file without a camera) is seen from (default "
                     "three-quarter: front and a little to the right, from above).")(f)
    return f
