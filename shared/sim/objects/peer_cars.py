"""`PeerCars`: the other cars of a multi-car race (HEAD_TO_MODEL, F1) as one car's env sees them.

Each car of a multi-car race drives its own `DeepRacerEnv`; the env is given a `PeerCars` in place of the
`TrackObjects` its `ChallengeConfig` would make (`DeepRacerEnv(track_objects=...)`). The other cars are drawn as DeepRacer
cars (mocap bodies the cameras and LIDAR see, one slot per other car, named as the SimApp names its agents:
`racecar_<i>`) at the poses the multi-car loop hands over before each step (`update`).

Collisions between cars follow the SimApp (deepracer-simapp v6.0.5 `bundle/markov/agent_ctrl/rollout_agent_ctrl.py`,
`_check_for_episode_termination`; `bundle/markov/track_geom/track_data.py`, `get_collided_object_name`): the same
rectangle test as for bot cars (`collisions.collided_object`), and the car whose progress from the start line is lower
(the one behind) is at fault: it is `crashed` and waits where it is for the collision penalty; the car ahead goes on.
A car serving a penalty is not collidable (the SimApp's blink effect puts it on `noncollidable_objects` for the
penalty, `bundle/markov/visual_effects/effects/blink_effect.py`) but still drawn. racer compares the distance raced
from the line (completed laps + progress) where the SimApp compares the lap shares only, so a lapped car and a car
just behind the line are not mistaken for the car ahead.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from racer.shared.sim.car.vehicle import CarPose
from racer.shared.sim.objects.bodies import ObjectSlot
from racer.shared.sim.objects.challenge import ChallengeConfig
from racer.shared.sim.objects.collisions import CrashVerdict, collided_object
from racer.shared.sim.objects.poses import ObjectKind, ObjectPose
from racer.shared.sim.objects.track_objects import TrackObjects
from racer.shared.sim.reward.params import NO_OBJECTS_ON_TRACK, ObjectsOnTrack, RewardObject, objects_on_track
from racer.shared.sim.tracks.track import Track


def car_name(index: int) -> str:
    """The SimApp's agent name of car `index` in a multi-car run (`racecar_<i>`)."""
    return f"racecar_{index}"


@dataclass(frozen=True)
class PeerState:
    """One car of the race at the instant a step judges, as the other cars see it."""

    index: int
    x_m: float
    y_m: float
    yaw_rad: float
    speed_mps: float
    raced_pct: float
    """Distance raced from the start line in percent of a lap (completed laps x 100 + the lap's progress)."""
    collidable: bool = True
    """False while the car serves a penalty (the SimApp's blink) or once it is parked."""
    on_track: bool = True
    """False once the car is parked off the track (F1): it is neither drawn nor hit."""


class PeerCars(TrackObjects):
    """What one car's env asks of the objects, answered with the other cars of the race."""

    def __init__(self, own_index: int, car_count: int, challenge: ChallengeConfig | None = None) -> None:
        super().__init__(challenge or ChallengeConfig())
        self.own_index = own_index
        self._slots = tuple(ObjectSlot(car_name(i), ObjectKind.BOT_CAR) for i in range(car_count) if i != own_index)
        self._peers: tuple[PeerState, ...] = ()
        self._objects: list[ObjectPose] = []
        self._collidable: list[ObjectPose] = []
        self._raced_by_name: dict[str, float] = {}
        self._view: tuple[list[ObjectPose], list[RewardObject], ObjectsOnTrack] | None = None
        self.own_laps_done = 0
        """Completed laps of this env's car: with a step's progress, its distance raced for the fault rule."""

    @property
    def slots(self) -> tuple[ObjectSlot, ...]:
        return self._slots

    @property
    def objects(self) -> list[ObjectPose]:
        return self._objects

    def update(self, peers: Sequence[PeerState]) -> None:
        """The other cars where they are now (this car's own entry, if given, is left out)."""
        self._peers = tuple(p for p in peers if p.index != self.own_index)
        on_track = [p for p in self._peers if p.on_track]
        self._objects = [
            ObjectPose(car_name(p.index), ObjectKind.BOT_CAR, p.x_m, p.y_m, p.yaw_rad, p.speed_mps) for p in on_track
        ]
        self._collidable = [o for o, p in zip(self._objects, on_track, strict=True) if p.collidable]
        self._raced_by_name = {car_name(p.index): p.raced_pct for p in self._peers}

    def restart(self, track: Track, rng: np.random.Generator) -> list[ObjectPose]:
        self._track = track
        self._view = None
        self.obstacle_crash_count = 0
        return self.objects

    def advance(self, episode_time_s: float, rng: np.random.Generator) -> None:
        """The other cars move in their own envs; the multi-car loop hands their poses over (`update`)."""

    def judge_crash(
        self, pose: CarPose, progress: float, start_ndist: float, episode_time_s: float
    ) -> CrashVerdict | None:
        hit = collided_object(pose.origin_x_m, pose.origin_y_m, pose.yaw_rad, self._collidable)
        if hit is None:
            return None
        own_raced = 100.0 * self.own_laps_done + progress
        return CrashVerdict(hit, own_raced < self._raced_by_name[hit.name])

    def bot_poses(self) -> list[ObjectPose]:
        return self._objects

    def reward_view(self, bot_poses: list[ObjectPose]) -> tuple[list[RewardObject], ObjectsOnTrack]:
        """The other cars in the reward params' `objects_*` keys, as the SimApp lists the other agents."""
        if not bot_poses or self._track is None:
            return [], NO_OBJECTS_ON_TRACK
        if self._view is None or self._view[0] is not bot_poses:
            cars = [
                RewardObject(o.x_m, o.y_m, o.yaw_rad, o.speed_mps, True, o.size.length_m, o.size.width_m)
                for o in bot_poses
            ]
            self._view = (bot_poses, cars, objects_on_track(self._track, cars))
        return list(self._view[1]), self._view[2]
