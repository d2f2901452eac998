"""DeepRacer on AWS's submission statistics and ranking (ModelPerformanceMetricsHelper.ts, jobFinalizer.ts).

Input: an entrant's EvaluationMetrics entries (one per lap, DeepRacer's keys), in lap order. Times are integer
milliseconds as DRoA stores them; lower wins.

* completedLapCount: the longest run of consecutive completed laps (completion_percentage 100).
* bestLapTime: the fastest completed lap (DRoA takes the minimum over every entry; racer counts completed laps
  only, so a lap cut short by the time limit cannot be "best").
* avgLapTime: the best mean over `minimumLaps` consecutive completed laps, floored to a millisecond.
* totalLapTime: the sum of every lap's elapsed time.
* An entrant is ranked only when completedLapCount >= minimumLaps; the others are listed after, with their reason.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

TIMING_FIELDS = {"BEST_LAP_TIME": "bestLapTime", "AVG_LAP_TIME": "avgLapTime", "TOTAL_TIME": "totalLapTime"}


@dataclass(frozen=True)
class Lap:
    completion_percentage: int
    elapsed_ms: int
    off_track_count: int = 0
    crash_count: int = 0
    reset_count: int = 0

    @property
    def completed(self) -> bool:
        return self.completion_percentage >= 100

    @classmethod
    def from_metrics_entry(cls, entry: Mapping[str, object]) -> Lap:
        return cls(
            completion_percentage=int(entry["completion_percentage"]),  # type: ignore[arg-type]
            elapsed_ms=int(entry["elapsed_time_in_milliseconds"]),  # type: ignore[arg-type]
            off_track_count=int(entry.get("off_track_count", 0)),  # type: ignore[arg-type]
            crash_count=int(entry.get("crash_count", 0)),  # type: ignore[arg-type]
            reset_count=int(entry.get("reset_count", 0)),  # type: ignore[arg-type]
        )


@dataclass(frozen=True)
class SubmissionStats:
    """DRoA's SubmissionStats names (camelCase, as leaderboard.json writes them)."""

    completedLapCount: int
    bestLapTime: int | None
    avgLapTime: int | None
    totalLapTime: int
    resetCount: int
    avgResets: float
    offTrackCount: int
    collisionCount: int
    lapCount: int


def max_consecutive_completed(laps: Sequence[Lap]) -> int:
    best = streak = 0
    for lap in laps:
        streak = streak + 1 if lap.completed else 0
        best = max(best, streak)
    return best


def best_average_lap_ms(laps: Sequence[Lap], window: int) -> int | None:
    """The lowest mean of `window` consecutive completed laps (floored), None if no such run exists."""
    best: int | None = None
    for start in range(len(laps) - window + 1):
        run = laps[start : start + window]
        if all(lap.completed for lap in run):
            mean = sum(lap.elapsed_ms for lap in run) // window
            best = mean if best is None else min(best, mean)
    return best


def submission_stats(laps: Sequence[Lap], minimum_laps: int) -> SubmissionStats:
    completed = [lap.elapsed_ms for lap in laps if lap.completed]
    resets = sum(lap.reset_count for lap in laps)
    return SubmissionStats(
        completedLapCount=max_consecutive_completed(laps),
        bestLapTime=min(completed) if completed else None,
        avgLapTime=best_average_lap_ms(laps, minimum_laps),
        totalLapTime=sum(lap.elapsed_ms for lap in laps),
        resetCount=resets,
        avgResets=round(resets / len(laps), 3) if laps else 0.0,
        offTrackCount=sum(lap.off_track_count for lap in laps),
        collisionCount=sum(lap.crash_count for lap in laps),
        lapCount=len(laps),
    )


def ranking_score(stats: SubmissionStats, timing_method: str) -> int | None:
    return getattr(stats, TIMING_FIELDS[timing_method])


@dataclass(frozen=True)
class Standing:
    entrant: str
    stats: SubmissionStats | None
    """None when the entrant never raced (its import or evaluation failed)."""
    score_ms: int | None
    rank: int | None
    dnf_reason: str | None
    error_code: str | None = None


def rank_entrants(
    results: Sequence[tuple[str, Sequence[Lap] | None, str | None, str | None]],
    *,
    timing_method: str,
    minimum_laps: int,
) -> tuple[Standing, ...]:
    """`results`: (entrant, laps or None, failure reason or None, error code or None). Ranked entrants first by
    score (ties: name), then the unranked ones by completed laps (more first), then name."""
    ranked: list[Standing] = []
    unranked: list[Standing] = []
    for entrant, laps, failure, code in results:
        if laps is None:
            unranked.append(Standing(entrant, None, None, None, failure or "did not race", code))
            continue
        stats = submission_stats(laps, minimum_laps)
        score = ranking_score(stats, timing_method)
        if stats.completedLapCount >= minimum_laps and score is not None and failure is None:
            ranked.append(Standing(entrant, stats, score, None, None))
            continue
        if failure is None:
            failure = (
                f"{stats.completedLapCount} consecutive completed lap{'s' if stats.completedLapCount != 1 else ''}, "
                f"{minimum_laps} needed (minimumLaps)"
            )
        unranked.append(Standing(entrant, stats, score, None, failure, code))
    ranked.sort(key=lambda s: (s.score_ms, s.entrant))
    unranked.sort(key=lambda s: (-(s.stats.completedLapCount if s.stats else -1), s.entrant))
    numbered = [
        Standing(s.entrant, s.stats, s.score_ms, index + 1, None, s.error_code) for index, s in enumerate(ranked)
    ]
    return (*numbered, *unranked)
