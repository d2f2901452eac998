"""Envs can be created, used, closed and dropped in any order in one process, with EGL and with OSMesa.

Each back end runs in its own Python process: MuJoCo reads MUJOCO_GL once, at import.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

SEQUENCE = r"""
import gc
import numpy as np
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv

def frame(obs):
    return obs["FRONT_FACING_CAMERA"][..., 0].copy()

# The first env is dropped without close() while the second exists.
env = DeepRacerEnv(EnvConfig()); env.reset(seed=1); env.step(0)
env = DeepRacerEnv(EnvConfig()); first, _ = env.reset(seed=1); env.step(1)

# Interleaved envs of different worlds; one closed, one dropped, the survivors keep rendering.
a = DeepRacerEnv(EnvConfig()); b = DeepRacerEnv(EnvConfig(world="wood")); c = DeepRacerEnv(EnvConfig(world="carpet"))
a.reset(seed=2); b.reset(seed=2); c.reset(seed=2)
for action in range(3):
    a.step(action); b.step(action); c.step(action)
a.close(); a.close()
wood_before = frame(b.step(0)[0])
del c; gc.collect()
env.step(2)
b.step(1)

# A replaced env renders exactly what a fresh one renders.
d = DeepRacerEnv(EnvConfig()); again, _ = d.reset(seed=1); del d; gc.collect()
assert np.array_equal(frame(first), frame(again)), "a replaced env renders differently"
for _ in range(5):
    e = DeepRacerEnv(EnvConfig()); e.reset(seed=3); e.step(0)
b.close()
assert frame(env.step(0)[0]).std() > 1.0, "the surviving env renders a blank frame"
assert wood_before.std() > 1.0
print("REPLACEMENT-OK")
# env is left open on purpose: interpreter exit must free it cleanly too.
"""


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["egl", "osmesa"])
def test_envs_can_be_replaced_and_dropped(backend):
    environ = dict(os.environ, MUJOCO_GL=backend)
    environ.pop("PYOPENGL_PLATFORM", None)
    result = subprocess.run(
        [sys.executable, "-c", SEQUENCE], env=environ, capture_output=True, text=True, timeout=600, check=False
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert "REPLACEMENT-OK" in result.stdout
    assert "GLError" not in result.stderr and "Exception ignored" not in result.stderr, result.stderr[-3000:]


def test_close_frees_the_gl_context():
    """close() releases the context at once (not at garbage collection) and the renderer refuses new frames."""
    from racer.shared.sim.config import EnvConfig
    from racer.shared.sim.env import DeepRacerEnv
    from racer.shared.sim.sensors.camera import CameraRenderer

    env = DeepRacerEnv(EnvConfig())
    try:
        env.reset(seed=0)
        renderer = CameraRenderer(env.model)
        finalizer = renderer._release
        assert finalizer.alive
        renderer.close()
        assert not finalizer.alive
        with pytest.raises(RuntimeError, match="closed"):
            renderer.start(env.data, "front_camera")
        env.step(0)  # the env's own renderer is untouched
    finally:
        env.close()
