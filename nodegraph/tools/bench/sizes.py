"""One drawing at every size: each shipped pipeline rendered large, area-averaged down, against a direct
small render, compared by SSIM on luminance (scikit-image's windowed `structural_similarity`).

    sketchgraph bench sizes [--small 400] [--large 1600] [--json F] [PIPELINE ...]
    python -m nodegraph.tools.bench.sizes ...

A pipeline whose image-space parameters follow its `reference_size` (docs/sizes.md) gives nearly the same
picture at both sizes; one whose parameters are per pixel does not (lines twice as thick, noise twice as
coarse at half the size). `--large` must be a whole multiple of `--small`, so the area average is exact.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

import click
import numpy as np

from ...fsio import atomic_write_text

# Rec. 709 luma weights, on the display values the PNG would hold
_LUMA = np.array([0.2126, 0.7152, 0.0722])


def luminance(img: np.ndarray) -> np.ndarray:
    """Luminance in [0, 1] of an (H, W, C) uint8 or float image (RGB weighted; one channel as it is)."""
    a = np.asarray(img, dtype=np.float64)
    if img.dtype == np.uint8:
        a = a / 255.0
    if a.ndim == 2:
        return a
    if a.shape[2] == 1:
        return a[..., 0]
    return a[..., :3] @ _LUMA


def area_down(img: np.ndarray, factor: int) -> np.ndarray:
    """Area average of a 2-D array by a whole `factor` (each output pixel the mean of factor x factor)."""
    h, w = img.shape
    if h % factor or w % factor:
        raise ValueError(f"{w}x{h} is not a whole multiple of {factor}")
    return img.reshape(h // factor, factor, w // factor, factor).mean(axis=(1, 3))


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """SSIM of two luminance images in [0, 1] (scikit-image, 7x7 windows, data_range 1)."""
    from skimage.metrics import structural_similarity

    return float(structural_similarity(a, b, data_range=1.0))


def render_luminance(session: Any, pipeline: str, size: int, overrides: tuple[str, ...] = ()) -> np.ndarray:
    pipe = session.load(pipeline, size=(size, size), set=list(overrides))
    # the picture: a pipeline whose first output is strokes (plotter_lines) names its drawing `image`
    return luminance(pipe.render("image" if "image" in pipe.outputs else None))


def compare(pipeline: str, small: int = 400, large: int = 1600, overrides: tuple[str, ...] = (),
            session: Any = None, keep: dict[str, np.ndarray] | None = None) -> dict[str, Any]:
    """SSIM of `pipeline` rendered at large x large, area-averaged to small x small, against a direct
    small x small render; `keep`, if given, receives both luminance images."""
    from ...api import Session

    if large % small:
        raise click.BadParameter(f"--large {large} must be a whole multiple of --small {small}")
    own = session is None
    session = session or Session(cache=False)
    try:
        t0 = time.perf_counter()
        direct = render_luminance(session, pipeline, small, overrides)
        big = render_luminance(session, pipeline, large, overrides)
        seconds = time.perf_counter() - t0
    finally:
        if own:
            session.close()
    down = area_down(big, large // small)
    if keep is not None:
        keep.update(direct=direct, down=down)
    return {"pipeline": pipeline, "small": small, "large": large, "ssim": round(ssim(direct, down), 4),
            "mean_abs_luminance": round(float(np.abs(direct - down).mean()), 4),
            "mean_luminance_small": round(float(direct.mean()), 4),
            "mean_luminance_large": round(float(down.mean()), 4), "seconds": round(seconds, 1)}


def compare_all(pipelines: list[str], small: int, large: int) -> list[dict[str, Any]]:
    from ...api import Session

    rows = []
    with Session(cache=False) as session:
        for name in pipelines:
            row = compare(name, small, large, session=session)
            print(f"{name:28s} ssim {row['ssim']:.4f}  mean |dL| {row['mean_abs_luminance']:.4f}  "
                  f"L {row['mean_luminance_small']:.3f} / {row['mean_luminance_large']:.3f}  "
                  f"({row['seconds']:.0f} s)", flush=True)
            rows.append(row)
    return rows


def sheet(pipelines: list[str], path: Path, sides: tuple[int, ...] = (400, 800, 1600), cell: int = 400) -> Path:
    """A PNG: for each pipeline two rows, per-pixel params (every size its own reference: how pipelines drew
    before reference_size) and the pipeline's reference size; one column per side, each area-averaged to
    `cell` px so sizes compare at one scale."""
    from ...api import Session
    from ...output.imageio import write

    rows = []
    gap = 6
    with Session(cache=False) as session:
        for name in pipelines:
            for own in (True, False):
                cells = []
                for side in sides:
                    pipe = session.load(name, size=(side, side), reference_size=side if own else None)
                    img = pipe.render()[..., :3].astype(np.float64) / 255.0
                    f = side // cell
                    cells.append(np.stack([area_down(img[..., c], f) for c in range(3)], axis=-1))
                    cells.append(np.ones((cell, gap, 3)))
                rows.append(np.concatenate(cells[:-1], axis=1))
                rows.append(np.ones((gap, rows[-1].shape[1], 3)))
    out = np.ascontiguousarray(np.concatenate(rows[:-1], axis=0)[::-1]).astype(np.float32)  # write() takes GL rows
    path.parent.mkdir(parents=True, exist_ok=True)
    write(path, out)
    return path


@click.command()
@click.argument("pipelines", nargs=-1)
@click.option("--small", default=400, show_default=True, help="Side of the direct render (square).")
@click.option("--large", default=1600, show_default=True, help="Side of the large render, a multiple of --small.")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
@click.option("--sheet", "sheet_path", type=click.Path(path_type=Path),
              help="Instead: write a PNG of the pipelines at 400, 800 and 1600 px (shown at 400), per-pixel params "
                   "above, the pipeline's reference size below.")
def command(pipelines: tuple[str, ...], small: int, large: int, json_path: Path | None,
            sheet_path: Path | None) -> None:
    """SSIM (luminance) of each pipeline at --large area-averaged to --small against a direct --small render
    (default: every shipped pipeline)."""
    from ...shipped import names

    if sheet_path is not None:
        click.echo(f"wrote {sheet(list(pipelines) or ['nienhaus_sketchy', 'pencil'], sheet_path)}")
        return

    rows = compare_all(list(pipelines) or names(), small, large)
    text = json.dumps({"small": small, "large": large, "results": rows}, indent=2) + "\n"
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json_path, text)
        click.echo(f"wrote {json_path}")
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    command()
