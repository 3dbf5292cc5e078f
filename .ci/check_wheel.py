"""CI: build the wheel from the repository's files, check that it holds everything it must, then install it
into a fresh virtual environment (dependencies from requirements.lock) and render the default pipeline by
name from an empty folder.

    .venv/bin/python .ci/check_wheel.py [--keep DIR]

Exit status 1 naming every problem (a file that should be in the wheel and is not, a generic top-level
module, a failed render). Needs the setuptools that requirements.lock pins (the build runs without
isolation, so it uses the interpreter running this script).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# repository folder -> where its files land in the wheel (setup.py's package_dir)
MAPPED = {"nodegraph": "nodegraph", "nodes": "nodegraph_nodes", "pipelines": "nodegraph_pipelines"}
GENERIC = ("nodes", "pipelines", "tests", "gallery", "docs")  # must never be top-level names in site-packages


def repo_files() -> list[str]:
    """Tracked and untracked-but-not-ignored files, as CI's clean clone has them."""
    out = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=ROOT, check=True,
                         capture_output=True).stdout.decode()
    return sorted(f for f in out.split("\0") if f and (ROOT / f).is_file())


def expected(files: list[str]) -> dict[str, str]:
    """Repository file -> its path in the wheel, for every file that must ship."""
    want: dict[str, str] = {}
    for f in files:
        top, _, rest = f.partition("/")
        if top not in MAPPED or "__pycache__" in f:
            continue
        p = Path(f)
        if (top == "pipelines"  # every file: pipelines, scenes and whatever the scenes name
                or p.suffix in (".py", ".glsl") or p.name == "py.typed"
                or f.startswith("nodegraph/tools/serve/static/")):  # the page of `sketchgraph serve`
            want[f] = f"{MAPPED[top]}/{rest}"
    return want


def build_wheel(files: list[str], work: Path) -> Path:
    """Copy the repository's files to `work/src` (so no stale build/ folder leaks into the wheel) and build."""
    src = work / "src"
    for f in files:
        (src / f).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / f, src / f)
    dist = work / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                    str(dist), str(src)], check=True)
    wheels = sorted(dist.glob("sketchgraph-*.whl"))
    if len(wheels) != 1:
        raise SystemExit(f"check_wheel: expected one wheel in {dist}, found {[w.name for w in wheels]}")
    return wheels[0]


def check_contents(wheel: Path, files: list[str]) -> list[str]:
    names = set(zipfile.ZipFile(wheel).namelist())
    problems = [f"{f} is not in the wheel (expected at {w})" for f, w in expected(files).items() if w not in names]
    dist_info = next((n.split("/")[0] for n in names if n.split("/")[0].endswith(".dist-info")), None)
    if dist_info is None:
        return [*problems, "the wheel has no .dist-info folder"]
    if "LICENSE" in files and f"{dist_info}/licenses/LICENSE" not in names:
        problems.append(f"LICENSE is not in the wheel (expected at {dist_info}/licenses/LICENSE)")
    tops = {n.split("/")[0] for n in names}
    problems += [f"the wheel has a generic top-level '{t}/' (site-packages would get a module '{t}')"
                 for t in GENERIC if t in tops]
    meta = zipfile.ZipFile(wheel).read(f"{dist_info}/METADATA").decode()
    if "License-Expression: MIT" not in meta:
        problems.append("METADATA has no 'License-Expression: MIT'")
    eps = zipfile.ZipFile(wheel).read(f"{dist_info}/entry_points.txt").decode()
    for needle in ("sketchgraph = nodegraph.cli:main", "builtin = nodegraph_nodes:register"):
        if needle not in eps:
            problems.append(f"entry_points.txt lacks '{needle}'")
    return problems


def run(cmd: list[str], cwd: Path, env: dict[str, str], timeout: float = 600) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def check_installed(wheel: Path, work: Path) -> list[str]:
    venv = work / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py, sg = venv / "bin" / "python", venv / "bin" / "sketchgraph"
    pip = [str(py), "-m", "pip", "install", "-q", "--disable-pip-version-check"]
    subprocess.run([*pip, "-r", str(ROOT / "requirements.lock")], check=True)
    subprocess.run([*pip, "--no-deps", str(wheel)], check=True)
    empty = work / "empty"
    empty.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["SKETCHGRAPH_CACHE_DIR"] = str(work / "cache")
    problems = []
    r = run([str(py), "-c", "import nodes"], empty, env)
    if r.returncode == 0:
        problems.append("installed: 'import nodes' works: a generic top-level module got installed")
    r = run([str(py), "-c", "import nodegraph, nodegraph_pipelines; print(nodegraph.__file__)"], empty, env)
    if r.returncode != 0 or str(venv) not in r.stdout:
        problems.append(f"installed: nodegraph does not import from the fresh venv: {r.stdout}{r.stderr}".strip())
    r = run([str(sg), "pipelines"], empty, env)
    shipped = sorted(p.stem for p in (ROOT / "pipelines").glob("*.yaml"))
    listed = sorted(line.split()[0] for line in r.stdout.splitlines() if line.strip())
    if r.returncode != 0 or listed != shipped:
        problems.append(f"installed: `sketchgraph pipelines` listed {listed}, expected {shipped} {r.stderr}".strip())
    t0 = time.perf_counter()
    r = run([str(sg), "run", "nienhaus_sketchy", "-o", "x.png"], empty, env)
    seconds = time.perf_counter() - t0
    if r.returncode != 0:
        return [*problems, f"installed: `sketchgraph run nienhaus_sketchy -o x.png` failed: {r.stderr.strip()}"]
    png = empty / "x.png"
    check = ("import sys, numpy as np; from nodegraph.output import imageio; a = imageio.read(sys.argv[1]); "
             "print(a.shape[1], a.shape[0], a.shape[2], float(np.std(a)))")
    r2 = run([str(py), "-c", check, str(png)], empty, env)
    if not png.is_file() or png.read_bytes()[:8] != b"\x89PNG\r\n\x1a\n" or r2.returncode != 0:
        problems.append(f"installed: x.png is missing or not a PNG image {r2.stderr.strip()}")
    else:
        w, h, c, std = r2.stdout.split()
        if (int(w), int(h)) != (800, 800) or float(std) < 0.05:
            problems.append(f"installed: x.png is {w}x{h}x{c} with std {float(std):.3f}: not the 800x800 drawing")
        else:
            print(f"check_wheel: installed wheel rendered x.png ({w}x{h}, std {float(std):.3f}) from an empty "
                  f"folder in {seconds:.1f} s")
    r = run([str(sg), "run", "sketchy_composite", "--size", "64x64", "-o", "c.png", "-q"], empty, env)
    if r.returncode != 0 or not (empty / "c.png").is_file():
        problems.append(f"installed: a shipped pipeline with a scene file (sketchy_composite) failed: "
                        f"{r.stderr.strip()}")
    # tools that read repository files when run from a checkout: shipped pipelines by name, or one line
    r = run([str(sg), "bench", "shower-door", "--frames", "2", "--size", "32x32"], empty, env)
    if r.returncode != 0 or "ratio" not in r.stdout:
        problems.append(f"installed: `bench shower-door` failed: {r.stderr.strip()}")
    for cmd, option in ((["gallery", "verify", "-q"], "--gallery FILE"), (["bench", "accuracy"], "--meshes DIR")):
        r = run([str(sg), *cmd], empty, env)
        err = r.stderr.strip()
        if r.returncode != 2 or "\n" in err or option not in err:
            problems.append(f"installed: `sketchgraph {' '.join(cmd)}` outside a checkout should fail in one line "
                            f"naming {option}; exit {r.returncode}: {err[-300:]}")
    return problems


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--keep", type=Path, help="Work in this folder and keep it (default: a temporary one).")
    ap.add_argument("--contents-only", action="store_true", help="Build and check the wheel; install nothing.")
    args = ap.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="sketchgraph-wheel-") as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        files = repo_files()
        wheel = build_wheel(files, work)
        problems = check_contents(wheel, files)
        n = len(zipfile.ZipFile(wheel).namelist())
        print(f"check_wheel: {wheel.name}: {n} files, {len(expected(files))} repository files expected inside")
        if not problems and not args.contents_only:
            problems = check_installed(wheel, work)
    for p in problems:
        print(f"check_wheel: {p}", file=sys.stderr)
    print(f"check_wheel: {'FAILED' if problems else 'ok'} in {time.perf_counter() - t0:.0f} s")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
