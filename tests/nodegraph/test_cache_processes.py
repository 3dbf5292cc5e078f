"""The disk cache under faults made real, with `sketchgraph run` in subprocesses: cache writes that fail (a
file where the folder should be, a read-only mount, a full disk, a file-size limit, permission denied) cost
one warning and never the image; SIGKILL at random points and in the middle of cache writes leaves no entry
that fails validation and no damaged earlier output; several processes sharing one cache (pruning it) give
byte-identical images. Randomness is seeded; counts are small so the whole file takes well under a minute.

With SKETCHGRAPH_FAULT_REPORT=FILE set, the kill and concurrency tests write what happened there (JSON), for
docs/reliability.md."""

from __future__ import annotations

import contextlib
import json
import os
import random
import resource
import signal
import subprocess
import sys
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import pytest

from nodegraph import pipeline as pl
from nodegraph.cache import Cache
from nodegraph.executor import Executor
from tests.helpers import ROOT

pytestmark = [pytest.mark.skipif(sys.platform != "linux", reason="faults are made with Linux mounts and rlimits"),
              pytest.mark.slow]  # about a minute: every test runs the CLI as processes

PENCIL = ROOT / "pipelines" / "pencil.yaml"  # EXR textures, an R8 texture array and curvature arrays (npz)
CONTOURS = ROOT / "pipelines" / "pencil_contours.yaml"  # EXR textures only: the quickest shipped pipeline
SIZE = 64


def _cmd() -> list[str]:
    script = Path(sys.executable).parent / "sketchgraph"
    return [str(script)] if script.exists() else [sys.executable, "-c", "from nodegraph.cli import main; main()"]


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("SKETCHGRAPH_CACHE_DIR", "SKETCHGRAPH_CACHE_LIMIT")}
    env["MESA_SHADER_CACHE_DISABLE"] = "true"  # the only file writes are the cache's and the image
    return env


def _args(pipeline: Path, out: Path, cache: Path | None, size: int = SIZE, extra: tuple[str, ...] = ()) -> list[str]:
    args = [*_cmd(), "run", str(pipeline), "--size", f"{size}x{size}", "-o", str(out), "-q", *extra]
    return [*args, "--cache-dir", str(cache)] if cache is not None else [*args, "--no-cache"]


def _run(pipeline: Path, out: Path, cache: Path | None, size: int = SIZE, extra: tuple[str, ...] = (),
         env: dict[str, str] | None = None, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(_args(pipeline, out, cache, size, extra), capture_output=True, text=True, timeout=120,
                          env=env or _env(), **kw)


def _warnings(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("warning:")]


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """Each pipeline's image from a run without any cache."""
    d = tmp_path_factory.mktemp("reference")
    refs = {}
    for p in (PENCIL, CONTOURS):
        r = _run(p, d / f"{p.stem}.png", None)
        assert r.returncode == 0, r.stderr
        refs[p.stem] = (d / f"{p.stem}.png").read_bytes()
    return refs


def _bad_entries(root: Path, pipeline: Path, sizes: list[int]) -> tuple[list[str], int]:
    """Entries that are not an output of `pipeline` at one of `sizes`, or that fail validation (loading one with
    what the plan expects, as a run would). Returns (problems, entries checked)."""
    planned: dict[tuple[str, str], tuple[Executor, str, str]] = {}
    for size in sizes:
        ex = Executor(pl.load(str(pipeline), size=(size, size)), None)
        keys = ex.keys()
        for nid in ex.plan.order:
            for port in ex.pipeline.nodes[nid].outputs:
                planned[(keys[nid], ex._entry(nid, port))] = (ex, nid, port)
    from nodegraph.gpu import gl as glmod

    cache = Cache(root, renderer=glmod.get().renderer)  # the runs' entries live in this renderer's namespace
    problems = []
    # node entries only: the mesh store's files (`meshes/`, nodegraph/scene/meshstore.py) are not outputs
    entries = [e for e in cache.entries() if e.path.parent != cache.mesh_store]
    for e in entries:
        key, rest = e.path.name.split(".", 1)
        name = rest.rsplit(".", 1)[0]
        if (key, name) not in planned:
            problems.append(f"{e.path.name}: no planned output has this name")
            continue
        ex, nid, port = planned[(key, name)]
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            loaded = cache.load(key, name, f"node '{nid}' port '{port}'", ex._expect(nid, port))
        if loaded is None or rec:
            problems.append("; ".join(str(w.message) for w in rec) or f"{e.path.name}: gone")
    return problems, len(entries)


def _report(section: str, data: dict) -> None:
    target = os.environ.get("SKETCHGRAPH_FAULT_REPORT")
    if not target:
        return
    path = Path(target)
    report = json.loads(path.read_text()) if path.exists() else {}
    report[section] = data
    path.write_text(json.dumps(report, indent=2))


# -- failed writes -------------------------------------------------------------------------------------------
@contextlib.contextmanager
def _mount(target: Path, *args: str) -> Iterator[None]:
    target.mkdir(parents=True, exist_ok=True)
    r = subprocess.run(["mount", *args, str(target)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount here ({r.stderr.strip() or 'mount failed'}; needs root in a mount namespace)")
    try:
        yield
    finally:
        subprocess.run(["umount", "-l", str(target)], capture_output=True)


def _without_dac_override() -> None:
    """In the child, before exec: drop root's power to ignore permission bits (CAP_DAC_OVERRIDE and
    CAP_DAC_READ_SEARCH leave the bounding set, so the program runs as root that obeys chmod)."""
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    for cap in (1, 2):  # CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH
        if libc.prctl(24, cap, 0, 0, 0) != 0:  # PR_CAPBSET_DROP
            raise OSError(ctypes.get_errno(), "prctl(PR_CAPBSET_DROP) failed")


FAULTS = ["cache path is a file", "cache folder inside a file", "read-only mount", "disk full",
          "file-size limit", "permission denied"]


@pytest.mark.parametrize("fault", FAULTS)
def test_a_failing_cache_costs_one_warning_never_the_image(tmp_path: Path, reference, fault):
    out = tmp_path / "out" / "image.png"
    env = _env()
    kw: dict = {}
    cache = tmp_path / "cache"
    with contextlib.ExitStack() as stack:
        if fault == "cache path is a file":
            cache.write_text("not a folder")
        elif fault == "cache folder inside a file":
            (tmp_path / "file").write_text("not a folder")
            cache = tmp_path / "file" / "cache"
        elif fault == "read-only mount":  # root ignores permission bits, not a read-only mount
            (tmp_path / "src").mkdir()
            stack.enter_context(_mount(cache, "--bind", str(tmp_path / "src")))
            if subprocess.run(["mount", "-o", "remount,ro,bind", str(cache)], capture_output=True).returncode:
                pytest.skip("cannot remount read-only here")
        elif fault == "disk full":
            stack.enter_context(_mount(cache, "-t", "tmpfs", "-o", "size=16k", "tmpfs"))  # room for a few small entries
        elif fault == "file-size limit":
            def limit() -> None:
                signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # write() fails with EFBIG instead of a signal
                resource.setrlimit(resource.RLIMIT_FSIZE, (8192, 8192))  # the 64x64 PNG is about 4.4 KB
            kw["preexec_fn"] = limit
        elif fault == "permission denied":
            if os.geteuid() == 0:  # root passes permission checks unless it gives up CAP_DAC_OVERRIDE
                probe = subprocess.run(["true"], preexec_fn=_without_dac_override, capture_output=True)
                if probe.returncode != 0:
                    pytest.skip("cannot drop CAP_DAC_OVERRIDE here, and root ignores permission bits")
                kw["preexec_fn"] = _without_dac_override
            cache.mkdir()
            cache.chmod(0o555)
        r = _run(CONTOURS, out, cache, env=env, **kw)
        assert r.returncode == 0, r.stderr
        warned = _warnings(r.stderr)
        assert len(warned) == 1 and "cannot write to the disk cache" in warned[0] and "still produced" in warned[0], \
            r.stderr
        assert out.read_bytes() == reference[CONTOURS.stem]
        if cache.is_dir():  # what did get written (a full disk, a size limit) is whole
            problems, _ = _bad_entries(cache, CONTOURS, [SIZE])
            assert problems == []
            assert Cache(cache).temp_files() == []


def test_a_frame_loop_whose_background_writes_fail_warns_once(tmp_path: Path):
    (tmp_path / "file").write_text("not a folder")
    r = _run(PENCIL, tmp_path / "f_####.png", tmp_path / "file", extra=("--frames", "0:3"))
    assert r.returncode == 0, r.stderr
    warned = _warnings(r.stderr)
    assert len(warned) == 1 and "cannot write to the disk cache" in warned[0], r.stderr
    assert "Traceback" not in r.stderr
    assert sorted(p.name for p in tmp_path.glob("f_*.png")) == ["f_0000.png", "f_0001.png", "f_0002.png"]


# -- SIGKILL ---------------------------------------------------------------------------------------------------
def _temps(root: Path) -> list[str]:
    """Temporary files in the entry folders, in any renderer's namespace (root/renderer-*/xx/.tmp-*)."""
    return [p.name for p in [*root.glob("*/.tmp-*"), *root.glob("renderer-*/*/.tmp-*")]]


def _kill_when(proc: subprocess.Popen, root: Path, delay: float | None, rng: random.Random) -> str:
    """SIGKILL `proc` after `delay` seconds, or (None) as soon as a cache write is under way (a temporary file
    exists) plus up to 2 ms. Returns where it was killed: 'write', 'running', or 'finished' (it was done)."""
    t0 = time.perf_counter()
    where = "running"
    while proc.poll() is None:
        if delay is not None:
            if time.perf_counter() - t0 >= delay:
                break
            time.sleep(0.002)
        elif _temps(root):
            time.sleep(rng.uniform(0.0, 0.002))
            where = "write"
            break
    if proc.poll() is not None:
        return "finished"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    return where


def test_sigkill_during_renders_and_cache_writes_leaves_a_cache_that_serves_only_good_entries(tmp_path, reference):
    rng = random.Random(20250)
    cache, out = tmp_path / "cache", tmp_path / "out"
    out.mkdir()
    earlier = out / "earlier.png"
    earlier.write_bytes(reference[PENCIL.stem])  # an output of an earlier run: no kill may damage it
    t0 = time.perf_counter()
    r = _run(PENCIL, out / "cold.png", tmp_path / "cold-cache")
    cold = time.perf_counter() - t0
    assert r.returncode == 0 and (out / "cold.png").read_bytes() == reference[PENCIL.stem]
    # each killed run at its own size, so every one computes and writes all its entries into the shared cache;
    # the first at the reference size, so the clean run below starts from what the kills left
    plan = [(SIZE + 8 * i, None if i % 2 else rng.uniform(0.05, 1.1 * cold)) for i in range(10)]
    kills = []
    for i, (size, delay) in enumerate(plan):
        proc = subprocess.Popen(_args(PENCIL, out / f"killed_{i}.png", cache, size), env=_env(),
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        where = _kill_when(proc, cache, delay, rng)
        if proc.stderr is not None:
            proc.stderr.close()
        kills.append({"size": size, "delay_s": None if delay is None else round(delay, 3), "killed": where,
                      "temp_files_left": len(_temps(cache)), "entries": len(Cache(cache).entries())})
    sizes = [s for s, _ in plan]
    problems, checked = _bad_entries(cache, PENCIL, sizes)
    assert problems == []
    left = Cache(cache).info()
    assert left["temp_files"] == len(_temps(cache))  # killed writers' temporary files count toward the size
    r = _run(PENCIL, out / "clean.png", cache)
    assert r.returncode == 0 and _warnings(r.stderr) == [], r.stderr
    assert (out / "clean.png").read_bytes() == reference[PENCIL.stem]
    assert earlier.read_bytes() == reference[PENCIL.stem]
    pr = subprocess.run([*_cmd(), "cache", "prune", "--cache-dir", str(cache)], capture_output=True, text=True,
                        env=_env(), timeout=60)
    assert pr.returncode == 0, pr.stderr
    assert _temps(cache) == []  # every writer is dead: all its temporary files go
    outcomes = {w: sum(1 for k in kills if k["killed"] == w) for w in ("write", "running", "finished")}
    assert outcomes["write"] >= 2 and outcomes["running"] >= 2, kills  # the kills did land where they should
    _report("sigkill", {"cold_run_s": round(cold, 2), "kills": kills, "outcomes": outcomes,
                        "entries_checked": checked, "bad_entries": len(problems),
                        "temp_files_before_prune": left["temp_files"], "clean_run_identical": True})


# -- concurrency ------------------------------------------------------------------------------------------------
def test_processes_sharing_one_pruned_cache_give_identical_images(tmp_path: Path, reference):
    cache, out = tmp_path / "cache", tmp_path / "out"
    out.mkdir()
    assert _run(CONTOURS, out / "first.png", tmp_path / "sizer").returncode == 0
    full = Cache(tmp_path / "sizer").info()["bytes"]
    env = _env()
    env["SKETCHGRAPH_CACHE_LIMIT"] = str(full // 2)  # every run prunes what others may be about to read
    rounds = []
    t0 = time.perf_counter()
    for rnd in range(3):
        procs = [subprocess.Popen(_args(CONTOURS, out / f"r{rnd}_p{i}.png", cache), env=env, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True) for i in range(4)]
        results = [(p.wait(timeout=120), *p.communicate()) for p in procs]
        for rc, _, err in results:
            assert rc == 0 and _warnings(err) == [], err
        rounds.append(Cache(cache).info()["bytes"])
    wall = time.perf_counter() - t0
    images = sorted(out.glob("r*_p*.png"))
    assert len(images) == 12 and all(p.read_bytes() == reference[CONTOURS.stem] for p in images)
    problems, checked = _bad_entries(cache, CONTOURS, [SIZE])
    assert problems == [] and Cache(cache).temp_files() == []
    assert max(rounds) <= full // 2
    _report("concurrency", {"processes": 4, "runs_each": 3, "limit_bytes": full // 2, "full_cache_bytes": full,
                            "bytes_after_each_round": rounds, "identical_images": len(images),
                            "entries_checked": checked, "wall_s": round(wall, 1)})
