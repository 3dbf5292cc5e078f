"""`sketchgraph bench strokes`: mesh_lines' vector lines per mesh: strokes (visible, hidden), samples, the
length distribution of visible strokes, and the time of each CPU stage of a frame: extraction (contour, crease
and boundary segments on the mesh), chaining, sampling + visibility (against the G-buffer's linear depth,
rendered once beforehand and not timed), splitting into strokes, and writing the layered SVG text. Meshes: the
built-in torus, the shared meshes that exist (spot, bunny, ogre) and a bumpy torus of about 1M triangles made
here. Each stage's median over `--repeats` runs of the same frame (the first run, which builds the per-mesh
topology cache, is reported apart as `first_ms`). With `--plotter` (the default) also plotter_lines (lines and
hatching) per mesh on an A4 page and its pen-up travel as vpype counts it, in file order and after `linesort`
(`pen_up`; vpype is in the [test] extra), and its hatching's cost (`hatching`: the stroke_hatching node's ms in the
frame, and its streamlines compiled against the Python loop on the same inputs), with the compiled loop's first
call in a new process reported apart (`hatching_first_call`: with an empty and with a filled Numba cache)."""

from __future__ import annotations

import json
import statistics
import time
from pathlib import Path
from typing import Any

import click
import numpy as np

from nodegraph.fsio import atomic_output, atomic_write_text

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "meshes"
MESHES = ("builtin:torus", "spot.obj", "stanford-bunny.obj", "ogre.obj", "made:1M")


def bumpy_torus(n_major: int = 1000, n_minor: int = 500) -> Any:
    """A torus of 2 x n_major x n_minor triangles (1M by default) with bumps (a sum of sines) on its tube."""
    from nodegraph.scene.meshes import Mesh

    u = 2 * np.pi * np.arange(n_major) / n_major
    v = 2 * np.pi * np.arange(n_minor) / n_minor
    uu, vv = np.meshgrid(u, v, indexing="ij")
    r = 0.35 * (1.0 + 0.08 * np.sin(7 * uu) * np.sin(5 * vv) + 0.04 * np.sin(23 * uu + 3 * vv))
    ring = 1.0 + r * np.cos(vv)
    V = np.stack([ring * np.cos(uu), r * np.sin(vv), ring * np.sin(uu)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")

    def idx(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return (a % n_major) * n_minor + b % n_minor

    a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
    F = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])
    return Mesh("bumpy_torus_1M", V, F)


def _scene(name: str) -> Any | None:
    from nodegraph.scene.scene import load_scene, scene_for_mesh

    if name == "made:1M":
        return scene_for_mesh(bumpy_torus())
    if name.startswith("builtin:"):
        return load_scene(name)
    path = SHARED / name
    return load_scene(str(path)) if path.exists() else None


def picture(svg_text: str, png: Path, title: str = "") -> None:
    """The layered SVG drawn with matplotlib (visible layers black, hidden ones grey dashed) as a PNG."""
    import xml.etree.ElementTree as ET

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from nodegraph.output.svg import read_layers

    vb = [float(v) for v in ET.fromstring(svg_text).get("viewBox", "0 0 1 1").split()]
    fig, ax = plt.subplots(figsize=(5, 5 * vb[3] / vb[2]), dpi=120)
    for name, polys in read_layers(svg_text).items():
        hidden = name.endswith("hidden")
        for poly in polys:
            ax.plot(poly[:, 0], poly[:, 1], color="0.6" if hidden else "0.05", lw=0.4 if hidden else 0.7,
                    ls=(0, (3, 2)) if hidden else "-")
    ax.set_xlim(0, vb[2])
    ax.set_ylim(vb[3], 0)
    ax.set_aspect("equal")
    ax.axis("off")
    if title:
        ax.set_title(title, fontsize=8)
    with atomic_output(png) as tmp:
        fig.savefig(tmp, bbox_inches="tight", format="png")
    plt.close(fig)


def outline_coverage(strokes: Any, zbuf: np.ndarray) -> float:
    """The share of the image's outline (the pixels at the rim of the depth buffer's covered region) that has a
    visible stroke sample within 1.5 px: how much of the silhouette the lines draw."""
    from scipy.ndimage import binary_erosion
    from scipy.spatial import cKDTree

    covered = zbuf > 0.0
    rows, cols = np.nonzero(covered & ~binary_erosion(covered))
    pts = strokes.xy[strokes["visible"]].astype(np.float64) if strokes.n_vertices else np.zeros((0, 2))
    if not len(rows):
        return float("nan")
    if not len(pts):
        return 0.0
    d = cKDTree(pts).query(np.c_[cols + 0.5, rows + 0.5])[0]  # zbuf row 0 is the bottom: y up, as the strokes
    return float((d <= 1.5).mean())


def measure(scene: Any, size: int, repeats: int, pictures: Path | None = None, name: str = "",
            outline: float = 1.0) -> dict[str, Any]:
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor
    from nodegraph.output.svg import layered_svg

    from . import (
        JUNCTION_REACH,
        MeshLines,
        crossing_parts,
        extract,
        object_lines,
        reconciled,
        solid_tests,
        split_lines,
        tested,
    )

    text = (f"pipeline: b\nsize: [{size}, {size}]\nreference_size: {size}\nscene: builtin:box\nnodes:\n"
            "  gbuf:\n    type: rasterize\noutputs:\n  z: gbuf.linear_depth\n")
    pipe = pl.loads(text, "b.yaml")
    pipe.scene = scene
    ex = Executor(pipe, None)
    try:
        zbuf = ex.run(0).values[("gbuf", "linear_depth")].read()[:, :, 0].astype(np.float64)
    finally:
        ex.close()
    p = MeshLines.Params(outline=outline)
    cam = scene.camera_at(0)
    view, proj = cam.view_matrix(), cam.projection_matrix(1.0)
    eye = np.r_[np.linalg.inv(view)[:3, 3], 1.0] if not cam.orthographic else cam.toward_eye()
    times: dict[str, list[float]] = {k: [] for k in ("extract", "chain", "sample_visibility", "split", "svg")}
    first = 0.0
    strokes = None
    for rep in range(repeats + 1):
        t = {k: 0.0 for k in times}
        parts, crossings = [], []
        far = None
        t_all = time.perf_counter()
        for index, obj in enumerate(scene.objects):
            model = np.asarray(obj.transform, np.float64)
            eye_obj = np.linalg.inv(model) @ eye
            t0 = time.perf_counter()
            segs, outlined = object_lines(obj.mesh, eye_obj, True, True, True, p.crease_angle, p.outline > 0,
                                          p.intersections)
            mv = view @ model
            v = extract.View(proj @ mv, mv, (size, size))
            inter = segs.kind == extract.KIND["intersection"]
            crossings.append((index, segs.select(inter), v))
            far = extract.outline_far(zbuf) if far is None else far
            solid = solid_tests(scene, [(index, model, None)], [segs], [v], JUNCTION_REACH)[0]  # each object alone
            segs = segs.select(~inter)
            if outlined is not None:
                edges, flat = outlined
                silhouette = extract.edge_points(edges, v, 0.5 * p.outline)
                edges = extract.outline_candidates(edges, v, far)
            t1 = time.perf_counter()
            half, off = extract.chain(segs.key, segs.kind, segs.p, p.junction_turn)
            if outlined is not None:
                half_o, off_o = extract.chain(edges.key, edges.kind, edges.p, p.junction_turn)
            t2 = time.perf_counter()
            sm, state = tested(segs, half, off, v, zbuf, p.spacing, p.depth_tolerance, far, solid)
            filled = None
            if outlined is not None:
                so, st_o = tested(edges, half_o, off_o, v, zbuf, p.spacing, p.depth_tolerance, far, solid)
                state, filled = reconciled(sm, state, so, st_o, flat, p.outline, far, silhouette, p.spacing,
                                           p.depth_tolerance)
            t3 = time.perf_counter()
            sm, state, idx, soff = split_lines(sm, state, p.split_angle, p.min_length, True, filled, p.outline,
                                              p.spacing)
            parts.append((index, sm, state, idx, soff))
            t4 = time.perf_counter()
            t["extract"] += t1 - t0
            t["chain"] += t2 - t1
            t["sample_visibility"] += t3 - t2
            t["split"] += t4 - t3
        t0 = time.perf_counter()
        parts += crossing_parts(crossings, parts, zbuf, p.spacing, p.depth_tolerance, p.split_angle, p.min_length,
                                True, p.junction_turn, max(p.outline, 1.0), far)
        t["split"] += time.perf_counter() - t0
        strokes = extract.to_strokes(parts, (size, size), p.width, p.color)
        t5 = time.perf_counter()
        visible = strokes.subset(strokes.stroke_attr("visible"))
        layered_svg(visible)
        t["svg"] = time.perf_counter() - t5
        if rep == 0:
            first = (time.perf_counter() - t_all) * 1e3
            continue
        for k in times:
            times[k].append(t[k] * 1e3)
    assert strokes is not None
    if pictures is not None:
        pictures.mkdir(parents=True, exist_ok=True)
        stem = Path(name.replace("builtin:", "")).stem.replace(":", "_")
        svg = layered_svg(strokes)
        atomic_write_text(pictures / f"{stem}.svg", svg)
        picture(svg, pictures / f"{stem}.png", f"{name}: visible (black) and hidden (grey) lines")
    vis = strokes.stroke_attr("visible")
    lens = strokes.lengths()[vis]
    med = {k: round(statistics.median(v), 2) for k, v in times.items()}
    return {"triangles": int(sum(o.mesh.n_faces for o in scene.objects)), "size": size,
            "strokes_visible": int(vis.sum()), "strokes_hidden": int((~vis).sum()),
            "samples": int(strokes.n_vertices),
            "kinds_visible": {name: int(((strokes.stroke_attr("kind") == i) & vis).sum())
                              for i, name in enumerate(extract.LINE_KINDS) if ((strokes.stroke_attr("kind") == i)
                                                                              & vis).any()},
            "length_px": {"total": round(float(lens.sum()), 1), **{f"p{q}": round(float(np.percentile(lens, q)), 1)
                                                                  for q in (10, 50, 90)}} if len(lens) else {},
            "outline_coverage": round(outline_coverage(strokes, zbuf), 4),
            "ms": med, "total_ms": round(sum(med.values()), 2), "first_ms": round(first, 2)}


def pen_up(svg_text: str) -> dict[str, Any] | None:
    """Pen-up travel (mm) of a layered SVG on a page, as vpype plots it: in the file's order, after `linesort`,
    and after `linemerge --tolerance 0.2mm linesort`; pen-down length and path counts beside. Travel is summed
    over layers (one pen each: vpype leaves out the moves between layers). None without vpype."""
    try:
        import vpype as vp
        import vpype_cli
    except ImportError:
        return None
    import io

    mm = 25.4 / 96.0  # vpype's unit is the CSS pixel

    def stats(doc: Any) -> dict[str, float]:
        return {"pen_up_mm": round(float(doc.pen_up_length()) * mm, 1),
                "pen_down_mm": round(float(doc.length()) * mm, 1), "paths": sum(len(lc) for lc in doc.layers.values())}

    def read() -> Any:
        return vp.read_multilayer_svg(io.StringIO(svg_text), quantization=0.1)

    return {"file_order": stats(read()), "linesort": stats(vpype_cli.execute("linesort", read())),
            "linemerge_linesort": stats(vpype_cli.execute("linemerge --tolerance 0.2mm linesort", read()))}


def plotter(scene: Any, size: int, page: str = "A4", repeats: int = 3) -> dict[str, Any]:
    """plotter_lines (lines and hatching) on `scene` at `size`, written on `page`; its strokes per layer, the time
    of the frame (curvature, hatching and the GPU drawing included), its pen-up travel (`pen_up`) and `hatching`:
    the stroke_hatching node's ms in that frame and its streamlines on the frame's inputs, compiled (median of
    `repeats`) against the Python loop (stroke_hatching.bench.compare)."""
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor
    from nodegraph.output.svg import layered_svg, parse_page, read_layers
    from nodegraph.registry import node_module

    hatch_bench = node_module("stroke_hatching", "bench")  # through the registry: no node imports a sibling
    pipe = pl.load("plotter_lines", size=(size, size), reference_size=size)
    pipe.scene = scene
    ex = Executor(pipe, None)
    try:
        with hatch_bench.recording() as calls:
            t0 = time.perf_counter()
            res = ex.run(0)
            ms = (time.perf_counter() - t0) * 1e3
        strokes = res.values[("hatch", "combined")]
    finally:
        ex.close()
    text = layered_svg(strokes, parse_page(page))
    hatching = {"node_ms": round(res.stats["hatch"].ms, 1), **hatch_bench.compare(calls, repeats)}
    return {"page": page, "frame_ms": round(ms, 1),
            "layers": {k: len(v) for k, v in read_layers(text).items()}, "pen": pen_up(text), "hatching": hatching}


@click.command(help=__doc__.split("\n\n")[0].replace("`sketchgraph bench strokes`: ", ""))
@click.option("--size", default=800, show_default=True, help="Square canvas in pixels.")
@click.option("--repeats", default=3, show_default=True, help="Timed runs per mesh (after one untimed).")
@click.option("--mesh", "meshes", multiple=True, help=f"Meshes to measure (default: {', '.join(MESHES)}).")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
@click.option("--pictures", type=click.Path(path_type=Path), help="Write each mesh's layered SVG (hidden lines "
              "too) and a PNG of it into this folder.")
@click.option("--plotter/--no-plotter", "with_plotter", default=True, show_default=True,
              help="Also run plotter_lines (lines and hatching) on each mesh, on an A4 page, and report its pen-up "
              "travel after vpype's linesort (needs vpype: the [test] extra).")
@click.option("--outline", default=1.0, show_default=True, type=click.FloatRange(0, 64),
              help="mesh_lines' `outline` for the lines measured (0: the interpolated contours alone).")
def command(size: int, repeats: int, meshes: tuple[str, ...], json_path: Path | None, pictures: Path | None,
            with_plotter: bool, outline: float) -> None:
    out: dict[str, Any] = {}
    if with_plotter:
        from nodegraph.registry import node_module

        hatch_bench = node_module("stroke_hatching", "bench")
        # before any frame: a fresh process's first compiled hatch call, with an empty Numba cache and a filled one
        c = out["hatching_first_call"] = hatch_bench.compile_seconds()
        click.echo(f"stroke_hatching first call in a new process (imports included): {c['cold_cache_s']} s with an "
                   f"empty Numba cache (compiling), {c['warm_cache_s']} s with it filled")
        hatch_bench.first_call()  # here too, so that no frame below counts it
    for name in meshes or MESHES:
        scene = _scene(name)
        if scene is None:
            click.echo(f"{name}: skipped (not found in {SHARED})")
            continue
        m = out[name] = measure(scene, size, repeats, pictures, name, outline)
        lp = m["length_px"]
        click.echo(f"{name}: {m['triangles']} triangles, {m['strokes_visible']} visible strokes "
                   f"({m['strokes_hidden']} hidden), lengths px p10/p50/p90 {lp.get('p10')}/{lp.get('p50')}/"
                   f"{lp.get('p90')}, total {lp.get('total')}; ms: "
                   + ", ".join(f"{k} {v}" for k, v in m["ms"].items()) + f"; total {m['total_ms']} ms; outline "
                   f"coverage {m['outline_coverage']}")
        if with_plotter:
            pm = m["plotter"] = plotter(scene, size, repeats=repeats)
            hm = pm["hatching"]
            click.echo(f"{name}: stroke_hatching {hm['streamlines']} streamlines, {hm['samples']} samples; node "
                       f"{hm['node_ms']} ms in the frame; streamlines alone {hm['jit_ms']} ms compiled, "
                       f"{hm['python_ms']} ms Python ({hm['speedup']}x), identical: {hm['identical']}")
            pen = pm["pen"]
            if pen is None:
                click.echo(f"{name}: plotter_lines pen-up travel not measured (vpype is not installed)")
            else:
                click.echo(f"{name}: plotter_lines on A4, {pm['layers']}, pen down {pen['file_order']['pen_down_mm']}"
                           f" mm; pen up {pen['file_order']['pen_up_mm']} mm in file order, "
                           f"{pen['linesort']['pen_up_mm']} after linesort, {pen['linemerge_linesort']['pen_up_mm']} "
                           "after linemerge + linesort")
    if json_path is not None:
        atomic_write_text(json_path, json.dumps(out, indent=1) + "\n")
