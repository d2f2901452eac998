"""The objects_* reward params in real scenes, checked against values worked out by hand from the route file, and
DeepRacer's own object-avoidance / head-to-head sample reward function run unmodified on them."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from racer.shared.sim.objects.challenge import ChallengeConfig, ObjectPosition
from racer.shared.sim.reward.function import load_reward_function
from racer.shared.sim.tracks.track import Track

from .conftest import place_front_at

STRAIGHT = 2
DPR401 = "reward_functions/dpr401_object_avoidance_head_to_head.py"


def _lane_point(waypoints: np.ndarray, dist_m: float, left_m: float) -> np.ndarray:
    """The hand calculation: the centre-line point `dist_m` along the route (linear interpolation of its rows),
    moved `left_m` to the left of that segment's direction."""
    line = waypoints[:, 0:2]
    seg = np.hypot(*np.diff(line, axis=0).T)
    i = int(np.searchsorted(np.cumsum(seg), dist_m))
    f = (dist_m - seg[:i].sum()) / seg[i]
    direction = (line[i + 1] - line[i]) / seg[i]
    return line[i] + f * (line[i + 1] - line[i]) + left_m * np.array([-direction[1], direction[0]])


@pytest.fixture
def oa_reward(tmp_path, deepracer_data):
    path = tmp_path / "reward_function.py"
    shutil.copyfile(deepracer_data / DPR401, path)  # a copy in the test's own folder, byte for byte
    return path


def test_object_params_and_the_dpr401_reward_match_a_hand_calculation(make_env, oa_reward):
    """racer_oval (counter-clockwise): a box on the inner lane 3 % of the lap from the line, one on the outer lane at
    half the lap; the car's front 0.5 % of the lap from the line, 0.2 m left of the centre line (the inner lane's side)."""
    challenge = ChallengeConfig(
        race_type="OBJECT_AVOIDANCE", object_positions=(ObjectPosition(0.03, 1), ObjectPosition(0.5, -1))
    )
    env = make_env(challenge=challenge, reward_function_path=oa_reward)
    env.reset(seed=0)
    env.step(STRAIGHT)
    length_m = env.track.length_m
    waypoints = env.track.waypoints
    place_front_at(env, 0.005, lateral_m=0.2)
    _, reward, *_, info = env.step(STRAIGHT)
    params = info["params"]

    width_m = 2 * 0.5349  # racer_oval: borders 0.5349 m either side of the centre line (its rows)
    inner0 = _lane_point(waypoints, 0.03 * length_m, width_m / 4)  # lane = half-way between centre and border
    outer1 = _lane_point(waypoints, 0.5 * length_m, -width_m / 4)
    assert np.allclose(params["objects_location"], [inner0, outer1], atol=0.005)
    assert params["objects_distance"] == pytest.approx([0.03 * length_m, 0.5 * length_m], abs=0.005)
    assert params["objects_distance_from_center"] == pytest.approx([width_m / 4, width_m / 4], abs=0.005)
    assert params["objects_left_of_center"] == [True, False]  # inner = left when driving counter-clockwise
    assert params["closest_objects"] == [1, 0]  # behind: the far box (wrapping round the lap); ahead: the near one
    assert params["objects_speed"] == [0.0, 0.0] and params["objects_heading"] == [0.0, 0.0]  # no bot cars
    assert params["object_in_camera"] is True  # 0.33 m ahead, 11 degrees to the left: inside the 65 degree view
    assert params["is_left_of_center"] is True and params["distance_from_center"] == pytest.approx(0.2, abs=1e-6)

    # The sample by hand: wheels on, 0.5 * 1.07 - 0.2 >= 0.05 -> lane 1.0; the next box is on the car's side and its
    # objects_distance (0.404 m: the sample uses the distance from the line as if it were the gap) is in [0.3, 0.5)
    # -> avoid 0.2; reward = 1e-3 + 1.0 * 1.0 + 4.0 * 0.2.
    assert 0.3 <= params["objects_distance"][0] < 0.5
    assert reward == pytest.approx(1e-3 + 1.0 + 0.8)
    assert reward == pytest.approx(load_reward_function(oa_reward)(params))

    # On the other side of the centre line the next box is in the other lane: avoid 1.0.
    place_front_at(env, 0.005, lateral_m=-0.2)
    _, reward, *_, info = env.step(STRAIGHT)
    assert info["params"]["is_left_of_center"] is False
    assert reward == pytest.approx(1e-3 + 1.0 + 4.0)


def test_bot_car_params_report_speed_and_heading_in_radians(make_env, oa_reward):
    """A bot 50 % of the lap ahead (racer_oval's far side, driving towards -x): heading about pi radians."""
    length_m = Track.load("racer_oval").length_m
    challenge = ChallengeConfig(
        race_type="HEAD_TO_BOT",
        number_of_bot_cars=1,
        bot_car_speed_mps=0.5,
        min_distance_between_bot_cars_m=0.5 * length_m,
    )
    env = make_env(challenge=challenge, reward_function_path=oa_reward)
    env.reset(seed=0)
    *_, info = env.step(STRAIGHT)  # prepare: params of the start pose, the bot where it started
    params = info["params"]
    assert params["objects_speed"] == [0.5]
    assert abs(params["objects_heading"][0]) == pytest.approx(math.pi, abs=0.05)
    assert params["objects_distance"] == pytest.approx([0.5 * length_m], abs=0.005)
    assert params["objects_left_of_center"] == [True]  # the first bot starts on the inner lane
    for _ in range(15):
        *_, info = env.step(0)  # the car turns off the track meanwhile; the bot drives on
    moved_m = info["params"]["objects_distance"][0] - params["objects_distance"][0]
    assert moved_m == pytest.approx(0.5, abs=0.01)  # BOT_CAR_SPEED for 1 s (15 steps)
