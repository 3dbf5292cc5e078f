"""`sketchgraph bench peer`: sketchgraph against Blender 5 on the same meshes, camera and size (800x800).

Two Blender setups by default (a third on request), each timed against every sketchgraph pipeline asked for
(default `nienhaus_sketchy`):

- `cycles`: Cycles on the CPU, `--cycles-samples` samples a pixel (default 16; adaptive sampling and denoising
  off), with Freestyle lines (one line set: visible silhouette, border and crease edges, 1.5 px).
- `freestyle_svg` (asked for with `--setup freestyle_svg`, beside `--pipeline plotter_lines`): Freestyle's
  lines written as an SVG a frame by Blender's Freestyle SVG Exporter (a bundled add-on up to Blender 4.1, an
  extension since: it must be installed in the bpy environment, else the worker answers one error line), on the
  `cycles` setup's line set with Cycles at 1 sample; the issue's vector-lines comparison (docs/strokes.md).
- `workbench`: Workbench (studio light, the material's colour, Blender's default 8 anti-aliasing samples) with a
  Grease Pencil v3 object whose Line Art modifier (`LINEART`, source: the scene) draws contour, crease and loose
  lines about 2 px wide.

Both see the mesh exactly as sketchgraph frames it: the OBJ read by Blender's own importer with its axes taken as
they are, then carried by the matrix that takes the file's vertices onto sketchgraph's stood-up mesh (`--up`,
nodegraph/scene/framing.py; solved from the vertices, so any axis swap or sign the framing chose), the camera set
to sketchgraph's eye, target, up, vertical field of view (which spans the shorter side in both), near and far,
and one sun from sketchgraph's default light direction (given in view space, turned into the world). The worker
projects the bounding box's corners through its camera and the result reports the largest disagreement with
sketchgraph's projection in pixels (`camera_match_px`).

Blender runs in a worker process of its own (`peer_blender.py` beside this file, run by a Python that imports
bpy: `--blender-python`, else this interpreter where it can import bpy, else the Python of the virtual
environment `$SKETCHGRAPH_PEER_VENV` names; with none the command prints one line and exits 0). bpy 5.0.1 has
wheels for Python 3.11 only and pins numpy<2: a fresh `pip install 'sketchgraph[peer]'` resolves (to an
OpenImageIO that takes numpy 1.26; both import in one process), but the environment requirements.lock pins
(numpy 2, OpenImageIO 3.2, which needs numpy 2) cannot hold it; there, give bpy a virtual environment of its own
(`python3.11 -m venv V && V/bin/pip install bpy==5.0.1`, then SKETCHGRAPH_PEER_VENV=V). The worker is
started once, loads every mesh once, and is told by JSON lines which scene to render; it times the render call
alone. sketchgraph renders in this process through the Python API, in one session without a disk cache whose
in-memory values are dropped before every render, so every node computes each time (the GL context, the parsed
mesh and the loaded pipeline stay, as Blender's loaded scene does).

Measured interleaved: each round renders, for every (pipeline, setup) pair, the sketchgraph pipeline and the
Blender setup back to back, the order within a pair and of the pairs turned round every other round, so drift in
the machine's speed hits both sides alike. Each way renders BACK_TO_BACK + 1 times in a row and the last is timed:
the frames of a film follow each other so, and a single render after other work pays for cold caches and memory
(sketchgraph's spot lines: 25 ms a frame back to back, 34 ms after a 0.25 s pause). Before each way's renders
there is a pause of SETTLE_S (0.25 s): on two cores the render just before leaves work behind (the other process's
threads winding down), which cost whichever side ran second 10-20 ms on spot, and 30-50 ms in a
round's first render. `--lone` times the single render after the pause instead (a still's cost; the JSON's
`back_to_back` says which). One round before the counted ones is not counted (first renders:
shader compilation, kernel loading). Reported per mesh: the median seconds of every way, `ratio` = Blender's
median / sketchgraph's median per (setup, pipeline) (above 1: sketchgraph is faster), the median of the pairs'
own ratios beside it, and the cold start apart: Blender's process start and `import bpy`, the OBJ import and the
scene setup and its first render, against a fresh sketchgraph process's import, load and first render.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import click
import numpy as np

from ...errors import SketchgraphError
from ...fsio import atomic_write_text
from .sides import SHARED_MESHES

SKIP_LINE = ("bench peer: bpy (Blender 5 as a Python module) is not installed: make a venv for it "
             "(python3.11 -m venv V && V/bin/pip install bpy==5.0.1, the [peer] extra's pin) and give "
             "SKETCHGRAPH_PEER_VENV=V or --blender-python V/bin/python")
VENV_ENV = "SKETCHGRAPH_PEER_VENV"
WORKER = Path(__file__).with_name("peer_blender.py")
# the shared test meshes sit beside a checkout (../shared/meshes); an installed package has none: --meshes-dir
DEFAULT_MESHES = ("spot.obj", "ogre.obj")
DEFAULT_PIPELINES = ("nienhaus_sketchy",)
SETTLE_S = 0.25  # seconds of pause before each way's renders in a round (module docstring)
BACK_TO_BACK = 1  # untimed renders of a way just before its timed one, as a film's frames follow each other
SETUPS = ("cycles", "workbench", "freestyle_svg")
DEFAULT_SETUPS = ("cycles", "workbench")
SENSOR_MM = 36.0  # Blender's sensor size along the fitted side; only lens / sensor matters


# -- the view Blender is given (pure: no Blender) ------------------------------------------------------------------
def look_at_matrix(eye: Any, target: Any, up: Any) -> np.ndarray:
    """Camera -> world (4, 4) of a camera at `eye` looking at `target`: the columns are right, true up and
    -forward, as Blender's and OpenGL's cameras both look down their local -Z with +Y up."""
    eye = np.asarray(eye, dtype=np.float64)
    f = np.asarray(target, dtype=np.float64) - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, np.asarray(up, dtype=np.float64))
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = r, u, -f, eye
    return m


def blender_camera(camera: dict[str, Any], size: tuple[int, int]) -> dict[str, Any]:
    """The Blender camera for a sketchgraph camera (`Camera.params()`): its world matrix (rows), the sensor fit
    (sketchgraph's fov spans the shorter image side: vertical for a wide or square image, horizontal for a tall
    one), sensor size and lens in mm, and the clip distances."""
    w, h = size
    lens = (SENSOR_MM / 2.0) / math.tan(math.radians(camera["fov_y_deg"]) / 2.0)
    return {"matrix_world": look_at_matrix(camera["eye"], camera["target"], camera["up"]).tolist(),
            "sensor_fit": "VERTICAL" if w >= h else "HORIZONTAL", "sensor_mm": SENSOR_MM, "lens_mm": lens,
            "clip_start": camera["near"], "clip_end": camera["far"]}


def project_blender(points: Any, cam: dict[str, Any], size: tuple[int, int]) -> np.ndarray:
    """World points (k, 3) -> (k, 2) in [0, 1] from the bottom left, by Blender's camera model (the fitted side's
    half extent over the lens; the other side follows the aspect): what `world_to_camera_view` gives."""
    w, h = size
    p = np.c_[np.asarray(points, dtype=np.float64).reshape(-1, 3), np.ones(len(np.asarray(points).reshape(-1, 3)))]
    c = p @ np.linalg.inv(np.asarray(cam["matrix_world"])).T
    t = (cam["sensor_mm"] / 2.0) / cam["lens_mm"]
    tx, ty = (t * w / h, t) if cam["sensor_fit"] == "VERTICAL" else (t, t * h / w)
    depth = -c[:, 2]
    return np.c_[c[:, 0] / depth / tx, c[:, 1] / depth / ty] * 0.5 + 0.5


def sun_rotation(toward_light: Any) -> list[list[float]]:
    """Rotation (3x3 rows) of a Blender sun lit from `toward_light` (a sun shines along its local -Z)."""
    z = np.asarray(toward_light, dtype=np.float64)
    z /= np.linalg.norm(z)
    helper = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.c_[x, np.cross(z, x), z].tolist()


def file_to_world(file_vertices: Any, world_vertices: Any) -> np.ndarray:
    """The affine map (4, 4) carrying a mesh file's vertices onto the same vertices in sketchgraph's world (however
    the framing stood the mesh up: an axis swap, a sign, or none): least squares over every vertex, then checked to
    carry each one there within 1e-6 of the extent."""
    src = np.asarray(file_vertices, dtype=np.float64).reshape(-1, 3)
    dst = np.asarray(world_vertices, dtype=np.float64).reshape(-1, 3)
    if src.shape != dst.shape or len(src) < 4:
        raise SketchgraphError(f"bench peer: the file has {len(src)} vertices and sketchgraph's mesh {len(dst)}: "
                               "cannot place Blender's import where sketchgraph draws the mesh")
    a = np.c_[src, np.ones(len(src))]
    x, *_ = np.linalg.lstsq(a, dst, rcond=None)
    scale = float(np.ptp(dst, axis=0).max()) or 1.0
    if float(np.abs(a @ x - dst).max()) > 1e-6 * scale:
        raise SketchgraphError("bench peer: sketchgraph's mesh is not an affine image of the file's vertices")
    m = np.eye(4)
    m[:3, :] = x.T
    m[np.abs(m) < 1e-12] = 0.0  # an axis swap comes out with round-off where zeros belong
    return m


def up_of(to_world: Any) -> str:
    """The file axis (x, y, z with a sign) that a file-to-world matrix turns to +Y, sketchgraph's up."""
    col = np.asarray(to_world, dtype=np.float64)[1, :3]  # world y as a function of the file's x, y, z
    k = int(np.argmax(np.abs(col)))
    return ("" if col[k] > 0 else "-") + "xyz"[k]


def peer_view(scene: Any, mesh_path: str | Path, size: tuple[int, int]) -> dict[str, Any]:
    """What the Blender worker needs to see `mesh_path` as sketchgraph's `scene` (the one-object scene `load` made
    of that file) shows it at frame 0: the matrix carrying the file's coordinates into sketchgraph's world, the
    camera, the sun's direction in the world, the mesh colour, and probe points (the bounding box's corners and
    centre) with where sketchgraph projects them."""
    from ...scene.meshes import load_mesh

    if len(scene.objects) != 1:
        raise SketchgraphError(f"bench peer: {mesh_path}: expected the one-object scene of a mesh file")
    to_world = file_to_world(load_mesh(mesh_path).vertices, scene.objects[0].world_vertices())
    lo, hi = scene.bounds()
    cam = scene.camera_at(0)
    light = np.asarray(scene.light_direction, dtype=np.float64)
    if scene.light_space == "view":  # view space: x right, y up, z toward the viewer
        r, u, f = cam.basis()
        light = r * light[0] + u * light[1] - f * light[2]
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    probes = np.r_[corners, [(lo + hi) / 2.0]]
    w, h = size
    ndc = cam.project(probes, aspect=w / h)
    return {"up_axis": up_of(to_world), "object_matrix": to_world.tolist(), "camera": cam.params(),
            "blender_camera": blender_camera(cam.params(), size),
            "light": (light / np.linalg.norm(light)).tolist(), "sun_rotation": sun_rotation(light),
            "color": list(scene.objects[0].color), "probe_points": probes.tolist(),
            "probe_expected": (ndc[:, :2] * 0.5 + 0.5).tolist()}


def camera_match_px(expected: Any, got: Any, size: tuple[int, int]) -> float:
    """The largest distance in pixels between two projections of the same points ([0, 1] image coordinates)."""
    d = (np.asarray(expected, dtype=np.float64) - np.asarray(got, dtype=np.float64)) * np.asarray(size, np.float64)
    return float(np.sqrt((d**2).sum(axis=1)).max()) if len(d) else 0.0


# -- the schedule and the figures (pure) ---------------------------------------------------------------------------
def split_pipeline(pipeline: str) -> tuple[str, str | None]:
    """`--pipeline` NAME or NAME:OUTPUT (e.g. plotter_lines:lines, its lines alone) -> (name, output or None)."""
    name, _, output = pipeline.partition(":")
    return name, output or None


def strokes_output(pipe: Any, output: str) -> bool:
    """Whether a loaded pipeline's output (a name or NODE.PORT) carries strokes (by its port type: nothing runs)."""
    nid, port = pipe.pipeline.outputs[output] if output in pipe.pipeline.outputs else pipe.pipeline.parse_ref(output)
    return pipe.pipeline.nodes[nid].outputs[port].type.kind == "Strokes"


def sg_way(pipeline: str) -> str:
    return f"sketchgraph:{pipeline}"


def blender_way(setup: str) -> str:
    return f"blender:{setup}"


def schedule(pipelines: list[str], setups: list[str], rounds: int) -> list[list[tuple[str, str]]]:
    """Each round's pairs (sketchgraph way, Blender way) in the order they run: every (pipeline, setup) pair once;
    on odd rounds the pairs run in reverse order and each pair Blender first (`order_of`)."""
    pairs = [(sg_way(p), blender_way(s)) for p in pipelines for s in setups]
    return [pairs if r % 2 == 0 else pairs[::-1] for r in range(rounds)]


def order_of(pair: tuple[str, str], round_index: int) -> tuple[str, str]:
    """The order of a pair's two renders in a round: sketchgraph first on even rounds, Blender first on odd."""
    return pair if round_index % 2 == 0 else (pair[1], pair[0])


def summarize(seconds: dict[str, list[float]], paired: dict[str, list[float]]) -> dict[str, Any]:
    """Medians of every way's seconds and, for every pair 'blender:S/sketchgraph:P' in `paired` (its per-pair
    Blender / sketchgraph ratios), the ratio of the two medians and the median of the pairs' ratios."""
    medians = {way: statistics.median(v) for way, v in seconds.items() if v}
    ratios: dict[str, dict[str, float]] = {}
    for key, per_pair in paired.items():
        bl, sg = key.split("/")
        ratios[key] = {"ratio": medians[bl] / medians[sg], "ratio_paired_median": statistics.median(per_pair)}
    return {"median_s": medians, "ratios": ratios}


# -- the Blender worker ------------------------------------------------------------------------------------------
def _finds_bpy(python: str) -> bool:
    try:
        done = subprocess.run([python, "-c", "import importlib.util, sys; "
                               "sys.exit(importlib.util.find_spec('bpy') is None)"], capture_output=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return done.returncode == 0


def bpy_importable_here() -> bool:
    """Whether this interpreter finds bpy (looked up, not imported: Blender never starts in this process)."""
    return importlib.util.find_spec("bpy") is not None


def _venv_python(venv: str) -> str:
    p = Path(venv).expanduser()
    if p.is_dir():
        for cand in (p / "bin" / "python", p / "Scripts" / "python.exe"):
            if cand.exists():
                return str(cand)
    return str(p)


def find_blender_python(explicit: str | None = None) -> str | None:
    """The Python that runs the worker: `explicit` (an error if it cannot import bpy), else this interpreter where
    bpy is importable, else the virtual environment (or Python) `$SKETCHGRAPH_PEER_VENV` names, else None."""
    if explicit:
        python = _venv_python(explicit)
        if not _finds_bpy(python):
            raise SketchgraphError(f"bench peer: --blender-python {explicit}: that Python cannot import bpy")
        return python
    if bpy_importable_here():
        return sys.executable
    venv = os.environ.get(VENV_ENV)
    if venv:
        python = _venv_python(venv)
        if _finds_bpy(python):
            return python
    return None


class BlenderWorker:
    """`peer_blender.py` run by `python`, spoken to in JSON lines; Blender's own output goes to a log file."""

    def __init__(self, python: str) -> None:
        fd, log = tempfile.mkstemp(prefix="sketchgraph-peer-", suffix=".log")
        self.log = Path(log)
        t0 = time.perf_counter()
        try:
            self.proc = subprocess.Popen([python, str(WORKER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                         stderr=fd, text=True, bufsize=1)
        finally:
            os.close(fd)  # the child holds its own copy
        ready = self._read()
        self.start_s = time.perf_counter() - t0  # process start, `import bpy`, the factory settings
        self.import_bpy_s = float(ready["import_s"])
        self.version = str(ready["version"])

    def _read(self) -> dict[str, Any]:
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        if not line:
            tail = [s for s in self.log.read_text(errors="replace").splitlines() if s.strip()][-1:]
            raise SketchgraphError(f"bench peer: the Blender worker stopped (exit {self.proc.wait()}): "
                                   f"{tail[0] if tail else 'no output'} (log: {self.log})")
        answer = json.loads(line)
        if not answer.pop("ok", False):
            raise SketchgraphError(f"bench peer: Blender: {answer.get('error')} (log: {self.log})")
        return answer

    def ask(self, **request: Any) -> dict[str, Any]:
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        return self._read()

    def close(self, keep_log: bool = False) -> None:
        """Ask the worker to quit (killed after 30 s); its log is removed unless `keep_log` (after a failure)."""
        if self.proc.poll() is None:
            with contextlib.suppress(OSError, SketchgraphError, ValueError):
                self.ask(op="quit")
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if not keep_log:
            self.log.unlink(missing_ok=True)


@contextlib.contextmanager
def blender_worker(python: str) -> Iterator[BlenderWorker]:
    worker = BlenderWorker(python)
    try:
        yield worker
    except BaseException:
        worker.close(keep_log=True)
        raise
    worker.close()


# -- sketchgraph's side ----------------------------------------------------------------------------------------------
_COLD_SCRIPT = """
import json, sys, tempfile, time
t0 = time.perf_counter()
import nodegraph as ng
t1 = time.perf_counter()
name, _, output = sys.argv[1].partition(":")
pipe = ng.load(name, scene=sys.argv[2], size=(int(sys.argv[3]), int(sys.argv[4])),
               session=ng.Session(cache=False), view=sys.argv[5] or None, up=sys.argv[6] or None)
t2 = time.perf_counter()
from nodegraph.tools.bench.peer import strokes_output
if output and strokes_output(pipe, output):
    pipe.write(tempfile.mkdtemp(prefix="peer_cold_") + "/lines.svg", output)
else:
    pipe.render(output or None)
t3 = time.perf_counter()
print(json.dumps({"import_s": t1 - t0, "load_s": t2 - t1, "first_render_s": t3 - t2}), flush=True)
"""


def sketchgraph_cold(pipeline: str, mesh: Path, size: tuple[int, int], view: str | None,
                     up: str | None) -> dict[str, float]:
    """A fresh process's `import nodegraph`, `load` (the mesh parsed, no disk cache) and first render; `total_s` is
    the wall time from starting the process to its answer."""
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", _COLD_SCRIPT, pipeline, str(mesh), str(size[0]), str(size[1]),
                           view or "", up or ""], capture_output=True, text=True)
    total = time.perf_counter() - t0
    lines = [s for s in done.stdout.splitlines() if s.startswith("{")]
    if done.returncode != 0 or not lines:
        last = (done.stderr.strip() or f"exit status {done.returncode}").splitlines()[-1]
        raise SketchgraphError(f"bench peer: the cold sketchgraph run failed: {last}")
    return {**json.loads(lines[-1]), "total_s": total}


class SketchgraphSide:
    """The pipelines of every mesh, loaded once in one session with no disk cache. A pipeline is a name or
    NAME:OUTPUT (`split_pipeline`); an output whose value is strokes is written as the SVG file `sketchgraph run -o
    F.svg` writes (inside the timing, as Freestyle's SVG Exporter writes its file inside Blender's render)."""

    def __init__(self, size: tuple[int, int], view: str | None, up: str | None) -> None:
        import nodegraph as ng

        self.ng = ng
        self.session = ng.Session(cache=False)
        self.size, self.view, self.up = size, view, up
        self.pipes: dict[tuple[str, str], Any] = {}
        self.outputs: dict[tuple[str, str], str | None] = {}
        self.svg: set[tuple[str, str]] = set()  # (mesh, pipeline) whose output is strokes: written as SVG
        self.folder = Path(tempfile.mkdtemp(prefix="peer_sg_"))

    def load(self, mesh: str, path: Path, pipeline: str) -> Any:
        name, output = split_pipeline(pipeline)
        pipe = self.ng.load(name, scene=str(path), size=self.size, session=self.session, view=self.view,
                            up=self.up)
        self.pipes[(mesh, pipeline)] = pipe
        self.outputs[(mesh, pipeline)] = output
        if output is not None and strokes_output(pipe, output):
            self.svg.add((mesh, pipeline))
        return pipe

    def render(self, mesh: str, pipeline: str) -> float:
        """Seconds of one render that computes every node (the session's values dropped first, not timed); the
        image is read back, as Blender's render ends with its result in memory, or strokes written as SVG."""
        pipe, output = self.pipes[(mesh, pipeline)], self.outputs[(mesh, pipeline)]
        self.session.close()
        t0 = time.perf_counter()
        if (mesh, pipeline) in self.svg:
            pipe.write(self.folder / f"{mesh}.svg", output)
        else:
            pipe.render(output)
        return time.perf_counter() - t0

    def picture(self, mesh: str, pipeline: str, images: Path) -> Path:
        """The pipeline's output written to `images` (a PNG, or the SVG of a strokes output)."""
        pipe, output = self.pipes[(mesh, pipeline)], self.outputs[(mesh, pipeline)]
        stem = f"{mesh}_sketchgraph_{pipeline.replace(':', '_')}"
        suffix = ".svg" if (mesh, pipeline) in self.svg else ".png"
        return Path(pipe.write(images / f"{stem}{suffix}", output))

    def renderer(self) -> str:
        return str(self.session.gl.renderer)

    def close(self) -> None:
        self.session.close()


# -- the benchmark ---------------------------------------------------------------------------------------------------
SETUP_TEXT = {
    "cycles": "Cycles, CPU, {samples} samples, no adaptive sampling, no denoising; Freestyle: one line set, visible "
              "silhouette + border + crease edges, 1.5 px",
    "workbench": "Workbench, studio light, material colour, 8 AA samples (default); Grease Pencil v3 Line Art "
                 "modifier (source: scene; contour + crease + loose lines)",
    "freestyle_svg": "Freestyle SVG Exporter (one SVG a frame) on the cycles setup's line set, Cycles at 1 sample",
}


def bench_peer(blender_python: str, meshes: list[Path], *, pipelines: tuple[str, ...] = DEFAULT_PIPELINES,
               setups: tuple[str, ...] = DEFAULT_SETUPS, rounds: int = 5, size: tuple[int, int] = (800, 800),
               cycles_samples: int = 16, view: str | None = None, up: str | None = None,
               images: Path | None = None, cold: bool = True, back_to_back: int = BACK_TO_BACK) -> dict[str, Any]:
    if rounds < 1:
        raise SketchgraphError("bench peer: --rounds must be at least 1")
    unknown = [s for s in setups if s not in SETUPS]
    if unknown:
        raise SketchgraphError(f"bench peer: unknown setups {unknown}; choose from {', '.join(SETUPS)}")
    names = [m.stem for m in meshes]
    out: dict[str, Any] = {
        "benchmark": "peer", "size": list(size), "rounds": rounds, "pipelines": list(pipelines),
        "setups": {s: SETUP_TEXT[s].format(samples=cycles_samples) for s in setups},
        "cycles_samples": cycles_samples, "blender_python": blender_python, "meshes": {},
        "back_to_back": back_to_back, "settle_s": SETTLE_S,
    }
    cold_sg: dict[str, dict[str, Any]] = {}
    if cold:  # before the worker starts: nothing else runs beside these processes
        for name, path in zip(names, meshes, strict=True):
            cold_sg[name] = {p: sketchgraph_cold(p, path, size, view, up) for p in pipelines}
    sg = SketchgraphSide(size, view, up)
    try:
        with blender_worker(blender_python) as bl:
            out["blender"] = {"version": bl.version, "start_s": bl.start_s, "import_bpy_s": bl.import_bpy_s}
            per_mesh: dict[str, dict[str, Any]] = {}
            for name, path in zip(names, meshes, strict=True):
                pipe = None
                for p in pipelines:
                    pipe = sg.load(name, path, p)
                assert pipe is not None
                view_of = peer_view(pipe.pipeline.scene, path, size)
                loaded = bl.ask(op="load", name=name, mesh=str(path), size=list(size), setups=list(setups),
                                cycles_samples=cycles_samples, **{k: view_of[k] for k in (
                                    "object_matrix", "blender_camera", "sun_rotation", "color", "probe_points")})
                per_mesh[name] = {
                    "mesh": str(path), "faces_blender": loaded["faces"], "object_matrix": view_of["object_matrix"],
                    "triangles_sketchgraph": pipe.pipeline.scene.n_triangles(), "up_axis": view_of["up_axis"],
                    "camera": view_of["camera"], "light_world": view_of["light"],
                    "camera_match_px": camera_match_px(view_of["probe_expected"], loaded["projected"], size),
                    "bounds_match": bool(np.allclose(loaded["bounds"], [list(b) for b in pipe.pipeline.scene.bounds()],
                                                     atol=1e-4 * float(np.ptp(np.array(loaded["bounds"]))))),
                    "blender_load_s": {"obj_import_s": loaded["import_s"], "setup_s": loaded["setup_s"]},
                }
            # one round not counted: every way's first render
            first: dict[str, dict[str, float]] = {n: {} for n in names}
            for name in names:
                for p in pipelines:
                    first[name][sg_way(p)] = sg.render(name, p)
                for s in setups:
                    first[name][blender_way(s)] = bl.ask(op="render", name=name, setup=s)["render_s"]
            out["blender"].update(bl.ask(op="info"))
            out["sketchgraph"] = {"renderer": sg.renderer()}
            seconds = {n: {w: [] for w in (*map(sg_way, pipelines), *map(blender_way, setups))} for n in names}
            paired: dict[str, dict[str, list[float]]] = {n: {} for n in names}
            for r, pairs in enumerate(schedule(list(pipelines), list(setups), rounds)):
                for name in names:
                    for pair in pairs:
                        took: dict[str, float] = {}
                        for way in order_of(pair, r):
                            kind, what = way.split(":", 1)
                            time.sleep(SETTLE_S)
                            for _ in range(1 + back_to_back):  # the last of back-to-back renders is timed
                                took[way] = (sg.render(name, what) if kind == "sketchgraph"
                                             else bl.ask(op="render", name=name, setup=what)["render_s"])
                            seconds[name][way].append(took[way])
                        key = f"{pair[1]}/{pair[0]}"
                        paired[name].setdefault(key, []).append(took[pair[1]] / took[pair[0]])
            for name in names:
                m = per_mesh[name]
                m["seconds"] = seconds[name]
                m.update(summarize(seconds[name], paired[name]))
                m["first_render_s"] = first[name]
                load = m["blender_load_s"]
                m["cold_s"] = {
                    blender_way(s): bl.start_s + load["obj_import_s"] + load["setup_s"] + first[name][blender_way(s)]
                    for s in setups}
                if cold:
                    m["sketchgraph_cold"] = cold_sg[name]
                    m["cold_s"].update({sg_way(p): cold_sg[name][p]["total_s"] for p in pipelines})
                    m["cold_ratios"] = {f"{blender_way(s)}/{sg_way(p)}": m["cold_s"][blender_way(s)]
                                        / m["cold_s"][sg_way(p)] for s in setups for p in pipelines}
            if images is not None:
                images.mkdir(parents=True, exist_ok=True)
                written = []
                for name in names:
                    for p in pipelines:
                        written.append(str(sg.picture(name, p, images)))
                    for s in setups:
                        written.append(bl.ask(op="save", name=name, setup=s,
                                              path=str((images / f"{name}_blender_{s}.png").absolute()))["path"])
                out["images"] = written
            out["meshes"] = per_mesh
    finally:
        sg.close()
    return out


def format_table(result: dict[str, Any]) -> str:
    """The figures as a table: per mesh and Blender setup, both medians and the ratios."""
    rows = [("mesh", "setup", "pipeline", "blender s", "sketchgraph s", "ratio", "paired", "cold ratio")]
    for name, m in result["meshes"].items():
        for key, r in m["ratios"].items():
            bl, sg = key.split("/")
            cold = m.get("cold_ratios", {}).get(key)
            rows.append((name, bl.split(":", 1)[1], sg.split(":", 1)[1], f"{m['median_s'][bl]:.3f}",
                         f"{m['median_s'][sg]:.3f}", f"{r['ratio']:.1f}", f"{r['ratio_paired_median']:.1f}",
                         "-" if cold is None else f"{cold:.1f}"))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(w) if i < 3 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths,
                                                                                                  strict=True)))
                     for row in rows)


def timed_render(back_to_back: int) -> str:
    """Which render of a way the figures time, in words."""
    if back_to_back == 0:
        return f"each way's lone render after a {SETTLE_S:g} s pause"
    return f"each way's last of {back_to_back + 1} renders in a row after a {SETTLE_S:g} s pause"


def print_peer(result: dict[str, Any]) -> None:
    b = result["blender"]
    click.echo(f"Blender {b['version']} (GPU backend {b.get('gpu_backend')}, {b.get('gpu_renderer', '-')}); "
               f"sketchgraph on {result['sketchgraph']['renderer']}; {result['size'][0]}x{result['size'][1]}, "
               f"{result['rounds']} interleaved rounds, medians of warm renders "
               f"({timed_render(result.get('back_to_back', BACK_TO_BACK))}); ratio = Blender / sketchgraph")
    for s, text in result["setups"].items():
        click.echo(f"  {s}: {text}")
    click.echo(format_table(result))
    click.echo(f"Blender cold start (process, import bpy): {b['start_s']:.2f} s")
    for name, m in result["meshes"].items():
        load = m["blender_load_s"]
        cold = ", ".join(f"{w} {s:.2f}" for w, s in m["cold_s"].items())
        click.echo(f"{name}: {m['triangles_sketchgraph']} triangles, camera match {m['camera_match_px']:.3f} px, "
                   f"OBJ import {load['obj_import_s']:.3f} s + setup {load['setup_s']:.3f} s; cold s: {cold}")
    for path in result.get("images", []):
        click.echo(f"wrote {path}")


@click.command(help="Speed against Blender 5 (Cycles + Freestyle, Workbench + Line Art) on the same meshes and "
                    "camera, interleaved; ratios Blender / sketchgraph. Needs bpy: pip install 'sketchgraph[peer]'.")
@click.option("--mesh", "mesh_names", multiple=True, help="A mesh file, or a name in --meshes-dir (repeatable; "
              f"default: {', '.join(DEFAULT_MESHES)}).")
@click.option("--meshes-dir", type=click.Path(path_type=Path), default=None,
              help="Folder of the shared test meshes (default: ../shared/meshes beside the checkout).")
@click.option("--pipeline", "pipelines", multiple=True, help="A sketchgraph pipeline, or NAME:OUTPUT for one "
              "output (a strokes output is written as SVG inside the timing; e.g. plotter_lines:lines) (repeatable; "
              f"default: {', '.join(DEFAULT_PIPELINES)}).")
@click.option("--setup", "setups", multiple=True, type=click.Choice(SETUPS),
              help="Blender setups (default: cycles and workbench).")
@click.option("--rounds", default=5, show_default=True, help="Interleaved rounds counted (after one not counted).")
@click.option("--size", default="800x800", show_default=True, help="WxH.")
@click.option("--cycles-samples", default=16, show_default=True, help="Cycles samples a pixel.")
@click.option("--view", default=None, help="The named view a mesh is seen from (as `run --view`).")
@click.option("--up", default=None, help="A mesh's up axis: x, y, z or auto (as `run --up`).")
@click.option("--no-cold", is_flag=True, help="Skip the fresh sketchgraph processes of the cold-start figures.")
@click.option("--lone", is_flag=True, help="Time each way's single render after the pause (a still), not the second "
              "of two in a row (a film's frame).")
@click.option("--blender-python", default=None, help="A Python (or virtual environment) that imports bpy "
              f"(default: this one where it can, else ${VENV_ENV}).")
@click.option("--images", "images_dir", type=click.Path(path_type=Path), help="Write one PNG of every way here.")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def command(mesh_names: tuple[str, ...], meshes_dir: Path | None, pipelines: tuple[str, ...],
            setups: tuple[str, ...], rounds: int, size: str, cycles_samples: int, view: str | None, up: str | None,
            no_cold: bool, lone: bool, blender_python: str | None, images_dir: Path | None,
            json_path: Path | None) -> None:
    python = find_blender_python(blender_python)
    if python is None:
        click.echo(SKIP_LINE)
        return
    from ...pipeline import parse_size

    folder = SHARED_MESHES if meshes_dir is None else meshes_dir
    meshes: list[Path] = []
    for name in mesh_names or DEFAULT_MESHES:
        path = Path(name) if Path(name).suffix and Path(name).is_file() else folder / name
        if path.is_file():
            meshes.append(path)
        else:
            click.echo(f"bench peer: skipping {name}: not found at {path} (--meshes-dir DIR: the shared test meshes)")
    if not meshes:
        click.echo(f"bench peer: no meshes to render (looked in {folder}); pass --meshes-dir DIR or --mesh FILE")
        return
    result = bench_peer(python, meshes, pipelines=pipelines or DEFAULT_PIPELINES, setups=setups or DEFAULT_SETUPS,
                        rounds=rounds, size=parse_size(size), cycles_samples=cycles_samples, view=view, up=up,
                        images=images_dir, cold=not no_cold, back_to_back=0 if lone else BACK_TO_BACK)
    print_peer(result)
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json_path, json.dumps(result, indent=2) + "\n")
        click.echo(f"wrote {json_path}")
