"""One lap (trial) of an evaluation, as both modes report it: times, progress, the reset rules that fired, status.

Counting follows the SimApp's EvalMetrics: every step whose status is crashed/immobilized/off_track/reversed counts
once for its rule, including the step that ends the lap when the reset budget is used up. `put_backs` counts only
the times the car was put back on the track (what the summit rule limits to 3 per lap).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from racer.evaluation_worker.driver import PENALTY_STATUSES, StepRecord
from racer.shared.deepracer.episode_status import EpisodeStatus


@dataclass(frozen=True)
class LapResult:
    lap_index: int
    """0-based (the simtrace `episode` column)."""
    trial: int
    """EvaluationMetrics `trial`: 1-based count of entries written so far (a time-up entry does not advance it)."""
    status: str
    """Simtrace status string of the lap's last step (`in_progress` for an intermediate lap of a continuous run)."""
    progress_pct: float
    start_time_s: float
    end_time_s: float
    crash_count: int
    immobilized_count: int
    off_track_count: int
    reversed_count: int
    put_backs: int
    steps: int
    total_reward: float
    """Sum of the step rewards (DeepRacer's evaluation reward), as the SimApp logs per evaluation episode."""

    @property
    def elapsed_s(self) -> float:
        """Includes penalty pauses (the simulation clock runs while the car waits)."""
        return self.end_time_s - self.start_time_s

    @property
    def completed(self) -> bool:
        return self.progress_pct >= 100.0

    @property
    def lap_time_s(self) -> float | None:
        return self.elapsed_s if self.completed else None

    @property
    def reset_count(self) -> int:
        return self.crash_count + self.immobilized_count + self.off_track_count + self.reversed_count

    @property
    def label(self) -> str:
        return EpisodeStatus(self.status).label


class LapTally:
    """Accumulates the steps of the current lap."""

    def __init__(self, lap_index: int, start_time_s: float) -> None:
        self.lap_index = lap_index
        self.start_time_s = start_time_s
        self.counts = dict.fromkeys(PENALTY_STATUSES, 0)
        self.put_backs = 0
        self.steps = 0
        self.total_reward = 0.0
        self.last: StepRecord | None = None

    def add(self, record: StepRecord) -> None:
        status = str(record.row["episode_status"])
        if status in self.counts:
            self.counts[status] += 1
        self.put_backs = record.lap_resets
        self.steps += 1
        self.total_reward += record.reward
        self.last = record

    def result(self, trial: int) -> LapResult:
        if self.last is None:
            raise RuntimeError(f"lap {self.lap_index} has no steps")
        row = self.last.row
        return LapResult(
            lap_index=self.lap_index,
            trial=trial,
            status=str(row["episode_status"]),
            progress_pct=float(row["progress"]),
            start_time_s=self.start_time_s,
            end_time_s=float(row["tstamp"]),
            crash_count=self.counts["crashed"],
            immobilized_count=self.counts["immobilized"],
            off_track_count=self.counts["off_track"],
            reversed_count=self.counts["reversed"],
            put_backs=self.put_backs,
            steps=self.steps,
            total_reward=self.total_reward,
        )


def describe_lap(lap: LapResult) -> str:
    """One progress line per lap."""
    time_text = f"{lap.lap_time_s:7.3f} s" if lap.lap_time_s is not None else f"({lap.elapsed_s:6.3f} s)"
    return (
        f"lap {lap.lap_index + 1:3d}: {lap.label:<12} {time_text}  progress {lap.progress_pct:6.2f} %  "
        f"put back {lap.put_backs}  steps {lap.steps}  reward {lap.total_reward:.1f}"
    )


LapCallback = Callable[[LapResult], None]
"""Called as each lap ends (progress lines, the metrics file rewritten after every lap as the SimApp does)."""


def ignore_lap(_lap: LapResult) -> None:
    """Default lap callback."""
