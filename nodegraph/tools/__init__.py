"""Tools built on the library face: explain, inspect, diff, viz, watch, wedge, benchmarks, accuracy,
stability, charts and the gallery. The CLI calls them; nothing in the engine imports them."""
