"""DeepRacer's reset rules (deepracer-simapp v5.3.3 `bundle/markov/reset/rules/`): which status a RUN step ends in, from
the pose before the action.

Priority as the SimApp: lap_complete (checked first: a car may go off track on the finish line), crashed,
then off_track, immobilized, reversed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from racer.shared.deepracer.episode_status import EpisodeStatus


@dataclass(frozen=True)
class RuleLimits:
    immobilized_steps: int = 15
    immobilized_distance_m: float = 0.0003
    reverse_steps: int = 15


class RuleCounters:
    """The consecutive-step counters behind `immobilized` and `reversed`."""

    def __init__(self, limits: RuleLimits) -> None:
        self.limits = limits
        self.immobilized_count = 0
        self.reverse_count = 0
        self._last_origin: tuple[float, float] | None = None

    def clear(self, origin: tuple[float, float] | None = None) -> None:
        self.immobilized_count = 0
        self.reverse_count = 0
        self._last_origin = origin

    def judge(
        self,
        *,
        progress: float,
        prev_progress: float,
        origin: tuple[float, float],
        any_wheel_on_track: bool,
        crashed: bool = False,
    ) -> str:
        """Update the counters with one RUN step and return its status."""
        if self._last_origin is not None and math.dist(origin, self._last_origin) <= self.limits.immobilized_distance_m:
            self.immobilized_count += 1
        else:
            self.immobilized_count = 0
        self._last_origin = origin
        self.reverse_count = self.reverse_count + 1 if progress < prev_progress else 0
        if progress >= 100.0:
            return EpisodeStatus.LAP_COMPLETE
        if crashed:
            return EpisodeStatus.CRASHED
        if not any_wheel_on_track:
            return EpisodeStatus.OFF_TRACK
        if self.immobilized_count >= self.limits.immobilized_steps:
            return EpisodeStatus.IMMOBILIZED
        if self.reverse_count >= self.limits.reverse_steps:
            return EpisodeStatus.REVERSED
        return EpisodeStatus.IN_PROGRESS
