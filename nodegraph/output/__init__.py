"""What leaves: image files (`imageio`), values written as files (`write`), films and frame sequences
(`film`, `frames_manifest`), strokes as SVG or pixels (`strokes`). Imports the core leaves and the scene and
gpu wings only."""
