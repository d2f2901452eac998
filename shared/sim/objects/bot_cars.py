"""Bot cars as the SimApp's `BotCarsCtrl` drives them: their lane at BOT_CAR_SPEED, lane changes on its timers.

Each episode the bots restart: equally spaced from MIN_DISTANCE_BETWEEN_BOT_CARS (metres) to 1 m before the lap's
end on alternating lanes (inner first), or spread at random on random lanes (RANDOMIZE_BOT_CAR_LOCATIONS). A bot's
distance along the centre line is `initial + speed · (t − episode start − crashes · PENALTY_SECONDS)`.
With IS_LANE_CHANGE, whenever a bot's last lane change has ended it schedules the next one to end
U(LOWER, UPPER) + LANE_CHANGE_DISTANCE / speed seconds later, so the change itself spans LANE_CHANGE_DISTANCE.

Lanes are periodic cubic splines through the points half-way between each centre waypoint and its border
waypoint, parameterised by their projection on the centre line, as the SimApp's `TrackSpline`. A lane change
blends the two lanes with a smoothstep over its span (zero sideways speed at both ends); the SimApp fits one
spline through waypoints of both lanes instead, which gives a similar S-curve.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from racer.shared.sim.objects.challenge import ChallengeConfig
from racer.shared.sim.objects.obstacles import END_GAP_M, spread_along_lap
from racer.shared.sim.objects.poses import ObjectKind, ObjectPose
from racer.shared.sim.tracks.track import Track

BOT_CAR_NAME_PREFIX = "bot_car"


class LaneSpline:
    """One lane of one driving direction as (x, y) of the distance along the centre line."""

    def __init__(self, track: Track, border: np.ndarray) -> None:
        length_m = track.length_m
        points = (border + track.center_line) / 2.0
        dists = np.array([track.project_normalized(x, y) * length_m for x, y in points])
        if track.is_loop:
            points, dists = points[:-1], dists[:-1]
            # Projections near the start may land at the end of the lap and vice versa (TrackSpline's unwrapping).
            half = 0.5 * length_m
            first = np.argmax(dists < half)
            dists[:first] -= length_m
            last = len(dists) - 1 - np.argmax(dists[::-1] > half)
            dists[last + 1 :] += length_m
            order = np.argsort(dists, kind="stable")
            dists, points = dists[order], points[order]
            keep = np.concatenate(([True], np.diff(dists) > 1e-9))
            dists, points = dists[keep], points[keep]
            # Close the curve one lap later.
            dists = np.append(dists, dists[0] + length_m)
            points = np.vstack((points, points[:1]))
            self._spline = CubicSpline(dists, points, bc_type="periodic")
        else:
            order = np.argsort(dists, kind="stable")
            dists, points = dists[order], points[order]
            keep = np.concatenate(([True], np.diff(dists) > 1e-9))
            self._spline = CubicSpline(dists[keep], points[keep])
        self._start_m = float(dists[0])
        self._length_m = length_m
        self._is_loop = track.is_loop
        # The spline's pieces as Python lists: one step evaluates a few points, where SciPy's call overhead would
        # cost more than the arithmetic.
        self._breaks = [float(b) for b in self._spline.x]
        self._coeffs = self._spline.c.transpose(1, 2, 0).tolist()  # [piece][x|y][c3, c2, c1, c0]

    def _u(self, dist_m: float) -> float:
        if self._is_loop:
            return self._start_m + (dist_m - self._start_m) % self._length_m
        return dist_m

    def point_and_tangent(self, dist_m: float) -> tuple[float, float, float, float]:
        """(x, y) and d(x, y)/d(distance) at a distance along the centre line, as plain floats (x, y, dx, dy)."""
        u = self._u(dist_m)
        i = min(max(bisect.bisect_right(self._breaks, u) - 1, 0), len(self._coeffs) - 1)
        h = u - self._breaks[i]
        (a3, a2, a1, a0), (b3, b2, b1, b0) = self._coeffs[i]
        return (
            ((a3 * h + a2) * h + a1) * h + a0,
            ((b3 * h + b2) * h + b1) * h + b0,
            (3 * a3 * h + 2 * a2) * h + a1,
            (3 * b3 * h + 2 * b2) * h + b1,
        )


def smoothstep(fraction: float) -> tuple[float, float]:
    """(s, ds/dfraction) of 3f² − 2f³ on [0, 1]."""
    f = min(max(fraction, 0.0), 1.0)
    return f * f * (3.0 - 2.0 * f), 6.0 * f * (1.0 - f)


@dataclass
class _Bot:
    initial_dist_m: float
    lane: str
    other_lane: str
    change_end_s: float
    """Sim time (since the episode start) when the current or last lane change ends; inf without lane changes."""
    change: tuple[float, float] | None = None
    """(start, end) centre-line distance of the lane change under way, or None while following `lane`."""


class BotCars:
    """The bot cars of one env: `restart()` at each episode, `advance()` on each running step."""

    def __init__(self, challenge: ChallengeConfig) -> None:
        self.challenge = challenge
        self._lanes: dict[int, dict[str, LaneSpline]] = {}
        self._bots: list[_Bot] = []
        self._track: Track | None = None
        self._crash_count = 0
        self._paused_until_s = 0.0
        self._objects: list[ObjectPose] = []
        self._lane_change_duration_s = challenge.lane_change_distance_m / challenge.bot_car_speed_mps

    @property
    def objects(self) -> list[ObjectPose]:
        """Where the bots are now (unchanged while they pause)."""
        return self._objects

    def restart(self, track: Track, rng: np.random.Generator) -> list[ObjectPose]:
        """New start positions and lanes; the episode clock starts at 0."""
        challenge = self.challenge
        self._track = track
        if id(track) not in self._lanes:
            self._lanes[id(track)] = {
                "inner": LaneSpline(track, track.inner_border),
                "outer": LaneSpline(track, track.outer_border),
            }
        count = challenge.number_of_bot_cars
        spacing_m = challenge.min_distance_between_bot_cars_m
        dists = spread_along_lap(
            count, spacing_m, track.length_m - END_GAP_M, challenge.randomize_bot_car_locations, rng
        )
        if challenge.randomize_bot_car_locations:
            lanes = ["outer" if rng.integers(2) else "inner" for _ in range(count)]
        else:
            lanes = ["inner" if i % 2 == 0 else "outer" for i in range(count)]
        first_end = 0.0 if challenge.is_lane_change else math.inf
        self._bots = [
            _Bot(d, lane, "outer" if lane == "inner" else "inner", first_end)
            for d, lane in zip(dists, lanes, strict=True)
        ]
        self._crash_count = 0
        self._paused_until_s = 0.0
        self._objects = [self._pose(i, bot, 0.0) for i, bot in enumerate(self._bots)]
        return self._objects

    def advance(self, episode_time_s: float, rng: np.random.Generator) -> list[ObjectPose]:
        """Move the bots to their place at `episode_time_s` (seconds since the episode start)."""
        if episode_time_s < self._paused_until_s:
            return self._objects
        for bot in self._bots:
            if episode_time_s >= bot.change_end_s:
                self._schedule_lane_change(bot, episode_time_s, rng)
        self._objects = [self._pose(i, bot, episode_time_s) for i, bot in enumerate(self._bots)]
        return self._objects

    def rear_ended(self, episode_time_s: float) -> None:
        """A bot ran into the agent from behind: every bot stops for PENALTY_SECONDS (SimApp: one shared pause).
        While they stand, further contact changes nothing (the SimApp judges bot crashes only while they run)."""
        if episode_time_s < self._paused_until_s:
            return
        penalty_s = self.challenge.penalty_seconds
        self._crash_count += 1
        self._paused_until_s = episode_time_s + penalty_s
        for bot in self._bots:
            bot.change_end_s += penalty_s

    def progress(self, bot_object: ObjectPose) -> float:
        """The bot's progress as the SimApp judges a crash: its front point's share of the lap, in percent."""
        assert self._track is not None
        front_x = bot_object.x_m + 0.14 * math.cos(bot_object.yaw_rad)
        front_y = bot_object.y_m + 0.14 * math.sin(bot_object.yaw_rad)
        return self._track.project_normalized(front_x, front_y) * 100.0

    def _dist_m(self, bot: _Bot, episode_time_s: float) -> float:
        assert self._track is not None
        driving_s = max(episode_time_s - self._crash_count * self.challenge.penalty_seconds, 0.0)
        return (bot.initial_dist_m + driving_s * self.challenge.bot_car_speed_mps) % self._track.length_m

    def _schedule_lane_change(self, bot: _Bot, now_s: float, rng: np.random.Generator) -> None:
        if bot.change is not None:
            bot.lane, bot.other_lane = bot.other_lane, bot.lane
            bot.change = None
        challenge = self.challenge
        end_s = now_s + rng.uniform(challenge.lower_lane_change_time_s, challenge.upper_lane_change_time_s)
        end_s += self._lane_change_duration_s
        bot.change_end_s = end_s
        bot.change = (self._dist_m(bot, end_s - self._lane_change_duration_s), self._dist_m(bot, end_s))

    def _pose(self, index: int, bot: _Bot, episode_time_s: float) -> ObjectPose:
        assert self._track is not None
        lanes = self._lanes[id(self._track)]
        dist_m = self._dist_m(bot, episode_time_s)
        x, y, tx, ty = lanes[bot.lane].point_and_tangent(dist_m)
        if bot.change is not None:
            start_m, end_m = bot.change
            length_m = self._track.length_m
            span_m = (end_m - start_m) % length_m
            into_m = (dist_m - start_m) % length_m
            if into_m > 0.5 * length_m:  # not started yet: it is behind the change's start
                into_m = 0.0
            if span_m > 0:
                s, ds = smoothstep(into_m / span_m)
                end_x, end_y, end_tx, end_ty = lanes[bot.other_lane].point_and_tangent(dist_m)
                slope = ds / span_m
                tx = (1 - s) * tx + s * end_tx + slope * (end_x - x)
                ty = (1 - s) * ty + s * end_ty + slope * (end_y - y)
                x = (1 - s) * x + s * end_x
                y = (1 - s) * y + s * end_y
        return ObjectPose(
            f"{BOT_CAR_NAME_PREFIX}_{index}",
            ObjectKind.BOT_CAR,
            x,
            y,
            math.atan2(ty, tx),
            self.challenge.bot_car_speed_mps,
        )
