"""The pictures of the compare page, one colour per run throughout (matplotlib's object API, no pyplot state)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from racer.compare.runs import ComparedRun

DPI = 100
RUN_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#7f7f7f")
SMOOTH_FROM = 20
"""With this many iterations or more, a run's curve is drawn faint and its moving mean over a tenth of them bold."""


def run_colour(index: int) -> str:
    return RUN_COLOURS[index % len(RUN_COLOURS)]


def _moving_mean(values: np.ndarray, window: int) -> np.ndarray:
    """Mean of the last `window` finite values at each point (shorter at the start)."""
    out = np.full(len(values), np.nan)
    for i in range(len(values)):
        chunk = values[max(0, i - window + 1) : i + 1]
        chunk = chunk[np.isfinite(chunk)]
        if len(chunk):
            out[i] = chunk.mean()
    return out


def _curve(ax, x: Sequence[float], y: Sequence[float], colour: str, label: str | None) -> None:
    x_values = np.asarray(x, dtype=float)
    y_values = np.asarray(y, dtype=float)
    if len(x_values) >= SMOOTH_FROM:
        ax.plot(x_values, y_values, color=colour, linewidth=0.8, alpha=0.3)
        window = max(2, len(x_values) // 10)
        ax.plot(x_values, _moving_mean(y_values, window), color=colour, linewidth=2.2, label=label)
    else:
        ax.plot(x_values, y_values, color=colour, linewidth=2, marker="o", markersize=4, label=label)


def _values(run: ComparedRun, key: str, scale: float = 1.0) -> list[float]:
    return [np.nan if r.get(key) is None else float(r[key]) * scale for r in run.iterations]


def training_curves(runs: Sequence[ComparedRun], path: Path) -> Path:
    """Mean reward and mean progress of each iteration's training episodes, by iteration and by wall time."""
    figure = Figure(figsize=(13, 8.2), layout="constrained")
    axes = figure.subplots(2, 2, sharex="col")
    timed = False
    for index, run in enumerate(runs):
        colour = run_colour(index)
        iterations = [int(r["iteration"]) for r in run.iterations]
        minutes = run.training_minutes()
        known = [i for i, m in enumerate(minutes) if m is not None]
        for row, (key, scale) in enumerate((("mean_reward", 1.0), ("mean_progress", 1.0))):
            values = _values(run, key, scale)
            _curve(axes[row][0], iterations, values, colour, run.label if row == 0 else None)
            if known:
                timed = True
                _curve(axes[row][1], [minutes[i] for i in known], [values[i] for i in known], colour, None)
    axes[0][0].set_title("by iteration")
    axes[0][1].set_title("by wall time of training")
    for row, name in enumerate(("mean reward per episode", "mean progress (%)")):
        for column in range(2):
            axes[row][column].set_ylabel(name)
            axes[row][column].grid(alpha=0.3)
    axes[1][0].set_xlabel("iteration")
    axes[1][1].set_xlabel("minutes")
    axes[1][0].xaxis.set_major_locator(MaxNLocator(integer=True))
    if not timed:
        for row in range(2):
            axes[row][1].text(
                0.5,
                0.5,
                "no wall time in these runs' files",
                ha="center",
                va="center",
                transform=axes[row][1].transAxes,
                color="0.4",
            )
    figure.legend(loc="outside upper center", ncols=min(len(runs), 5), frameon=False, fontsize=11)
    figure.savefig(path, dpi=DPI)
    return path


def evaluation_curves(runs: Sequence[ComparedRun], path: Path) -> Path:
    """Worker 0's greedy evaluation of each checkpoint: mean progress and the share of trials that finished a lap;
    a star on the checkpoint the run chose as its best."""
    figure = Figure(figsize=(13, 4.4), layout="constrained")
    progress_ax, laps_ax = figure.subplots(1, 2, sharex=True)
    for index, run in enumerate(runs):
        rows = [r for r in run.evaluations if r.get("trials")]
        if not rows:
            continue
        colour = run_colour(index)
        x = [r["checkpoint_number"] for r in rows]
        progress = [r["mean_progress"] for r in rows]
        laps = [100 * r["laps_completed"] / r["trials"] for r in rows]
        progress_ax.plot(x, progress, color=colour, marker="D", markersize=4, linewidth=1.8, label=run.label)
        laps_ax.plot(x, laps, color=colour, marker="D", markersize=4, linewidth=1.8)
        for r, p, lap_share in zip(rows, progress, laps, strict=True):
            if r.get("is_best"):
                progress_ax.plot(r["checkpoint_number"], p, marker="*", markersize=16, color=colour, mec="black")
                laps_ax.plot(r["checkpoint_number"], lap_share, marker="*", markersize=16, color=colour, mec="black")
    progress_ax.set_ylabel("mean progress (%)")
    laps_ax.set_ylabel("trials that finished a lap (%)")
    for ax in (progress_ax, laps_ax):
        ax.set_xlabel("checkpoint")
        ax.grid(alpha=0.3)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    laps_ax.set_ylim(-5, 105)
    figure.legend(loc="outside upper center", ncols=min(len(runs), 5), frameon=False, fontsize=11)
    figure.savefig(path, dpi=DPI)
    return path


def best_laps(runs: Sequence[ComparedRun], path: Path) -> Path:
    """Each run's best lap (or furthest episode) on its own track map: runs may train on different tracks."""
    columns = min(len(runs), 3)
    rows = -(-len(runs) // columns)
    figure = Figure(figsize=(4.6 * columns, 3.9 * rows), layout="constrained")
    axes = np.atleast_1d(figure.subplots(rows, columns)).ravel()
    for ax in axes[len(runs) :]:
        ax.set_visible(False)
    for index, (run, ax) in enumerate(zip(runs, axes[: len(runs)], strict=True)):
        colour = run_colour(index)
        ax.set_xticks([])
        ax.set_yticks([])
        track, best = run.track, run.best_lap
        if track and track.get("outer"):
            outer, inner = np.asarray(track["outer"]), np.asarray(track["inner"])
            ax.fill(*np.vstack([outer, inner[::-1]]).T, color="0.92", zorder=0)
            for border in (outer, inner):
                ax.plot(*border.T, color="0.4", linewidth=1.0, zorder=1)
            ax.plot(*np.asarray(track["center"]).T, color="0.65", linewidth=0.6, linestyle="--", zorder=1)
            ax.set_aspect("equal")
        if best and best.get("path"):
            path_xy = np.asarray(best["path"])
            ax.plot(*path_xy.T, color=colour, linewidth=2.2, zorder=2)
            ax.plot(*path_xy[0], marker="o", color="#16a34a", markersize=7, zorder=3)
        title = f"{run.label}\n{best_lap_text(best)}"
        ax.set_title(title, fontsize=10, color=colour)
        if not (track and track.get("outer")):
            ax.text(0.5, 0.5, "track unknown: no map", ha="center", va="center", transform=ax.transAxes, color="0.4")
    figure.savefig(path, dpi=DPI)
    return path


def best_lap_text(best: dict | None) -> str:
    """`12.345 s lap, training iteration 3 (worker 0)` or `no lap: furthest 45.2 % in 12.3 s, ...`."""
    if not best:
        return "no simtrace"
    where = (
        f"evaluation {best['run']}"
        if best.get("phase") == "evaluation"
        else f"training iteration {best.get('iteration')} (worker {best.get('worker')})"
    )
    if best.get("complete"):
        return f"{best['lap_time_s']:.3f} s lap, {where}"
    return f"no lap: furthest {best['progress']:.1f} % in {best['time_s']:.1f} s, {where}"
