"""Help text a user reads: node and parameter docs name papers by title, enumerated parameters list their
values, `bench --help` lists every benchmark with its options, and long renders report progress on a terminal
only (never with -q, never into a pipe or a log)."""

from __future__ import annotations

import re
import typing

from click.testing import CliRunner

from nodegraph import registry
from nodegraph.cli import _choices, _node_info, main
from nodegraph.tools.bench import pipeline as benchmod

SEED_NUMBERS = re.compile(r"\bseeds?[ _/]?0\d\d|\bthe seed's\b|\bseed (page|document)", re.IGNORECASE)


def test_node_docs_name_papers_not_seed_files():
    bad = []
    for name, cls in registry.default().items():
        info = _node_info(cls)
        texts = [info["doc"]] + [p["description"] for p in info["params"].values()]
        texts += [d["doc"] for kind in ("inputs", "outputs") for d in info[kind].values()]
        bad += [f"{name}: {m.group(0)!r}" for t in texts for m in [SEED_NUMBERS.search(t or "")] if m]
    assert not bad, "docs name a seed file instead of the paper: " + "; ".join(bad)


def test_enumerated_params_list_their_values():
    out = CliRunner().invoke(main, ["nodes", "edge_detect"]).output
    assert 'operator = "four_neighbour"  ["four_neighbour" | "sobel"]' in out
    assert 'mode = "normal_depth"  ["normal_depth" | "normal" | "depth"]' in out
    listed = 0
    for _, cls in registry.default().items():
        for fname, f in cls.Params.model_fields.items():
            if typing.get_origin(f.annotation) is typing.Literal:
                assert _node_info(cls)["params"][fname]["values"] == list(typing.get_args(f.annotation))
                listed += 1
    assert listed >= 5


def test_choices_of_mixed_annotations():
    assert _choices(typing.Literal["a", "b"] | None) == ["a", "b", None]
    assert _choices(int | typing.Literal["pipeline"] | None) == []  # open-ended: a number too
    assert _choices(float) == []


def test_bench_help_lists_every_benchmark_with_its_options():
    out = CliRunner().invoke(main, ["bench", "--help"]).output
    for name in benchmod.NAMED:
        line = next((ln for ln in out.splitlines() if ln.startswith(f"  {name}: ")), None)
        assert line is not None, f"bench --help does not list {name}"
        assert len(line) > len(f"  {name}: ") + 10, f"{name} has no help line"
    assert "  PIPELINE: Frames back to back" in out
    assert out.count("--json PATH") >= 10  # each benchmark's options, not just the dispatcher's
    assert "--help  Show this message" not in out


def test_progress_reaches_every_computed_node(gl, tmp_path):
    from nodegraph import pipeline as pl
    from nodegraph.executor import Executor, on_compute

    pipe = pl.load("nienhaus_sketchy", size=(48, 40))
    seen: list[tuple[str, str]] = []
    ex = Executor(pipe, None, gl=gl)
    try:
        with on_compute(lambda nid, t: seen.append((nid, t))):
            result = ex.run(0)
        assert [n for n, _ in seen] == result.computed()
        assert all(t == pipe.nodes[n].type_name for n, t in seen)
        seen.clear()
        ex.run(0)  # outside the block: nothing is told
    finally:
        ex.close()
    assert seen == []


def test_no_progress_line_into_a_pipe(tmp_path):
    """CliRunner's stderr is not a terminal: the run prints its result line and no carriage-return updates."""
    res = CliRunner().invoke(main, ["run", "nienhaus_sketchy", "--size", "48x40", "--no-cache",
                                    "-o", str(tmp_path / "a.png")])
    assert res.exit_code == 0, res.output
    assert "\r" not in res.output and "node/s" not in res.output
