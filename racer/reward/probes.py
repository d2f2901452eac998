"""The params `racer reward test` calls a reward function with: poses spread along the whole track (across its
width and beyond it, headings around the track direction and reversed, each action of the model's action space,
driven the other way) and the obstacles or bot cars of the race type, built with `make_reward_params` as the env
builds them."""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.sim.reward.params import RewardObject, make_reward_params
from racer.shared.sim.tracks.track import Track

CAR_HALF_WIDTH_M = 0.1
"""Half the car's track width: all wheels are on the road when the centre is this far inside the border."""
STEPS_PER_S = 15.0
BOX_SIZE_M = (0.4, 0.5)
BOT_CAR_SIZE_M = (0.32352, 0.1961)


def model_actions(metadata: ModelMetadata | None) -> list[tuple[float, float]]:
    """(steering_deg, speed_mps) of every discrete action, or a 3 x 3 grid over a continuous space."""
    if metadata is None:
        from racer.shared.sim.config import DEFAULT_MODEL_METADATA

        metadata = DEFAULT_MODEL_METADATA
    if not metadata.is_continuous:
        return [(a.steering_angle_deg, a.speed_mps) for a in metadata.discrete_actions]
    space = metadata.continuous_action_space
    assert space is not None
    steerings = (space.steering_angle_low_deg, (space.steering_angle_low_deg + space.steering_angle_high_deg) / 2,
                 space.steering_angle_high_deg)  # fmt: skip
    speeds = (space.speed_low_mps, (space.speed_low_mps + space.speed_high_mps) / 2, space.speed_high_mps)
    return [(s, v) for s in steerings for v in speeds]


def probe_objects(track: Track, race_type: str) -> list[RewardObject]:
    """Obstacles (object avoidance) or bot cars (head to bot) spread over the lap, in alternate lanes."""
    if race_type == "OBJECT_AVOIDANCE":
        places, size, bot, speed = (0.2, 0.5, 0.8), BOX_SIZE_M, False, 0.0
    elif race_type == "HEAD_TO_BOT":
        places, size, bot, speed = (0.33, 0.66), BOT_CAR_SIZE_M, True, 0.2
    else:
        return []
    objects = []
    for i, ndist in enumerate(places):
        x, y, yaw = track.pose_at(ndist, "inner" if i % 2 == 0 else "outer")
        objects.append(RewardObject(x, y, yaw, speed, bot, size[0], size[1]))
    return objects


@dataclass(frozen=True)
class Pose:
    ndist: float
    lateral: float
    """Fraction of the track width left of the centre line (±0.5 is the border)."""
    heading_offset_deg: float
    action: tuple[float, float]
    reversed: bool = False


def poses(actions: Sequence[tuple[float, float]], objects_at: Sequence[float], quick: bool) -> Iterator[Pose]:
    """Poses over the whole track: stations x lateral offsets x headings (one action each, in turn), every action
    at some stations, the other driving direction, and both lanes just behind each object."""
    stations = 12 if quick else 40
    laterals = (0.0, 0.2, -0.2, 0.4, -0.4, 0.6, -0.6)
    headings = (0.0, 30.0, -30.0, 180.0)
    i = 0
    for s in range(stations):
        ndist = s / stations
        for lateral in laterals:
            for heading in headings:
                yield Pose(ndist, lateral, heading, actions[i % len(actions)])
                i += 1
        if s % 4 == 0:
            for action in actions:
                yield Pose(ndist, 0.1, 0.0, action)
        if s % 5 == 0:
            yield Pose(ndist, 0.0, 0.0, actions[s % len(actions)], reversed=True)
            yield Pose(ndist, 0.6, 180.0, actions[(s + 1) % len(actions)], reversed=True)
    yield Pose(0.999, 0.0, 0.0, actions[0])  # just before the finish line: progress close to 100
    for ndist in objects_at:
        for lateral in (0.25, -0.25):
            for gap in (0.005, 0.02, 0.05):
                yield Pose((ndist - gap) % 1.0, lateral, 0.0, actions[-1])


def params_at(track: Track, pose: Pose, objects: Sequence[RewardObject]) -> dict:
    """The params dict for a pose, with the geometry-derived flags as the env would set them."""
    driven = track.reversed() if pose.reversed else track
    ndist = (1.0 - pose.ndist) % 1.0 if pose.reversed else pose.ndist
    cx, cy, yaw = driven.pose_at(ndist)
    width = driven.track_width_at(cx, cy)
    offset = pose.lateral * width
    x, y = cx - offset * math.sin(yaw), cy + offset * math.cos(yaw)
    geometry = driven.point_geometry(x, y)
    half = geometry.track_width_m / 2
    distance = geometry.distance_from_center_m
    progress = min(100.0, 100.0 * ndist) if not pose.reversed else min(100.0, 100.0 * pose.ndist)
    steps = 1 + int(progress / 100.0 * track.length_m * STEPS_PER_S)
    crashed = any(math.hypot(o.x - x, o.y - y) < 0.3 for o in objects)
    steering, speed = pose.action
    return make_reward_params(
        driven,
        x=x,
        y=y,
        heading_deg=math.degrees(yaw) + pose.heading_offset_deg,
        speed_mps=speed,
        steering_angle_deg=steering,
        steps=steps,
        progress=progress,
        all_wheels_on_track=distance + CAR_HALF_WIDTH_M <= half,
        is_offtrack=distance - CAR_HALF_WIDTH_M > half,
        is_crashed=crashed,
        sim_time_s=steps / STEPS_PER_S,
        objects=objects,
        geometry=geometry,
    )
