"""The AWS Summit physical-track rule: drive for 4 minutes of simulated time, lap after lap, 3 put-backs per lap.

A lap attempt starts at the line. Leaving the track (or any other reset rule: reversed, immobilized, crashed) puts
the car back on the track near where it left (the env's reset position, docs/evaluation.md) after `reset_penalty_s`,
up to `resets_per_lap` times in a lap; the next exit ends the attempt and the next attempt starts at the line.
A completed lap runs straight into the next one (`continuous`, as on a physical track) with a fresh reset budget.
When the rule's clock passes the duration (SimApp's RaceTimeRule: `elapsed > duration`), the current step becomes
`time_up` and the run ends, mid-lap if need be; that partial lap is reported too.
"""

from __future__ import annotations

from dataclasses import dataclass

from racer.evaluation_worker.config import SummitRules
from racer.evaluation_worker.driver import EvaluationDriver
from racer.evaluation_worker.laps import LapCallback, LapResult, LapTally, ignore_lap
from racer.shared.deepracer.episode_status import EpisodeStatus

_CLOCK_TOLERANCE_S = 1e-6
"""The sim clock is a sum of physics steps; this keeps a step landing exactly on the limit inside the run."""


@dataclass(frozen=True)
class SummitResult:
    rules: SummitRules
    laps: tuple[LapResult, ...]
    race_start_s: float
    race_end_s: float
    """Sim time of the last step."""

    @property
    def completed_laps(self) -> tuple[LapResult, ...]:
        return tuple(lap for lap in self.laps if lap.completed)

    @property
    def best_lap_time_s(self) -> float | None:
        times = [lap.lap_time_s for lap in self.completed_laps if lap.lap_time_s is not None]
        return min(times) if times else None

    @property
    def total_progress_pct(self) -> float:
        """Sum of every lap attempt's progress: 100 per completed lap plus the partial ones."""
        return float(sum(min(lap.progress_pct, 100.0) for lap in self.laps))


def run_summit(driver: EvaluationDriver, rules: SummitRules, on_lap: LapCallback = ignore_lap) -> SummitResult:
    race_start_s = driver.start_lap(0)
    laps: list[LapResult] = []
    lap_index = 0
    tally = LapTally(lap_index, race_start_s)

    def past_limit(sim_time_s: float) -> bool:
        return sim_time_s - race_start_s > rules.race_duration_s + _CLOCK_TOLERANCE_S

    while True:
        outcome = driver.step()
        time_up = past_limit(outcome.sim_time_s)
        crossing = outcome.status == EpisodeStatus.LAP_COMPLETE
        if time_up:
            record = driver.record(outcome, status=EpisodeStatus.TIME_UP, done=True)
        elif crossing and rules.continuous:
            record = driver.record(outcome, done=False)
        else:
            record = driver.record(outcome)
        tally.add(record)
        if not (time_up or crossing or outcome.terminated or outcome.truncated):
            continue
        # SimApp: a time-up entry does not advance the trial counter; every other entry does.
        trial = sum(1 for lap in laps if lap.status != EpisodeStatus.TIME_UP) + (0 if time_up else 1)
        lap = tally.result(trial=trial)
        laps.append(lap)
        on_lap(lap)
        if time_up:
            break
        lap_index += 1
        if crossing and rules.continuous:
            driver.continue_after_lap(lap_index, outcome.sim_time_s, clear_reset_budget=True)
            tally = LapTally(lap_index, outcome.sim_time_s)
            continue
        if past_limit(driver.sim_time_s):
            break
        tally = LapTally(lap_index, driver.start_lap(lap_index))
    return SummitResult(rules=rules, laps=tuple(laps), race_start_s=race_start_s, race_end_s=laps[-1].end_time_s)
