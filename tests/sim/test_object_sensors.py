"""The env's observations see the obstacles and bot cars the track-object logic places: LIDAR variants, camera, stereo."""

from __future__ import annotations

import math

import numpy as np
import pytest

from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.sim.car.vehicle import LIDAR_POS_M
from racer.shared.sim.objects.bodies import BOX_LENGTH_M, BOX_WIDTH_M
from racer.shared.sim.objects.challenge import ChallengeConfig, ObjectPosition
from racer.shared.sim.objects.poses import ObjectKind
from racer.shared.sim.sensors import lidar as lidar_sensor

BOX_AHEAD = ChallengeConfig(race_type="OBJECT_AVOIDANCE", object_positions=(ObjectPosition(0.1, 1),))
"""racer_oval: 10 % of the lap is on the first straight; the box stands on the inner (left) lane."""
BOT = ChallengeConfig(race_type="HEAD_TO_BOT", number_of_bot_cars=1, bot_car_speed_mps=0.3)
LIDAR_SLICE = {
    # (centre ahead of the object's origin, length, width) of what a ray 0.16 m above the floor meets
    ObjectKind.BOX_OBSTACLE: (0.0, BOX_LENGTH_M, BOX_WIDTH_M),
    ObjectKind.BOT_CAR: (0.05, 0.22, 0.132),  # the bot's upper body (0.105-0.175 m high)
}
NOISE_TOLERANCE_M = 0.04
"""The LIDAR's Gaussian noise has σ = 1 cm."""


def _metadata(sensors):
    return parse_model_metadata(
        {
            "action_space": [{"steering_angle": 0.0, "speed": 1.0}, {"steering_angle": 20.0, "speed": 1.0}],
            "sensor": list(sensors),
            "version": "5",
            "lidar_config": {"num_sectors": 8, "num_values_per_sector": 4, "clipping_dist": 1.0},
        }
    )


def _expected_ranges(env) -> np.ndarray:
    """Each ray's distance to the objects' outlines at the LIDAR's height (inf = no hit), from the geometry."""
    pose = env.car.pose(env.data)
    origin = np.array([pose.origin_x_m, pose.origin_y_m]) + LIDAR_POS_M[0] * np.array(
        [math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)]
    )
    angles = pose.yaw_rad + np.linspace(lidar_sensor.MIN_ANGLE_RAD, lidar_sensor.MAX_ANGLE_RAD, lidar_sensor.NUM_RAYS)
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    best = np.full(lidar_sensor.NUM_RAYS, np.inf)
    for obj in env.object_poses:
        ahead_m, length_m, width_m = LIDAR_SLICE[obj.kind]
        c, s = math.cos(obj.yaw_rad), math.sin(obj.yaw_rad)
        centre = np.array([obj.x_m + ahead_m * c, obj.y_m + ahead_m * s])
        local_o = np.array([[c, s], [-s, c]]) @ (origin - centre)
        local_d = directions @ np.array([[c, s], [-s, c]]).T
        half = np.array([length_m / 2, width_m / 2])
        with np.errstate(divide="ignore", invalid="ignore"):
            t1, t2 = (-half - local_o) / local_d, (half - local_o) / local_d
        near = np.nanmax(np.minimum(t1, t2), axis=1)
        far = np.nanmin(np.maximum(t1, t2), axis=1)
        best = np.minimum(best, np.where((near <= far) & (near > 0), near, np.inf))
    return best


def _start_behind(env, obj, gap_m: float) -> float:
    """The start (share of the lap) whose centre-line pose is `gap_m` behind the object along the route."""
    return env.track.project_normalized(obj.x_m, obj.y_m) - gap_m / env.track.length_m


def _reliable_sectors(ranges: np.ndarray, sectors: int, values: int, clip_m: float) -> np.ndarray:
    """Sectors whose nearest expected return is not within the noise of a bin edge (their bit cannot flip)."""
    nearest = ranges.reshape(sectors, -1).min(axis=1)
    edges = np.arange(1, values + 1) * clip_m / values
    return np.array([np.isinf(r) or np.min(np.abs(edges - r)) > NOISE_TOLERANCE_M for r in nearest])


@pytest.mark.parametrize(
    "sensors",
    [
        ("STEREO_CAMERAS", "LIDAR"),
        ("FRONT_FACING_CAMERA", "SECTOR_LIDAR"),
        ("FRONT_FACING_CAMERA", "DISCRETIZED_SECTOR_LIDAR"),
    ],
    ids="+".join,
)
def test_every_sensor_sees_the_obstacle_and_the_time_trial_does_not(make_env, sensors):
    metadata = _metadata(sensors)
    race_env = make_env(challenge=BOX_AHEAD, model_metadata=metadata, track="racer_oval")
    trial_env = make_env(model_metadata=metadata, track="racer_oval")
    race_env.reset(seed=3)
    (box,) = race_env.object_poses
    options = {"evaluation": True, "start_ndist": _start_behind(race_env, box, 0.6)}
    seen, _ = race_env.reset(seed=3, options=options)
    empty, _ = trial_env.reset(seed=3, options=options)
    camera, lidar = sensors

    changed = np.abs(seen[camera].astype(int) - empty[camera].astype(int)) > 12
    for eye in range(seen[camera].shape[2]):  # both stereo eyes
        assert changed[:, :, eye].mean() > 0.05, f"{camera} channel {eye} does not show the box"

    expected = _expected_ranges(race_env)
    assert np.isfinite(expected).sum() >= 4 and expected.min() < 0.5
    if lidar == "LIDAR":
        hits = np.isfinite(expected)
        clipped = np.clip(expected[hits], lidar_sensor.MIN_RANGE_M, lidar_sensor.LIDAR_CLIP_HIGH_M)
        assert np.max(np.abs(seen["LIDAR"][hits] - clipped)) < NOISE_TOLERANCE_M
        # The other rays see what the time trial sees (walls, or nothing within 1 m); same seed, same noise.
        np.testing.assert_array_equal(seen["LIDAR"][~hits], empty["LIDAR"][~hits])
        return
    shape = (8, 1, lidar_sensor.SECTOR_LIDAR_CLIP_M) if lidar == "SECTOR_LIDAR" else (8, 4, 1.0)
    bits = lidar_sensor.sector_bits(expected, *shape).reshape(shape[0], shape[1])
    reliable = _reliable_sectors(expected, *shape)
    assert reliable.sum() >= 6 and bits[reliable].any()
    np.testing.assert_array_equal(seen[lidar].reshape(shape[0], shape[1])[reliable], bits[reliable])
    assert not empty[lidar].any()


def test_the_lidar_measures_a_bot_car_and_its_camera_shows_it(make_env):
    metadata = _metadata(("FRONT_FACING_CAMERA", "LIDAR"))
    env = make_env(challenge=BOT, model_metadata=metadata, track="racer_oval")
    trial_env = make_env(model_metadata=metadata, track="racer_oval")
    env.reset(seed=1)
    (bot,) = env.object_poses
    options = {"evaluation": True, "start_ndist": _start_behind(env, bot, 0.45)}
    seen, _ = env.reset(seed=1, options=options)
    empty, _ = trial_env.reset(seed=1, options=options)
    assert env.object_poses[0].x_m == pytest.approx(bot.x_m)  # the bot starts each episode at its place
    expected = _expected_ranges(env)
    assert np.isfinite(expected).sum() >= 2
    hits = np.isfinite(expected)
    clipped = np.clip(expected[hits], lidar_sensor.MIN_RANGE_M, lidar_sensor.LIDAR_CLIP_HIGH_M)
    assert np.max(np.abs(seen["LIDAR"][hits] - clipped)) < NOISE_TOLERANCE_M
    np.testing.assert_array_equal(seen["LIDAR"][~hits], empty["LIDAR"][~hits])
    changed = np.abs(seen["FRONT_FACING_CAMERA"].astype(int) - empty["FRONT_FACING_CAMERA"].astype(int)) > 12
    assert changed.mean() > 0.03


def test_domain_randomization_recolours_each_obstacle_per_episode_but_not_bot_cars(make_env):
    """ENABLE_DOMAIN_RANDOMIZATION: each static obstacle gets one colour per episode, as the SimApp's
    ModelVisualRandomizer does; bot cars driving their lane keep theirs; seeded resets repeat the colours."""
    from racer.shared.sim.objects.bodies import obstacle_materials

    two = ChallengeConfig(
        race_type="OBJECT_AVOIDANCE", object_positions=(ObjectPosition(0.1, 1), ObjectPosition(0.5, -1))
    )
    env = make_env(challenge=two, domain_randomization=True, track="racer_oval")
    groups = obstacle_materials(env.model)
    assert [len(group) for group in groups] == [1, 1]
    colours = []
    for seed in (1, 2, 1):
        env.reset(seed=seed)
        colours.append([env.model.mat_rgba[group[0], :3].copy() for group in groups])
    assert not np.allclose(colours[0][0], colours[1][0]) and not np.allclose(colours[0][0], colours[0][1])
    np.testing.assert_array_equal(colours[0], colours[2])

    bots = make_env(challenge=BOT, domain_randomization=True, track="racer_oval")
    assert obstacle_materials(bots.model) == []
    parked_bot_obstacles = ChallengeConfig(
        race_type="OBJECT_AVOIDANCE", number_of_obstacles=1, is_obstacle_bot_car=True
    )
    parked = make_env(challenge=parked_bot_obstacles, domain_randomization=True, track="racer_oval")
    (group,) = obstacle_materials(parked.model)
    parked.reset(seed=4)
    body, wheels = parked.model.mat_rgba[group, :3]
    assert len(group) == 2 and np.array_equal(body, wheels)  # one colour for the whole obstacle
