"""Where it is drawn: the GL context and its pools (`gl`), the GLSL loader and the engine's shaders (`glsl`,
`shaders/`), footprints and sampling helpers. Imports the core leaves and the scene wing only."""
