"""Latency of `sketchgraph serve` as a user sees it, in a real headless Chromium (Debian's, driven by Playwright).

    sketchgraph bench serve [--size 800x800] [--changes 30] [--param edges.normal_threshold] [--no-prefetch]
                            [--json F] [PIPELINE ...]

For each pipeline (default: nienhaus_sketchy, the design's example, and pencil) a server is started on
127.0.0.1 with a fresh cache folder and the page opened at a size where the final image is shown whole, one
buffer pixel per screen pixel. Figures, each the median and 90th percentile:
- **change**: from the slider's input event in the page to the updated final image drawn (the next animation
  frame after it is on the canvas), one change at a time, waiting for each; alternating values so every change
  recomputes what it reaches.
- **drag**: a drag of `--drag-steps` input events 16 ms apart (a 60 Hz pointer); the latency of its last value,
  and how many renders the server made for the drag (changes coalesce to the latest value).
- **change after a pause**: changes each made 0.2 to 0.45 s after the previous one was drawn, so that many
  arrive while the server's idle prefetch (after 0.2 s of quiet) is running a step; with the server's own
  record of how long a message waited for the step in progress (`prefetch_delays_ms`).
- **view**: from clicking an output port in the graph to its buffer drawn, for every port of the planned nodes:
  the first time and again (the drawn view is kept until the buffer changes). Before each first view the bench
  waits `VIEW_PAUSE_S` (0.5 s), as a user clicks a port seconds after a change, not within milliseconds: the
  server's idle prefetch has by then planned every port, so a first view is one read-back from the GPU and the
  drawing. First views are also reported apart by whether the ordinary run makes the port (`made` in the
  server's state); a view that still had to compute its port (the header's `ran`) is listed in
  `computed_on_view`.
  Each view's parts are kept too (`view_ports_ms`): the server's wait, read-back and drawing (from the image
  header), the rest until the page has the bytes, the page's decoding and drawing, and the wait for the next
  animation frame.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import click
import numpy as np

from ...errors import SketchgraphError
from ...fsio import atomic_write_text

DEFAULT_PIPELINES = ("nienhaus_sketchy", "pencil")
COMPUTES = "(id) => window.sg.state.nodes.find(n => n.id === id).computes"
# a view's parts: the server's wait (request arrived -> drawing starts; it includes computing a port the run did
# not make), read-back, drawing and PNG encoding; the rest until the page received the bytes (the request's way
# there, the send, the transfer); the page's decoding and drawing on the canvas; and the wait for the next
# animation frame (where the picture is on screen)
VIEW_PAUSE_S = 0.5  # before each first view: a user clicks a port well after the change it follows
CHANGE_PAUSES_S = (0.2, 0.45)  # the range of pauses before each "change after a pause"
VIEW_PARTS = ("server_wait", "server_read", "server_draw", "server_encode", "transfer", "page_decode",
              "page_frame")


def _stats(values: list[float]) -> dict[str, Any]:
    a = np.asarray(values, np.float64)
    if a.size == 0:
        return {"n": 0}
    return {"n": int(a.size), "median_ms": round(float(np.median(a)), 2),
            "p90_ms": round(float(np.percentile(a, 90)), 2), "min_ms": round(float(a.min()), 2),
            "max_ms": round(float(a.max()), 2)}


def _start(pipeline: str, size: str, cache: Path, out: Path, prefetch: bool = True) -> tuple[subprocess.Popen, str]:
    root = Path(__file__).resolve().parents[3]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(root), os.environ.get("PYTHONPATH")]))}
    proc = subprocess.Popen([sys.executable, "-m", "nodegraph.cli", "serve", pipeline, "--port", "0", "--size", size,
                             "--cache-dir", str(cache), "--out-dir", str(out),
                             *([] if prefetch else ["--no-prefetch"])], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, env=env, cwd=out)
    line = proc.stdout.readline() if proc.stdout else ""
    m = re.search(r"http://\S+\?token=\S+", line)
    if m is None:
        proc.kill()
        raise SketchgraphError(f"bench serve: the server did not start: {line.strip()}")
    return proc, m.group(0)


def _server_state(url: str) -> dict[str, Any]:
    import urllib.request

    with urllib.request.urlopen(url.replace("/?token=", "/api/state?token="), timeout=30) as r:
        return json.loads(r.read())


def bench_one(browser: Any, pipeline: str, size: str, changes: int, drag_steps: int, param: str,
              values: tuple[float, float], prefetch: bool = True) -> dict[str, Any]:
    node, _, name = param.partition(".")
    w, h = (int(v) for v in size.lower().split("x"))
    with tempfile.TemporaryDirectory(prefix="bench-serve-") as tmp:
        proc, url = _start(pipeline, size, Path(tmp) / "cache", Path(tmp), prefetch)
        try:
            page = browser.new_page(viewport={"width": w + 1000, "height": h + 260}, device_scale_factor=1)
            page.goto(url)
            page.wait_for_function("window.sg && window.sg.lastImage && window.sg.state && !window.sg.state.error",
                                   timeout=120000)
            final = page.evaluate("Object.values(window.sg.state.outputs)[0]")
            shown = page.evaluate("[window.sg.lastImage.width, window.sg.lastImage.height]")
            page.click(f'[data-node="{node}"] .type')
            slider = page.locator(f'input[type=range][data-param="{name}"]')
            slider.wait_for(timeout=10000)
            # one change at a time
            for i in range(changes + 2):
                seq = page.evaluate("window.sg.seq") + 1
                slider.fill(str(values[i % 2]))
                page.wait_for_function(f"window.sg.lastImage.seq >= {seq}", timeout=60000)
            timings = page.evaluate("window.sg.timings.map(t => t.ms)")[2:]  # the first two warm up
            # changes after a pause: many of them arrive during a prefetch step
            page.evaluate("window.sg.timings = []")
            lo_p, hi_p = CHANGE_PAUSES_S
            for i in range(changes):
                page.wait_for_timeout(1000 * (lo_p + (hi_p - lo_p) * i / max(1, changes - 1)))
                seq = page.evaluate("window.sg.seq") + 1
                slider.fill(str(values[i % 2]))
                page.wait_for_function(f"window.sg.lastImage.seq >= {seq}", timeout=60000)
            paused = page.evaluate("window.sg.timings.map(t => t.ms)")
            delays = _server_state(url)["prefetch"]["delays_ms"]
            # drags: input events 16 ms apart, then the last value's latency
            drags, renders = [], []
            for d in range(max(1, changes // 6)):
                before = page.evaluate(COMPUTES, node)
                page.evaluate("window.sg.timings = []")
                lo, hi = values
                steps = [lo + (hi - lo) * k / max(1, drag_steps - 1) for k in range(drag_steps)]
                if d % 2:
                    steps.reverse()
                for v in steps:
                    slider.fill(f"{v:.4f}")
                    page.wait_for_timeout(16)
                seq = page.evaluate("window.sg.seq")
                page.wait_for_function(f"window.sg.lastImage.seq >= {seq} && window.sg.state.seq >= {seq}",
                                       timeout=60000)
                last = page.evaluate(f"window.sg.timings.filter(t => t.seq === {seq}).map(t => t.ms)")
                drags += last
                renders.append(page.evaluate(COMPUTES, node)
                               - before)
            # buffer views: every port the run produced, clicked in the graph
            ports = page.eval_on_selector_all("[data-port]", "els => els.map(e => e.dataset.port)")
            state = page.evaluate("window.sg.state")
            planned = {n["id"] for n in state["nodes"] if n["status"] not in ("not planned", "not run")}
            ports = [p for p in ports if p.split(".")[0] in planned]
            made = set(state.get("made", []))
            first, again, parts = [], [], {"first": [], "again": []}
            per_port: dict[str, list[list[float]]] = {}
            computed: set[str] = set()  # ports the ordinary run does not make: computed on their first look
            for rnd, part in ((first, parts["first"]), (again, parts["again"])):
                for port in ports:
                    if rnd is first:
                        page.wait_for_timeout(1000 * VIEW_PAUSE_S)
                    t = page.evaluate("""async (port) => {
                        const t0 = performance.now();
                        window.sgView(port);
                        return await new Promise((ok) => { const poll = () => {
                          const li = window.sg.lastImage;
                          if (li && li.port === port && li.at > t0) ok(li.empty ? null : [li.at - t0,
                            li.wait_ms, li.read_ms, li.draw_ms, li.encode_ms,
                            li.recv - t0 - li.wait_ms - li.read_ms - li.draw_ms - li.encode_ms,
                            li.shown - li.recv, li.at - li.shown, li.ran]);
                          else if (performance.now() - t0 > 20000) ok(null); else setTimeout(poll, 1); };
                          poll(); });
                    }""", port)
                    if t is not None:  # ports that are not pictures (a scene, strokes as text) are left out
                        rnd.append(t[0])
                        part.append(t[1:-1])
                        per_port.setdefault(port, []).append([round(v, 2) for v in t[:-1]])
                        if t[-1]:
                            computed.add(port)
            run_ms = state["run_ms"]
            pre = _server_state(url)["prefetch"]
            page.close()
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
    return {"pipeline": pipeline, "prefetch": prefetch, "size": size, "final": final, "shown": shown, "param": param,
            "values": list(values), "change": _stats(timings), "drag": {**_stats(drags), "steps": drag_steps,
                                                                         "renders": renders},
            "view_first": _stats(first), "view_again": _stats(again), "ports": len(first),
            "change_after_pause": _stats(paused), "prefetch_delays_ms": _stats(delays),
            "prefetch_steps_ms": _stats(pre["steps_ms"]),
            "memory_mb": {"ordinary_run": round(pre["memory_run_bytes"] / 2**20, 1),
                          "all_ports": round(pre["memory_bytes"] / 2**20, 1)},
            "view_pause_s": VIEW_PAUSE_S,
            "view_first_made": _stats([per_port[p][0][0] for p in per_port if p in made]),
            "view_first_not_made": _stats([per_port[p][0][0] for p in per_port if p not in made]),
            "computed_on_view": sorted(computed),
            "view_parts_median_ms": {rnd: {k: round(float(np.median([p[i] for p in got])), 2) if got else None
                                           for i, k in enumerate(VIEW_PARTS)}
                                     for rnd, got in parts.items()},
            "view_ports_ms": {"columns": ["total", *VIEW_PARTS], "first_then_again": per_port},
            "last_run_ms": run_ms}


def run(pipelines: list[str], size: str, changes: int, drag_steps: int, param: str,
        values: tuple[float, float], prefetch: bool = True) -> dict[str, Any]:
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        raise SketchgraphError("bench serve needs chromium (Debian: apt-get install chromium)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        raise SketchgraphError("bench serve needs playwright: pip install playwright") from None
    out: dict[str, Any] = {"benchmark": "serve", "chromium": chromium, "results": []}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, headless=True, args=["--no-sandbox"])
        try:
            for pipe in pipelines:
                out["results"].append(bench_one(browser, pipe, size, changes, drag_steps, param, values, prefetch))
        finally:
            browser.close()
    return out


def _ms(stats: dict[str, Any], key: str) -> float:
    return float(stats.get(key, float("nan")))


def report(data: dict[str, Any]) -> str:
    lines = []
    for r in data["results"]:
        c, d, f, a = r["change"], r["drag"], r["view_first"], r["view_again"]
        lines.append(f"{r['pipeline']} {r['size']} ({r['final']} shown at {r['shown'][0]}x{r['shown'][1]}), "
                     f"{r['param']}{'' if r.get('prefetch', True) else ', no prefetch'}:")
        lines.append(f"  change -> final image drawn: median {_ms(c, 'median_ms'):.1f} ms, "
                     f"p90 {_ms(c, 'p90_ms'):.1f} ms ({c['n']} changes)")
        lines.append(f"  end of a {d['steps']}-step drag -> drawn: median {_ms(d, 'median_ms'):.1f} ms, "
                     f"p90 {_ms(d, 'p90_ms'):.1f} ms; renders per drag {d['renders']}")
        lines.append(f"  buffer view ({r['ports']} ports): first median {_ms(f, 'median_ms'):.1f} ms, p90 "
                     f"{_ms(f, 'p90_ms'):.1f} ms; again median {_ms(a, 'median_ms'):.1f} ms, "
                     f"p90 {_ms(a, 'p90_ms'):.1f} ms")
        m, k = r["view_first_made"], r["view_first_not_made"]
        how = ", prefetched" if r.get("prefetch", True) else ""
        lines.append(f"  first view of a port the run made ({m['n']}): median {_ms(m, 'median_ms'):.1f} ms; of one "
                     f"it does not make ({k['n']}{how}): median {_ms(k, 'median_ms'):.1f} ms; computed on "
                     f"view: {r['computed_on_view'] or 'none'}")
        q, dl, st = r["change_after_pause"], r["prefetch_delays_ms"], r["prefetch_steps_ms"]
        lines.append(f"  change after a pause: median {_ms(q, 'median_ms'):.1f} ms, p90 {_ms(q, 'p90_ms'):.1f} ms; "
                     f"messages that waited for a prefetch step ({dl['n']}): median {_ms(dl, 'median_ms'):.1f} ms, "
                     f"max {_ms(dl, 'max_ms'):.1f} ms; prefetch steps: median {_ms(st, 'median_ms'):.1f} ms, "
                     f"max {_ms(st, 'max_ms'):.1f} ms; GPU memory held: {r['memory_mb']['ordinary_run']} MB after a "
                     f"change, {r['memory_mb']['all_ports']} MB with every port")
        lines.append(f"  a view's parts (medians, ms): {r['view_parts_median_ms']}")
    return "\n".join(lines)


@click.command(help="Latency of `sketchgraph serve` in headless Chromium: a parameter change to the final image "
                    "drawn, the end of a drag, and a buffer view (median and p90).")
@click.argument("pipelines", nargs=-1)
@click.option("--size", default="800x800", show_default=True, help="WxH of the pipelines.")
@click.option("--changes", default=30, show_default=True, help="Single changes measured per pipeline.")
@click.option("--drag-steps", default=30, show_default=True, help="Input events per drag (16 ms apart).")
@click.option("--param", default="edges.normal_threshold", show_default=True, help="NODE.PARAM the slider moves.")
@click.option("--values", default=(0.3, 0.6), nargs=2, type=float, show_default=True,
              help="The two values changes alternate between (a drag goes from one to the other).")
@click.option("--no-prefetch", is_flag=True, help="Serve with `--no-prefetch` (for comparison).")
@click.option("--json", "json_path", type=click.Path(path_type=Path), help="Write the figures as JSON.")
def command(pipelines: tuple[str, ...], size: str, changes: int, drag_steps: int, param: str,
            values: tuple[float, float], no_prefetch: bool, json_path: Path | None) -> None:
    t0 = time.perf_counter()
    data = run(list(pipelines) or list(DEFAULT_PIPELINES), size, changes, drag_steps, param, values, not no_prefetch)
    data["wall_s"] = round(time.perf_counter() - t0, 1)
    click.echo(report(data))
    text = json.dumps(data, indent=2)
    click.echo(text)
    if json_path is not None:
        atomic_write_text(json_path, text + "\n")


if __name__ == "__main__":  # pragma: no cover
    command()
