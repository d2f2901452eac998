"""`python -m benchmarks race-pace --picture`: where the drawn lap loses its time to the bound's line, per track
section and per corner, with `racer analyze`'s own measure (racer.analysis.line_comparison), so the bench's figure
and a report of the same lap read alike. A goal the bench does not meet is then explained by the corners that cost
the most, not only by the total."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from benchmarks.race_pace_picture import DrivenLap
from racer.analysis.line_analysis import LapAgainstLine
from racer.analysis.line_comparison import (
    LineStations,
    corner_curvature_per_m,
    corners,
    lap_clock,
    losses,
    sections,
)
from racer.analysis.line_picture import best_lap_over_line
from racer.analysis.loading import add_step_deltas
from racer.analysis.run_line import RunCar
from racer.racing_line import RacingLine
from racer.shared.sim.tracks.track import Track

SECTIONS = 10
"""`racer analyze`'s default section count: the bench's sections are the report's."""
TOP_LOSSES = 3


def lap_against_line(route: Track, bound: RacingLine, lap: DrivenLap) -> LapAgainstLine | None:
    """The driven lap's losses to `bound` per section and corner; None for a lap that did not finish."""
    if lap.lap_time_s is None or not lap.simtrace_rows:
        return None
    rows = pd.DataFrame(list(lap.simtrace_rows))
    rows["file"] = "lap"
    stations = LineStations.of(bound)
    stretches = sections(route, stations, SECTIONS) + corners(stations, corner_curvature_per_m(bound.limits))
    clock = lap_clock(add_step_deltas(rows), stations, lap.lap_time_s)
    return LapAgainstLine(
        run=lap.checkpoint,
        lap=lap.lap_index + 1,
        lap_time_s=lap.lap_time_s,
        time_from="the bench's evaluation, driven again",
        car=RunCar(route, bound.limits),
        stations=stations,
        clock=clock,
        stretches=losses(clock, stations, stretches),
    )


def loss_summary(lap: LapAgainstLine, picture: Path | None) -> dict:
    """The JSON of the lap's losses: every section and corner (lap, line and loss seconds), the corners' and the
    straights' shares of the loss, the costliest stretches and, with `picture`, the report's best-lap picture."""
    table = lap.stretches
    by_kind = {kind: table[table["kind"] == kind] for kind in ("section", "corner")}
    total_loss_s = lap.lap_time_s - lap.line_lap_s
    corner_loss_s = float(by_kind["corner"]["loss_s"].sum())
    found: dict = {
        "lap_s": round(lap.lap_time_s, 3),
        "line_flying_lap_s": round(lap.line_lap_s, 3),
        "loss_s": round(total_loss_s, 3),
        "corner_threshold_per_m": round(corner_curvature_per_m(lap.car.limits), 4),
        "in_corners_s": round(corner_loss_s, 3),
        "between_corners_s": round(total_loss_s - corner_loss_s, 3),
        "costliest": _rows(table.nlargest(TOP_LOSSES, "loss_s")),
        "sections": _rows(by_kind["section"]),
        "corners": _rows(by_kind["corner"]),
    }
    if picture is not None:
        found["picture"] = str(best_lap_over_line(lap, picture))
    return found


def _rows(table: pd.DataFrame) -> list[dict]:
    return [
        {
            "stretch": f"{row.kind} {row.stretch}",
            "where": row.where,
            "lap_s": round(float(row.lap_s), 3),
            "line_s": round(float(row.line_s), 3),
            "loss_s": round(float(row.loss_s), 3),
        }
        for row in table.itertuples()
    ]
