"""The SimApp's crash test and its priority rules (deepracer-simapp v5.3.3 `bundle/markov/`:
`track_data.get_collided_object_name`,
`rollout_agent_ctrl._check_for_episode_termination`).

A crash is one of the four corners of the agent's rectangle (a DeepRacer car, 0.1961 m wide and 0.32352 m long,
centred on the car's origin) strictly inside another object's rectangle; the first such object in order
(obstacles, then bot cars) is the one hit. Who is at fault: a static obstacle always counts; for a bot car, the
crash counts only when the agent's progress (from the start line, lap share) is lower than the bot's: the agent
ran into it from behind. Otherwise the bot ran into the agent: the agent goes on and the bots stop for a while.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from racer.shared.sim.objects.obstacles import OBSTACLE_NAME_PREFIX
from racer.shared.sim.objects.poses import BOT_CAR_SIZE, SIZES, ObjectPose, ObjectSize


def rectangle_corners(x_m: float, y_m: float, yaw_rad: float, size: ObjectSize) -> list[tuple[float, float]]:
    """The four floor corners of an object's rectangle (length along the heading, width across)."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    half_l, half_w = 0.5 * size.length_m, 0.5 * size.width_m
    return [
        (x_m + c * lx - s * ly, y_m + s * lx + c * ly)
        for lx, ly in ((half_l, half_w), (half_l, -half_w), (-half_l, -half_w), (-half_l, half_w))
    ]


def _inside(obj: ObjectPose, px: float, py: float) -> bool:
    c, s = math.cos(obj.yaw_rad), math.sin(obj.yaw_rad)
    dx, dy = px - obj.x_m, py - obj.y_m
    size = obj.size
    return abs(c * dx + s * dy) < 0.5 * size.length_m and abs(-s * dx + c * dy) < 0.5 * size.width_m


_REACH_M = {
    kind: 0.5 * math.hypot(size.length_m, size.width_m) + 0.5 * math.hypot(BOT_CAR_SIZE.length_m, BOT_CAR_SIZE.width_m)
    for kind, size in SIZES.items()
}
"""Centre distance beyond which an object's rectangle and the car's cannot overlap (half diagonals summed)."""


def collided_object(
    car_x_m: float, car_y_m: float, car_yaw_rad: float, objects: Sequence[ObjectPose]
) -> ObjectPose | None:
    """The first object with a corner of the car's rectangle strictly inside its own, or None."""
    corners: list[tuple[float, float]] | None = None
    for obj in objects:
        reach_m = _REACH_M[obj.kind]
        if abs(obj.x_m - car_x_m) > reach_m or abs(obj.y_m - car_y_m) > reach_m:
            continue
        if corners is None:  # only with an object in reach: most steps have none
            corners = rectangle_corners(car_x_m, car_y_m, car_yaw_rad, BOT_CAR_SIZE)
        if any(_inside(obj, px, py) for px, py in corners):
            return obj
    return None


def is_static(obj: ObjectPose) -> bool:
    """Static obstacles (boxes or parked bot cars) carry the SimApp's obstacle name prefix."""
    return obj.name.startswith(OBSTACLE_NAME_PREFIX)


def start_line_progress(progress: float, start_ndist: float) -> float:
    """Progress measured from the start line instead of the episode's start (SimApp `get_normalized_progress`)."""
    return (progress + start_ndist * 100.0) % 100.0


@dataclass(frozen=True)
class CrashVerdict:
    obj: ObjectPose
    counts: bool
    """True: `crashed` (pause or end); False: the bot hit the agent from behind and the agent goes on."""

    @property
    def static(self) -> bool:
        return is_static(self.obj)


def judge_crash(obj: ObjectPose, agent_progress: float, agent_start_ndist: float, bot_progress: float) -> CrashVerdict:
    """Whether a collision with `obj` ends or pauses the agent's run (`bot_progress` unused for static obstacles)."""
    if is_static(obj):
        return CrashVerdict(obj, True)
    return CrashVerdict(obj, start_line_progress(agent_progress, agent_start_ndist) < bot_progress)
