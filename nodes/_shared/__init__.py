"""Helpers that several built-in nodes share (never a node itself: it defines no `NODE`).

A node imports `nodegraph` and this package only, never a sibling node (docs: DESIGN.md, layout rule 3).
"""
