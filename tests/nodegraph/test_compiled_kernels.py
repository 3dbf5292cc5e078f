"""`fsio.compiled`: the Numba kernels are optional. Where one cannot be imported the caller's NumPy or Python code
runs silently; where Numba finds no writable folder for its cache (importing the kernel raises RuntimeError) the
same fallback runs and one warning says so, naming what runs instead, for each of the four compiled kernels."""

from __future__ import annotations

import importlib
import importlib.abc
import sys
import warnings

import pytest

from nodegraph import fsio


class _Refuse(importlib.abc.MetaPathFinder):
    """Importing `name` raises what Numba raises where it cannot cache compiled code."""

    def __init__(self, name: str) -> None:
        self.name = name

    def find_spec(self, fullname, path, target=None):  # noqa: ANN001
        if fullname == self.name:
            raise RuntimeError(f"cannot cache function 'kernel': no locator available for file '{fullname}'")
        return None


def _refuse(monkeypatch: pytest.MonkeyPatch, name: str) -> None:
    package, _, leaf = name.rpartition(".")
    monkeypatch.delitem(sys.modules, name, raising=False)
    monkeypatch.delattr(importlib.import_module(package), leaf, raising=False)
    monkeypatch.setattr(sys, "meta_path", [_Refuse(name), *sys.meta_path])
    monkeypatch.setattr(fsio, "_COMPILED_WARNED", set())


def test_compiled_by_hand(tmp_path, monkeypatch):
    pkg = tmp_path / "kernels_pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "ok.py").write_text("VALUE = 3\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # neither a present nor a missing module says anything
        assert fsio.compiled("kernels_pkg", "ok", "x is", "y").VALUE == 3
        assert fsio.compiled("kernels_pkg", "missing", "x is", "y") is None
    _refuse(monkeypatch, "kernels_pkg.ok")
    with pytest.warns(RuntimeWarning, match=r"^the kernel is unavailable \(cannot cache.*\); running the slow "
                                            r"loop\. Set NUMBA_CACHE_DIR to a writable folder\.$"):
        assert fsio.compiled("kernels_pkg", "ok", "the kernel is", "the slow loop") is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once per module
        assert fsio.compiled("kernels_pkg", "ok", "the kernel is", "the slow loop") is None


@pytest.mark.parametrize("module, attr, kernel, says", [
    ("nodegraph_nodes.stroke_hatching", "_JIT", "nodegraph_nodes.stroke_hatching.jit", "the Python loop"),
    ("nodegraph_nodes.particle_sketch.core", None, "nodegraph_nodes.particle_sketch.jit", "the NumPy engine"),
    ("nodegraph_nodes.mesh_lines.intersect", "_JIT", "nodegraph_nodes.mesh_lines.intersect_jit", "the NumPy search"),
    ("nodegraph.scene.posing", "_JIT", "nodegraph.scene.posing_jit", "the NumPy skinning"),
])
def test_every_kernel_warns_once_where_numba_cannot_cache(monkeypatch, module, attr, kernel, says):
    caller = importlib.import_module(module)
    if attr is not None:
        monkeypatch.setattr(caller, attr, None)  # not looked up yet
    _refuse(monkeypatch, kernel)
    with pytest.warns(RuntimeWarning, match=f"unavailable .*; running {says}"):
        assert caller._jit() is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert caller._jit() is None
