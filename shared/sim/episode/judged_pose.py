"""What a step knows of the pose it judges: the car's pose, the track geometry of its front-of-car point and the
on-track flag per wheel (remembered for one state of the joints), and the reward params of that pose."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from racer.shared.sim.reward.params import make_reward_params

if TYPE_CHECKING:
    from racer.shared.sim.car.vehicle import Car, CarPose
    from racer.shared.sim.episode.phase import StepVerdict
    from racer.shared.sim.objects.poses import ObjectPose
    from racer.shared.sim.objects.track_objects import TrackObjects
    from racer.shared.sim.scene._mujoco import mujoco
    from racer.shared.sim.sensors.spaces import ChosenAction
    from racer.shared.sim.tracks.track import PointGeometry, Track


class PoseJudge:
    """The judged pose of one car in one simulation.

    Remembered for one state of the joints: `step()` computes it for the frame it starts rendering, and the next
    `step()` finds it here when nothing moved the car in between (a teleport or reset changes qpos).
    """

    def __init__(self, car: Car, data: mujoco.MjData) -> None:
        self._car = car
        self._data = data
        self._cache: tuple[tuple, tuple[CarPose, PointGeometry, np.ndarray]] | None = None

    def judge(self, track: Track) -> tuple[CarPose, PointGeometry, np.ndarray]:
        """The car's pose, the track geometry of its front-of-car point and the on-track flag per wheel."""
        key = (track, self._data.qpos.tobytes())
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        pose = self._car.pose(self._data)
        result = (pose, track.point_geometry(*pose.model_point), track.contains_points(pose.wheel_xs, pose.wheel_ys))
        self._cache = (key, result)
        return result


def judged_reward_params(
    track: Track,
    pose: CarPose,
    geometry: PointGeometry,
    chosen: ChosenAction,
    verdict: StepVerdict,
    all_on: bool,
    any_on: bool,
    steps: float,
    now_s: float,
    track_objects: TrackObjects | None,
    bot_poses: list[ObjectPose],
) -> dict[str, Any]:
    """The reward params of the judged pose, with the objects where they stood then."""
    objects, objects_track = track_objects.reward_view(bot_poses) if track_objects is not None else ((), None)
    mx, my = pose.model_point
    return make_reward_params(
        track,
        x=mx,
        y=my,
        heading_deg=math.degrees(pose.yaw_rad),
        speed_mps=chosen.speed_mps,
        steering_angle_deg=chosen.steering_deg,
        steps=steps,
        progress=verdict.progress,
        all_wheels_on_track=all_on,
        is_offtrack=not any_on,
        is_crashed=verdict.is_crashed,
        sim_time_s=now_s,
        objects=objects,
        geometry=geometry,
        objects_track=objects_track,
    )
