"""Headless GL backend choice (egl, then osmesa, clear error) and rgb_array rendering."""

from __future__ import annotations

import numpy as np
import pytest

from racer.shared.sim.scene.gl import GLBackendError, ensure_gl_backend, probe_backend


def test_explicit_backend_is_honoured():
    environ = {"MUJOCO_GL": "osmesa"}
    assert ensure_gl_backend(environ, imported_modules=(), probe=lambda b: "must not be called") == "osmesa"


def test_egl_first_then_osmesa():
    tried = []

    def probe(backend):
        tried.append(backend)
        return "EGL: no display" if backend == "egl" else None

    environ: dict[str, str] = {}
    assert ensure_gl_backend(environ, imported_modules=(), probe=probe) == "osmesa"
    assert tried == ["egl", "osmesa"] and environ["MUJOCO_GL"] == "osmesa"
    environ = {}
    assert ensure_gl_backend(environ, imported_modules=(), probe=lambda b: None) == "egl"


def test_clear_error_when_nothing_works():
    with pytest.raises(GLBackendError, match=r"MUJOCO_GL=egl: no EGL.*MUJOCO_GL=osmesa: no OSMesa"):
        ensure_gl_backend({}, imported_modules=(), probe=lambda b: f"no {'EGL' if b == 'egl' else 'OSMesa'}")
    with pytest.raises(GLBackendError, match="imported before MUJOCO_GL"):
        ensure_gl_backend({}, imported_modules=("mujoco",), probe=lambda b: None)


def test_this_machine_has_a_working_headless_backend():
    results = {backend: probe_backend(backend) for backend in ("egl", "osmesa")}
    assert any(problem is None for problem in results.values()), results


def test_rgb_array_render(make_env):
    from racer.shared.sim.config import EnvConfig
    from racer.shared.sim.env import DeepRacerEnv

    env = DeepRacerEnv(EnvConfig(), render_mode="rgb_array")
    try:
        obs, _ = env.reset(seed=0)
        frame = env.render()
        assert frame.shape == (120, 160, 3) and frame.dtype == np.uint8
        gray = (0.2989 * frame[..., 0] + 0.5870 * frame[..., 1] + 0.1140 * frame[..., 2]).astype(np.uint8)
        np.testing.assert_array_equal(gray, obs["FRONT_FACING_CAMERA"][..., 0])
    finally:
        env.close()


def test_full_resolution_path_gives_a_similar_picture():
    """DeepRacer's 640x480 + bilinear resize and the direct 160x120 render show the same scene."""
    from racer.shared.sim.config import EnvConfig
    from racer.shared.sim.env import DeepRacerEnv

    images = []
    for full in (False, True):
        env = DeepRacerEnv(EnvConfig(render_full_resolution=full))
        try:
            obs, _ = env.reset(seed=0)
            images.append(obs["FRONT_FACING_CAMERA"][..., 0].astype(np.int32))
        finally:
            env.close()
    direct, resized = images
    assert direct.shape == resized.shape == (120, 160)
    assert np.abs(direct - resized).mean() < 6.0
    assert not np.array_equal(direct, resized)


def test_camera_renderer_matches_mujoco_renderer():
    """The lean renderer draws exactly what `mujoco.Renderer` draws for the same camera (without the
    anti-aliasing of the direct frame, which `test_camera_look.py` compares with the full-resolution path)."""
    from racer.shared.sim.config import EnvConfig
    from racer.shared.sim.env import DeepRacerEnv
    from racer.shared.sim.scene._mujoco import mujoco
    from racer.shared.sim.sensors.camera import CameraRenderer

    env = DeepRacerEnv(EnvConfig())
    reference = mujoco.Renderer(env.model, height=120, width=160)
    plain = CameraRenderer(env.model, antialias=False)
    try:
        env.reset(seed=0)
        for action in (2, 7, 9):
            env.step(action)
            reference.update_scene(env.data, "front_camera")
            np.testing.assert_array_equal(plain.rgb(env.data, "front_camera"), reference.render())
    finally:
        plain.close()
        reference.close()
        env.close()
