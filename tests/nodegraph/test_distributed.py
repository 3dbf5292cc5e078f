"""Frame sequences, wedges and galleries on a real Dask cluster (two spawned worker processes on loopback,
one cluster for the whole module): byte-identical to serial runs, a killed worker costs only its chunk,
errors arrive as the same one line, the shared cache is namespaced by renderer and never pruned by workers."""

from __future__ import annotations

import json
import os
import shutil
import signal
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

pytest.importorskip("distributed")

from nodegraph import distributed as dist  # noqa: E402
from nodegraph.cache import MESH_STORE, Cache, renderer_namespace  # noqa: E402
from nodegraph.cli import main  # noqa: E402
from nodegraph.errors import NodeError, PipelineError  # noqa: E402
from nodegraph.output.frames_manifest import FramesManifest, manifest_path  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
PIPELINES = ROOT / "pipelines"
SIZE = "96x96"
FRAMES = list(range(12))


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory):
    root = tmp_path_factory.mktemp("shared-cache")
    with dist.connect("local:2", cache_root=root) as client:
        client.wait_for_workers(2, timeout=60)
        yield client, root


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The 12-frame pencil sequence rendered serially in this process, without a cache."""
    out = tmp_path_factory.mktemp("serial")
    res = CliRunner().invoke(main, ["run", "pencil", "--size", SIZE, "--frames", "0:12", "-o",
                                    str(out / "f_####.png"), "--no-cache", "-q"])
    if res.exit_code != 0 and "OpenGL" in res.output:
        pytest.skip(f"no OpenGL: {res.output.strip()}")
    assert res.exit_code == 0, res.output
    return out


def same_files(a: Path, b: Path, frames: list[int] = FRAMES) -> None:
    for f in frames:
        name = f"f_{f:04d}.png"
        assert (a / name).read_bytes() == (b / name).read_bytes(), f"frame {f} differs"


@pytest.mark.slow  # a Dask cluster
def test_sequence_is_byte_identical_to_serial(cluster, serial: Path, tmp_path: Path) -> None:
    client, root = cluster
    seen: list[int] = []
    spec = dist.PipeSpec.make("pencil", size=SIZE)
    rep = dist.render_frames(client, spec, FRAMES, tmp_path / "f_####.png", chunk=3, cache_root=root,
                             on_frame=lambda f, p: seen.append(f))
    same_files(serial, tmp_path)
    assert seen == FRAMES  # in frame order, whatever order the chunks finished in
    assert rep.rendered == 12 and rep.tasks == 4 and sum(rep.per_worker.values()) == 12
    # curvature and the hatching tones do not change over the frames: computed once, reached through the cache
    assert {"curv.out", "tam.tones"} <= set(rep.prepared)
    man = json.loads(manifest_path(tmp_path / "f_####.png").read_text())
    assert sorted(int(f) for f in man["frames"]) == FRAMES
    # the shared cache holds node entries only inside renderer namespaces (node keys are not changed by them),
    # beside the mesh store's folder (parsing meshes is the same for every renderer)
    assert root.exists() and all(p.name.startswith("renderer-") for p in root.iterdir()
                                 if p.name not in (".tmp", MESH_STORE))

    # a resumed run skips every finished frame, and renders again only what is missing or changed
    again = dist.render_frames(client, spec, FRAMES, tmp_path / "f_####.png", resume=True, cache_root=root)
    assert (again.skipped, again.rendered) == (12, 0)
    (tmp_path / "f_0005.png").unlink()
    (tmp_path / "f_0007.png").write_bytes(b"not a png")
    again = dist.render_frames(client, spec, FRAMES, tmp_path / "f_####.png", resume=True, cache_root=root)
    assert (again.skipped, again.rendered) == (10, 2)
    same_files(serial, tmp_path)


@pytest.mark.slow  # a Dask cluster
def test_a_killed_worker_costs_only_its_chunk(cluster, serial: Path, tmp_path: Path) -> None:
    client, root = cluster
    pids = client.run(os.getpid)
    run = dist.FrameRun(client, dist.PipeSpec.make("pencil", size=SIZE), FRAMES, tmp_path / "f_####.png",
                        chunk=2, cache_root=root)
    got = []
    for frame, _path in run:
        if not got:  # the first chunk is done: kill a worker in the middle of its next one
            victim = max(run.report.per_worker, key=lambda w: run.report.per_worker[w])
            os.kill(pids[victim], signal.SIGKILL)
        got.append(frame)
    assert got == FRAMES
    same_files(serial, tmp_path)
    assert run.report.retries >= 1
    client.wait_for_workers(2, timeout=60)  # the nanny starts a new one (the plugin is registered on it too)


@pytest.mark.slow  # a Dask cluster
def test_task_errors_arrive_as_the_same_one_line(cluster, tmp_path: Path) -> None:
    client, _root = cluster
    bad = dist.PipeSpec.make("pencil", overrides=("nope.x=1",), size=SIZE)
    with pytest.raises(PipelineError) as local:
        bad.open()
    res = client.submit(dist.render_frames_task, bad, [0], str(tmp_path / "f_####.png"), False, False,
                        pure=False).result()
    with pytest.raises(PipelineError) as remote:
        dist._raise_failure(res)
    assert type(remote.value) is type(local.value) and str(remote.value) == str(local.value)
    assert "\n" not in str(remote.value)
    # attributes travel too; an unknown class falls back to the base class with the same message
    err = dist.TaskFailure.of(NodeError("boom", "hatch", "pencil_shade")).error()
    assert isinstance(err, NodeError) and str(err) == "node 'hatch' (pencil_shade): boom" and err.node_id == "hatch"
    assert str(dist.TaskFailure("no.such:Error", "x: y").error()) == "x: y"
    # through the command line: exit 2 and one line
    res = CliRunner().invoke(main, ["run", "pencil", "--size", SIZE, "--scheduler", "local:1", "--set", "nope.x=1"])
    assert res.exit_code == 2 and res.output.count("\n") == 1 and "unknown node 'nope'" in res.output


LLVMPIPE = "llvmpipe (LLVM 15.0.6, 256 bits) | 4.5 (Core Profile) Mesa 22.3.6"
NVIDIA = "NVIDIA H200/PCIe/SSE2 | 4.6.0 NVIDIA 550.54"


def test_renderer_namespaces_are_disjoint(tmp_path: Path) -> None:
    a = dist.namespaced_cache(tmp_path, LLVMPIPE)
    b = dist.namespaced_cache(tmp_path, NVIDIA)
    key = "ab" * 32
    a.store(key, "out", "arrays", _arrays(), {"node": "n", "type": "t"})
    assert a.find(key, "out") is not None and b.find(key, "out") is None
    b.store(key, "out", "arrays", _arrays(), {"node": "n", "type": "t"})
    assert a.find(key, "out") != b.find(key, "out")
    assert {p.name for p in tmp_path.iterdir()} == {renderer_namespace(r) for r in (LLVMPIPE, NVIDIA)}
    assert Cache(tmp_path).find(key, "out") is None  # a cache bound to no renderer reads neither
    assert len(Cache(tmp_path).entries()) == 2  # info and prune see every renderer's entries
    # a worker's cache never prunes, whatever its limit
    w = dist.namespaced_cache(tmp_path, LLVMPIPE, dist.WorkerCache)
    w.limit = 0
    assert w.prune() == (0, 0) and a.find(key, "out") is not None


def _arrays():
    from nodegraph.values import Arrays

    return Arrays({"x": np.arange(4, dtype=np.float32)})


class ListSink:
    def __init__(self) -> None:
        self.frames: list[tuple[int, np.ndarray]] = []
        self.closed = False

    def add(self, frame: int, rgb: np.ndarray) -> None:
        self.frames.append((frame, rgb))

    def close(self) -> None:
        self.closed = True


@pytest.mark.slow  # a Dask cluster
def test_video_outputs_feed_a_sink_in_frame_order(cluster, serial: Path, tmp_path: Path) -> None:
    from nodegraph.output.imageio import read, to_uint8

    client, root = cluster
    sink = ListSink()
    out = tmp_path / "orbit.mp4"
    dist.render_frames(client, dist.PipeSpec.make("pencil", size=SIZE), FRAMES[:6], out, chunk=2, cache_root=root,
                       sink=sink)
    assert sink.closed and [f for f, _ in sink.frames] == FRAMES[:6]
    for f, rgb in sink.frames:
        assert rgb.dtype == np.uint8 and rgb.shape == (96, 96, 3)
        assert np.array_equal(rgb, to_uint8(read(serial / f"f_{f:04d}.png")[::-1][:, :, :3]))
    assert not dist.video_frames_dir(out).exists()  # the temporary frames are gone once the sink closed


@pytest.mark.slow  # a Dask cluster
def test_api_frames_on_a_client(cluster, tmp_path: Path) -> None:
    import nodegraph as ng

    client, root = cluster
    pipe = ng.load("nienhaus_sketchy", size=(64, 64), session=ng.api.Session(cache=tmp_path / "c"))
    want = dict(pipe.frames(range(4)))
    got = list(pipe.frames(range(4), scheduler=client, chunk=2))
    assert [f for f, _ in got] == [0, 1, 2, 3]
    assert all(np.array_equal(want[f], a) and a.dtype == np.uint8 for f, a in got)


@pytest.mark.slow  # a Dask cluster
def test_wedge_is_byte_identical_to_serial(cluster, tmp_path: Path) -> None:
    from nodegraph import render
    from nodegraph.tools import viz
    from nodegraph.tools import wedge as wedgemod

    client, root = cluster
    path = str(PIPELINES / "nienhaus_sketchy.yaml")
    axes = wedgemod.axes_from(["edges.normal_threshold=0.2,0.8", "noise.scale=0.01,0.02"])
    serial = wedgemod.run(lambda extra: render.open_pipeline(path, tuple(extra), SIZE), axes)
    remote = wedgemod.run_distributed(client, dist.PipeSpec.make(path, size=SIZE), axes, 0, str(root))
    viz.write_png(tmp_path / "a.png", wedgemod.sheet(serial, axes, "w", 64))
    viz.write_png(tmp_path / "b.png", wedgemod.sheet(remote, axes, "w", 64))
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()
    assert [c.label for c in remote] == [c.label for c in serial]


GALLERY = f"""\
cell: 48
entries:
  - name: still
    pipeline: {PIPELINES / "nienhaus_sketchy.yaml"}
    size: [40, 32]
  - name: orbit
    pipeline: {PIPELINES / "pencil.yaml"}
    size: [32, 32]
    frames: "0:4:2"
"""


@pytest.mark.slow  # a Dask cluster
def test_gallery_build_is_byte_identical_to_serial(cluster, tmp_path: Path) -> None:
    from nodegraph.tools import gallery as gal

    client, _root = cluster
    built = {}
    for name, scheduler in (("serial", None), ("cluster", client)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "gallery.yaml").write_text(GALLERY)
        g = gal.load(tmp_path / name / "gallery.yaml")
        report = gal.build(g, gal.node_cache(g), progress=False, echo=lambda s: None, scheduler=scheduler)
        assert not report.failed, [r.note for r in report.results]
        assert [r.status for r in report.results] == ["rendered", "rendered"]
        built[name] = report.manifest
    a, b = built["serial"], built["cluster"]
    assert a["renderer"] == b["renderer"]
    for entry in ("still", "orbit"):
        assert a["entries"][entry]["build_key"] == b["entries"][entry]["build_key"]
        assert {k: v["sha256"] for k, v in a["entries"][entry]["files"].items()} == \
               {k: v["sha256"] for k, v in b["entries"][entry]["files"].items()}
    shutil.rmtree(tmp_path / "serial")


def test_frames_manifest_round_trip(tmp_path: Path) -> None:
    m = FramesManifest(tmp_path / "f_####.png")
    (tmp_path / "f_0001.png").write_bytes(b"x")
    from nodegraph.output.frames_manifest import file_sha256

    m.record(1, "d1", file_sha256(tmp_path / "f_0001.png"))
    m.save()
    back = FramesManifest.load(tmp_path / "f_####.png")
    assert back.done(1, "d1", tmp_path / "f_0001.png")
    assert not back.done(1, "other", tmp_path / "f_0001.png") and not back.done(2, "d1", tmp_path / "f_0002.png")
    (tmp_path / ".f_####.png.frames.json").write_text("{not json")
    assert FramesManifest.load(tmp_path / "f_####.png").frames == {}


def test_default_chunk() -> None:
    assert dist.default_chunk(12, 2) == 4
    assert dist.default_chunk(2, 2) == 2
    assert dist.default_chunk(10_000, 4) == dist.MAX_CHUNK
    assert dist.lp_threads_for(4, cores=2) == 1 and dist.lp_threads_for(2, cores=16) == 8


@pytest.mark.parametrize("ext", [".png", ".exr"])
def test_a_task_writes_each_frame_as_the_frame_rendered_alone(gl, tmp_path: Path, ext: str, monkeypatch) -> None:
    # render_frames_task in this process (no cluster): a PNG frame's 8-bit pass is issued at the next run's
    # hand-over and read back and written at the one after (GL.pack_png), an EXR frame at the next hand-over;
    # each file has the bytes (PNG) or values (EXR) of its frame rendered and written alone, and the task
    # reports the frames in order with their files' hashes; PNG frames are synced together before it returns
    from nodegraph.executor import Executor
    from nodegraph.output import imageio, write
    from nodegraph.output.frames_manifest import file_sha256
    from tests import gltf_files as gf

    spec = dist.PipeSpec.make("nienhaus_sketchy", size="64x48", scene=str(gf.animated_box(tmp_path / "box.glb")))
    frames = [0, 3, 6, 9, 12]
    synced: list[str] = []
    real_sync = dist.sync_written
    monkeypatch.setattr(dist, "sync_written",
                        lambda paths: (synced.extend(Path(p).name for p in paths), real_sync(paths)))
    res = dist.render_frames_task(spec, frames, str(tmp_path / "seq" / f"f_####{ext}"), True, False)
    assert "error" not in res, res
    assert synced == ([f"f_{f:04d}.png" for f in frames] if ext == ".png" else [])
    assert [f["frame"] for f in res["frames"]] == frames
    pipe = spec.open()
    ref = dist.ref_of(pipe, None)
    for f, info in zip(frames, res["frames"], strict=True):
        got = Path(info["path"])
        assert got == tmp_path / "seq" / f"f_{f:04d}{ext}" and info["sha256"] == file_sha256(got) and info["ms"] > 0
        one = write.write_frame(Executor(pipe, None, requested=[ref], gl=gl).run(f).values[ref],
                                 tmp_path / "one" / f"f_{f:04d}{ext}", gl)
        if ext == ".png":
            assert got.read_bytes() == one.read_bytes()
        else:
            np.testing.assert_array_equal(imageio.read(got), imageio.read(one))
    assert len({file_sha256(Path(i["path"])) for i in res["frames"]}) == len(frames)  # the box moves


def test_the_spec_carries_camera_and_fps_to_the_workers(tmp_path: Path) -> None:
    from tests import gltf_files as gf

    cams = gf.two_cameras(tmp_path / "cams.glb")
    spec = dist.PipeSpec.make("nienhaus_sketchy", scene=str(cams), size="64x48", camera="side")
    eye = np.linalg.inv(spec.open().scene.camera_at(0).view_matrix())[:3, 3]
    np.testing.assert_allclose(eye, [5.0, 0.0, 0.0], atol=1e-6)  # the 'side' camera's node, not 'front' at z = 5
    moving = gf.animated_box(tmp_path / "box.glb")
    plain = dist.PipeSpec.make("nienhaus_sketchy", scene=str(moving), size="64x48").open().scene.animation.fps
    spec = dist.PipeSpec.make("nienhaus_sketchy", scene=str(moving), size="64x48", fps=7.5)
    assert spec.open().scene.animation.fps == 7.5 != plain


@pytest.mark.parametrize("option", [["--png-level", "3"], ["--page", "A4"]])
def test_options_workers_do_not_take_are_refused_before_a_cluster_starts(option: list[str], tmp_path: Path,
                                                                          monkeypatch) -> None:
    monkeypatch.setattr(dist, "connect", lambda *a, **k: pytest.fail("a cluster was started"))
    res = CliRunner().invoke(main, ["run", "nienhaus_sketchy", "--size", "32x32", "--scheduler", "local:1",
                                    "-o", str(tmp_path / "f_####.png"), "--frames", "0:2", *option])
    assert res.exit_code != 0 and f"{option[0]} is not passed to cluster workers" in res.output
    assert len(res.output.strip().splitlines()) == 1


@pytest.mark.slow  # a Dask cluster
def test_camera_and_fps_reach_the_workers(cluster, tmp_path: Path) -> None:
    from tests import gltf_files as gf

    client, root = cluster
    moving = gf.animated_box(tmp_path / "box.glb")
    args = ["--size", "48x32", "--fps", "6", "--frames", "0:3", "--no-cache", "-q"]
    res = CliRunner().invoke(main, ["run", "nienhaus_sketchy", "--scene", str(moving), *args,
                                    "-o", str(tmp_path / "serial" / "f_####.png")])
    assert res.exit_code == 0, res.output
    spec = dist.PipeSpec.make("nienhaus_sketchy", scene=str(moving), size="48x32", fps=6.0)
    dist.render_frames(client, spec, [0, 1, 2], tmp_path / "cluster" / "f_####.png", cache_root=False)
    same_files(tmp_path / "serial", tmp_path / "cluster", [0, 1, 2])
    other = dist.PipeSpec.make("nienhaus_sketchy", scene=str(moving), size="48x32")  # the file's own rate
    dist.render_frames(client, other, [2], tmp_path / "own" / "f_####.png", cache_root=False)
    assert (tmp_path / "own" / "f_0002.png").read_bytes() != (tmp_path / "serial" / "f_0002.png").read_bytes()
