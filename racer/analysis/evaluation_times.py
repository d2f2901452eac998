"""Evaluation lap times as DeepRacer's EvaluationMetrics give them, when the source has the file.

The metrics time a lap from the reset to its last step (racer.evaluation_worker.laps, deepracer-simapp v5.3.3
`bundle/markov/metrics/s3_metrics.py`); the simtrace's span starts at its `prepare` row, which is already one step
after the reset. So a lap from a standing start is one step (1/15 s in racer) shorter in the simtrace than in the
metrics, `racer evaluate`'s table and the console; a continuous evaluation's later laps have no prepare row and agree.
The report shows the metrics' time and the span beside it; without the file it says the times are the span.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from racer.analysis import aggregate
from racer.analysis.sources import SimtraceFiles
from racer.shared.deepracer.metrics import MetricsError, read_evaluation_metrics
from racer.shared.model_layout import EVALUATION_PREFIX

METRICS = "EvaluationMetrics"
SIMTRACE = "simtrace"
_TIMESTAMP = re.compile(r"(?:^|[/!])metrics/(?:evaluation/evaluation-|EvaluationMetrics-)(?P<timestamp>[^/]+)\.json$")


def metrics_file_of_run(files: SimtraceFiles, run: str) -> str | None:
    """The name of the EvaluationMetrics file of evaluation `run` (`<prefix>/evaluation-<ts>`): the one at
    `<prefix>/metrics/evaluation/evaluation-<ts>.json` (or racer's earlier `metrics/EvaluationMetrics-<ts>.json`)."""
    prefix, _, folder = run.rpartition("/")
    if not folder.startswith(EVALUATION_PREFIX):
        return None
    timestamp = folder.removeprefix(EVALUATION_PREFIX)
    for name in sorted(files.evaluation_metrics):
        match = _TIMESTAMP.search(name)
        if match is None or match["timestamp"] != timestamp:
            continue
        head = name[: match.start()]  # what holds metrics/: the model folder, named as the run's prefix
        if not prefix or head == prefix or head.endswith((f"/{prefix}", f"!{prefix}")):
            return name
    return None


def timed_laps(files: SimtraceFiles, laps: pd.DataFrame, notes: list[str]) -> pd.DataFrame:
    """`laps` (aggregate.evaluation_laps) with `time_s` and `lap_time_s` from each run's EvaluationMetrics where
    the file is there and has one entry per lap, `simtrace_time_s` the simtrace's span, `time_from` which one."""
    laps = laps.assign(simtrace_time_s=laps["time_s"], time_from=SIMTRACE)
    spans_only = []
    for run, rows in laps.groupby("run", sort=True):
        name = metrics_file_of_run(files, str(run))
        if name is None:
            spans_only.append(str(run))
            continue
        try:
            entries = read_evaluation_metrics(files.evaluation_metrics[name], source=name).entries
        except MetricsError as error:
            notes.append(f"{error}; the lap times of {run} are the simtrace's span")
            continue
        if len(entries) != len(rows):
            notes.append(
                f"{name} has {len(entries)} laps but the simtrace of {run} has {len(rows)}: its lap times are the "
                "simtrace's span"
            )
            continue
        by_trial = {entry.trial: entry.elapsed_time_ms / 1000.0 for entry in entries}
        if set(by_trial) != set(rows["lap"]):
            notes.append(f"{name}: its trials {sorted(by_trial)} are not the simtrace's laps; lap times from the span")
            continue
        laps.loc[rows.index, "time_s"] = rows["lap"].map(by_trial).to_numpy()
        laps.loc[rows.index, "time_from"] = METRICS
    if spans_only:
        notes.append(
            f"No EvaluationMetrics file beside {', '.join(spans_only)}: its lap times are the simtrace's span, one step "
            "shorter than DeepRacer's for a lap from a standing start (the metrics count from the reset)."
        )
    laps["lap_time_s"] = laps["time_s"].where(laps["lap_complete"], np.nan)
    first = ["run", "lap", "lap_time_s", "time_s", "simtrace_time_s", "time_from"]
    return laps[first + [c for c in laps.columns if c not in first]]


def evaluations(laps: pd.DataFrame) -> pd.DataFrame:
    """aggregate.evaluations of the timed laps."""
    return aggregate.evaluations_of_laps(laps)
