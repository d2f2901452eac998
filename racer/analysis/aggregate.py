"""Steps -> episodes -> iterations: the tables users know from deepracer-utils (simulation_agg, training progress).

Definitions (deepracer-utils' `AnalysisUtils.simulation_agg` where one exists; docs/analysis.md):
- time_s: sum of step time deltas without the `prepare` row; lap_time_s is time_s of an episode that reached 100 %.
- projected_lap_time_s: time_s * 100 / progress_pct, what the lap would take at the same pace.
- throttle_mps: mean commanded speed (deepracer-utils calls it "speed"); speed_mps: driven distance / time_s.
- resets: DeepRacer's reset_count, the episode's off_track + crashed + immobilized + reversed events (each such
  row, whether the car was put back, with or without penalty pause rows, or the event ended the episode);
  penalty_s: time spent in pause rows.
- crashed: the episode's `crashed` rows (collisions with an obstacle or bot car that paused or ended it);
  obstacle_crash_counter: the largest value of that simtrace column in the episode, when the files have it (the
  SimApp's count of resets behind the same obstacle in a row). Per iteration: crashes (sum) and crashed_episodes
  (episodes with at least one crash).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from racer.analysis.loading import EPISODE_KEY
from racer.analysis.sources import EVALUATION, TRAINING

RESET_STATUSES = ("off_track", "crashed", "immobilized", "reversed")
"""The events DeepRacer's EvaluationMetrics count in reset_count (sum of their four counters)."""


def episodes(steps: pd.DataFrame) -> pd.DataFrame:
    """One row per episode (a training episode, or one evaluation lap/trial)."""
    steps = steps.assign(
        is_incident=steps["episode_status"].isin(RESET_STATUSES),
        pause_dt_s=steps["dt_s"].where(steps["episode_status"] == "pause", 0.0),
        is_off_track=steps["episode_status"] == "off_track",
        is_crashed=steps["episode_status"] == "crashed",
    )
    table = steps.groupby(EPISODE_KEY, sort=False).agg(
        steps=("steps", "size"),
        start_waypoint=("closest_waypoint", "first"),
        start_tstamp_s=("tstamp", "first"),
        progress_pct=("progress", "max"),
        time_s=("dt_s", "sum"),
        distance_m=("distance_m", "sum"),
        throttle_mps=("throttle", "mean"),
        reward=("reward", "sum"),
        status=("episode_status", "last"),
        resets=("is_incident", "sum"),
        off_track=("is_off_track", "sum"),
        crashed=("is_crashed", "sum"),
        penalty_s=("pause_dt_s", "sum"),
        **({"obstacle_crash_counter": ("obstacle_crash_counter", "max")} if "obstacle_crash_counter" in steps else {}),
    )
    table = table.reset_index()
    table["lap_complete"] = table["progress_pct"] >= 100.0
    with np.errstate(divide="ignore", invalid="ignore"):
        table["speed_mps"] = table["distance_m"] / table["time_s"].where(table["time_s"] > 0)
        progress_pct = table["progress_pct"].where(table["progress_pct"] > 0)
        table["projected_lap_time_s"] = table["time_s"] * 100.0 / progress_pct
    table["lap_time_s"] = table["time_s"].where(table["lap_complete"])
    order = [
        "phase",
        "run",
        "worker",
        "iteration",
        "episode",
        "steps",
        "start_waypoint",
        "progress_pct",
        "time_s",
        "distance_m",
        "speed_mps",
        "throttle_mps",
        "reward",
        "status",
        "lap_complete",
        "lap_time_s",
        "projected_lap_time_s",
        "resets",
        "off_track",
        "crashed",
        "penalty_s",
        *(["obstacle_crash_counter"] if "obstacle_crash_counter" in table else []),
        "start_tstamp_s",
    ]
    return table[order].sort_values(["phase", "run", "worker", "start_tstamp_s"], ignore_index=True)


def _summary(episode_table: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    episode_table = episode_table.assign(has_crash=episode_table["crashed"] > 0)
    table = episode_table.groupby(by, sort=True).agg(
        episodes=("episode", "size"),
        reward_mean=("reward", "mean"),
        reward_std=("reward", "std"),
        progress_mean_pct=("progress_pct", "mean"),
        progress_std_pct=("progress_pct", "std"),
        laps_complete=("lap_complete", "sum"),
        completion_rate=("lap_complete", "mean"),
        best_lap_time_s=("lap_time_s", "min"),
        mean_lap_time_s=("lap_time_s", "mean"),
        time_mean_s=("time_s", "mean"),
        speed_mean_mps=("speed_mps", "mean"),
        crashes=("crashed", "sum"),
        crashed_episodes=("has_crash", "sum"),
    )
    return table.reset_index()


def iterations(episode_table: pd.DataFrame, *, per_worker: bool = False) -> pd.DataFrame:
    """Training progress per iteration (all workers together, or one row per worker and iteration)."""
    training = episode_table[episode_table["phase"] == TRAINING]
    return _summary(training, ["run", "worker", "iteration"] if per_worker else ["run", "iteration"])


def workers(episode_table: pd.DataFrame) -> pd.DataFrame:
    """Training per worker (world): shows a world the policy has not learnt yet."""
    return _summary(episode_table[episode_table["phase"] == TRAINING], ["run", "worker"])


def evaluation_laps(episode_table: pd.DataFrame) -> pd.DataFrame:
    """One row per evaluation lap (trial), numbered from 1 per evaluation run like EvaluationMetrics' `trial`."""
    laps = episode_table[episode_table["phase"] == EVALUATION].copy()
    laps["lap"] = laps.groupby("run").cumcount() + 1
    columns = [
        "run",
        "lap",
        "lap_time_s",
        "time_s",
        "progress_pct",
        "lap_complete",
        "status",
        "resets",
        "off_track",
        "crashed",
        "penalty_s",
        "steps",
        "speed_mps",
    ]
    return laps[columns].reset_index(drop=True)


def evaluations(episode_table: pd.DataFrame) -> pd.DataFrame:
    """One row per evaluation run: laps finished, best and mean lap, total time and resets."""
    return evaluations_of_laps(evaluation_laps(episode_table))


def evaluations_of_laps(laps: pd.DataFrame) -> pd.DataFrame:
    """`evaluations` of a table of evaluation laps (racer.analysis.evaluation_times gives them DeepRacer's times)."""
    table = laps.groupby("run").agg(
        laps=("lap", "size"),
        laps_complete=("lap_complete", "sum"),
        best_lap_time_s=("lap_time_s", "min"),
        mean_lap_time_s=("lap_time_s", "mean"),
        total_time_s=("time_s", "sum"),
        resets=("resets", "sum"),
        penalty_s=("penalty_s", "sum"),
    )
    return table.reset_index()


def best_laps(episode_table: pd.DataFrame, phase: str, count: int) -> pd.DataFrame:
    """The fastest complete laps; when none finished, the episodes that got furthest (then fastest)."""
    table = episode_table[episode_table["phase"] == phase]
    complete = table[table["lap_complete"]].sort_values("lap_time_s")
    if len(complete):
        return complete.head(count)
    return table.sort_values(["progress_pct", "time_s"], ascending=[False, True]).head(count)
