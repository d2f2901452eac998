"""The scene and its rendering: the MJCF of a route in a world, the worlds' looks, the headless GL backend."""
