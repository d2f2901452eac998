"""What the camera sees: DeepRacer's colours, the anti-aliased default frame, domain randomisation."""

from __future__ import annotations

import numpy as np
import pytest

from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.sensors.camera import rgb_to_y

COLOUR_TOLERANCE = 12
"""Per channel, 0-255: rendered colour against the colour DeepRacer's Gazebo frames show."""
GAZEBO_RENDERED = {
    "road": (36, 52, 68),
    "edge line": (229, 230, 225),
    "centre line": (236, 143, 2),
    "field": (100, 143, 110),
}
"""Mean colours in `frames/gazebo_reinvent_episode` (classified by hue, 92 frames)."""
GAZEBO_WALL_RANGE = ((10, 20, 25), (50, 90, 105))
"""Walls there range from (16, 26, 32) (facing away from the sun) to (37, 63, 76) (facing it)."""


@pytest.fixture(scope="module")
def reinvent_route(deepracer_data):
    return deepracer_data / "routes" / "reinvent_base.npy"


def _frame(env: DeepRacerEnv, ndist: float, lateral_m: float = 0.0) -> np.ndarray:
    x, y, yaw = env.track.pose_at(ndist, "center")
    env.teleport(x - lateral_m * np.sin(yaw), y + lateral_m * np.cos(yaw), yaw)
    env._camera.start(env.data, "front_camera")
    return env._camera.finish().copy()


def _median_rgb(frame: np.ndarray, rows: slice, columns: slice) -> np.ndarray:
    return np.median(frame[rows, columns].reshape(-1, 3), axis=0)


def test_base_world_colours_match_deepracer(reinvent_route):
    """At the start of re:Invent 2018 on the centre line: road, lines, field and walls where they must be."""
    env = DeepRacerEnv(EnvConfig(track=reinvent_route))
    try:
        env.reset(seed=0)
        frame = _frame(env, 0.0)
        # Locate each surface by its colour class, then compare its median colour with DeepRacer's.
        r, g, b = (frame[..., i].astype(int) for i in range(3))
        classes = {
            "road": (b > r + 15) & (b > g + 5) & (r < 70),
            "edge line": (r > 170) & (g > 170) & (b > 170),
            "centre line": (r > 150) & (b < 60),
            "field": (g > r + 20) & (g > b + 10),
        }
        for name, mask in classes.items():
            assert mask.sum() >= 30, f"{name}: only {mask.sum()} pixels of its colour in the frame"
            median = np.median(frame[mask], axis=0)
            assert np.all(np.abs(median - GAZEBO_RENDERED[name]) <= COLOUR_TOLERANCE), (name, median)
        # Lower middle: road; bottom centre: a dash of the centre line; the walls fill the top rows.
        assert np.all(np.abs(_median_rgb(frame, slice(100, 120), slice(20, 50)) - GAZEBO_RENDERED["road"]) <= 12)
        walls = frame[:12].reshape(-1, 3)
        low, high = GAZEBO_WALL_RANGE
        assert np.all(np.median(walls, axis=0) >= low) and np.all(np.median(walls, axis=0) <= high)
    finally:
        env.close()


@pytest.mark.parametrize("world", ["carpet", "concrete", "wood"])
def test_other_worlds_floor_is_their_surface(reinvent_route, world):
    """carpet / concrete / wood: road and field are one surface (the SimApp's road_* mesh lies off the field)."""
    from racer.shared.sim.scene.world_look import get_look

    env = DeepRacerEnv(EnvConfig(track=reinvent_route, world=world))
    try:
        env.reset(seed=0)
        frame = _frame(env, 0.0)
        road = _median_rgb(frame, slice(100, 120), slice(20, 50))
        assert np.all(np.abs(road - get_look(world).road_rgb) <= 15), (world, road)
    finally:
        env.close()


def test_default_frame_matches_the_full_resolution_path(reinvent_route):
    """Direct 160x120 vs DeepRacer's 640x480 + bilinear resize, 16 poses around the lap: within 1.1 grey levels
    mean absolute difference (the bench measures 0.98 over 40 poses; goal 1.0)."""
    frames = {}
    for full in (False, True):
        env = DeepRacerEnv(EnvConfig(track=reinvent_route, render_full_resolution=full))
        try:
            env.reset(seed=0)
            frames[full] = np.stack([rgb_to_y(_frame(env, i / 16)) for i in range(16)]).astype(int)
        finally:
            env.close()
    difference = np.abs(frames[False] - frames[True]).mean()
    assert difference <= 1.1, difference
    assert not np.array_equal(frames[False], frames[True])


def _light_state(env: DeepRacerEnv) -> np.ndarray:
    m = env.model
    return np.concatenate([m.light_diffuse.ravel(), m.light_attenuation.ravel()])


def test_domain_randomization_changes_lights_per_episode_and_repeats_under_a_seed(reinvent_route):
    env = DeepRacerEnv(EnvConfig(track=reinvent_route, domain_randomization=True))
    other = DeepRacerEnv(EnvConfig(track=reinvent_route, domain_randomization=True))
    try:
        first, _ = env.reset(seed=5)
        lights = [_light_state(env)]
        env.reset()
        lights.append(_light_state(env))
        assert not np.allclose(lights[0], lights[1])
        assert np.all(env.model.light_diffuse <= 0.57 + 1e-9) and np.all(env.model.light_attenuation <= 1.0)
        again, _ = other.reset(seed=5)
        assert np.allclose(_light_state(other), lights[0])
        np.testing.assert_array_equal(first["FRONT_FACING_CAMERA"], again["FRONT_FACING_CAMERA"])
        other.reset()
        assert np.allclose(_light_state(other), lights[1])
        # The picture changes with the light.
        means = []
        for _ in range(4):
            obs, _ = env.reset()
            means.append(obs["FRONT_FACING_CAMERA"].mean())
        assert np.ptp(means) > 3.0, means
    finally:
        env.close()
        other.close()


def test_randomization_is_off_by_default(reinvent_route):
    env = DeepRacerEnv(EnvConfig(track=reinvent_route))
    try:
        env.reset(seed=1)
        before = _light_state(env).copy()
        cameras = env.model.cam_pos.copy()
        for seed in (2, 3):
            env.reset(seed=seed)
            np.testing.assert_array_equal(_light_state(env), before)
            np.testing.assert_array_equal(env.model.cam_pos, cameras)
    finally:
        env.close()


def test_car_randomization_tints_blurs_and_moves_the_camera(reinvent_route):
    plain = DeepRacerEnv(EnvConfig(track=reinvent_route))
    car = DeepRacerEnv(EnvConfig(track=reinvent_route, car_randomization=True))
    try:
        reference, _ = plain.reset(seed=3)
        observed, _ = car.reset(seed=3)
        assert not np.allclose(car.model.cam_pos, plain.model.cam_pos)
        assert not np.allclose(car.model.mat_rgba, plain.model.mat_rgba)
        assert np.abs(observed["FRONT_FACING_CAMERA"].astype(int) - reference["FRONT_FACING_CAMERA"]).mean() > 1.0
        effects = car._randomizer.effects
        car.reset(seed=3)
        assert car._randomizer.effects == effects
    finally:
        plain.close()
        car.close()


def test_track_plot_rendered_top_view(tmp_path):
    """`racer track plot NAME OUT --rendered base`: racer's own track in DeepRacer's look, seen from above."""
    from click.testing import CliRunner
    from PIL import Image

    from racer.track.cli import plot_command

    out = tmp_path / "oval.png"
    result = CliRunner().invoke(plot_command, ["racer_oval", str(out), "--rendered", "base"])
    assert result.exit_code == 0, result.output
    image = np.asarray(Image.open(out).convert("RGB")).reshape(-1, 3).astype(int)
    assert image.shape[0] == 640 * 480
    r, g, b = image.T
    road = (b > r + 15) & (b > g + 5) & (r < 70)
    field = (g > r + 20) & (g > b + 10)
    white = (r > 170) & (g > 170) & (b > 170)
    assert road.mean() > 0.05 and field.mean() > 0.2 and white.mean() > 0.005
