"""Object avoidance and head-to-bot in real scenes: placement, bot motion, crashes and their priorities, resets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from racer.shared.sim.objects.challenge import ChallengeConfig, ObjectPosition
from racer.shared.sim.objects.collisions import rectangle_corners
from racer.shared.sim.objects.poses import BOT_CAR_SIZE, BOX_OBSTACLE_SIZE

STRAIGHT = 2  # default metadata: index 2 = steering 0°, 1 m/s
BOX_AHEAD = ChallengeConfig(race_type="OBJECT_AVOIDANCE", object_positions=(ObjectPosition(0.1, 1),))
"""racer_oval: its first straight runs along +x from the origin; 10 % of the lap is 1.35 m down it, inner lane = left."""


def _first_run_step(env, seed: int = 0) -> None:
    env.reset(seed=seed)
    env.step(STRAIGHT)  # prepare


def test_a_car_crashes_exactly_where_its_corner_enters_the_box(make_env):
    """The SimApp's test: a corner of the 0.1961 x 0.32352 m car rectangle strictly inside the 0.4 x 0.5 m box."""
    env = make_env(challenge=BOX_AHEAD)
    _first_run_step(env)
    (box,) = env.object_poses
    # Drive along the box's own heading on its lane: the car's front corners meet the box's rear face when the car's
    # origin is (box length + car length) / 2 behind the box's centre.
    gap_m = 0.5 * (BOX_OBSTACLE_SIZE.length_m + BOT_CAR_SIZE.length_m)
    for offset_m, expected in ((gap_m + 0.001, "in_progress"), (gap_m - 0.001, "crashed")):
        x = box.x_m - offset_m * math.cos(box.yaw_rad)
        y = box.y_m - offset_m * math.sin(box.yaw_rad)
        env.teleport(x, y, box.yaw_rad)
        *_, terminated, _, info = env.step(STRAIGHT)
        assert info["episode_status"] == expected, offset_m
        assert info["params"]["is_crashed"] is (expected == "crashed")
        if terminated:
            break
    assert terminated  # NUMBER_OF_RESETS 0 (training): the crash ends the episode


def test_a_car_driven_straight_at_a_box_crashes_at_the_predicted_distance(make_env):
    """Driving at 1 m/s from the start line: the first `crashed` row is the first pose past the geometric limit."""
    env = make_env(challenge=BOX_AHEAD)
    env.reset(seed=0)
    (box,) = env.object_poses
    limit_x = box.x_m - 0.5 * BOX_OBSTACLE_SIZE.length_m - 0.5 * BOT_CAR_SIZE.length_m
    rows = []
    for _ in range(60):
        *_, terminated, _, info = env.step(STRAIGHT)
        rows.append(info["simtrace"])
        if terminated:
            break
    assert rows[-1]["episode_status"] == "crashed" and rows[-1]["done"]
    origin_x = [row["X"] - 0.14 * math.cos(math.radians(row["yaw"])) for row in rows]
    assert origin_x[-2] <= limit_x < origin_x[-1]  # the front corners reach the box's rear face between two rows
    assert origin_x[-1] - limit_x < 1.0 / 15 + 0.01  # at most one step of 1 m/s past it
    # A box on the inner lane overlaps the centre-line car sideways: 0.2 m half width vs the lane's offset.
    corners = rectangle_corners(origin_x[-1], rows[-1]["Y"], math.radians(rows[-1]["yaw"]), BOT_CAR_SIZE)
    assert max(y for _, y in corners) > box.y_m - 0.5 * BOX_OBSTACLE_SIZE.width_m


def test_a_crash_with_resets_left_pauses_behind_the_obstacle_on_the_other_lane(make_env):
    env = make_env(challenge=BOX_AHEAD, number_of_resets=3, collision_penalty_s=1.0)
    env.reset(seed=0)
    (box,) = env.object_poses
    statuses = []
    for _ in range(60):
        *_, info = env.step(STRAIGHT)
        statuses.append(info["episode_status"])
        if statuses[-1] == "pause":
            break
    assert statuses[-2:] == ["crashed", "pause"]
    pose = env.car.pose(env.data)
    box_dist_m = env.track.project_normalized(box.x_m, box.y_m) * env.track.length_m
    car_dist_m = env.track.project_normalized(pose.origin_x_m, pose.origin_y_m) * env.track.length_m
    assert car_dist_m == pytest.approx(box_dist_m - 1.0, abs=0.02)  # RESET_BEHIND_DIST
    assert env.track.nearer_lane(box.x_m, box.y_m) == "inner"
    assert env.track.nearer_lane(pose.origin_x_m, pose.origin_y_m) == "outer"


def test_mercy_reset_puts_the_car_ahead_after_max_resets_behind_the_same_obstacle(make_env):
    challenge = ChallengeConfig(
        race_type="OBJECT_AVOIDANCE",
        object_positions=(ObjectPosition(0.1, 1),),
        enable_mercy_reset=True,
        max_resets_after_crash=2,
    )
    env = make_env(challenge=challenge, number_of_resets=5, collision_penalty_s=0.0)
    _first_run_step(env)
    (box,) = env.object_poses
    box_dist_m = env.track.project_normalized(box.x_m, box.y_m) * env.track.length_m
    counters, spots = [], []
    for _ in range(2):
        offset_m = 0.5 * (BOX_OBSTACLE_SIZE.length_m + BOT_CAR_SIZE.length_m) - 0.01
        env.teleport(box.x_m - offset_m, box.y_m, box.yaw_rad)
        *_, info = env.step(STRAIGHT)
        assert info["episode_status"] == "crashed"
        counters.append(info["simtrace"]["obstacle_crash_counter"])
        pose = env.car.pose(env.data)
        spots.append(env.track.project_normalized(pose.origin_x_m, pose.origin_y_m) * env.track.length_m)
        env.step(STRAIGHT)  # the pause step (0 s penalty)
    assert counters == [1, 0]  # the second reset behind the same box is the mercy one: the counter starts again
    assert spots[0] == pytest.approx(box_dist_m - 1.0, abs=0.02)
    assert spots[1] == pytest.approx(box_dist_m + 1.0, abs=0.02)  # RESET_AHEAD_DIST


def test_training_starts_on_the_other_lane_when_an_object_is_within_a_metre(make_env):
    challenge = ChallengeConfig(race_type="OBJECT_AVOIDANCE", object_positions=(ObjectPosition(0.03, -1),))
    env = make_env(challenge=challenge, change_start_position=False)
    env.reset(seed=0)
    pose = env.car.pose(env.data)
    assert env.track.nearer_lane(pose.origin_x_m, pose.origin_y_m) == "inner"
    assert env.track.distance_from_center(pose.origin_x_m, pose.origin_y_m) > 0.1
    env.reset(options={"evaluation": True})  # evaluation starts on the centre line whatever stands there
    pose = env.car.pose(env.data)
    assert env.track.distance_from_center(pose.origin_x_m, pose.origin_y_m) < 1e-6
    # racer's spread evaluation starts ask for the training rule: the same spot, on the lane away from the box
    env.reset(options={"evaluation": True, "start_ndist": 0.03, "clear_start": True})
    pose = env.car.pose(env.data)
    assert env.track.nearer_lane(pose.origin_x_m, pose.origin_y_m) == "inner"
    assert env.track.distance_from_center(pose.origin_x_m, pose.origin_y_m) > 0.1
    env.reset(options={"evaluation": True, "start_ndist": 0.5, "clear_start": True})  # no object within 1 m
    pose = env.car.pose(env.data)
    assert env.track.distance_from_center(pose.origin_x_m, pose.origin_y_m) < 1e-6


def test_a_crash_into_a_bot_ahead_counts_and_a_bot_hitting_the_car_from_behind_does_not(make_env):
    challenge = ChallengeConfig(
        race_type="HEAD_TO_BOT", number_of_bot_cars=1, bot_car_speed_mps=0.2, penalty_seconds=1.0
    )
    env = make_env(challenge=challenge, number_of_resets=3, collision_penalty_s=0.0)
    _first_run_step(env)
    (bot,) = env.object_poses
    c, s = math.cos(bot.yaw_rad), math.sin(bot.yaw_rad)
    # The car 0.3 m ahead of the bot, overlapping its front: the bot ran into the car; the car goes on.
    env.teleport(bot.x_m + 0.3 * c, bot.y_m + 0.3 * s, bot.yaw_rad)
    *_, info = env.step(STRAIGHT)
    assert info["episode_status"] == "in_progress" and info["params"]["is_crashed"] is False
    env.step(STRAIGHT)  # still touching: no second penalty while the bots stand
    stopped = env.object_poses[0]
    for _ in range(10):  # the bots stop for PENALTY_SECONDS (1 s = 15 steps)
        env.teleport(bot.x_m + 2.0 * c, bot.y_m + 2.0 * s, bot.yaw_rad)
        env.step(STRAIGHT)
        assert (env.object_poses[0].x_m, env.object_poses[0].y_m) == (stopped.x_m, stopped.y_m)
    for _ in range(8):
        env.teleport(bot.x_m + 2.0 * c, bot.y_m + 2.0 * s, bot.yaw_rad)
        env.step(STRAIGHT)
    moved_m = math.dist((env.object_poses[0].x_m, env.object_poses[0].y_m), (stopped.x_m, stopped.y_m))
    assert 0.0 < moved_m < 0.2 * 8 / 15 + 0.01  # it drives on after 1 s, from where it stopped
    bot = env.object_poses[0]
    # The car 0.3 m behind the bot, overlapping its rear: the car ran into it; crashed, held where it is.
    env.teleport(bot.x_m - 0.3 * c, bot.y_m - 0.3 * s, bot.yaw_rad)
    *_, info = env.step(STRAIGHT)
    assert info["episode_status"] == "crashed" and info["params"]["is_crashed"] is True
    held = env.car.pose(env.data)
    assert math.dist((held.origin_x_m, held.origin_y_m), (bot.x_m - 0.3 * c, bot.y_m - 0.3 * s)) < 0.01


def test_a_bot_changes_lanes_in_the_configured_time(make_env):
    """IS_LANE_CHANGE with LOWER = UPPER = 1 s and LANE_CHANGE_DISTANCE 0.5 m at 0.5 m/s: the bot leaves its lane
    1 s after the episode start and is on the other lane 1 s (0.5 m / 0.5 m/s) later, smoothly."""
    challenge = ChallengeConfig(
        race_type="HEAD_TO_BOT",
        number_of_bot_cars=1,
        bot_car_speed_mps=0.5,
        is_lane_change=True,
        lower_lane_change_time_s=1.0,
        upper_lane_change_time_s=1.0,
        lane_change_distance_m=0.5,
        min_distance_between_bot_cars_m=5.5,  # 5.5 m ahead of the start line, through a bend
    )
    env = make_env(challenge=challenge)
    env.reset(seed=0)
    track = env.track
    offsets, times = [], []
    for _ in range(40):
        env.step(STRAIGHT)
        bot = env.object_poses[0]
        side = 1.0 if track.is_left_of_center(bot.x_m, bot.y_m) else -1.0
        offsets.append(side * track.distance_from_center(bot.x_m, bot.y_m))
        times.append(env.sim_time_s)
    lane_offset_m = offsets[0]
    assert lane_offset_m > 0.1  # starts on the inner (left) lane
    start_s = 1.0 / 15  # the first running step schedules the change: 1 s later it starts
    before = [o for o, t in zip(offsets, times, strict=True) if t < start_s + 1.0 - 1e-6]
    during = [o for o, t in zip(offsets, times, strict=True) if start_s + 1.0 + 0.1 < t < start_s + 2.0 - 0.1]
    after = [o for o, t in zip(offsets, times, strict=True) if t > start_s + 2.0 + 1e-6]
    assert np.allclose(before, lane_offset_m, atol=0.01)
    assert all(-lane_offset_m + 0.005 < o < lane_offset_m - 0.005 for o in during)
    assert np.all(np.diff(during) < 0)  # moves steadily across
    assert np.allclose(after, -lane_offset_m, atol=0.01)
    assert len(after) >= 3


def test_randomised_placements_differ_per_episode_and_repeat_under_the_same_seed(make_env):
    challenge = ChallengeConfig(
        race_type="OBJECT_AVOIDANCE",
        number_of_obstacles=3,
        randomize_obstacle_locations=True,
    )

    def layouts(env, episodes: int) -> list[list[tuple[float, float]]]:
        seen = []
        for episode in range(episodes):
            env.reset(seed=7 if episode == 0 else None)
            seen.append([(round(o.x_m, 9), round(o.y_m, 9)) for o in env.object_poses])
        return seen

    first = layouts(make_env(challenge=challenge), 3)
    again = layouts(make_env(challenge=challenge), 3)
    assert first == again
    assert len({tuple(layout) for layout in first}) == 3
    env = make_env(challenge=challenge)
    env.reset(seed=8)
    assert [(round(o.x_m, 9), round(o.y_m, 9)) for o in env.object_poses] != first[0]  # another seed
    # Spacing: MIN_DISTANCE_BETWEEN_OBSTACLES percent of the lap between neighbours along the centre line.
    track = env.track
    for layout in first:
        dists = sorted(track.project_normalized(x, y) * track.length_m for x, y in layout)
        assert min(np.diff(dists)) >= 0.02 * track.length_m - 1e-6


def test_fixed_layout_alternates_lanes_and_spacing(make_env):
    challenge = ChallengeConfig(race_type="OBJECT_AVOIDANCE", number_of_obstacles=3)
    env = make_env(challenge=challenge)
    env.reset(seed=0)
    track = env.track
    dists = [track.project_normalized(o.x_m, o.y_m) * track.length_m for o in env.object_poses]
    lanes = [track.nearer_lane(o.x_m, o.y_m) for o in env.object_poses]
    spacing = 0.02 * track.length_m
    assert dists == pytest.approx(list(np.linspace(spacing, track.length_m - 1.0, 3)), abs=0.01)
    assert lanes == ["inner", "outer", "inner"]


def test_a_time_trial_has_no_race_objects(make_env):
    env = make_env()
    env.reset(seed=0)
    assert env.object_poses == []
    *_, info = env.step(STRAIGHT)
    assert info["params"]["objects_location"] == [] and info["simtrace"]["obstacle_crash_counter"] == 0
