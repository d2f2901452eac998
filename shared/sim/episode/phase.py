"""`PhaseMachine`: what one env step decides before the physics, as the SimApp's agent does (deepracer-simapp v5.3.3
`bundle/markov/agent_ctrl/rollout_agent_ctrl.py`).

An episode starts with one `prepare` step, then RUN steps (`in_progress`) until a rule ends the episode or breaks a
rule with resets left: then the car is put back and held for the rule's penalty (`pause` steps), and runs again. This
module keeps that state (phase, progress of the previous step, resets used, penalty left, where to respawn) and judges
each step's pose; the env then drives the car as the verdict says.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from racer.shared.deepracer.episode_status import EpisodeStatus
from racer.shared.sim.car.vehicle import MAX_SPEED_MPS, Car, CarPose
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.episode import reset_rules as rules
from racer.shared.sim.objects.collisions import CrashVerdict
from racer.shared.sim.objects.track_objects import TrackObjects
from racer.shared.sim.tracks.track import PointGeometry, Track, compute_progress

PENALTY_STATUSES = (EpisodeStatus.CRASHED, EpisodeStatus.OFF_TRACK, EpisodeStatus.IMMOBILIZED, EpisodeStatus.REVERSED)
"""The rules that pause and reset the car while resets are left, and end the episode otherwise."""


@dataclass(frozen=True, slots=True)
class StepVerdict:
    """What the phase machine decided for one step's judged pose."""

    progress: float
    status: str
    """The row's `episode_status`."""
    run_step: bool
    """A RUN step: the reward function is called (not on `prepare` and `pause` steps)."""
    drives: bool
    """The chosen action drives the car for this step; otherwise a zero command."""
    hold_pose: tuple[float, float, float] | None
    """During a pause: where the car is held (origin x, y, yaw), put there before the physics."""
    terminated: bool
    is_crashed: bool
    """The reward params' `is_crashed`."""
    pause_duration_s: float
    """The row's `pause_duration`: the penalty left."""


class PhaseMachine:
    """The episode's phases, penalties, reset budget and respawn spot, for one env (its episodes one after another)."""

    # The state of the current episode (set by `start`).
    _track: Track
    start_ndist: float
    """Where the episode started (normalised distance along the route): progress counts from here."""
    _phase: str
    """PREPARE, IN_PROGRESS (the RUN phase) or PAUSE: the phase the next step starts in."""
    _prev_progress: float
    _reset_count: int
    _pause_remaining_s: float
    _respawn_pose: tuple[float, float, float] | None
    _prev_run_origin: tuple[float, float] | None
    """The car's origin at the previous RUN step: the SimApp's respawn takes the lane nearer to it."""
    _last_model_point: tuple[float, float] | None
    _last_on_road_ndist: float | None
    """For `reset_position="where_it_left"`: the last judged point with all four wheels on the road."""

    def __init__(self, config: EnvConfig, track_objects: TrackObjects | None, track: Track, start_ndist: float) -> None:
        self._config = config
        self._track_objects = track_objects
        self._counters = rules.RuleCounters(
            rules.RuleLimits(config.immobilized_steps, config.immobilized_distance_m, config.number_of_reverse_counts)
        )
        self.start(track, start_ndist)

    def start(self, track: Track, start_ndist: float) -> None:
        """A new episode on `track` (in its driving direction) from `start_ndist`: the prepare step comes next."""
        self._track = track
        self.start_ndist = start_ndist
        self._phase = EpisodeStatus.PREPARE
        self._prev_progress = 0.0
        self._reset_count = 0
        self._pause_remaining_s = 0.0
        self._respawn_pose = None
        self._prev_run_origin = None
        self._last_model_point = None
        self._last_on_road_ndist = None
        self._counters.clear()

    def continue_after_lap(self, origin: tuple[float, float], *, renew_reset_budget: bool) -> None:
        """The episode goes on across the finish line: the rules' counters restart, the reset budget maybe too."""
        if renew_reset_budget:
            self._reset_count = 0
        self._counters.clear(origin)

    def judge(
        self,
        pose: CarPose,
        geometry: PointGeometry,
        *,
        all_on: bool,
        any_on: bool,
        objects_time_s: float,
    ) -> StepVerdict:
        """Judge the pose a step starts from (where its observation was taken) and move the phases on.

        `all_on` / `any_on`: all four / any wheel centres on the road; `objects_time_s`: the track objects' clock.
        """
        progress = compute_progress(geometry.ndist, self.start_ndist, self._prev_progress)
        origin = (pose.origin_x_m, pose.origin_y_m)
        phase = self._phase
        status = phase
        terminated = is_crashed = False
        if phase == EpisodeStatus.PREPARE:
            self._counters.clear(origin)
            self._phase = EpisodeStatus.IN_PROGRESS
        elif phase == EpisodeStatus.PAUSE:
            self._count_down_pause(origin)
        else:
            status, is_crashed, terminated = self._judge_run(pose, progress, any_on, objects_time_s)
        self._prev_progress = 0.0 if progress == 100 else progress
        if phase == EpisodeStatus.IN_PROGRESS:
            self._prev_run_origin = origin
        self._remember_where_on_road(phase, pose.model_point, geometry.ndist, all_on)
        pausing = self._phase == EpisodeStatus.PAUSE
        return StepVerdict(
            progress=progress,
            status=status,
            run_step=phase == EpisodeStatus.IN_PROGRESS,
            drives=phase == EpisodeStatus.IN_PROGRESS and not pausing,
            hold_pose=self._respawn_pose if pausing else None,
            terminated=terminated,
            is_crashed=is_crashed,
            pause_duration_s=self._pause_remaining_s,
        )

    def _count_down_pause(self, origin: tuple[float, float]) -> None:
        self._pause_remaining_s -= self._config.step_duration_s
        if self._pause_remaining_s <= 1e-9:
            # The SimApp writes what is left of the penalty, negative on the last pause row when the penalty is not a
            # whole number of steps (a 0 s penalty still spends this one pause step).
            if abs(self._pause_remaining_s) <= 1e-9:
                self._pause_remaining_s = 0.0
            self._phase = EpisodeStatus.IN_PROGRESS
            self._counters.clear(origin)

    def _judge_run(
        self, pose: CarPose, progress: float, any_wheel_on_track: bool, objects_time_s: float
    ) -> tuple[str, bool, bool]:
        """(status, is_crashed, terminated) of a RUN step; a rule broken with resets left starts a pause."""
        self._pause_remaining_s = 0.0  # the SimApp clears it on every RUN step; a pause below sets the penalty
        crash = None
        if self._track_objects is not None:
            crash = self._track_objects.judge_crash(pose, progress, self.start_ndist, objects_time_s)
        status = self._counters.judge(
            progress=progress,
            prev_progress=self._prev_progress,
            origin=(pose.origin_x_m, pose.origin_y_m),
            any_wheel_on_track=any_wheel_on_track,
            crashed=crash is not None and crash.counts,
        )
        is_crashed = False
        if crash is not None:
            # Lap completion wins over a crash (the row says lap_complete, the params is_crashed).
            is_crashed = crash.counts or status == EpisodeStatus.LAP_COMPLETE
            if not crash.counts and status != EpisodeStatus.LAP_COMPLETE:
                status = EpisodeStatus.IN_PROGRESS  # hit from behind by a bot: no other rule is judged
        if status == EpisodeStatus.LAP_COMPLETE:
            return status, is_crashed, True
        if status in PENALTY_STATUSES:
            if self._reset_count >= self._config.number_of_resets:
                return status, is_crashed, True
            self._reset_count += 1
            self._start_pause(status, pose, progress, crash)
        return status, is_crashed, False

    def _start_pause(self, status: str, pose: CarPose, progress: float, crash: CrashVerdict | None) -> None:
        """Pause for the rule's penalty, then continue on a lane at the last progress (deepracer-simapp 01f5f015
        `bundle/markov/agent_ctrl/rollout_agent_ctrl.py` `_get_car_reset_model_state`).

        As the SimApp (`_get_car_reset_model_state`): the spot is the previous step's progress, as a share of the
        lap measured from the route's origin in the driving direction, on whichever lane's spot is nearer to the car's
        pose of the previous step. The pause always lasts at least one step, also for a 0 s penalty.
        """
        cfg = self._config
        self._pause_remaining_s = {
            EpisodeStatus.OFF_TRACK: cfg.off_track_penalty_s,
            EpisodeStatus.CRASHED: cfg.collision_penalty_s,
            EpisodeStatus.REVERSED: cfg.effective_reverse_penalty_s,
            EpisodeStatus.IMMOBILIZED: cfg.immobilized_penalty_s,
        }[status]
        self._phase = EpisodeStatus.PAUSE
        self._respawn_pose = self._respawn_spot(status, pose, progress, crash)

    def _respawn_spot(
        self, status: str, pose: CarPose, progress: float, crash: CrashVerdict | None
    ) -> tuple[float, float, float]:
        track = self._track
        if crash is not None and not crash.static:
            # A crash into a bot car ahead: the car waits where it is.
            return (pose.origin_x_m, pose.origin_y_m, pose.yaw_rad)
        if self._track_objects is not None:
            # Near a static obstacle the SimApp resets behind it on the other lane (or ahead: mercy rule); a crash
            # measures from the progress of this step, the other rules from the previous step's.
            spawn_progress = progress if status == EpisodeStatus.CRASHED else self._prev_progress
            spot = self._track_objects.reset_pose(track, spawn_progress / 100.0 * track.length_m)
            if spot is not None:
                return spot
        if self._config.reset_position == "where_it_left" and self._last_on_road_ndist is not None:
            # The seed's summit-rule code: back half the last step from where the car left, on the centre line.
            step_m = math.dist(pose.model_point, self._last_model_point or pose.model_point)
            half_step_m = 0.5 * min(step_m, MAX_SPEED_MPS * self._config.step_duration_s)  # a step is ≤ 4 m/s long
            # pose_at places the car's origin; its front (the judged point) is Car.FRONT_OF_CAR_M further on.
            ndist = self._last_on_road_ndist - (half_step_m + Car.FRONT_OF_CAR_M) / track.length_m
            return track.pose_at(ndist, "center")
        ndist = self._prev_progress / 100.0
        inner = track.pose_at(ndist, "inner")
        outer = track.pose_at(ndist, "outer")
        previous = self._prev_run_origin or (pose.origin_x_m, pose.origin_y_m)
        return inner if math.dist(inner[:2], previous) < math.dist(outer[:2], previous) else outer

    def _remember_where_on_road(self, phase: str, model_point: tuple[float, float], ndist: float, all_on: bool) -> None:
        if phase == EpisodeStatus.PAUSE:
            self._last_model_point = None
            return
        if all_on:
            self._last_on_road_ndist = ndist
        self._last_model_point = model_point
