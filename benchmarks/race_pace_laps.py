"""What `python -m benchmarks race-pace` reads from a run's checkpoint evaluations: the best lap without a reset, the best
average of 3 consecutive laps without a reset, when each was first reached, the curve of bests against minutes, and
how the last checkpoint compares.

Each evaluation is worker 0's continuous run of a checkpoint (RACER_EVAL_CONTINUOUS: up to 3 laps from the start line,
the first reset rule ending the run), so every completed lap is a lap without a reset and an evaluation that completed
all its laps is 3 consecutive laps without one.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from racer.shared.deepracer.episode_status import EpisodeStatus

CONSECUTIVE_LAPS = 3
"""DeepRacer's evaluation: three laps (NUMBER_OF_TRIALS)."""
LAP_COMPLETE = EpisodeStatus.LAP_COMPLETE.value
RESET_STATUSES = frozenset(
    status.value
    for status in (EpisodeStatus.OFF_TRACK, EpisodeStatus.CRASHED, EpisodeStatus.REVERSED, EpisodeStatus.IMMOBILIZED)
)
"""The reset rules' statuses: a lap ending in one of them is a lap with a reset (the step cap's in_progress is not)."""


@dataclass(frozen=True)
class CheckpointLaps:
    """One checkpoint's evaluation as the bench saw it arrive."""

    minutes: float
    """Wall minutes from the bench's start until the evaluation's record arrived (training and evaluation in it)."""
    env_steps: int | None
    """Training env steps behind the checkpoint."""
    checkpoint: str
    lap_times_s: tuple[float | None, ...]
    """Each lap of the run; None for the lap a reset rule (or the step cap) ended."""
    statuses: tuple[str, ...]
    progresses: tuple[float, ...]
    """Each lap's progress (%) when it ended: 100 for a completed one."""

    @classmethod
    def from_record(cls, record: Mapping, minutes: float) -> CheckpointLaps:
        """From an `evaluations` stream record (racer.rollout_worker.training_log); a record without per-lap times is
        refused, naming the setting that gives them."""
        if "lap_times_s" not in record or not record.get("continuous"):
            raise ValueError(
                f"evaluation of {record.get('checkpoint')!r} has no consecutive laps: the run's workers.json needs "
                "RACER_EVAL_CONTINUOUS True"
            )
        return cls(
            minutes=minutes,
            env_steps=record.get("env_steps_total"),
            checkpoint=str(record["checkpoint"]),
            lap_times_s=tuple(None if t is None else float(t) for t in record["lap_times_s"]),
            statuses=tuple(str(s) for s in record["statuses"]),
            progresses=tuple(float(p) for p in record.get("progresses", ())),
        )

    @property
    def completed_laps_s(self) -> tuple[float, ...]:
        return tuple(t for t, s in zip(self.lap_times_s, self.statuses, strict=True) if s == LAP_COMPLETE and t)

    @property
    def best_lap_s(self) -> float | None:
        return min(self.completed_laps_s, default=None)

    @property
    def average_s(self) -> float | None:
        """The mean of its laps when it drove CONSECUTIVE_LAPS without a reset, else None."""
        laps = self.completed_laps_s
        return sum(laps) / len(laps) if len(laps) >= CONSECUTIVE_LAPS else None

    @property
    def ended_by(self) -> str:
        """How the run ended: `lap_complete` (all its laps), else the status of the lap that ended it."""
        return self.statuses[-1] if self.statuses else "none"

    def summary(self) -> dict:
        return {
            "checkpoint": self.checkpoint,
            "minutes": round(self.minutes, 2),
            "env_steps": self.env_steps,
            "laps_s": [None if t is None else round(t, 3) for t in self.lap_times_s],
            "ended_by": self.ended_by,
        }


@dataclass(frozen=True)
class FirstReached:
    """A best value and the evaluation that first reached it."""

    value_s: float
    minutes: float
    env_steps: int | None
    checkpoint: str

    def summary(self) -> dict:
        return {
            "seconds": round(self.value_s, 3),
            "minutes": round(self.minutes, 2),
            "env_steps": self.env_steps,
            "checkpoint": self.checkpoint,
        }


def best_lap(evaluations: Sequence[CheckpointLaps]) -> FirstReached | None:
    """The fastest lap without a reset, and the first evaluation that drove it (an equal lap later is no news)."""
    return _first_best(evaluations, lambda evaluation: evaluation.best_lap_s)


def best_average(evaluations: Sequence[CheckpointLaps]) -> FirstReached | None:
    """The best average of 3 consecutive laps without a reset, and the first evaluation that drove it."""
    return _first_best(evaluations, lambda evaluation: evaluation.average_s)


def _first_best(evaluations: Sequence[CheckpointLaps], value) -> FirstReached | None:
    best: FirstReached | None = None
    for evaluation in evaluations:
        seconds = value(evaluation)
        if seconds is not None and (best is None or seconds < best.value_s):
            best = FirstReached(seconds, evaluation.minutes, evaluation.env_steps, evaluation.checkpoint)
    return best


@dataclass(frozen=True)
class LapOfCheckpoint:
    """Which lap of which evaluation: what the picture drives again."""

    checkpoint: str
    lap_index: int
    lap_time_s: float | None
    progress: float | None


def lap_to_draw(evaluations: Sequence[CheckpointLaps]) -> LapOfCheckpoint | None:
    """The best lap without a reset, first reached; before any, the furthest a run got (its last lap's progress)."""
    lap = best_lap(evaluations)
    if lap is not None:
        evaluation = next(e for e in evaluations if e.checkpoint == lap.checkpoint)
        return LapOfCheckpoint(lap.checkpoint, evaluation.lap_times_s.index(lap.value_s), lap.value_s, 100.0)
    furthest = None
    for evaluation in evaluations:
        if evaluation.progresses and (furthest is None or evaluation.progresses[-1] > furthest.progresses[-1]):
            furthest = evaluation
    if furthest is None:
        return None
    index = len(furthest.progresses) - 1
    return LapOfCheckpoint(furthest.checkpoint, index, furthest.lap_times_s[index], furthest.progresses[-1])


def curve(evaluations: Sequence[CheckpointLaps]) -> list[dict]:
    """The best lap and best 3-lap average so far at each evaluation: the run's progress against wall minutes."""
    points = []
    for index, evaluation in enumerate(evaluations):
        lap, average = best_lap(evaluations[: index + 1]), best_average(evaluations[: index + 1])
        points.append(
            {
                "minutes": round(evaluation.minutes, 2),
                "env_steps": evaluation.env_steps,
                "best_lap_s": None if lap is None else round(lap.value_s, 3),
                "best_average_s": None if average is None else round(average.value_s, 3),
            }
        )
    return points


def pace_figures(evaluations: Sequence[CheckpointLaps]) -> dict:
    """The bench's figures from the run's evaluations, in the order they arrived."""
    lap, average = best_lap(evaluations), best_average(evaluations)
    last = evaluations[-1] if evaluations else None
    last_average = None if last is None else last.average_s
    return {
        "best_lap": None if lap is None else lap.summary(),
        "best_three_lap_average": None if average is None else average.summary(),
        "last_checkpoint": None if last is None else last.checkpoint,
        "last_three_lap_average_s": None if last_average is None else round(last_average, 3),
        "last_to_best_average": (
            None if last_average is None or average is None else round(last_average / average.value_s, 4)
        ),
        "evaluations": len(evaluations),
        "evaluations_ended_by_a_reset": sum(1 for e in evaluations if e.ended_by in RESET_STATUSES),
        "laps_completed": sum(len(e.completed_laps_s) for e in evaluations),
        "curve": curve(evaluations),
        "checkpoints": [e.summary() for e in evaluations],
    }
