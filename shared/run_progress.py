"""How far a training run is and how long it has left: the figures `racer train` prints and the viewer shows.

The trainer measures them after each iteration, since it owns both stop conditions (the episode limit, resolved from
`--max-episodes` or the hyperparameters' `term_cond_max_episodes`, and the clock `--max-minutes` counts on), and puts
them into the iteration's summary as `progress` (racer.trainer.iteration_summary): the summary goes to the run's
iterations log in the store and onto the run's `iterations` stream in Redis, so the terminal and the viewer show the
same numbers. Between iterations both count on from the measurement (`RunProgress.at`).

The estimate of the time left, `remaining_s`, is the sooner of the two stops:

- the time limit: `60 * max_minutes - elapsed_s` (the trainer stops within one update's grace of it);
- the episode limit: the iterations still needed to reach it (`ceil(episodes left / episodes per iteration)`; the
  trainer checks the limit after each whole iteration) times the recent pace, the mean length of the last
  `PACE_WINDOW` iterations. The first iteration's length is counted from the trainer's start, so it includes the
  set-up, and the first estimate runs long; later ones use iteration lengths alone, and a run that speeds up or slows
  down (a worker lost, a second one joining) is followed within a few iterations.

The evaluation worker 0 runs on the last checkpoint after the stop is not part of the estimate.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import asdict, dataclass, replace

PACE_WINDOW = 5
"""Iterations the pace is averaged over: short enough to follow a change of speed, long enough to smooth one slow
iteration (a checkpoint upload, an evaluation on the same cores)."""

STOPS_BY_TIME = "time"
STOPS_BY_EPISODES = "episodes"


@dataclass(frozen=True)
class StopCondition:
    """When the trainer stops: after `max_episodes` training episodes or `max_minutes` of its wall time."""

    max_episodes: int
    max_minutes: float | None = None
    episodes_per_iteration: int = 1


def clock(seconds: float) -> str:
    """`754.2` -> `12:34`, `4000` -> `1:06:40` (what people read on a run's clock)."""
    whole = max(0, int(seconds))
    hours, rest = divmod(whole, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


@dataclass(frozen=True)
class RunProgress:
    """One measurement: after `iteration`, at `elapsed_s` of the trainer's clock (wall time `measured_at`)."""

    iteration: int
    """The iteration just trained (from 0)."""
    elapsed_s: float
    episodes: int
    """Training episodes played so far (also those beyond DeepRacer's memory cap: they count towards the limit)."""
    max_episodes: int
    max_minutes: float | None
    remaining_s: float
    """Estimated time left until the trainer stops (module docstring)."""
    stops_by: str
    """`time` or `episodes`: the limit the estimate expects to stop the run."""
    measured_at: float
    """Unix time of the measurement; whoever shows it later counts on from here."""

    @property
    def fraction_done(self) -> float:
        """The share of the limit that stops the run that is used up, 0..1."""
        if self.stops_by == STOPS_BY_TIME and self.max_minutes:
            return min(1.0, self.elapsed_s / (60 * self.max_minutes))
        return min(1.0, self.episodes / max(1, self.max_episodes))

    def at(self, now: float) -> RunProgress:
        """The same run `now` (Unix time), assuming it went on at the measured pace."""
        passed_s = max(0.0, now - self.measured_at)
        return replace(
            self,
            elapsed_s=self.elapsed_s + passed_s,
            remaining_s=max(0.0, self.remaining_s - passed_s),
            measured_at=max(now, self.measured_at),
        )

    def describe(self) -> str:
        """`3:20 of 10:00, about 6:40 left` (time limit) or `16/1000 episodes, about 12:05 left`: what `racer train`
        adds to its lines; `..., stopping` once the limit is reached (the trainer saves and evaluates a last time)."""
        if self.stops_by == STOPS_BY_TIME and self.max_minutes:
            used = f"{clock(self.elapsed_s)} of {clock(60 * self.max_minutes)}"
        else:
            used = f"{self.episodes}/{self.max_episodes} episodes"
        return f"{used}, about {clock(self.remaining_s)} left" if self.remaining_s >= 1 else f"{used}, stopping"

    def to_dict(self) -> dict:
        return {**asdict(self), "fraction_done": round(self.fraction_done, 4)}

    @classmethod
    def from_dict(cls, data: dict) -> RunProgress:
        """The inverse of to_dict; KeyError/TypeError/ValueError on a record that is not one."""
        return cls(
            iteration=int(data["iteration"]),
            elapsed_s=float(data["elapsed_s"]),
            episodes=int(data["episodes"]),
            max_episodes=int(data["max_episodes"]),
            max_minutes=None if data.get("max_minutes") is None else float(data["max_minutes"]),
            remaining_s=float(data["remaining_s"]),
            stops_by=str(data["stops_by"]),
            measured_at=float(data["measured_at"]),
        )


class RunPace:
    """The trainer's progress estimator: give it each iteration's end; it keeps the last few for the pace."""

    def __init__(self, condition: StopCondition, window: int = PACE_WINDOW):
        self.condition = condition
        self._ends_s: deque[float] = deque(maxlen=window + 1)
        """Trainer clock at the ends of the last iterations (this trainer process's: a restart starts afresh)."""

    def seconds_per_iteration(self) -> float:
        ends = list(self._ends_s)
        if len(ends) == 1:
            return ends[0]  # the first iteration, set-up included
        return (ends[-1] - ends[0]) / (len(ends) - 1)

    def after_iteration(
        self, iteration: int, elapsed_s: float, episodes: int, measured_at: float | None = None
    ) -> RunProgress:
        """The progress once `iteration` is trained, `elapsed_s` into the trainer's run, with `episodes` played."""
        self._ends_s.append(elapsed_s)
        condition = self.condition
        episodes_left = max(0, condition.max_episodes - episodes)
        iterations_left = math.ceil(episodes_left / max(1, condition.episodes_per_iteration))
        remaining_s, stops_by = iterations_left * self.seconds_per_iteration(), STOPS_BY_EPISODES
        if condition.max_minutes is not None:
            time_left_s = max(0.0, 60 * condition.max_minutes - elapsed_s)
            if time_left_s <= remaining_s:
                remaining_s, stops_by = time_left_s, STOPS_BY_TIME
        return RunProgress(
            iteration=iteration,
            elapsed_s=round(elapsed_s, 3),
            episodes=episodes,
            max_episodes=condition.max_episodes,
            max_minutes=condition.max_minutes,
            remaining_s=round(remaining_s, 3),
            stops_by=stops_by,
            measured_at=time.time() if measured_at is None else measured_at,
        )
