"""Helpers for the simulator tests."""

from __future__ import annotations

import math

import pytest

from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv

REWARD_RECORDING = """
calls = []

def reward_function(params):
    calls.append(dict(params))
    return 1.0 if params["all_wheels_on_track"] else 0.25
"""


def place_front_at(
    env: DeepRacerEnv, ndist: float, backwards: bool = False, lateral_m: float = 0.0
) -> tuple[float, float]:
    """Teleport the car so its front-of-car point sits on the centre line at `ndist` (optionally shifted left)."""
    x, y, yaw = env.track.pose_at(ndist)
    if lateral_m:
        x -= lateral_m * math.sin(yaw)
        y += lateral_m * math.cos(yaw)
    heading = yaw + math.pi if backwards else yaw
    env.teleport(x - 0.14 * math.cos(heading), y - 0.14 * math.sin(heading), heading)
    return x, y


@pytest.fixture
def recording_reward(tmp_path):
    path = tmp_path / "recording_reward.py"
    path.write_text(REWARD_RECORDING)
    return path


@pytest.fixture
def make_env():
    envs = []

    def factory(**overrides) -> DeepRacerEnv:
        env = DeepRacerEnv(EnvConfig(**overrides), wall_clock=lambda: 1700000000.0)
        envs.append(env)
        return env

    yield factory
    for env in envs:
        env.close()


def place_far_off_track(env: DeepRacerEnv) -> None:
    """Teleport the car well outside the road (beyond the route's bounding box)."""
    corner = env.track.waypoints.reshape(-1, 3, 2).max(axis=(0, 1))
    env.teleport(float(corner[0]) + 2.0, float(corner[1]) + 2.0, 0.0)
