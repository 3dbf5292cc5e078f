"""Every benchmark and measurement: `sketchgraph bench` and its named benchmarks (`pipeline` holds the
registry of names), accuracy and stability sweeps, the charts, the ground truth they measure against, and
what they share (`measure`). Commands that print figures and write JSON; never timed tests."""
