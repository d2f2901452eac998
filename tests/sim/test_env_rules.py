"""Episode rules by teleporting the car (deepracer-simapp v5.3.3 `bundle/markov/reset/rules/`): prepare step, off track,
lap, reversed, immobilized, resets."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from racer.shared.deepracer.simtrace import SIMTRACE_COLUMNS
from racer.shared.sim.reward.params import PARAM_KEYS

from .conftest import place_far_off_track, place_front_at

STRAIGHT = 2  # default metadata: index 2 = steering 0°, 1 m/s


def test_prepare_step_has_reward_zero_and_zero_command(make_env, recording_reward):
    env = make_env(reward_function_path=recording_reward)
    env.reset(seed=1)
    start = env.car.pose(env.data)
    _, reward, terminated, truncated, info = env.step(9)  # 30°, 2 m/s chosen but not sent
    row = info["simtrace"]
    assert reward == 0.0 and not terminated and not truncated
    assert row["episode_status"] == "prepare" and row["steps"] == 1.0
    assert row["steer"] == 30.0 and row["throttle"] == 2.0 and row["action"] == 9
    moved = math.dist(
        (start.origin_x_m, start.origin_y_m), (env.car.pose(env.data).origin_x_m, env.car.pose(env.data).origin_y_m)
    )
    assert moved < 0.002
    assert tuple(row) == SIMTRACE_COLUMNS
    assert tuple(info["params"]) == PARAM_KEYS
    # First RUN step: reward function called with every key; steps is a float 2.0.
    _, reward, *_, info = env.step(STRAIGHT)
    assert info["episode_status"] == "in_progress" and reward == 1.0
    assert info["params"]["steps"] == 2.0 and isinstance(info["params"]["steps"], float)


def test_first_row_progress_is_front_of_car_offset(make_env):
    env = make_env()
    env.reset(seed=0)
    *_, info = env.step(STRAIGHT)
    expected = 0.14 / env.track.length_m * 100
    assert info["progress"] == pytest.approx(expected, abs=0.01)


def test_centre_line_gives_zero_distance_from_center(make_env):
    env = make_env()
    env.reset(seed=0)
    env.step(STRAIGHT)
    for ndist in (0.13, 0.42, 0.77):
        x, y = place_front_at(env, ndist)
        *_, info = env.step(STRAIGHT)
        params = info["params"]
        assert params["x"] == pytest.approx(x, abs=1e-9) and params["y"] == pytest.approx(y, abs=1e-9)
        assert params["distance_from_center"] == pytest.approx(0.0, abs=1e-9)
        assert params["all_wheels_on_track"] is True
    place_front_at(env, 0.3, lateral_m=0.2)
    *_, info = env.step(STRAIGHT)
    assert info["params"]["distance_from_center"] == pytest.approx(
        0.2, abs=0.005
    )  # yaw is towards the next waypoint, not the local normal
    assert info["params"]["is_left_of_center"] is True


def test_beyond_the_border_is_off_track_and_reward_still_called(make_env, recording_reward):
    env = make_env(reward_function_path=recording_reward)
    env.reset(seed=0)
    env.step(STRAIGHT)
    width = env.track.track_width_at(*env.track.pose_at(0.25)[:2])
    place_front_at(env, 0.25, lateral_m=-(width / 2 + 0.6))
    _, reward, terminated, truncated, info = env.step(STRAIGHT)
    assert terminated and not truncated
    assert info["episode_status"] == "off_track" and info["simtrace"]["done"] is True
    assert info["params"]["is_offtrack"] is True and info["params"]["all_wheels_on_track"] is False
    assert reward == 0.25  # the user's function decided, no hidden off-track reward
    with pytest.raises(RuntimeError, match="reset"):
        env.step(STRAIGHT)


def test_some_wheels_off_is_not_off_track(make_env):
    env = make_env()
    env.reset(seed=0)
    env.step(STRAIGHT)
    width = env.track.track_width_at(*env.track.pose_at(0.25)[:2])
    place_front_at(env, 0.25, lateral_m=width / 2)  # left wheels beyond the border, right wheels on the road
    _, _, terminated, _, info = env.step(STRAIGHT)
    assert not terminated and info["episode_status"] == "in_progress"
    assert info["params"]["all_wheels_on_track"] is False and info["params"]["is_offtrack"] is False


def test_crossing_the_line_after_a_loop_completes_the_lap(make_env):
    env = make_env()
    env.reset(seed=0)
    env.step(STRAIGHT)
    progress = []
    for ndist in [*np.arange(0.05, 1.0, 0.05), 0.995, 0.004, 0.02]:
        place_front_at(env, float(ndist) % 1.0)
        _, _, terminated, _, info = env.step(STRAIGHT)
        progress.append(info["progress"])
        if terminated:
            break
    assert info["episode_status"] == "lap_complete" and terminated
    assert info["progress"] == 100
    assert progress[-2] > 99.0 and all(b > a for a, b in itertools.pairwise(progress))
    # Every row of the lap counts, the prepare row included: the last row is stamped after its physics (SimApp).
    assert info["lap_time_s"] == pytest.approx((len(progress) + 1) / 15.0, abs=1e-6)


def test_driving_backwards_is_reversed(make_env):
    env = make_env()
    env.reset(seed=0)
    env.step(STRAIGHT)
    place_front_at(env, 0.5, backwards=True)
    statuses = []
    progress = []
    for _ in range(40):
        _, _, terminated, _, info = env.step(STRAIGHT)
        statuses.append(info["episode_status"])
        progress.append(info["progress"])
        if terminated:
            break
    assert statuses[-1] == "reversed"
    decreasing = sum(1 for a, b in itertools.pairwise(progress) if b < a)
    assert decreasing == 15 and all(s == "in_progress" for s in statuses[:-1])


def test_standing_still_is_immobilized(make_env):
    env = make_env()
    env.reset(seed=0)
    env.step(STRAIGHT)
    statuses = []
    for _ in range(30):
        place_front_at(env, 0.4)
        _, _, terminated, _, info = env.step(STRAIGHT)
        statuses.append(info["episode_status"])
        if terminated:
            break
    assert statuses == ["in_progress"] * 15 + ["immobilized"]


def test_resets_pause_respawn_and_continue_progress(make_env):
    env = make_env(number_of_resets=2, off_track_penalty_s=0.2)
    env.reset(seed=0)
    env.step(STRAIGHT)
    place_front_at(env, 0.3)
    *_, info = env.step(STRAIGHT)
    before = info["progress"]
    place_far_off_track(env)
    _, _, terminated, _, info = env.step(STRAIGHT)
    assert info["episode_status"] == "off_track" and not terminated
    assert info["simtrace"]["pause_duration"] == pytest.approx(0.2)
    pause_rows = []
    while True:
        _, reward, terminated, _, info = env.step(STRAIGHT)
        if info["episode_status"] != "pause":
            break
        pause_rows.append((reward, info["simtrace"]["pause_duration"]))
    assert len(pause_rows) == 3 and all(r == 0.0 for r, _ in pause_rows)
    assert [d for _, d in pause_rows] == sorted((d for _, d in pause_rows), reverse=True)
    assert info["episode_status"] == "in_progress"
    # The car's origin goes to the spot of the previous progress (SimApp), so its front is 0.14 m further on:
    # 1.04 % of racer_oval, plus the lane's projection on a bend.
    assert before < info["progress"] < before + 1.6
    assert info["params"]["all_wheels_on_track"] is True
    # Two resets allowed: the third off-track ends the episode.
    for expected_done in (False, True):
        place_far_off_track(env)
        _, _, terminated, _, info = env.step(STRAIGHT)
        assert info["episode_status"] == "off_track" and terminated == expected_done
        while not terminated and info["episode_status"] in ("off_track", "pause"):
            _, _, terminated, _, info = env.step(STRAIGHT)


def test_round_robin_start_evaluation_and_alternate_direction(make_env):
    env = make_env(alternate_driving_direction=True)
    starts, reversed_flags = [], []
    for episode in range(3):
        _, info = env.reset()
        starts.append(info["start_ndist"])
        reversed_flags.append(info["is_reversed"])
        env.step(STRAIGHT)
        place_far_off_track(env)
        *_, terminated, _, step_info = env.step(STRAIGHT)
        assert terminated and step_info["simtrace"]["episode"] == episode
    assert starts == pytest.approx([0.0, 0.05, 0.1])
    assert reversed_flags == [False, True, False]
    _, info = env.reset(options={"evaluation": True})
    env.step(STRAIGHT)
    place_far_off_track(env)
    env.step(STRAIGHT)
    _, after_eval = env.reset()
    assert info["start_ndist"] == pytest.approx(0.15) and after_eval["start_ndist"] == pytest.approx(0.15)
    assert after_eval["is_reversed"] is True


def test_an_evaluation_episode_can_start_anywhere_and_moves_nothing(make_env):
    env = make_env()
    _, info = env.reset(options={"evaluation": True, "start_ndist": 1.4})
    assert info["start_ndist"] == pytest.approx(0.4)
    x, y, _ = env.track.pose_at(0.4, "center")
    assert (env.car.pose(env.data).origin_x_m, env.car.pose(env.data).origin_y_m) == pytest.approx((x, y), abs=1e-6)
    *_, step_info = env.step(STRAIGHT)  # the prepare step: progress counts from this start
    front_of_car_pct = 100 * 0.14 / env.track.length_m  # the params point is 0.14 m ahead of the car's origin
    assert step_info["progress"] == pytest.approx(front_of_car_pct, abs=0.2)
    _, after = env.reset()
    assert after["start_ndist"] == 0.0  # the training round robin did not move
    with pytest.raises(ValueError, match="'start_ndist' is for evaluation episodes"):
        env.reset(options={"start_ndist": 0.5})


def test_fixed_start_when_change_start_position_is_off(make_env):
    env = make_env(change_start_position=False, start_position_offset=0.3, reverse_dir=True)
    for _ in range(2):
        _, info = env.reset()
        assert info["start_ndist"] == pytest.approx(0.3) and info["is_reversed"] is True
        *_, step_info = env.step(STRAIGHT)
        assert step_info["params"]["is_reversed"] is True
        place_far_off_track(env)
        env.step(STRAIGHT)


def test_step_cap_truncates(make_env):
    env = make_env(max_steps=5)
    env.reset(seed=0)
    for _ in range(5):
        _, _, terminated, truncated, info = env.step(STRAIGHT)
    assert truncated and not terminated and info["simtrace"]["done"] is True


def test_real_deepracer_route_first_row_matches_real_simtrace(make_env, deepracer_data):
    """Same start as the AWS console 2022 training episode 0 on reinvent_base: first row X, Y, progress, waypoint."""
    env = make_env(track=deepracer_data / "routes" / "reinvent_base.npy")
    env.reset(seed=0)
    *_, info = env.step(STRAIGHT)
    row = info["simtrace"]
    # console2022_training_0-iteration.csv, row 1: X 3.19990, Y 0.68312, progress 0.79148, closest_waypoint 1
    assert row["X"] == pytest.approx(3.19990, abs=0.003) and row["Y"] == pytest.approx(0.68312, abs=0.003)
    assert row["progress"] == pytest.approx(0.79148, abs=0.003)
    assert row["closest_waypoint"] == 1 and row["track_len"] == pytest.approx(17.709159380834848, abs=1e-12)
    assert info["params"]["track_width"] == pytest.approx(0.762, abs=0.01)


def test_open_route_is_completed_by_driving_to_its_end(make_env, deepracer_data):
    """DeepRacer's only open route: straight ahead at 2 m/s reaches 100 % after its 5.7 m."""
    env = make_env(track=deepracer_data / "routes" / "Straight_track.npy")
    env.reset(seed=0)
    for _ in range(120):
        _, _, terminated, truncated, info = env.step(7)  # 0°, 2 m/s
        if terminated or truncated:
            break
    assert info["episode_status"] == "lap_complete" and info["progress"] == 100
    assert 2.5 < info["lap_time_s"] < 4.5


def _off_track_then_rows(env, ndist: float) -> list[dict]:
    """Drive to `ndist`, leave the road, and return the rows from the off-track one until the car runs again."""
    place_front_at(env, ndist)
    env.step(STRAIGHT)
    place_far_off_track(env)
    rows = [env.step(STRAIGHT)[-1]["simtrace"]]
    while rows[-1]["episode_status"] in ("off_track", "pause") and not rows[-1]["done"]:
        rows.append(env.step(STRAIGHT)[-1]["simtrace"])
    return rows


def test_a_zero_second_penalty_still_spends_one_pause_step(make_env):
    """SimApp: a reset rule moves the agent to the PAUSE phase; the next step is a `pause` row whatever the penalty."""
    env = make_env(number_of_resets=2, off_track_penalty_s=0.0)
    env.reset(seed=0)
    env.step(STRAIGHT)
    rows = _off_track_then_rows(env, 0.3)
    assert [row["episode_status"] for row in rows] == ["off_track", "pause", "in_progress"]
    assert rows[0]["pause_duration"] == 0.0 and rows[1]["reward"] == 0.0
    assert rows[1]["pause_duration"] == pytest.approx(-1 / 15)  # what is left of the penalty, not clamped
    assert rows[1]["X"] == pytest.approx(rows[2]["X"], abs=0.01)  # held where it was put back, then drives on


def test_the_last_pause_row_shows_the_penalty_overrun(make_env):
    env = make_env(number_of_resets=2, off_track_penalty_s=0.5)
    env.reset(seed=0)
    env.step(STRAIGHT)
    rows = _off_track_then_rows(env, 0.3)
    pauses = [row["pause_duration"] for row in rows if row["episode_status"] == "pause"]
    assert len(pauses) == 8  # ceil(0.5 s * 15)
    assert pauses[0] == pytest.approx(0.5 - 1 / 15) and pauses[-1] == pytest.approx(0.5 - 8 / 15)
    assert pauses[-1] < 0.0
    # A rule that ends the episode writes no penalty (the SimApp clears pause_duration on every RUN step).
    ending = make_env(number_of_resets=0)
    ending.reset(seed=0)
    ending.step(STRAIGHT)
    assert _off_track_then_rows(ending, 0.3)[0]["pause_duration"] == 0.0


def test_respawn_is_measured_from_the_route_origin_on_the_lane_nearer_the_previous_pose(make_env):
    """SimApp `_get_car_reset_model_state`: spawn_dist = prev_progress% of the lap along the centre line from its
    start (not from the episode's start line); inner or outer lane, whichever is nearer to the previous car pose."""
    env = make_env(number_of_resets=2, off_track_penalty_s=0.0, start_position_offset=0.5)
    _, info = env.reset(seed=0)
    assert info["start_ndist"] == pytest.approx(0.5)
    env.step(STRAIGHT)
    place_front_at(env, 0.62)
    *_, before = env.step(STRAIGHT)
    prev_progress = before["progress"]
    assert prev_progress == pytest.approx(12.0, abs=0.5)
    place_far_off_track(env)
    *_, off = env.step(STRAIGHT)
    assert off["episode_status"] == "off_track"
    held = env.car.pose(env.data)
    spots = [env.track.pose_at(prev_progress / 100.0, lane) for lane in ("inner", "outer")]
    assert min(math.dist((held.origin_x_m, held.origin_y_m), spot[:2]) for spot in spots) < 0.01

    for lateral_m, expected in (
        (-0.15, "outer" if env.track.is_ccw else "inner"),
        (0.15, "inner" if env.track.is_ccw else "outer"),
    ):
        env = make_env(number_of_resets=2, off_track_penalty_s=0.0)
        env.reset(seed=0)
        env.step(STRAIGHT)
        place_front_at(env, 0.3, lateral_m=lateral_m)  # negative: right of the centre line
        *_, before = env.step(STRAIGHT)
        place_far_off_track(env)
        env.step(STRAIGHT)
        held = env.car.pose(env.data)
        x, y, yaw = env.track.pose_at(before["progress"] / 100.0, expected)
        assert (held.origin_x_m, held.origin_y_m) == pytest.approx((x, y), abs=0.01), lateral_m
        assert math.cos(held.yaw_rad - yaw) > 0.99


def test_where_it_left_gives_back_what_a_cut_gained_while_leaving(make_env):
    """The summit rule's put-back (reset_position="where_it_left"): a car that jumps ahead with two wheels still on
    the road (a corner cut: still in progress) and then leaves is put back behind the last point where all four
    wheels were on the road. DeepRacer's own spot (previous progress) would keep the gain."""
    results = {}
    for reset_position in ("deepracer", "where_it_left"):
        env = make_env(number_of_resets=3, off_track_penalty_s=0.0, reset_position=reset_position)
        env.reset(seed=0)
        env.step(STRAIGHT)
        place_front_at(env, 0.20)
        *_, legal = env.step(STRAIGHT)
        assert legal["params"]["all_wheels_on_track"]
        half_width = legal["params"]["track_width"] / 2
        place_front_at(env, 0.35, lateral_m=half_width)  # straddling the left border, further on
        *_, cut = env.step(STRAIGHT)
        assert cut["episode_status"] == "in_progress" and not cut["params"]["all_wheels_on_track"]
        assert cut["progress"] > legal["progress"] + 10.0
        place_far_off_track(env)
        *_, off = env.step(STRAIGHT)
        assert off["episode_status"] == "off_track"
        *_, pause = env.step(STRAIGHT)
        assert pause["episode_status"] == "pause"
        results[reset_position] = pause["progress"]
    assert results["deepracer"] > legal["progress"] + 10.0  # the SimApp's spot keeps what the cut gained
    assert results["where_it_left"] <= legal["progress"]  # the summit rule's does not
    assert results["where_it_left"] > legal["progress"] - 5.0
