"""Each shipped pipeline's film setting (docs/animation.md, "Making films"): what `sketchgraph run --film` and
`sketchgraph bench coherence` render a film with.

A film setting is `hold: 0` on every node that has a hold (nothing is drawn anew at random from frame to frame),
then the overrides FILM names, applied to the pipeline itself or to the variant file FILM_PIPELINE names (in
`pipelines/film/`, beside the shipped pipelines). The settings were chosen by measurement with `sketchgraph bench
coherence`; the docs give the figures. A pipeline that is not shipped gets the holds at 0 only.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .errors import PipelineError

# overrides as `--set NODE.PARAM=VALUE` takes them, on top of `hold: 0` on every node that has a hold; {} = the
# pipeline with every hold at 0. Where the screen-space Perlin uncertainty is the method (the paper's default), the
# film setting is a variant file (FILM_PIPELINE) with geometry-controlled uncertainty instead.
FILM: dict[str, dict[str, Any]] = {
    "chalk": {},
    "loose_and_sketchy": {},  # particles started from points fixed on the surfaces (starts: surface)
    "loose_and_sketchy_shaded": {},
    "nienhaus_sketchy": {},
    "object_space_uncertainty": {"noise.octaves": 1},  # one octave: no fine wobble to change as outlines slide
    # hatching fixed to the (rest-pose) surface, one contour attempt instead of three (each attempt's screen-space
    # shake swims over a moving surface): docs/pencil.md
    "pencil": {"shade.anchor": "surface", "distortion.layers": 1},
    "pencil_contours": {},
    "repeated_edges": {},
    "sketchy_composite": {},
    "sketchy_lines": {},
    "sketchy_strokes": {},  # its uncertainty is read on the surface already (stroke_style), held at 0
    "plotter_lines": {"hatch.anchor": "surface"},  # hatching seeded from fixed surface points
}
# variant pipelines (paths relative to the shipped pipelines' folder) that FILM's overrides apply to
FILM_PIPELINE: dict[str, str] = {name: f"film/{name}.yaml" for name in (
    "chalk", "loose_and_sketchy", "loose_and_sketchy_shaded", "nienhaus_sketchy", "repeated_edges", "sketchy_composite",
    "sketchy_lines")}


def held_nodes(pipeline: Any) -> list[str]:
    """The ids of a loaded pipeline's (`pipeline.Pipeline`) nodes that have a `hold`."""
    from .node import HOLD_PARAM

    return [nid for nid, node in pipeline.nodes.items() if HOLD_PARAM in type(node.params).model_fields]


def film_pipeline(name: str) -> str:
    """The pipeline a film setting runs: the variant file FILM_PIPELINE names (beside the shipped pipelines), or
    `name` itself."""
    if name not in FILM_PIPELINE:
        return name
    from . import shipped

    root = shipped.folder()
    if root is None:
        raise PipelineError("the shipped pipelines are not installed: no film variant to load")
    return str(root / FILM_PIPELINE[name])


def film_overrides(pipeline: Any, name: str | None) -> dict[str, Any]:
    """A film setting as `--set` overrides for a loaded pipeline (the one `film_pipeline` names): `hold: 0` on every
    node that has a hold, then FILM[name] (nothing more for a pipeline that is not shipped, `name` None)."""
    return {**{f"{nid}.hold": 0 for nid in held_nodes(pipeline)}, **(FILM.get(name, {}) if name else {})}


def shipped_name(spec: str | Path) -> str | None:
    """The shipped pipeline `spec` is (its name, or the path of its file), else None. A spec that names nothing is
    the one-line PipelineError `shipped.resolve` gives."""
    from . import shipped

    path = shipped.resolve(spec).resolve()
    return next((name for name, p in shipped.paths().items() if p.resolve() == path), None)


def film_setting(spec: str) -> tuple[str, list[str]]:
    """`sketchgraph run --film`: the pipeline to load for `spec` (a shipped name or a file) and its film setting as
    `--set` strings, to come before the user's own."""
    from . import pipeline as pl

    name = shipped_name(spec)
    source = film_pipeline(name) if name else spec
    overrides = film_overrides(pl.load(source), name)
    return source, [f"{key}={_yaml_value(value)}" for key, value in overrides.items()]


def _yaml_value(value: Any) -> str:
    """A value as `--set` reads it (YAML): a word that YAML reads back as itself as it is, anything else as JSON
    (which YAML reads)."""
    import yaml

    if isinstance(value, str) and value.replace("_", "").isalnum() and yaml.safe_load(value) == value:
        return value
    return json.dumps(value)
