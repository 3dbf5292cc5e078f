"""particle_sketch: Curtis' loose and sketchy particle drawing from a depth map (seed 004).

The float64 CPU core (filters, force field, particle system, SVG, measures) is in `core`; the node
class that wraps it comes with the engine. `python -m nodes.particle_sketch.bench` measures it.
"""
