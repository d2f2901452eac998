"""The `mujoco` module, imported only after the headless GL backend has been chosen (see `gl.py`)."""

from racer.shared.sim.scene.gl import ensure_gl_backend

ensure_gl_backend()

import mujoco  # noqa: E402  (must follow the backend choice)

__all__ = ["mujoco"]
