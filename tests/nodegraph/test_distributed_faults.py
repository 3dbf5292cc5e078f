"""Issue 34, the Dask part: a worker of more than one thread is refused before anything renders (a real
`dask worker --nthreads 2`), a cluster that lost its only worker fails within the stated time with one line,
and malformed `--scheduler` addresses (or a refused connection) fail with one line before anything connects.

The real clusters are `dask scheduler` / `dask worker` processes on 127.0.0.1 (free ports), each in its own
process group, killed by the test that started them."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("distributed")

from nodegraph import distributed as dist  # noqa: E402
from nodegraph.errors import SketchgraphError  # noqa: E402
from tests.nodegraph.faultkit import ROOT, assert_one_line_error, cli, cli_subprocess  # noqa: E402

DASK = Path(sys.executable).with_name("dask")
START_TIMEOUT = 90.0  # a scheduler or worker process must be up within this (setup, not a speed check)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def deadline(seconds: float, what: str) -> Iterator[None]:
    """Fail (instead of hanging the suite) if the block runs past `seconds`."""

    def expired(signum: int, frame: object) -> None:
        raise AssertionError(f"{what}: still running after {seconds:g} s")

    old = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


class DaskCluster:
    """A `dask scheduler` on 127.0.0.1 and the `dask worker` processes added to it."""

    def __init__(self, tmp: Path) -> None:
        if not DASK.exists():
            pytest.skip(f"no dask command beside {sys.executable}")
        self.tmp = tmp
        self.cache = tmp / "cache"
        self.port = free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        self.procs: list[subprocess.Popen] = []
        self.env = {**os.environ, "SKETCHGRAPH_CACHE_DIR": str(self.cache), "LP_NUM_THREADS": "1",
                    "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
        self.env.pop("SKETCHGRAPH_DEBUG", None)
        self.scheduler = self._start("scheduler", ["scheduler", "--host", "127.0.0.1", "--port", str(self.port),
                                                   "--no-dashboard"])
        end = time.monotonic() + START_TIMEOUT
        while True:
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
                break
            except OSError:
                if self.scheduler.poll() is not None or time.monotonic() > end:
                    self.close()
                    pytest.fail(f"dask scheduler did not start: {self.log('scheduler')[-2000:]}")
                time.sleep(0.2)

    def _start(self, name: str, args: list[str]) -> subprocess.Popen:
        log = open(self.tmp / f"{name}.log", "ab")  # noqa: SIM115 - closed with the process
        proc = subprocess.Popen([str(DASK), *args], cwd=ROOT, env=self.env, stdout=log, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, start_new_session=True)
        log.close()
        self.procs.append(proc)
        return proc

    def log(self, name: str) -> str:
        p = self.tmp / f"{name}.log"
        return p.read_text(errors="replace") if p.exists() else ""

    def add_worker(self, nthreads: int, name: str = "worker") -> subprocess.Popen:
        """A `dask worker --nthreads N` (with its nanny), registered with the scheduler when this returns."""
        before = set(self.threads())
        proc = self._start(name, ["worker", self.address, "--nthreads", str(nthreads), "--nworkers", "1",
                                  "--host", "127.0.0.1", "--no-dashboard", "--name", name])
        end = time.monotonic() + START_TIMEOUT
        while not set(self.threads()) - before:
            if proc.poll() is not None or time.monotonic() > end:
                pytest.fail(f"dask worker did not register: {self.log(name)[-2000:]}")
            time.sleep(0.3)
        return proc

    def threads(self) -> dict[str, int]:
        from distributed import Client

        with Client(self.address, timeout="20s") as c:
            return c.nthreads()

    @staticmethod
    def kill(proc: subprocess.Popen) -> None:
        """SIGKILL the process and everything it started (the nanny and its worker)."""
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=30)

    def close(self) -> None:
        for proc in reversed(self.procs):
            if proc.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGTERM)
                try:
                    proc.wait(timeout=15)
                except subprocess.TimeoutExpired:
                    self.kill(proc)


@pytest.fixture
def dask_cluster(tmp_path: Path) -> Iterator[DaskCluster]:
    c = DaskCluster(tmp_path)
    try:
        yield c
    finally:
        c.close()


def run_args(scheduler: str, out: Path, frames: str = "0:2") -> list[str]:
    return ["run", "nienhaus_sketchy", "--size", "32x32", "--frames", frames, "-o", str(out / "f_####.png"),
            "--scheduler", scheduler]


def pngs(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.glob("*.png")) if folder.exists() else []


# -- one thread per worker -------------------------------------------------------------------------------
THREADS_RULE = "has 2 threads; sketchgraph needs --nthreads 1 per worker (one GL context each)"


def test_worker_threads_reads_the_current_worker_api() -> None:
    """`Worker.nthreads` is gone from distributed; the thread count is `Worker.state.nthreads` (read on a real
    in-process worker of two threads), and a cluster with such a worker is refused before any task."""
    from distributed import Client, LocalCluster, Worker

    assert not hasattr(Worker, "nthreads")  # what the old check read, silently defaulting to 1
    # in-process (inproc:// transport: nothing listens on a network)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        seen = client.run(lambda dask_worker: dist.worker_threads(dask_worker))
        assert list(seen.values()) == [2]
        addr = client.scheduler.address
        with pytest.raises(SketchgraphError) as err, dist.connect(client):
            pass
        assert str(err.value) == f"{addr}: worker {next(iter(seen))} {THREADS_RULE}"
        # a worker of 2+ threads that joins after the check: its task refuses before it touches GL
        spec = dist.PipeSpec.make("nienhaus_sketchy", size="32x32")
        res = client.submit(dist.render_frames_task, spec, [0], "/nonexistent/f_####.png", False, False,
                            pure=False).result(timeout=60)
        assert isinstance(res.get("error"), dist.TaskFailure) and THREADS_RULE in res["error"].message


@pytest.mark.slow
class _LostResult:
    """A future that finished, whose result lived on a worker lost before it was gathered: its result() waits
    for a rerun that no worker will make (every call times out)."""

    status = "pending"

    def __init__(self) -> None:
        self.waits = 0

    def result(self, timeout: float | None = None) -> object:
        assert timeout is not None, "an unbounded wait would hang"
        self.waits += 1
        raise TimeoutError


class _NoWorkers:
    def __init__(self, after: int) -> None:
        self.checks, self.after = 0, after

    def check(self) -> None:
        self.checks += 1
        if self.checks >= self.after:
            raise SketchgraphError("tcp://127.0.0.1:1: no live workers for 3 s (all lost, or none joined)")


def test_a_result_lost_with_its_worker_fails_by_the_watch() -> None:
    """The race the cluster test below can hit: the only worker dies after its task finished and before the
    client gathered the result. The wait is cut into WATCH_INTERVAL pieces, the watch checked between them."""
    fut, watch = _LostResult(), _NoWorkers(after=3)
    with pytest.raises(SketchgraphError, match="no live workers"):
        dist.watched_result(fut, watch)
    assert fut.waits == 3 and watch.checks == 3
    fut.status = "error"  # a task that raised TimeoutError itself: its error, not a wait
    with pytest.raises(TimeoutError):
        dist.watched_result(fut, _NoWorkers(after=1))


def test_a_real_two_thread_worker_is_refused_before_rendering(dask_cluster: DaskCluster, tmp_path: Path) -> None:
    c = dask_cluster
    c.add_worker(nthreads=2)
    (waddr,) = c.threads()
    out = cli_subprocess(*run_args(c.address, tmp_path / "x", "0:20"), timeout=180, env=c.env)
    assert_one_line_error(out, f"error: {c.address}: worker {waddr} {THREADS_RULE}")
    assert pngs(tmp_path / "x") == []
    # on the worker itself (as a worker that joined after the client's check would): refused before any GL
    from distributed import Client

    with Client(c.address, timeout="20s") as client:
        spec = dist.PipeSpec.make("nienhaus_sketchy", size="32x32")
        res = client.submit(dist.render_frames_task, spec, [0, 1], str(tmp_path / "y" / "f_####.png"), True, False,
                            pure=False).result(timeout=120)
    assert res["error"].message == f"{c.address}: worker {waddr} {THREADS_RULE}"
    assert pngs(tmp_path / "y") == []
    assert "signal 11" not in c.log("worker")  # no worker died on two threads sharing a context


# -- a cluster without live workers ----------------------------------------------------------------------
@pytest.mark.slow
def test_losing_the_only_worker_fails_within_the_stated_time(dask_cluster: DaskCluster, tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    from distributed import Client

    c = dask_cluster
    worker = c.add_worker(nthreads=1)
    serial = cli("run", "nienhaus_sketchy", "--size", "32x32", "--frames", "0:4", "-o",
                 str(tmp_path / "serial" / "f_####.png"), "--no-cache", "-q")
    if serial.code != 0 and "OpenGL" in serial.stderr:
        pytest.skip(f"no OpenGL: {serial.stderr.strip()}")
    assert serial.code == 0, serial.stderr
    monkeypatch.setattr(dist, "NO_WORKERS_TIMEOUT", 3.0)
    monkeypatch.setattr(dist, "WATCH_INTERVAL", 0.2)
    spec = dist.PipeSpec.make("nienhaus_sketchy", size="32x32")
    with deadline(240, "the run after its only worker died"), dist.connect(c.address, cache_root=c.cache) as client:
        # a one-thread worker renders the same bytes as a serial run
        dist.render_frames(client, spec, range(4), tmp_path / "tcp" / "f_####.png", chunk=1, cache_root=c.cache)
        for f in range(4):
            name = f"f_{f:04d}.png"
            assert (tmp_path / "tcp" / name).read_bytes() == (tmp_path / "serial" / name).read_bytes(), name
        run = dist.FrameRun(client, spec, range(200), tmp_path / "long" / "f_####.png", chunk=2, cache_root=False)
        got: list[int] = []
        with pytest.raises(SketchgraphError) as err:
            for frame, _path in run:
                if not got:
                    c.kill(worker)  # the worker and its nanny: nothing restarts it
                got.append(frame)
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith(f"{c.address}: no live workers for 3 s"), msg
    assert f"frames not rendered (--resume goes on); start workers with `dask worker {c.address} --nthreads 1`" in msg
    assert 0 < len(got) < 200
    with Client(c.address, timeout="20s") as client:
        assert client.nthreads() == {}


@pytest.mark.slow
def test_a_cluster_without_workers_fails_through_the_cli(dask_cluster: DaskCluster, tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(dist, "NO_WORKERS_TIMEOUT", 2.0)
    monkeypatch.setattr(dist, "WATCH_INTERVAL", 0.2)
    with deadline(120, "a run on a cluster without workers"):
        out = cli(*run_args(dask_cluster.address, tmp_path / "x"), "-q")
    assert_one_line_error(out, f"error: {dask_cluster.address}: no live workers for 2 s", "2 of 2 frames not rendered")
    assert pngs(tmp_path / "x") == []


# -- --scheduler addresses -------------------------------------------------------------------------------
MALFORMED = {
    "": "empty address",
    "   ": "empty address",
    "\t\n": "empty address",
    "tcp://": "no host and port",
    "tcp://host": "no port",
    "tcp://host:": "no port",
    "tcp://:8786": "no host",
    "tcp://host:0": "port '0' is not a number from 1 to 65535",
    "tcp://host:99999": "port '99999' is not a number from 1 to 65535",
    "tcp://host:abc": "port 'abc' is not a number from 1 to 65535",
    "tcp://host:-1": "port '-1' is not a number from 1 to 65535",
    "tcp://ho st:8786": "whitespace or control characters",
    "tcp://host:87\t86": "whitespace or control characters",
    "tcp://host:8786/path": "unexpected '/'",
    "tcp://a..b:8786": "'a..b' is not a host name or address",
    "tcp://::1:8786": "an IPv6 host goes in brackets",
    "tcp://[::1:8786": "closing ']'",
    "local:0": "N must be a whole number from 1 to 256",
    "local:-1": "N must be a whole number from 1 to 256",
    "local:x": "N must be a whole number from 1 to 256",
    "local:257": "N must be a whole number from 1 to 256",
    "local:": "N must be a whole number from 1 to 256",
    "udp://h:1": "unsupported scheme 'udp'",
    "inproc://h:1": "unsupported scheme 'inproc'",
    "127.0.0.1:8786": "no scheme (did you mean tcp://127.0.0.1:8786?)",
    "tcp://" + "a" * 5000 + ":8786": "address too long (5011 characters, at most 300)",
    "local:" + "9" * 400: "address too long",
    "x" * 100_000: "address too long (100000 characters, at most 300)",
}


@pytest.fixture
def no_client(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if anything tries to connect: the address must be refused before."""
    import distributed

    def refuse(*a: object, **k: object) -> None:
        raise AssertionError("distributed.Client was called for an address that should have been refused")

    monkeypatch.setattr(distributed, "Client", refuse)
    monkeypatch.setattr(distributed, "LocalCluster", refuse)


@pytest.mark.parametrize("address", list(MALFORMED), ids=lambda a: repr(a[:24]))
def test_malformed_scheduler_addresses_are_one_line(address: str, tmp_path: Path, no_client: None) -> None:
    out = cli(*run_args(address, tmp_path / "x"))
    line = assert_one_line_error(out, "--scheduler", MALFORMED[address],
                                 "expected local:N (N from 1 to 256), tcp://HOST:PORT or tls://HOST:PORT")
    assert len(line) < 400  # a long address is shown cut
    assert pngs(tmp_path / "x") == []


@pytest.mark.slow  # 3.5 s: a CLI process
def test_a_malformed_address_is_one_line_from_a_real_process(tmp_path: Path) -> None:
    out = cli_subprocess(*run_args("tcp://host:99999", tmp_path / "x"), timeout=120)
    assert_one_line_error(out, "--scheduler 'tcp://host:99999': port '99999' is not a number from 1 to 65535")


def test_a_refused_connection_fails_at_once_naming_the_address(tmp_path: Path, no_client: None) -> None:
    port = free_port()  # bound, then released: nothing listens there
    out = cli(*run_args(f"tcp://127.0.0.1:{port}", tmp_path / "x"))
    assert_one_line_error(out, f"--scheduler tcp://127.0.0.1:{port}: connection refused (no scheduler listens "
                               f"there); start one with `dask scheduler --host 127.0.0.1 --port {port}`")


def test_well_formed_addresses_parse() -> None:
    cases = {"local:1": "local:1", "local:256": "local:256", " tcp://127.0.0.1:8786\n": "tcp://127.0.0.1:8786",
             "TCP://sched.example.org:1": "tcp://sched.example.org:1", "tls://[::1]:65535": "tls://[::1]:65535",
             "tcp://worker_3:8786": "tcp://worker_3:8786"}
    for text, want in cases.items():
        assert dist.parse_scheduler(text).address == want
    assert dist.parse_scheduler("tcp://h:9").port == 9 and dist.parse_scheduler("local:3").workers == 3
