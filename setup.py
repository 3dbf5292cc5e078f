"""Package layout only (metadata lives in pyproject.toml): the repository's `nodes/` folder installs as the
`nodegraph_nodes` package, so site-packages gets no generic top-level `nodes` module, and `pipelines/` (with
`pipelines/scenes/`) installs as the data package `nodegraph_pipelines`, so shipped pipelines run by name."""

from setuptools import find_packages, setup

builtin = ["nodegraph_nodes" + p[len("nodes"):] for p in find_packages(include=["nodes", "nodes.*"])]
setup(
    packages=find_packages(include=["nodegraph", "nodegraph.*"]) + builtin + ["nodegraph_pipelines"],
    package_dir={"nodegraph_nodes": "nodes", "nodegraph_pipelines": "pipelines"},
)
