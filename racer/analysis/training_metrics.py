"""The console's reward graph from TrainingMetrics.json: training and in-training evaluation per iteration.

Simtraces hold only training steps; the greedy evaluation episodes worker 0 runs after each checkpoint appear only
in TrainingMetrics.json (deepracer-simapp v5.3.3 `bundle/markov/metrics/s3_metrics.py`). An iteration starts at each
training entry with trial 1 (`trial`
counts the training episodes of the current iteration); evaluation entries belong to the iteration before them.
Only worker 0's file is used: the other workers run no evaluations.
"""

from __future__ import annotations

import pandas as pd

from racer.shared.deepracer.episode_status import EpisodeStatus
from racer.shared.deepracer.metrics import TrainingMetrics, read_training_metrics


def entries_table(metrics: TrainingMetrics) -> pd.DataFrame:
    """One row per entry, with the iteration it belongs to."""
    rows = []
    iteration = -1
    for entry in metrics.entries:
        if entry.phase == "training" and (entry.trial == 1 or iteration < 0):
            iteration += 1
        complete = entry.episode_status == EpisodeStatus.LAP_COMPLETE
        rows.append(
            {
                "iteration": max(iteration, 0),
                "phase": entry.phase,
                "episode": entry.episode,
                "progress_pct": float(entry.completion_percentage),
                "reward": float(entry.reward_score),
                "lap_complete": complete,
                "lap_time_s": entry.elapsed_time_ms / 1000 if complete else float("nan"),
            }
        )
    return pd.DataFrame(
        rows, columns=["iteration", "phase", "episode", "progress_pct", "reward", "lap_complete", "lap_time_s"]
    )


def iteration_table(metrics: TrainingMetrics) -> pd.DataFrame:
    """Per iteration: training and evaluation episodes, mean progress, completion rate and best lap."""
    entries = entries_table(metrics)
    summary = (
        entries.groupby(["iteration", "phase"])
        .agg(
            episodes=("episode", "size"),
            progress_mean_pct=("progress_pct", "mean"),
            completion_rate=("lap_complete", "mean"),
            best_lap_time_s=("lap_time_s", "min"),
        )
        .unstack("phase")
    )
    summary.columns = [f"{phase}_{name}" for name, phase in summary.columns]
    columns = [
        f"{phase}_{name}"
        for phase in ("training", "evaluation")
        for name in ("episodes", "progress_mean_pct", "completion_rate", "best_lap_time_s")
    ]
    summary = summary.reindex(columns=columns)
    for phase in ("training", "evaluation"):
        summary[f"{phase}_episodes"] = summary[f"{phase}_episodes"].fillna(0).astype(int)
    return summary.reset_index()


def read_iteration_table(data: bytes, name: str) -> pd.DataFrame:
    return iteration_table(read_training_metrics(data, source=name))
