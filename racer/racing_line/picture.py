"""line.png: the track with the line coloured by speed and the braking points marked (matplotlib, no display)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from racer.racing_line.line import RacingLine
from racer.shared.sim.tracks.track import Track

DPI = 110


def draw_line(track: Track, line: RacingLine, title: str, path: Path) -> Path:
    """One map: the road, the line coloured by the flying lap's speed, a triangle where each braking zone starts."""
    figure = Figure(figsize=(8.0, 6.0), layout="constrained")
    ax = figure.subplots()
    draw_road(ax, track)
    closed = np.vstack((line.points_m, line.points_m[:1]))
    speeds = np.append(line.speeds_mps, line.speeds_mps[:1])
    norm = Normalize(float(line.speeds_mps.min()), float(line.speeds_mps.max()))
    collection = speed_segments(closed, 0.5 * (speeds[:-1] + speeds[1:]), norm, width=3.0)
    ax.add_collection(collection)
    braking = line.braking_indices
    ax.scatter(
        *line.points_m[braking].T,
        marker="v",
        s=60,
        color="red",
        edgecolors="black",
        zorder=5,
        label=f"braking point ({len(braking)})",
    )
    ax.plot(*line.points_m[0], "o", color="green", markersize=6, zorder=5, label="start")
    ax.legend(loc="upper right", fontsize="small")
    ax.set_title(
        f"{title}\n{line.lap_time_s:.2f} s flying lap, {line.standing_average_s:.2f} s over 3 from rest, "
        f"{line.length_m:.1f} m"
    )
    figure.colorbar(collection, ax=ax, label="speed (m/s)", shrink=0.8)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=DPI)
    return path


def speed_segments(points: np.ndarray, speeds: np.ndarray, norm: Normalize, width: float) -> LineCollection:
    """A polyline's segments coloured by `speeds` (one per segment)."""
    segments = np.stack([points[:-1], points[1:]], axis=1)
    collection = LineCollection(segments, cmap="plasma", norm=norm, linewidth=width, zorder=3)
    collection.set_array(speeds)
    return collection


def draw_road(ax, track: Track) -> None:
    """The road in light grey between its borders, the start line in black, no axes."""
    ax.fill(*np.vstack([track.outer_border, track.inner_border[::-1]]).T, color="0.93", zorder=0)
    for border in (track.inner_border, track.outer_border):
        ax.plot(*border.T, color="0.35", linewidth=1.0, zorder=1)
    start = np.vstack((track.inner_border[0], track.outer_border[0]))
    ax.plot(*start.T, color="black", linewidth=2.0, zorder=1)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
