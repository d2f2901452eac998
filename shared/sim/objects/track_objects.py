"""`TrackObjects`: the obstacles and bot cars of one env, what the env asks of them each episode and step.

The env stays a time-trial env that calls this when `ChallengeConfig.has_objects`: the objects' poses (for the scene's
bodies, the sensors, the reward params and the crash test), the start lane, the reset spot near an obstacle
(with the mercy rule) and the bots' pause after they hit the agent.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from racer.shared.sim.car.vehicle import CarPose
from racer.shared.sim.objects.bodies import ObjectSlot
from racer.shared.sim.objects.bot_cars import BOT_CAR_NAME_PREFIX, BotCars
from racer.shared.sim.objects.challenge import ChallengeConfig
from racer.shared.sim.objects.collisions import CrashVerdict, collided_object, judge_crash, start_line_progress
from racer.shared.sim.objects.moving_projection import MovingProjection
from racer.shared.sim.objects.obstacles import OBSTACLE_NAME_PREFIX, place_obstacles
from racer.shared.sim.objects.poses import ObjectKind, ObjectPose
from racer.shared.sim.reward.params import NO_OBJECTS_ON_TRACK, ObjectsOnTrack, RewardObject, objects_on_track
from racer.shared.sim.tracks.track import Track

CLOSEST_OBJ_GAP_M = 1.0
"""An object nearer than this (along the centre line) to a start or reset spot moves the car (SimApp constant)."""


def object_slots(challenge: ChallengeConfig) -> tuple[ObjectSlot, ...]:
    """Every object the run will have: the scene builds one body per slot."""
    kind = ObjectKind.BOT_CAR if challenge.is_obstacle_bot_car else ObjectKind.BOX_OBSTACLE
    obstacles = tuple(ObjectSlot(f"{OBSTACLE_NAME_PREFIX}_{i}", kind) for i in range(challenge.num_obstacles))
    bots = tuple(
        ObjectSlot(f"{BOT_CAR_NAME_PREFIX}_{i}", ObjectKind.BOT_CAR) for i in range(challenge.number_of_bot_cars)
    )
    return obstacles + bots


class TrackObjects:
    def __init__(self, challenge: ChallengeConfig) -> None:
        self.challenge = challenge
        self._bots = BotCars(challenge) if challenge.number_of_bot_cars else None
        self._obstacles: list[ObjectPose] = []
        self._track: Track | None = None
        self._last_obstacle: str | None = None
        self._obstacles_view: tuple[list[RewardObject], ObjectsOnTrack] = ([], NO_OBJECTS_ON_TRACK)
        """The reward params' view of the static obstacles, computed once per episode (they do not move)."""
        self._bots_view: tuple[list[ObjectPose], list[RewardObject], ObjectsOnTrack] | None = None
        """The bots' view, for the pose list it was computed from (the same list until the bots move)."""
        self._bot_projection: MovingProjection | None = None
        self.obstacle_crash_count = 0
        """The simtrace's obstacle_crash_counter: resets behind the same obstacle in a row (mercy rule only)."""

    @property
    def slots(self) -> tuple[ObjectSlot, ...]:
        """The scene's bodies for these objects (`object_slots`)."""
        return object_slots(self.challenge)

    @property
    def objects(self) -> list[ObjectPose]:
        return self._obstacles + (self._bots.objects if self._bots else [])

    def restart(self, track: Track, rng: np.random.Generator) -> list[ObjectPose]:
        """A new episode: obstacles placed again (the same unless randomised), bots back at their starts."""
        self._track = track
        self._obstacles = place_obstacles(track, self.challenge, rng)
        obstacles = self._to_reward_objects(self._obstacles)
        self._obstacles_view = (obstacles, objects_on_track(track, obstacles))
        self._bots_view = None
        if self._bots is not None:
            self._bots.restart(track, rng)
            self._bot_projection = MovingProjection(track, self.challenge.number_of_bot_cars)
        self._last_obstacle = None
        self.obstacle_crash_count = 0
        return self.objects

    def advance(self, episode_time_s: float, rng: np.random.Generator) -> None:
        if self._bots is not None:
            self._bots.advance(episode_time_s, rng)

    def judge_crash(
        self, pose: CarPose, progress: float, start_ndist: float, episode_time_s: float
    ) -> CrashVerdict | None:
        """The SimApp's crash test on the judged pose and who is at fault; bots that hit the agent stop a while."""
        hit = collided_object(pose.origin_x_m, pose.origin_y_m, pose.yaw_rad, self.objects)
        if hit is None:
            return None
        bot_progress = self._bots.progress(hit) if self._bots is not None else 0.0
        verdict = judge_crash(hit, progress, start_ndist, bot_progress)
        if self._bots is not None and not verdict.static and start_line_progress(progress, start_ndist) > bot_progress:
            self._bots.rear_ended(episode_time_s)
        return verdict

    def bot_poses(self) -> list[ObjectPose]:
        """The bots' poses now, to hand to `reward_view` later: the list stays as it is when the bots move on (the env
        computes the reward params' view while the next frame renders)."""
        return self._bots.objects if self._bots is not None else []

    def reward_view(self, bot_poses: list[ObjectPose]) -> tuple[list[RewardObject], ObjectsOnTrack]:
        """The objects as the reward params see them (with bot cars present every object reports BOT_CAR_SPEED, as
        the SimApp) and their centre-line facts (`objects_on_track`): the static obstacles' from the episode's start,
        the bots' from `bot_poses` (`bot_poses()` of the judged instant)."""
        obstacles, obstacles_track = self._obstacles_view
        if self._bots is None:
            return list(obstacles), obstacles_track
        if self._bots_view is None or self._bots_view[0] is not bot_poses:
            assert self._track is not None
            bots = self._to_reward_objects(bot_poses)
            self._bots_view = (bot_poses, bots, objects_on_track(self._track, bots, self._bot_projection))
        _, bots, bots_track = self._bots_view
        return obstacles + bots, obstacles_track + bots_track

    def _to_reward_objects(self, objects: Sequence[ObjectPose]) -> list[RewardObject]:
        speed = self.challenge.bot_car_speed_mps if self.challenge.number_of_bot_cars else 0.0
        return [
            RewardObject(
                o.x_m,
                o.y_m,
                o.yaw_rad,
                speed,
                is_bot_car=o.name.startswith(BOT_CAR_NAME_PREFIX),
                length_m=o.size.length_m,
                width_m=o.size.width_m,
            )
            for o in objects
        ]

    def _closest(self, track: Track, dist_m: float, obstacles_only: bool) -> tuple[float, ObjectPose] | None:
        """The object nearest along the centre line within CLOSEST_OBJ_GAP_M of `dist_m` (SimApp `_get_closest_obj`)."""
        best: tuple[float, ObjectPose] | None = None
        gap_limit = CLOSEST_OBJ_GAP_M
        candidates: Sequence[ObjectPose] = self._obstacles if obstacles_only else self.objects
        for obj in candidates:
            obj_dist = track.project_normalized(obj.x_m, obj.y_m) * track.length_m
            # The SimApp's gap, kept as it is: not the circular one, so an object just across the start line from
            # `dist_m` is not found.
            gap = abs(obj_dist - dist_m) % track.length_m
            if gap < gap_limit:
                gap_limit, best = gap, (obj_dist, obj)
        return best

    def start_pose(self, track: Track, start_ndist: float) -> tuple[float, float, float] | None:
        """A training start with an object within 1 m: the lane away from the object; None = the centre line."""
        found = self._closest(track, start_ndist * track.length_m, obstacles_only=False)
        if found is None:
            return None
        lane = "outer" if track.nearer_lane(found[1].x_m, found[1].y_m) == "inner" else "inner"
        return track.pose_at(start_ndist, lane)

    def reset_pose(self, track: Track, spawn_dist_m: float) -> tuple[float, float, float] | None:
        """Where a reset near a static obstacle puts the car: RESET_BEHIND_DIST behind it on the other lane, or with
        ENABLE_MERCY_RESET RESET_AHEAD_DIST ahead of it after MAX_RESETS_AFTER_CRASH resets behind the same one.
        None = no obstacle within 1 m of the spot (the env's usual reset)."""
        found = self._closest(track, spawn_dist_m, obstacles_only=True)
        if found is None:
            return None
        obj_dist_m, obj = found
        challenge = self.challenge
        dist_m = obj_dist_m - challenge.reset_behind_dist_m
        if challenge.enable_mercy_reset:
            if self._last_obstacle != obj.name:
                self._last_obstacle, self.obstacle_crash_count = obj.name, 1
            else:
                self.obstacle_crash_count += 1
            if self.obstacle_crash_count == challenge.max_resets_after_crash:
                dist_m = obj_dist_m + challenge.reset_ahead_dist_m
                self.obstacle_crash_count = 0
        lane = "outer" if track.nearer_lane(obj.x_m, obj.y_m) == "inner" else "inner"
        pose = track.pose_at(dist_m / track.length_m, lane)
        return pose if all(math.isfinite(v) for v in pose) else None
