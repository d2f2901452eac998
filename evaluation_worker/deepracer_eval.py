"""DeepRacer's evaluation job (deepracer-simapp v5.3.3 `bundle/markov/evaluation_worker.py`): NUMBER_OF_TRIALS laps,
IS_CONTINUOUS, NUMBER_OF_RESETS, penalties.

Non-continuous: every trial starts at the line; it ends with `lap_complete`, or with the status of the reset rule
that fired once the reset budget (per trial) is used up. Continuous: one run from the line; each crossing of the line
closes a trial (`In progress` until the last, which is `Lap complete`); the reset budget covers the whole run and a
rule firing beyond it ends the run. Penalties pause the car on the track (simtrace `pause` rows); the simulation clock
keeps running, so the pause is part of the lap time.
"""

from __future__ import annotations

from racer.evaluation_worker.config import DeepRacerRules
from racer.evaluation_worker.driver import EvaluationDriver
from racer.evaluation_worker.laps import LapCallback, LapResult, LapTally, ignore_lap
from racer.shared.deepracer.episode_status import EpisodeStatus


def run_deepracer_evaluation(
    driver: EvaluationDriver, rules: DeepRacerRules, on_lap: LapCallback = ignore_lap
) -> list[LapResult]:
    if rules.is_continuous:
        return _continuous(driver, rules, on_lap)
    laps: list[LapResult] = []
    for lap_index in range(rules.number_of_trials):
        tally = LapTally(lap_index, driver.start_lap(lap_index))
        while True:
            outcome = driver.step()
            tally.add(driver.record(outcome))
            if outcome.terminated or outcome.truncated:
                break
        lap = tally.result(trial=len(laps) + 1)
        laps.append(lap)
        on_lap(lap)
    return laps


def _continuous(driver: EvaluationDriver, rules: DeepRacerRules, on_lap: LapCallback) -> list[LapResult]:
    laps: list[LapResult] = []
    tally = LapTally(0, driver.start_lap(0))
    while True:
        outcome = driver.step()
        crossing = outcome.status == EpisodeStatus.LAP_COMPLETE
        last_trial = len(laps) + 1 >= rules.number_of_trials
        if crossing and not last_trial:
            tally.add(driver.record(outcome, status=EpisodeStatus.IN_PROGRESS, done=False))
        else:
            tally.add(driver.record(outcome))
        if not (crossing or outcome.terminated or outcome.truncated):
            continue
        lap = tally.result(trial=len(laps) + 1)
        laps.append(lap)
        on_lap(lap)
        if not crossing or last_trial:
            return laps
        driver.continue_after_lap(len(laps), outcome.sim_time_s, clear_reset_budget=False)
        tally = LapTally(len(laps), outcome.sim_time_s)
