"""The `sketchgraph` command line. Every error is one line on stderr and exit status 2."""

from __future__ import annotations

import contextlib
import json
import os
import sys
import time
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from .errors import SketchgraphError
from .output.write import frame_path, parse_frames, write_frame, write_value
from .render import open_cache, open_pipeline
from .scene.views import click_options as framing_options

if TYPE_CHECKING:
    pass


def _warn_one_line(message: Any, category: Any, filename: str, lineno: int, file: Any = None, line: Any = None) -> None:
    print(f"warning: {message}", file=sys.stderr)


class _Group(click.Group):
    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except SketchgraphError as exc:
            if os.environ.get("SKETCHGRAPH_DEBUG"):
                raise
            click.echo("error: " + " ".join(str(exc).splitlines()), err=True)  # one line, whatever it quotes
            sys.exit(2)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="sketchgraph")
def main() -> None:
    """Sketchy, pencil and loose-line drawings of 3D meshes from YAML node graphs."""
    warnings.showwarning = _warn_one_line


# -- shared options -------------------------------------------------------------------------
def pipeline_options(f: Any) -> Any:
    f = click.option("--set", "overrides", multiple=True, metavar="NODE.PARAM=VALUE",
                     help="Override a node parameter (YAML value; repeatable).")(f)
    f = click.option("--size", metavar="WxH", help="Output size, e.g. 1200x900.")(f)
    f = framing_options(f)
    f = click.option("--scene", metavar="SCENE", help="builtin:NAME, a scene YAML or a mesh file.")(f)
    return f


def out_dir_options(f: Any) -> Any:
    f = click.option("--allow-outside-out-dir", "allow_outside", is_flag=True,
                     help="Let the pipeline's write/strokes_svg paths leave --out-dir.")(f)
    f = click.option("--out-dir", type=click.Path(path_type=Path), help="Folder the pipeline's own file paths "
                     "(write, strokes_svg) resolve against and must stay in (default: the current directory).")(f)
    return f


def scheduler_options(f: Any) -> Any:
    f = click.option("--chunk", type=int, default=None, metavar="N", help="With --scheduler: work items per task "
                     "(default: chosen from the measured per-task overhead; docs/distributed.md).")(f)
    f = click.option("--scheduler", metavar="local:N|tcp://HOST:PORT", help="Run on a Dask cluster: N local worker "
                     "processes, or a running scheduler (the cache folder must be shared; docs/distributed.md).")(f)
    return f


def cache_options(f: Any) -> Any:
    f = click.option("--no-cache", is_flag=True, help="Neither read nor write the disk cache.")(f)
    f = click.option("--cache-dir", type=click.Path(path_type=Path), help="Cache folder "
                     "(default $SKETCHGRAPH_CACHE_DIR or ~/.cache/sketchgraph).")(f)
    return f


# -- run ------------------------------------------------------------------------------------
@main.command()
@click.argument("pipeline", type=click.Path())
@click.option("-o", "--out", "out", metavar="FILE", help="Image (PNG, EXR), image sequence (#### = frame number) "
              "or film (.mp4, .webm, .gif) to write. Default: out/<pipeline>.png")
@click.option("--output", "output_name", metavar="NAME", help="Which pipeline output to write (default: the first).")
@click.option("--frames", metavar="START:END[:STEP]", help="Render a frame sequence along the scene's orbit.")
@click.option("--explain", is_flag=True, help="Print the plan (what runs, why, from where, formats, memory) first.")
@click.option("--quiet", "-q", is_flag=True, help="Print nothing but errors.")
@click.option("--watch", is_flag=True, help="Re-render whenever the pipeline, its scene file or the scene's "
              "meshes change; only nodes whose key changed recompute. Ctrl-C stops.")
@click.option("--interval", default=0.5, show_default=True, metavar="SECONDS", help="How often --watch polls.")
@click.option("--fps", type=float, metavar="N", help="Frames per second of the animation and the film "
              "(default: the scene's fps:, else 24).")
@click.option("--camera", "camera", metavar="NAME|INDEX", help="Look through this camera of a glTF scene.")
@click.option("--crf", type=int, metavar="N", help="Film quality (.mp4 H.264 / .webm VP9 constant rate factor: "
              "lower is better; default 18 / 32).")
@click.option("--resume", is_flag=True, help="Image sequences: skip frames an earlier (killed) run finished: the "
              "sidecar manifest beside the pattern says which, checked against keys and file hashes.")
@click.option("--png-level", type=click.IntRange(0, 9), default=None, metavar="0-9", help="zlib level of the PNGs "
              "written (default 1: fastest measured at nearly the size of 6; docs/performance.md).")
@click.option("--page", metavar="A4|A3|letter|WxHmm", help="SVG output: the page's physical size in mm, the drawing "
              "fitted inside a 10 mm margin, stroke widths in mm (docs/strokes.md). Default: pixels.")
@click.option("--film", "film_setting", is_flag=True, help="Render with the pipeline's film setting "
              "(docs/animation.md, Making films): every hold at 0 and, for a shipped pipeline, the setting measured "
              "for films (a variant file or parameters); --set applies on top.")
@pipeline_options
@cache_options
@out_dir_options
@scheduler_options
def run(pipeline: str, out: str | None, output_name: str | None, frames: str | None, explain: bool, quiet: bool,
        watch: bool, interval: float, fps: float | None, camera: str | None, crf: int | None, resume: bool,
        png_level: int | None, page: str | None, film_setting: bool, overrides: tuple[str, ...], size: str | None,
        scene: str | None, no_cache: bool, cache_dir: Path | None, out_dir: Path | None, allow_outside: bool,
        scheduler: str | None, chunk: int | None, view: str | None = None, up: str | None = None,
        fill: float | None = None) -> None:
    """Render a pipeline to an image (or a frame sequence)."""
    from .executor import Executor

    if film_setting:
        from . import films

        pipeline, film_overrides = films.film_setting(pipeline)
        overrides = (*film_overrides, *overrides)
        if not quiet:
            click.echo(f"film setting: {pipeline} " + " ".join(f"--set {o}" for o in film_overrides), err=True)

    if scheduler is not None:
        if watch or explain:
            raise SketchgraphError("--scheduler renders on a cluster; drop --watch and --explain")
        from . import distributed as dist
        from .output import film

        for given, option in ((png_level, "--png-level"), (page, "--page")):
            if given is not None:
                raise SketchgraphError(f"{option} is not passed to cluster workers: drop it, or render without "
                                       "--scheduler")
        if fps is not None:
            fps = film.check_fps(fps)
        spec = dist.PipeSpec.make(pipeline, overrides, size, scene, output_name, view=view, up=up, fill=fill,
                                  camera=camera, fps=fps)
        opened = spec.open()  # --camera and --fps applied, as every worker applies them
        dist.ref_of(opened, output_name)  # load-time errors before a cluster starts
        frame_list, rate = film.prepare(opened, out, frames, fps, None)
        pattern = out or f"out/{Path(pipeline).stem}.png"
        from .output.film import check_target

        check_target(pattern, frame_list)  # -o faults as one line before a cluster starts
        root: Any = False if no_cache else cache_dir
        with dist.connect(scheduler, cache_root=root) as client:
            report = dist.render_frames(client, spec, frame_list, pattern, chunk=chunk, resume=resume,
                                        progress=not quiet, cache_root=root, fps=rate, crf=crf)
        if not quiet:
            click.echo(report.format())
            click.echo(f"wrote {len(frame_list)} frames to {frame_path(pattern, frame_list[0], True).parent}"
                       if len(frame_list) > 1 else f"wrote {frame_path(pattern, frame_list[0], False)}")
        return
    if chunk is not None:
        raise SketchgraphError("--chunk splits work for --scheduler; give --scheduler too")

    if watch:
        if frames is not None and len(parse_frames(frames)) > 1:
            raise SketchgraphError("--watch renders one frame; give --frames N or drop --frames")
        from .tools import watch as watchmod

        watcher = watchmod.Watcher(pipeline, out, output_name, overrides, size, scene,
                                   open_cache(no_cache, cache_dir), frame=parse_frames(frames)[0],
                                   out_dir=out_dir, allow_outside=allow_outside, view=view, up=up, fill=fill)
        click.echo(f"watching {pipeline} (Ctrl-C stops)", err=True)
        watchmod.watch(watcher, interval, echo=click.echo)
        return
    from .output.svg import parse_page

    svg_page = parse_page(page)
    cache = open_cache(no_cache, cache_dir)  # first: a mesh file parsed in an earlier run is read from its root
    pipe = open_pipeline(pipeline, overrides, size, scene, out_dir=out_dir, allow_outside=allow_outside, view=view,
                         up=up, fill=fill)
    from .output import film

    frame_list, fps = film.prepare(pipe, out, frames, fps, camera)
    name = output_name or default_output(pipe, out)
    if name not in pipe.outputs:
        raise SketchgraphError(f"pipeline has no output '{name}'; outputs: {', '.join(pipe.outputs)}")
    ref = pipe.outputs[name]
    ex = Executor(pipe, cache, mode="loop" if len(frame_list) > 1 or film.is_film(out or "") else "single",
                  requested=[ref], background_writes=True)  # the image first; close() waits for the cache
    if explain:
        from .tools.explain import explain as explain_plan

        click.echo(explain_plan(ex, frame_list[0]))
    pattern = out or f"out/{Path(pipeline).stem}.png"
    from .output.film import check_target

    check_target(pattern, frame_list)  # -o faults as one line before anything renders
    many = len(frame_list) > 1
    t0 = time.perf_counter()
    if film.is_film(pattern) or many:
        try:
            done = film.render_frames(ex, ref, frame_list, pattern, fps=fps, crf=crf, resume=resume,
                                      bar=lambda fl: _progress(fl, quiet, "frames"), png_level=png_level,
                                      page=svg_page)
        finally:
            ex.close()
        if not quiet:
            skipped = f" ({done['skipped']} already written)" if done["skipped"] else ""
            where = done["path"] if film.is_film(pattern) else done["path"].parent
            click.echo(f"wrote {done['frames']} frames{skipped} to {where} in {time.perf_counter() - t0:.1f} s")
        return
    frame = frame_list[0]  # one frame: sequences and films went through film.render_frames above
    target = frame_path(pattern, frame, False)
    try:
        with _node_progress(quiet):
            result = ex.run(frame)
        path = write_frame(result.values[ref], target, lambda: ex.gl, png_level, svg_page)
        if not quiet:
            click.echo(f"wrote {path}  ({summary(result)})")
    finally:
        ex.close(None if quiet else lambda text: click.echo(text, err=True))


def summary(result: Any) -> str:
    """'4 of 5 nodes computed: a, b, c, d; 1 pass-through; 120 ms in nodes'."""
    computed = result.computed()
    by_status: dict[str, int] = {}
    for st in result.stats.values():
        if st.status not in ("computed", "skipped"):
            by_status[st.status] = by_status.get(st.status, 0) + 1
    extra = "".join(f"; {n} {'from ' if s in ('memory', 'disk') else ''}{s}" for s, n in sorted(by_status.items()))
    ms = sum(s.ms for s in result.stats.values())
    return (f"{len(computed)} of {len(result.stats)} nodes computed: {', '.join(computed) or 'none'}{extra}; "
            f"{ms:.0f} ms in nodes")


@contextlib.contextmanager
def _node_progress(quiet: bool) -> Iterator[None]:
    """One updating line on stderr naming the node being computed, for renders that take a while (shown after
    half a second); nothing with -q or when stderr is not a terminal."""
    from .executor import on_compute

    if quiet or not sys.stderr.isatty():
        yield
        return
    from tqdm import tqdm

    with tqdm(unit="node", file=sys.stderr, leave=False, delay=0.5) as bar:

        def step(nid: str, type_name: str) -> None:
            bar.set_postfix_str(f"{nid} ({type_name})", refresh=False)
            bar.update()

        with on_compute(step):
            yield


def _progress(items: list[int], disable: bool, unit: str) -> Any:
    from tqdm import tqdm

    return tqdm(items, disable=disable or not sys.stderr.isatty(), unit=unit, file=sys.stderr, leave=False)


def _progress_total(items: Any, total: int, disable: bool, unit: str) -> Any:
    from tqdm import tqdm

    return tqdm(items, total=total, disable=disable or not sys.stderr.isatty(), unit=unit, file=sys.stderr,
                leave=False)


# -- inspect --------------------------------------------------------------------------------
@main.command()
@click.argument("pipeline", type=click.Path())
@click.argument("port", required=False)
@click.option("-o", "--out", "out", metavar="FILE", help="File to write (.exr keeps exact values, .png to look at).")
@click.option("--frame", default=0, show_default=True, help="Frame to render.")
@click.option("--all", "all_", is_flag=True, help="Every planned node output into the folder -o DIR: EXR + PNG "
              "each, a contact sheet and an HTML page (default DIR: out/<pipeline>.inspect).")
@click.option("--quiet", "-q", is_flag=True, help="No progress line.")
@pipeline_options
@cache_options
@out_dir_options
def inspect(pipeline: str, port: str | None, out: str | None, frame: int, all_: bool, quiet: bool,
            overrides: tuple[str, ...], size: str | None, scene: str | None, no_cache: bool, cache_dir: Path | None,
            out_dir: Path | None, allow_outside: bool, view: str | None = None, up: str | None = None,
            fill: float | None = None) -> None:
    """Write any node's output (NODE.PORT) to a file; runs only what that output needs."""
    from .executor import Executor

    cache = open_cache(no_cache, cache_dir)  # first: a mesh file parsed in an earlier run is read from its root
    pipe = open_pipeline(pipeline, overrides, size, scene, out_dir=out_dir, allow_outside=allow_outside, view=view,
                         up=up, fill=fill)
    if all_:
        if port is not None:
            raise SketchgraphError("--all writes every output; drop NODE.PORT or drop --all")
        from .output.film import check_folder
        from .tools.inspect_all import inspect_all

        check_folder(out or f"out/{Path(pipeline).stem}.inspect")  # -o faults as one line before anything renders
        with _node_progress(quiet):
            insp, page = inspect_all(pipe, Path(out or f"out/{Path(pipeline).stem}.inspect"), frame, cache)
        click.echo(f"wrote {len(insp.ports())} outputs of {len(insp.nodes)} nodes to {page.parent}  "
                   f"(page {page}; {insp.total_ms:.0f} ms in nodes)")
        return
    if port is None:
        raise SketchgraphError("name the output to inspect as NODE.PORT; outputs: "
                               + ", ".join(f"{n}.{p}" for n, node in pipe.nodes.items() for p in node.outputs))
    ref = pipe.parse_ref(port)
    from .output.film import check_target

    check_target(out or f"out/{ref[0]}.{ref[1]}.exr", writers=False)  # -o faults as one line before anything renders
    ex = Executor(pipe, cache, requested=[ref])
    try:
        with _node_progress(quiet):
            result = ex.run(frame)
        value = result.values[ref]
        path = Path(out or f"out/{ref[0]}.{ref[1]}.exr")
        write_value(value, path, {"sketchgraph:port": f"{ref[0]}.{ref[1]}"})
        stats = _value_stats(value)
        click.echo(f"wrote {path}  {stats}")
    finally:
        ex.close()


def _value_stats(value: Any) -> str:
    from .values import Tex

    if not isinstance(value, Tex):
        return type(value).__name__
    import numpy as np

    arr = value.read()
    parts = []
    for c in range(arr.shape[2]):
        ch = arr[:, :, c]
        finite = ch[np.isfinite(ch)]
        lo, hi, mean = (float(finite.min()), float(finite.max()), float(finite.mean())) if finite.size else (0, 0, 0)
        parts.append(f"{'RGBA'[c]}[{lo:.4g}..{hi:.4g} mean {mean:.4g}]")
    return f"{value.fmt} {value.size[0]}x{value.size[1]} " + " ".join(parts)


# -- nodes / graph / schema -----------------------------------------------------------------
@main.command()
@click.argument("name", required=False)
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
def nodes(name: str | None, as_json: bool) -> None:
    """Every node type: ports with types, params with defaults and docs."""
    from .registry import default
    from .yamlio import suggest

    reg = default()
    if name:
        if name not in reg:
            raise SketchgraphError(f"unknown node type '{name}'" + suggest(name, reg.names()))
        items = [(name, reg.get(name))]
    else:
        items = reg.items()
    if as_json:
        click.echo(json.dumps({n: _node_info(c) for n, c in items}, indent=2))
        return
    for n, cls in items:
        info = _node_info(cls)
        click.echo(f"{n}  (version {info['version']})")
        if info["doc"]:
            click.echo("  " + info["doc"].split("\n\n")[0].replace("\n", "\n  "))
        for kind in ("inputs", "outputs"):
            if info[kind]:
                click.echo(f"  {kind}:")
                for p, d in info[kind].items():
                    opt = " (optional)" if d.get("optional") else ""
                    click.echo(f"    {p}: {d['type']}{opt}  {d['doc']}")
        if info["params"]:
            click.echo("  params:")
            for p, d in info["params"].items():
                values = f"  [{' | '.join(json.dumps(v) for v in d['values'])}]" if d.get("values") else ""
                click.echo(f"    {p} = {json.dumps(d['default'])}{values}  {d['description']}")
        click.echo("")


def _choices(annotation: Any) -> list[Any]:
    """The values an enumerated parameter takes (Literal members, Enum members, None where optional); [] when
    the annotation also admits open-ended values (a number, a string, a list)."""
    import enum
    import types as pytypes
    import typing

    origin = typing.get_origin(annotation)
    if origin is typing.Literal:
        return list(typing.get_args(annotation))
    if origin in (typing.Union, pytypes.UnionType):
        out: list[Any] = []
        for arg in typing.get_args(annotation):
            if arg is type(None):
                out.append(None)
                continue
            sub = _choices(arg)
            if not sub:
                return []
            out += sub
        return out
    if isinstance(annotation, type) and issubclass(annotation, enum.Enum):
        return [m.value for m in annotation]
    return []


def _node_info(cls: Any) -> dict[str, Any]:
    params = {}
    for fname, f in cls.Params.model_fields.items():
        if f.is_required():
            default = "(required)"
        else:
            from pydantic_core import to_jsonable_python

            default = to_jsonable_python(f.get_default(call_default_factory=True))
        params[fname] = {"default": default, "description": f.description or "",
                         "type": str(f.annotation).replace("typing.", "")}
        values = _choices(f.annotation)
        if values:
            params[fname]["values"] = values
    doc = " ".join((cls.doc or cls.__doc__ or "").split())
    return {
        "version": cls.version,
        "doc": doc,
        "inputs": {p: {"type": str(i.type), "doc": i.doc, "optional": i.optional} for p, i in cls.inputs.items()},
        "outputs": {p: {"type": str(o.type), "doc": o.doc} for p, o in cls.outputs.items()},
        "params": params,
    }


@main.command()
@click.argument("pipeline", type=click.Path())
@pipeline_options
def graph(pipeline: str, overrides: tuple[str, ...], size: str | None, scene: str | None, view: str | None = None,
          up: str | None = None, fill: float | None = None) -> None:
    """Print the DAG as Graphviz DOT text (pipe into `dot -Tsvg`)."""
    from .tools.dot import to_dot

    pipe = open_pipeline(pipeline, overrides, size, scene, load_scene=False)
    click.echo(to_dot(pipe))


@main.command()
@click.argument("pipeline", type=click.Path())
@pipeline_options
@click.option("--out-dir", type=click.Path(path_type=Path), help="Folder the pipeline's own file paths (write, "
              "strokes_svg) resolve against and must stay in (default: the current directory).")
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to listen on (anything but "
              "127.0.0.1 lets other machines reach the page; they still need the token).")
@click.option("--port", default=8765, show_default=True, help="Port to listen on (0: any free port).")
@click.option("--frame", default=0, show_default=True, help="Frame shown first.")
@click.option("--no-prefetch", is_flag=True, help="Do not compute every port of the planned nodes when idle "
              "(a port the ordinary run does not make is then computed on its first view).")
@cache_options
def serve(pipeline: str, overrides: tuple[str, ...], size: str | None, scene: str | None, out_dir: Path | None,
          host: str, port: int, frame: int, no_prefetch: bool, no_cache: bool, cache_dir: Path | None,
          view: str | None = None, up: str | None = None, fill: float | None = None) -> None:
    """A live authoring view in the browser: the graph, every buffer, parameters that re-render as you drag
    (docs/serve.md). Prints the page's address with its token."""
    from .tools.serve import serve as run_server

    run_server(pipeline, overrides=overrides, size=size, scene=scene, out_dir=out_dir, view=view, up=up, fill=fill,
               cache=open_cache(no_cache, cache_dir), host=host, port=port, frame=frame,
               prefetch=not no_prefetch, echo=click.echo)


@main.command()
@click.option("--scene", "scene_format", is_flag=True, help="The scene file format instead (objects, camera, "
              "light, orbit).")
def schema(scene_format: bool) -> None:
    """JSON Schema of the pipeline format (every node type's params), for editor completion."""
    if scene_format:
        from .scene.scene import json_schema as scene_schema

        click.echo(json.dumps(scene_schema(), indent=2))
        return
    from .pipeline import json_schema

    click.echo(json.dumps(json_schema(), indent=2))


@main.command()
@click.option("--paths", "show_paths", is_flag=True, help="Also print where each file is installed.")
def pipelines(show_paths: bool) -> None:
    """The shipped pipelines, one a line: `sketchgraph run NAME` runs one from any folder."""
    from . import shipped

    found = shipped.paths()
    if not found:
        raise SketchgraphError(f"no shipped pipelines found (is the {shipped.PACKAGE} package installed?)")
    width = max(len(n) for n in found)
    for name, path in found.items():
        click.echo(f"{name:<{width}}  {shipped.describe(path)}" + (f"  [{path}]" if show_paths else ""))


# -- scene ----------------------------------------------------------------------------------
@main.group("scene")
def scene_group() -> None:
    """What a scene file holds."""


@scene_group.command("info")
@click.argument("file", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print the findings as JSON.")
@click.option("--allow-outside-scene-dir", "allow_outside", is_flag=True,
              help="Let a glTF file's buffers and images lie outside its folder (a trusted file).")
def scene_info(file: str, as_json: bool, allow_outside: bool) -> None:
    """A glTF/GLB file's meshes, materials, textures, animations, skins, morph targets, cameras, lights and
    extensions; a mesh file's size, up axis and health; a scene YAML's objects; and for each part what
    sketchgraph does with it (drawn, used or ignored, and why)."""
    from .scene.info import format_info, info

    found = info(file, allow_outside=allow_outside)
    click.echo(json.dumps(found, indent=2) if as_json else format_info(found))


# -- cache ----------------------------------------------------------------------------------
@main.group()
def cache() -> None:
    """Inspect or prune the disk cache."""


@cache.command("info")
@click.option("--cache-dir", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True)
def cache_info(cache_dir: Path | None, as_json: bool) -> None:
    """Where the cache is, how many entries and bytes, and its limit."""
    from .cache import Cache

    info = Cache(cache_dir).info()
    if as_json:
        click.echo(json.dumps(info, indent=2))
        return
    click.echo(f"cache: {info['root']}\nentries: {info['entries']} ({info['by_kind']['exr']} EXR, "
               f"{info['by_kind']['npz']} npz; {info['meshes']} of them the mesh store's)\n"
               f"size: {_mb(info['bytes'])} of {_mb(info['limit'])} limit")


@cache.command("prune")
@click.option("--cache-dir", type=click.Path(path_type=Path))
@click.option("--max-size", default=None, help="Evict least-recently-used entries down to this size (e.g. 500M, 0).")
def cache_prune(cache_dir: Path | None, max_size: str | None) -> None:
    """Evict least-recently-used entries until the cache fits its limit (or --max-size)."""
    from .cache import Cache, parse_bytes

    c = Cache(cache_dir)
    try:
        limit = parse_bytes(max_size) if max_size is not None else None
    except (ValueError, OverflowError):
        limit = -1
    if limit is not None and limit < 0:
        raise SketchgraphError(f"--max-size: expected a size such as 500M or 2G, found '{max_size[:40]}'")
    files, freed = c.prune(limit)
    click.echo(f"removed {files} entries ({_mb(freed)}); {_mb(c.info()['bytes'])} left in {c.root}")


def _mb(n: int) -> str:
    return f"{n / 1024**2:.1f} MiB"


# -- bench ----------------------------------------------------------------------------------


@main.command(context_settings={"ignore_unknown_options": True, "allow_extra_args": True, "help_option_names": []})
@click.argument("target", required=False)
@click.pass_context
def bench(ctx: click.Context, target: str | None) -> None:
    """Benchmarks: `bench PIPELINE [--scene M] [--frames N] [--size WxH] [--json F]`, or a named one:
    film, startup, cold-cache, pencil-shade, shower-door, particles, accuracy, ... (an unknown name lists them
    all; `bench NAME --help`)."""
    from .tools.bench import pipeline as benchmod

    if target in (None, "-h", "--help"):  # --help after a name goes to that benchmark
        click.echo(ctx.get_help())
        click.echo(_bench_catalogue(benchmod))
        return
    from .scene.views import facing
    from .tools.bench import sides

    command = benchmod.command_for(target)
    with facing(sides.fixed()):  # the shared meshes seen from fixed sides, whatever the framing rules find
        command.main(args=ctx.args, prog_name=f"sketchgraph bench {target}", standalone_mode=False)


def _bench_catalogue(benchmod: Any) -> str:
    """Every benchmark with its first help line and its options (`bench --help`)."""
    entries = [("PIPELINE", benchmod.command_for("nienhaus_sketchy"))]
    entries += [(name, benchmod.command_for(name)) for name in sorted(benchmod.NAMED)]
    lines = ["", "Benchmarks (`sketchgraph bench NAME --help` for one):"]
    for name, command in entries:
        ctx = click.Context(command, info_name=name)
        lines.append(f"  {name}: {command.get_short_help_str(limit=110)}".rstrip())
        for param in command.get_params(ctx):
            if not isinstance(param, click.Option) or "--help" in param.opts:
                continue
            record = param.get_help_record(ctx)
            if record:
                lines.append(f"      {record[0]}" + (f"  {' '.join(record[1].split())}" if record[1] else ""))
    return "\n".join(lines)


# -- diff -----------------------------------------------------------------------------------
@main.command()
@click.argument("a", type=click.Path())
@click.argument("b", type=click.Path(), required=False)
@click.option("--set-a", "set_a", multiple=True, metavar="NODE.PARAM=VALUE", help="Override for A only.")
@click.option("--set-b", "set_b", multiple=True, metavar="NODE.PARAM=VALUE", help="Override for B only.")
@click.option("-o", "--out", "out", metavar="DIR", default="out/diff", show_default=True,
              help="Folder for difference images, diff_sheet.png (A | B | |A-B|) and diff.json.")
@click.option("--frame", default=0, show_default=True, help="Frame to compare.")
@click.option("--keys-only", is_flag=True, help="Compare keys only; render nothing.")
@click.option("--quiet", "-q", is_flag=True, help="No progress line.")
@pipeline_options
@cache_options
def diff(a: str, b: str | None, set_a: tuple[str, ...], set_b: tuple[str, ...], out: str, frame: int,
         keys_only: bool, quiet: bool, overrides: tuple[str, ...], size: str | None, scene: str | None,
         no_cache: bool, cache_dir: Path | None, view: str | None = None, up: str | None = None,
         fill: float | None = None) -> None:
    """Which nodes differ between two pipelines (or one pipeline with --set-a/--set-b) and why; max and
    mean absolute difference and a difference image per differing output. Exit 1 if anything differs."""
    from .tools.diff import diff as diff_pipelines
    from .tools.diff import format_report

    cache = open_cache(no_cache, cache_dir)  # first: a mesh file parsed in an earlier run is read from its root
    pipe_a = open_pipeline(a, overrides + set_a, size, scene, view=view, up=up, fill=fill)
    pipe_b = open_pipeline(b or a, overrides + set_b, size, scene, view=view, up=up, fill=fill)
    with _node_progress(quiet):
        report = diff_pipelines(pipe_a, pipe_b, frame, cache, None if keys_only else Path(out), pixels=not keys_only)
    click.echo(f"A: {a}" + "".join(f" --set {s}" for s in overrides + set_a))
    click.echo(f"B: {b or a}" + "".join(f" --set {s}" for s in overrides + set_b))
    click.echo(format_report(report))
    if report.out is not None and report.ports:
        click.echo(f"wrote {report.out}/ (diff_sheet.png, diff.json)")
    if report.changed:
        sys.exit(1)


# -- wedge ----------------------------------------------------------------------------------
@main.command()
@click.argument("pipeline", type=click.Path())
@click.option("-p", "--param", "params", multiple=True, required=True, metavar="NODE.PARAM=V1,V2,...",
              help="A param and the values to sweep (YAML values; give -p once or twice).")
@click.option("-o", "--out", "out", metavar="FILE", help="Sheet to write (default: out/<pipeline>.wedge.png).")
@click.option("--output", "output_name", metavar="NAME", help="Which pipeline output to show (default: the first).")
@click.option("--cell", default=256, show_default=True, help="Cell size of the sheet in pixels.")
@click.option("--frame", default=0, show_default=True, help="Frame to render.")
@pipeline_options
@cache_options
@scheduler_options
def wedge(pipeline: str, params: tuple[str, ...], out: str | None, output_name: str | None, cell: int, frame: int,
          overrides: tuple[str, ...], size: str | None, scene: str | None, no_cache: bool,
          cache_dir: Path | None, scheduler: str | None, chunk: int | None, view: str | None = None,
          up: str | None = None, fill: float | None = None) -> None:
    """Sweep one or two params over listed values: a labelled contact sheet (columns: the first param)."""
    from .tools import viz
    from .tools import wedge as wedgemod

    axes = wedgemod.axes_from(list(params))
    t0 = time.perf_counter()
    n = len(wedgemod.combinations(axes))
    if scheduler is not None:
        from . import distributed as dist

        spec = dist.PipeSpec.make(pipeline, overrides, size, scene, output_name, view=view, up=up, fill=fill)
        spec.open()  # load-time errors before a cluster starts
        root: Any = False if no_cache else cache_dir
        with dist.connect(scheduler, cache_root=root) as client:
            cells = wedgemod.run_distributed(client, spec, axes, frame, root, chunk,
                                             progress=lambda it: _progress_total(it, n, n < 2, "cells"))
    elif chunk is not None:
        raise SketchgraphError("--chunk splits work for --scheduler; give --scheduler too")
    else:
        cells = wedgemod.run(lambda extra: open_pipeline(pipeline, overrides + tuple(extra), size, scene, view=view,
                                                         up=up, fill=fill), axes,
                             output_name, frame, open_cache(no_cache, cache_dir),
                             progress=lambda it: _progress(list(it), n < 2, "cells"))
    path = Path(out or f"out/{Path(pipeline).stem}.wedge.png")
    viz.write_png(path, wedgemod.sheet(cells, axes, Path(pipeline).stem, cell))
    for c in cells:
        click.echo(f"  {c.label}: recomputed {', '.join(c.computed) or 'nothing'} ({c.ms:.0f} ms)")
    click.echo(f"wrote {path}  ({len(cells)} cells in {time.perf_counter() - t0:.1f} s)")


# -- gallery --------------------------------------------------------------------------------
@main.group()
def gallery() -> None:
    """Build the gallery (images, contact sheets, index.html, manifest.json) or verify it."""


def _gallery_options(f: Any) -> Any:
    f = click.option("--gallery", "gallery_file", default="gallery/gallery.yaml", show_default=True,
                     type=click.Path(path_type=Path), help="The gallery file.")(f)
    f = click.option("--only", multiple=True, metavar="ENTRY", help="Only these entries (repeatable).")(f)
    f = click.option("--quiet", "-q", is_flag=True, help="No progress bar.")(f)
    return f


@gallery.command("build")
@_gallery_options
@click.option("--force", is_flag=True, help="Render every entry, even those the manifest says are up to date.")
@click.option("--cold", is_flag=True, help="Empty the gallery's node cache first and render everything "
              "(implies --force): the baseline for build times.")
@click.option("--inspect", "inspect_", is_flag=True, help="Also dump every entry's intermediates (EXR, PNG, "
              "page) under gallery/out/inspect/.")
@click.option("--no-cache", is_flag=True, help="Neither read nor write the node cache.")
@click.option("--cache-dir", type=click.Path(path_type=Path), help="Node cache folder (default: gallery/out/cache).")
@scheduler_options
def gallery_build(gallery_file: Path, only: tuple[str, ...], quiet: bool, force: bool, cold: bool, inspect_: bool,
                  no_cache: bool, cache_dir: Path | None, scheduler: str | None, chunk: int | None) -> None:
    """Render every entry that is not up to date; print the time per entry and in total."""
    from .tools import gallery as gal

    if chunk not in (None, 1):
        raise SketchgraphError(f"gallery build --chunk: an entry is one task; expected 1, found {chunk}")
    g = gal.load(gallery_file)
    cache = gal.node_cache(g, no_cache, cache_dir, cold)
    if scheduler is not None:
        from . import distributed as dist

        with dist.connect(scheduler, cache_root=cache.root if cache is not None else False) as client:
            report = gal.build(g, cache, only=list(only), force=force or cold, inspect=inspect_, echo=click.echo,
                               progress=not quiet, cold=cold, scheduler=client)
    else:
        report = gal.build(g, cache, only=list(only), force=force or cold, inspect=inspect_, echo=click.echo,
                           progress=not quiet, cold=cold)
    click.echo(gal.format_build(report))
    click.echo(f"wrote {g.manifest_path} and {g.root / 'index.html'}")
    if report.failed:
        sys.exit(1)


@gallery.command("verify")
@_gallery_options
@click.option("--cache", "use_cache", is_flag=True, help="Let the rebuild use the node cache (default: compute "
              "everything again).")
@click.option("--cache-dir", type=click.Path(path_type=Path), help="Cache folder for --cache (default: "
              "gallery/out/cache).")
def gallery_verify(gallery_file: Path, only: tuple[str, ...], quiet: bool, use_cache: bool,
                   cache_dir: Path | None) -> None:
    """Render every entry again and compare with manifest.json; exit 1 naming every entry that differs."""
    from .tools import gallery as gal

    g = gal.load(gallery_file)
    checks, info = gal.verify(g, gal.node_cache(g, not use_cache, cache_dir), only=list(only), echo=click.echo,
                              progress=not quiet)
    click.echo(gal.format_verify(checks, info))
    if any(c.status in ("differs", "failed") for c in checks):
        sys.exit(1)


def default_output(pipe: Any, out: str | None) -> str:
    """The output `-o` writes when --output is not given: the first one, except that a pipeline with strokes and
    an image (plotter_lines) writes its first Strokes output to .svg and its first other output elsewhere."""
    from .types import STROKES

    names = list(pipe.outputs)
    if out is None or len(names) < 2:
        return names[0]
    strokes = [n for n in names if pipe.nodes[pipe.outputs[n][0]].outputs[pipe.outputs[n][1]].type == STROKES]
    want_svg = out.lower().endswith(".svg")
    pick = [n for n in names if (n in strokes) == want_svg]
    return pick[0] if pick else names[0]


if __name__ == "__main__":  # pragma: no cover
    main()
