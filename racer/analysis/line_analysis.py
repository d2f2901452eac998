"""Each evaluation lap against its run's racing line: the run's car from its evaluation_params.yaml, the line once per
(route, car, world) from a LineBook, every complete lap's losses per track section and per corner
(racer.analysis.line_comparison) and its ratio to the flying lap. A run whose car or track is not known gets a note
instead."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import PurePosixPath

import pandas as pd
import yaml

from racer.analysis.line_comparison import (
    LapClock,
    LineStations,
    Stretch,
    corner_curvature_per_m,
    corners,
    lap_clock,
    losses,
    sections,
)
from racer.analysis.loading import EPISODE_KEY
from racer.analysis.results import Analysis
from racer.analysis.run_line import LineBook, RunCar, ratio_to_bound, run_car
from racer.analysis.sources import EVALUATION


@dataclass(frozen=True)
class LapAgainstLine:
    run: str
    lap: int
    lap_time_s: float
    time_from: str
    car: RunCar
    stations: LineStations
    clock: LapClock
    stretches: pd.DataFrame
    """line_comparison.losses of the lap's sections and corners."""

    @property
    def line_lap_s(self) -> float:
        return self.stations.line.lap_time_s

    @property
    def ratio(self) -> float | None:
        return ratio_to_bound(self.lap_time_s, self.stations.line)


@dataclass
class LineComparison:
    laps: list[LapAgainstLine] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    corner_threshold_per_m: dict[str, float] = field(default_factory=dict)
    """By run: the curvature above which the line is a corner."""

    def best(self) -> LapAgainstLine | None:
        return min(self.laps, key=lambda lap: lap.ratio or float("inf"), default=None)


def run_params(analysis: Analysis, run: str) -> tuple[str, dict] | None:
    """(name, keys) of the params yaml in the evaluation run's own folder (racer evaluate's evaluation_params.yaml)."""
    for name, data in sorted(analysis.files.params_yaml.items()):
        folder = PurePosixPath(name.replace("!", "/")).parent.as_posix()
        if folder == run or folder.endswith(f"/{run}"):
            try:
                params = yaml.safe_load(data)
            except yaml.YAMLError:
                continue
            if isinstance(params, dict):
                return name, params
    return None


def compare_with_line(analysis: Analysis, book: LineBook, section_count: int) -> LineComparison:
    """Every complete evaluation lap of `analysis` against its run's line."""
    found = LineComparison()
    laps = analysis.evaluation_laps
    if not len(laps):
        return found
    if analysis.track is None:
        found.notes.append("Laps against the line: no track, no line (give --track).")
        return found
    steps = analysis.steps[analysis.steps["phase"] == EVALUATION]
    episodes = analysis.episodes[analysis.episodes["phase"] == EVALUATION]
    for run, run_laps in laps.groupby("run", sort=True):
        car = _car_of_run(analysis, str(run), found.notes)
        if car is None:
            continue
        line = book.line(car)
        if isinstance(line, str):
            found.notes.append(f"Laps against the line: {run}: no line ({line}).")
            continue
        stations = LineStations.of(line)
        threshold = corner_curvature_per_m(car.limits)
        found.corner_threshold_per_m[str(run)] = threshold
        stretches: list[Stretch] = sections(car.track, stations, section_count) + corners(stations, threshold)
        run_episodes = episodes[episodes["run"] == run].sort_values("start_tstamp_s").reset_index(drop=True)
        for lap in run_laps.itertuples():
            if not lap.lap_complete:
                continue
            key = run_episodes.loc[lap.lap - 1, EPISODE_KEY]
            rows = steps[(steps[EPISODE_KEY] == key.to_numpy()).all(axis=1)]
            clock = lap_clock(rows, stations, float(lap.lap_time_s))
            found.laps.append(
                LapAgainstLine(
                    str(run), int(lap.lap), float(lap.lap_time_s), lap.time_from, car, stations, clock,
                    losses(clock, stations, stretches),
                )
            )  # fmt: skip
    return found


def _car_of_run(analysis: Analysis, run: str, notes: list[str]) -> RunCar | None:
    params = run_params(analysis, run)
    if params is None:
        notes.append(
            f"Laps against the line: {run} has no evaluation_params.yaml beside its simtrace, so its car is not "
            "known; no line comparison."
        )
        return None
    car = run_car(params[1], params[0], analysis.track)
    if isinstance(car, str):
        notes.append(f"Laps against the line: {car}; no line comparison for {run}.")
        return None
    return car


def lap_table(comparison: LineComparison) -> pd.DataFrame:
    """One row per lap: its time, the line's flying lap, the ratio, the loss, and what the line is."""
    return pd.DataFrame(
        [
            {
                "run": lap.run,
                "lap": lap.lap,
                "lap_time_s": lap.lap_time_s,
                "time_from": lap.time_from,
                "line_lap_s": lap.line_lap_s,
                "ratio_to_bound": lap.ratio,
                "loss_s": lap.lap_time_s - lap.line_lap_s,
                "line_three_lap_average_s": lap.stations.line.standing_average_s,
                "line": lap.car.describe(),
            }
            for lap in comparison.laps
        ]
    )


def stretch_table(comparison: LineComparison, kind: str) -> pd.DataFrame:
    """One row per section (or corner) of each run's line: where it is, the line's time, each lap's loss."""
    tables = []
    for run in sorted({lap.run for lap in comparison.laps}):
        run_laps = [lap for lap in comparison.laps if lap.run == run]
        first = run_laps[0].stretches
        base = first[first["kind"] == kind][["stretch", "where", "start_m", "end_m", "line_s"]].reset_index(drop=True)
        base.insert(0, "run", run)
        for lap in run_laps:
            rows = lap.stretches[lap.stretches["kind"] == kind].reset_index(drop=True)
            base[f"lap {lap.lap} loss_s"] = rows["loss_s"]
        tables.append(base)
    return pd.concat(tables, ignore_index=True) if tables else pd.DataFrame()


def line_tables(comparison: LineComparison | None) -> dict[str, pd.DataFrame]:
    """The comparison's tables by CSV name (none without a compared lap)."""
    if comparison is None or not comparison.laps:
        return {}
    return {
        "laps_against_line": lap_table(comparison),
        "section_losses": stretch_table(comparison, "section"),
        "corner_losses": stretch_table(comparison, "corner"),
    }
