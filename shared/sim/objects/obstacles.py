"""Static obstacles placed as the SimApp's `ObstaclesCtrl` places them, once per episode.

Fixed `OBJECT_POSITIONS` ("ndist,lane") win over the generated layout. Generated obstacles start equally spaced
from MIN_DISTANCE_BETWEEN_OBSTACLES (percent of the track length) to 1 m before the end of the lap, alternating
inner, outer, inner...; with RANDOMIZE_OBSTACLE_LOCATIONS each one moves to a uniform spot between its neighbours
(visited in random order, keeping the spacing) on a random lane. Distances are along the centre line of the
episode's driving direction; an obstacle stands on its lane (half-way between the centre line and a border),
heading along the lane.

One deliberate difference: the SimApp converts the percent spacing into metres again at every episode (so from the
second episode on the spacing shrinks towards 0); racer converts it once.
"""

from __future__ import annotations

import numpy as np

from racer.shared.sim.objects.challenge import INNER_LANE, ChallengeConfig
from racer.shared.sim.objects.poses import ObjectKind, ObjectPose
from racer.shared.sim.tracks.track import Track

OBSTACLE_NAME_PREFIX = "obstacle"
"""The SimApp's prefix: a crash into an object whose name has it always counts (static obstacle)."""
END_GAP_M = 1.0
"""Generated obstacles (and bot cars) end this far before the lap's end."""


def obstacle_dists_and_lanes(
    track: Track, challenge: ChallengeConfig, rng: np.random.Generator
) -> list[tuple[float, str]]:
    """(distance along the centre line in metres, "inner"|"outer") of every obstacle."""
    length_m = track.length_m
    if challenge.object_positions:
        return [(p.ndist * length_m, "inner" if p.lane == INNER_LANE else "outer") for p in challenge.object_positions]
    count = challenge.number_of_obstacles
    if count == 0:
        return []
    spacing_m = challenge.min_distance_between_obstacles / 100.0 * length_m
    dists = spread_along_lap(count, spacing_m, length_m - END_GAP_M, challenge.randomize_obstacle_locations, rng)
    if challenge.randomize_obstacle_locations:
        lanes = ["outer" if rng.integers(2) else "inner" for _ in range(count)]
    else:
        lanes = ["inner" if i % 2 == 0 else "outer" for i in range(count)]
    return list(zip(dists, lanes, strict=True))


def spread_along_lap(
    count: int, start_m: float, end_m: float, randomize: bool, rng: np.random.Generator
) -> list[float]:
    """Equally spaced from start to end; randomised: each (in random order) moved uniformly between its neighbours
    less the spacing `start_m`, as the SimApp does for obstacles and bot cars."""
    dists = np.linspace(start_m, end_m, count)
    if randomize:
        for i in rng.permutation(count):
            lo = start_m if i == 0 else dists[i - 1] + start_m
            hi = end_m if i == count - 1 else dists[i + 1] - start_m
            if lo < hi:
                dists[i] = rng.uniform(lo, hi)
    return [float(d) for d in dists]


def place_obstacles(track: Track, challenge: ChallengeConfig, rng: np.random.Generator) -> list[ObjectPose]:
    """This episode's obstacles, named obstacle_0, obstacle_1, ... (boxes, or parked bot cars)."""
    kind = ObjectKind.BOT_CAR if challenge.is_obstacle_bot_car else ObjectKind.BOX_OBSTACLE
    objects = []
    for i, (dist_m, lane) in enumerate(obstacle_dists_and_lanes(track, challenge, rng)):
        x, y, yaw = track.pose_at(dist_m / track.length_m, lane)
        objects.append(ObjectPose(f"{OBSTACLE_NAME_PREFIX}_{i}", kind, x, y, yaw))
    return objects
