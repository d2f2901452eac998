"""The best evaluation lap over its racing line: on the track coloured by the time it loses per metre, its speed
beside the line's along the line, and its loss per track section and per corner."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure

from racer.analysis.line_analysis import LapAgainstLine
from racer.analysis.line_comparison import loss_per_metre
from racer.analysis.plots import _draw_track, _save

LOSS_SCALE_QUANTILE = 0.95
"""The colour scale ends at this quantile of |loss per metre|: a standing start's first metres lose far more than
anywhere else and would leave every other stretch one colour."""


def best_lap_over_line(lap: LapAgainstLine, path: Path) -> Path:
    figure = Figure(figsize=(15, 10), layout="constrained")
    grid = figure.add_gridspec(2, 2, height_ratios=[1.4, 1])
    map_ax, loss_ax = figure.add_subplot(grid[0, 0]), figure.add_subplot(grid[0, 1])
    speed_ax = figure.add_subplot(grid[1, :])
    _draw_map(map_ax, lap, figure)
    _draw_losses(loss_ax, lap)
    _draw_speeds(speed_ax, lap)
    figure.suptitle(
        f"{lap.run} lap {lap.lap}: {lap.lap_time_s:.3f} s, line {lap.line_lap_s:.3f} s (flying lap), "
        f"ratio {lap.ratio:.3f} · {lap.car.describe()}"
    )
    return _save(figure, path)


def _draw_map(ax, lap: LapAgainstLine, figure: Figure) -> None:
    _draw_track(ax, lap.car.track, centre=False)
    line = lap.stations.line.points_m
    ax.plot(*np.vstack((line, line[:1])).T, color="0.2", linewidth=0.8, linestyle="--", zorder=2, label="line")
    rate = loss_per_metre(lap.clock, lap.stations)
    finite = np.abs(rate[np.isfinite(rate)])
    scale = max(float(np.quantile(finite, LOSS_SCALE_QUANTILE)) if len(finite) else 0.0, 1e-3)
    segments = np.stack((lap.clock.xy_m[:-1], lap.clock.xy_m[1:]), axis=1)
    drawn = LineCollection(
        segments, cmap="RdBu_r", norm=TwoSlopeNorm(0.0, -scale, scale), linewidths=3.5, zorder=3
    )  # fmt: skip
    drawn.set_array(np.nan_to_num(rate, nan=0.0))
    ax.add_collection(drawn)
    ax.plot(*lap.clock.xy_m[0], "o", color="green", markersize=7, zorder=4)
    sections = lap.stretches[lap.stretches["kind"] == "section"]
    for row in sections.itertuples():
        middle = lap.stations.distance_m.searchsorted((row.start_m + row.end_m) / 2) % len(line)
        ax.annotate(
            f"{row.stretch}\n{row.loss_s:+.2f}",
            line[middle],
            ha="center",
            va="center",
            fontsize=8,
            bbox={"boxstyle": "round", "facecolor": "white", "alpha": 0.85},
            zorder=5,
        )
    figure.colorbar(drawn, ax=ax, label="time lost to the line (s per m of line); blue: faster", shrink=0.8)
    ax.set_title("the lap (colour: time lost) over the line (dashed); boxes: section, loss (s)")


def _draw_losses(ax, lap: LapAgainstLine) -> None:
    table = lap.stretches
    names = [
        f"S{name}" if kind == "section" else name for kind, name in zip(table["kind"], table["stretch"], strict=True)
    ]
    colours = ["C0" if kind == "section" else "C1" for kind in table["kind"]]
    ax.barh(range(len(table)), table["loss_s"], color=colours)
    ax.set_yticks(range(len(table)), names, fontsize=8)
    ax.invert_yaxis()
    ax.axvline(0.0, color="0.3", linewidth=0.8)
    ax.set_xlabel("lap time - line time (s)")
    sections = table[table["kind"] == "section"]
    ax.set_title(f"loss per section (blue; sum {sections['loss_s'].sum():.3f} s = lap - line) and per corner (orange)")


def _draw_speeds(ax, lap: LapAgainstLine) -> None:
    stations = lap.stations
    ax.plot(stations.distance_m, stations.speed_mps, color="0.2", linewidth=1.2, label="line")
    clock = lap.clock
    ax.plot(clock.distance_m, clock.speed_mps, color="C3", linewidth=1.2, label=f"lap {lap.lap}")
    corners = lap.stretches[lap.stretches["kind"] == "corner"]
    for row in corners.itertuples():
        spans = (
            [(row.start_m, row.end_m)]
            if row.end_m >= row.start_m
            else [(row.start_m, stations.length_m), (0.0, row.end_m)]
        )
        for start, end in spans:
            ax.axvspan(start, end, color="C1", alpha=0.15, linewidth=0)
        ax.text(row.start_m, ax.get_ylim()[1], row.stretch, fontsize=8, va="top", color="C1")
    ax.set_xlim(0.0, stations.length_m)
    ax.set_xlabel("distance along the line from the start line (m)")
    ax.set_ylabel("speed (m/s)")
    ax.set_title("speed along the lap and the line's (shaded: corners)")
    ax.legend(loc="lower right")
