"""The shipped pipelines as package data: this folder installs as `nodegraph_pipelines` (see setup.py), so
`sketchgraph run NAME` finds `NAME.yaml` here after a plain `pip install`. Nothing to import; the engine
reads the files through `importlib.resources` (nodegraph/shipped.py)."""
