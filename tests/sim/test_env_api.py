"""Gymnasium contract: registration, check_env, spaces, actions, determinism."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from racer.shared.deepracer.model_metadata import load_model_metadata
from racer.shared.deepracer.simtrace import SIMTRACE_COLUMNS
from racer.shared.sim import ENV_ID
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv


def test_registered_env_passes_check_env_without_warnings():
    env = gym.make(ENV_ID, wall_clock=lambda: 0.0, render_mode="rgb_array")
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env.unwrapped)
        assert [str(w.message) for w in caught] == []
        assert isinstance(env.unwrapped, DeepRacerEnv)
    finally:
        env.close()


def test_continuous_env_passes_check_env_and_scales_actions(deepracer_data):
    metadata = load_model_metadata(
        deepracer_data / "config" / "dpr401_model_metadata_front_shallow_continuous_ppo.json"
    )
    env = DeepRacerEnv(EnvConfig(model_metadata=metadata), wall_clock=lambda: 0.0)
    try:
        check_env(env, skip_render_check=True)
        assert env.action_space == gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        space = metadata.continuous_action_space
        env.reset(seed=0)
        *_, info = env.step(np.array([1.0, -1.0], dtype=np.float32))
        row = info["simtrace"]
        assert row["steer"] == pytest.approx(space.steering_angle_high_deg)
        assert row["throttle"] == pytest.approx(space.speed_low_mps)
        assert row["action"] == "[{} {}]".format(row["steer"], row["throttle"])  # as the SimApp formats it
        *_, info = env.step(np.array([-5.0, 7.0], dtype=np.float32))  # clipped to [-1, 1] first
        assert info["params"]["steering_angle"] == pytest.approx(space.steering_angle_low_deg)
        assert info["params"]["speed"] == pytest.approx(space.speed_high_mps)
    finally:
        env.close()


def test_discrete_action_space_matches_metadata(deepracer_data, make_env):
    metadata = load_model_metadata(deepracer_data / "config" / "console2022_model_metadata.json")
    env = make_env(model_metadata=metadata)
    assert env.action_space == gym.spaces.Discrete(len(metadata.discrete_actions))
    env.reset(seed=0)
    env.step(0)
    *_, info = env.step(len(metadata.discrete_actions) - 1)
    last = metadata.discrete_actions[-1]
    assert info["params"]["speed"] == last.speed_mps and info["params"]["steering_angle"] == last.steering_angle_deg
    with pytest.raises(ValueError, match="outside"):
        env.step(len(metadata.discrete_actions))


def test_simtrace_row_has_the_19_columns_with_deepracer_types(make_env):
    env = make_env()
    env.reset(seed=0)
    for _ in range(3):
        *_, info = env.step(2)
    row = info["simtrace"]
    assert tuple(row) == SIMTRACE_COLUMNS and len(row) == 19
    assert isinstance(row["steps"], float) and isinstance(row["episode"], int) and isinstance(row["action"], int)
    assert isinstance(row["done"], bool) and isinstance(row["all_wheels_on_track"], bool)
    assert row["track_len"] == env.track.length_m
    assert row["tstamp"] == pytest.approx(3 / 15.0, abs=1e-9)  # stamped after the third step's physics
    assert row["wall_clock"] == 1700000000.0
    assert info["episode_status"] == row["episode_status"] == "in_progress"


def test_same_seed_same_observations_and_rewards(tmp_path):
    reward = tmp_path / "reward.py"
    reward.write_text("def reward_function(params):\n    return params['distance_from_center'] + params['progress']\n")
    rng = np.random.default_rng(5)
    actions = rng.integers(10, size=60)
    runs = []
    for _ in range(2):
        env = DeepRacerEnv(EnvConfig(reward_function_path=reward, model_metadata=_lidar_metadata()))
        try:
            obs, _ = env.reset(seed=42)
            frames, rewards = [obs], []
            for action in actions:
                obs, r, terminated, truncated, _ = env.step(int(action))
                frames.append(obs)
                rewards.append(r)
                if terminated or truncated:
                    obs, _ = env.reset()
                    frames.append(obs)
            runs.append((frames, rewards))
        finally:
            env.close()
    (frames_a, rewards_a), (frames_b, rewards_b) = runs
    assert rewards_a == rewards_b and len(set(rewards_a)) > 5
    assert len(frames_a) == len(frames_b)
    for a, b in zip(frames_a, frames_b, strict=True):
        assert a.keys() == b.keys()
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    assert any(not np.array_equal(frames_a[0]["FRONT_FACING_CAMERA"], f["FRONT_FACING_CAMERA"]) for f in frames_a[1:])


def _lidar_metadata():
    from racer.shared.deepracer.model_metadata import parse_model_metadata

    return parse_model_metadata(
        {
            "action_space": [{"steering_angle": s, "speed": v} for v in (1.0, 2.0) for s in (-30, -15, 0, 15, 30)],
            "sensor": ["FRONT_FACING_CAMERA", "LIDAR"],
            "version": "5",
        }
    )


def test_bad_config_values_are_rejected():
    with pytest.raises(ValueError, match="world"):
        EnvConfig(world="moon")
    with pytest.raises(ValueError, match="round_robin_advance_dist"):
        EnvConfig(round_robin_advance_dist=1.5)
    with pytest.raises(ValueError, match="number_of_resets"):
        EnvConfig(number_of_resets=-1)


def test_unknown_reset_option_is_rejected(make_env):
    env = make_env()
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(options={"evaluaton": True})
