"""Curvature: per-vertex principal curvatures and directions (libigl) with defined fallbacks."""
