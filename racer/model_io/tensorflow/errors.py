"""Errors of the TensorFlow conversions, importable without torch or TensorFlow (the CLI catches them)."""


class UnsupportedGraphError(ValueError):
    """A DeepRacer graph holds something racer's networks cannot represent; the message says exactly what."""
