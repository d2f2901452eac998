"""All simtrace rows of a run in one DataFrame, each row tagged with phase, run, worker, iteration and file."""

from __future__ import annotations

import sys

import click
import numpy as np
import pandas as pd

from racer.analysis.robomaker_log import relabel_error, simtrace_csv_from_log
from racer.analysis.sources import SimtraceFile, SimtraceFiles
from racer.shared.deepracer.simtrace import SimtraceError, read_simtrace

PLACEMENT_COLUMNS = ["phase", "run", "worker", "iteration"]
EPISODE_KEY = ["phase", "run", "worker", "iteration", "episode"]
"""One episode never spans files. Training episode numbers count per worker across iterations (but restart when a
worker restarts); evaluation episode numbers count laps per run."""


def read_one(file: SimtraceFile) -> pd.DataFrame:
    if file.from_log:
        text = file.read_bytes().decode("utf-8", errors="replace")
        data, line_numbers = simtrace_csv_from_log(text, file.name)
        try:
            frame = read_simtrace(data, source=file.name)
        except SimtraceError as error:
            raise relabel_error(error, file.name, line_numbers) from error
    else:
        frame = read_simtrace(file.read_bytes(), source=file.name)
    frame = fill_missing_status(frame)
    frame.insert(0, "file", file.name)
    for position, column in enumerate(PLACEMENT_COLUMNS, start=1):
        frame.insert(position, column, getattr(file, column))
    return frame


def fill_missing_status(frame: pd.DataFrame) -> pd.DataFrame:
    """15-column files (2019) have no episode_status/pause_duration: every row counts as driving, and the last
    row of an episode is `lap_complete` at 100 % progress, else `unknown` (the file does not say why it ended)."""
    if "episode_status" in frame.columns:
        return frame
    last_row = frame["episode"].ne(frame["episode"].shift(-1))
    status = np.where(last_row, np.where(frame["progress"] >= 100.0, "lap_complete", "unknown"), "in_progress")
    return frame.assign(episode_status=status, pause_duration=0.0)


def load_steps(files: SimtraceFiles, *, progress: bool = True) -> pd.DataFrame:
    """Read every CSV (with a progress bar on stderr: drawn on a terminal, its label once in a log) and derive the
    per-step columns analysis needs."""
    with click.progressbar(
        files.simtraces, label=f"reading {len(files.simtraces)} simtrace files", hidden=not progress, file=sys.stderr
    ) as simtraces:
        frames = [read_one(file) for file in simtraces]
    return add_step_deltas(pd.concat(frames, ignore_index=True))


def add_step_deltas(steps: pd.DataFrame) -> pd.DataFrame:
    """Time and distance of each step, as deepracer-utils' simulation_agg counts them.

    dt_s = tstamp minus the previous row's tstamp in the same file, 0 on `prepare` rows (the episode has not
    started yet). Continuous evaluations have no prepare row between laps, so a lap's first step counts the time
    since the previous lap's last step, which is how the EvaluationMetrics file times those laps too.
    distance_m = the straight line from the previous row, 0 on `prepare` and `pause` rows (after an off-track
    reset the car is teleported back onto the track; that jump is not driven distance).
    """
    steps = steps.copy()
    by_file = steps.groupby("file", sort=False)
    steps["dt_s"] = (steps["tstamp"] - by_file["tstamp"].shift(1)).fillna(0.0)
    dx = steps["X"] - by_file["X"].shift(1)
    dy = steps["Y"] - by_file["Y"].shift(1)
    steps["distance_m"] = np.hypot(dx, dy).fillna(0.0)
    not_driving = steps["episode_status"].isin(["prepare"])
    steps.loc[not_driving, "dt_s"] = 0.0
    steps.loc[not_driving | (steps["episode_status"] == "pause"), "distance_m"] = 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        steps["speed_mps"] = np.where(steps["dt_s"] > 0, steps["distance_m"] / steps["dt_s"], np.nan)
    return steps
