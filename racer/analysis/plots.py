"""The report's pictures, drawn with matplotlib's object API (no pyplot state, so it is safe in any process)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Polygon
from matplotlib.ticker import MaxNLocator

from racer.analysis.loading import EPISODE_KEY
from racer.analysis.track_sections import Track, section_of_waypoint
from racer.shared.sim.objects.poses import ObjectKind, ObjectPose

DPI = 110
INCIDENT_STATUSES = ("off_track", "crashed", "immobilized", "reversed")
"""Statuses marked with a red cross on the lap maps (where a reset or the end of the episode happened)."""


def _save(figure: Figure, path: Path) -> Path:
    figure.savefig(path, dpi=DPI, bbox_inches="tight")
    return path


OBSTACLE_COLORS = {ObjectKind.BOX_OBSTACLE: "#7b614f", ObjectKind.BOT_CAR: "#282828"}
"""The SimApp's box brown and DeepRacer's dark grey shell."""


def object_outline(obj: ObjectPose) -> np.ndarray:
    """The object's collision rectangle on the floor (the SimApp's crash test uses it), 4 corners (x, y)."""
    half_length, half_width = obj.size.length_m / 2, obj.size.width_m / 2
    c, s = math.cos(obj.yaw_rad), math.sin(obj.yaw_rad)
    local = np.array(
        [[half_length, half_width], [half_length, -half_width], [-half_length, -half_width], [-half_length, half_width]]
    )
    return np.array([obj.x_m, obj.y_m]) + local @ np.array([[c, s], [-s, c]])


def _draw_track(ax, track: Track, *, centre: bool = True, obstacles: Sequence[ObjectPose] = ()) -> None:
    ax.fill(*np.vstack([track.outer_border, track.inner_border[::-1]]).T, color="0.93", zorder=0)
    for border in (track.inner_border, track.outer_border):
        ax.plot(*border.T, color="0.35", linewidth=1.0, zorder=1)
    if centre:
        ax.plot(*track.center_line.T, color="0.6", linewidth=0.6, linestyle="--", zorder=1)
    for obj in obstacles:
        ax.add_patch(
            Polygon(
                object_outline(obj),
                closed=True,
                facecolor=OBSTACLE_COLORS[obj.kind],
                edgecolor="black",
                linewidth=0.8,
                zorder=1.5,
            )
        )
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def training_progress(
    iteration_table: pd.DataFrame, worker_table: pd.DataFrame, path: Path, *, metrics_table: pd.DataFrame | None = None
) -> Path:
    """Reward, progress and completion per iteration: is training still improving?

    `metrics_table` (training_metrics.iteration_table) adds the greedy in-training evaluations, as the console did.
    """
    figure = Figure(figsize=(9, 9))
    reward_ax, progress_ax, completion_ax = figure.subplots(3, 1, sharex=True)
    several_workers = worker_table["worker"].nunique() > 1
    for run, rows in iteration_table.groupby("run"):
        label = "" if iteration_table["run"].nunique() == 1 else f" ({run})"
        x = rows["iteration"]
        for ax, column, unit in ((reward_ax, "reward", ""), (progress_ax, "progress", "_pct")):
            mean, std = rows[f"{column}_mean{unit}"], rows[f"{column}_std{unit}"].fillna(0.0)
            ax.plot(x, mean, marker="o", markersize=3, label=f"mean{label}")
            ax.fill_between(x, mean - std, mean + std, alpha=0.2, label=f"± 1 std{label}")
        completion_ax.plot(x, 100 * rows["completion_rate"], marker="o", markersize=3, label=f"laps complete{label}")
        best = rows.dropna(subset=["best_lap_time_s"])
        if len(best):
            lap_ax = completion_ax.twinx()
            lap_ax.plot(
                best["iteration"], best["best_lap_time_s"], "s", color="tab:red", markersize=4, label="best lap"
            )
            lap_ax.set_ylabel("best lap time (s)", color="tab:red")
    if several_workers:
        for worker, rows in worker_table.groupby("worker"):
            style = {"linewidth": 0.8, "alpha": 0.8, "marker": "x", "markersize": 4, "label": f"worker {worker}"}
            reward_ax.plot(rows["iteration"], rows["reward_mean"], **style)
            progress_ax.plot(rows["iteration"], rows["progress_mean_pct"], **style)
    if metrics_table is not None:
        for source, rows in metrics_table.groupby("source"):
            rows = rows[rows["evaluation_episodes"] > 0]
            label = "evaluation" if metrics_table["source"].nunique() == 1 else f"evaluation ({Path(source).name})"
            style = {"linestyle": "--", "marker": "D", "markersize": 3, "color": "tab:green"}
            progress_ax.plot(rows["iteration"], rows["evaluation_progress_mean_pct"], label=label, **style)
            training = metrics_table[(metrics_table["source"] == source) & (metrics_table["training_episodes"] > 0)]
            if not set(training["iteration"]) <= set(iteration_table["iteration"]):  # simtraces of some are missing
                progress_ax.plot(
                    training["iteration"],
                    training["training_progress_mean_pct"],
                    linestyle=":",
                    color="0.4",
                    label=label.replace("evaluation", "training, TrainingMetrics"),
                )
            completion_ax.plot(rows["iteration"], 100 * rows["evaluation_completion_rate"], label=label, **style)
    reward_ax.set_ylabel("episode reward")
    progress_ax.set_ylabel("progress (%)")
    completion_ax.set_ylabel("episodes completing a lap (%)")
    completion_ax.set_ylim(-2, 102)
    completion_ax.set_xlabel("iteration")
    completion_ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    for ax in (reward_ax, progress_ax, completion_ax):
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
    reward_ax.set_title("Training progress by iteration")
    return _save(figure, path)


def laps_by_speed(
    steps: pd.DataFrame,
    laps: pd.DataFrame,
    track: Track,
    path: Path,
    title: str,
    obstacles: Sequence[ObjectPose] = (),
) -> Path:
    """One small map per lap with the driven path coloured by speed: where the car is slow or wide."""
    count = len(laps)
    columns = min(count, 2)
    rows = int(np.ceil(count / columns))
    figure = Figure(figsize=(6.5 * columns, 4.6 * rows), layout="constrained")
    axes = np.atleast_1d(figure.subplots(rows, columns)).ravel()
    keyed = steps.set_index(EPISODE_KEY).sort_index()
    traces = []
    for lap in laps.itertuples(index=False):
        trace = keyed.loc[tuple(getattr(lap, column) for column in EPISODE_KEY)]
        traces.append(trace[trace["episode_status"] != "pause"])
    speeds = pd.concat(traces)["speed_mps"]
    norm = Normalize(float(np.nanpercentile(speeds, 1)), max(0.5, float(np.nanpercentile(speeds, 99))))
    collection = None
    for ax, lap, trace in zip(axes, laps.itertuples(index=False), traces, strict=False):
        _draw_track(ax, track, centre=False, obstacles=obstacles)
        points = trace[["X", "Y"]].to_numpy()
        # No segment out of an off-track/crash row: after it the car was put back on the track (a reset).
        driven = ~trace["episode_status"].isin(INCIDENT_STATUSES).to_numpy()[:-1]
        segments = np.stack([points[:-1], points[1:]], axis=1)[driven]
        collection = LineCollection(segments, cmap="plasma", norm=norm, linewidth=2.5, zorder=2)
        # A 5-step (1/3 s) centred mean: one 15 Hz step's displacement is too noisy to read as a speed.
        smooth_mps = trace["speed_mps"].rolling(5, center=True, min_periods=1).mean()
        collection.set_array(smooth_mps.to_numpy()[1:][driven])
        ax.add_collection(collection)
        ax.plot(*points[0], "o", color="green", markersize=5, zorder=3)
        incidents = trace[trace["episode_status"].isin(INCIDENT_STATUSES)]
        ax.plot(incidents["X"], incidents["Y"], "x", color="red", markersize=8, markeredgewidth=2, zorder=4)
        time_text = f"{lap.lap_time_s:.2f} s" if lap.lap_complete else f"{lap.progress_pct:.0f} % in {lap.time_s:.1f} s"
        where = (
            f"iteration {lap.iteration}, episode {lap.episode}" if lap.phase == "training" else f"lap {lap.episode + 1}"
        )
        if lap.resets and lap.phase != "training":  # a training episode ends at its first incident
            time_text += f" ({lap.resets} reset{'s' if lap.resets > 1 else ''}, {lap.penalty_s:.1f} s penalty)"
        ax.set_title(f"{where}: {time_text}", fontsize=10)
    for ax in axes[count:]:
        ax.set_visible(False)
    if collection is not None:
        figure.colorbar(collection, ax=axes[:count].tolist(), label="speed (m/s)", shrink=0.8)
    figure.suptitle(title)
    return _save(figure, path)


def reward_heatmap(steps: pd.DataFrame, track: Track, path: Path, obstacles: Sequence[ObjectPose] = ()) -> Path:
    """Mean step reward where the car was: shows what the reward function pays for on each part of the track."""
    figure = Figure(figsize=(10, 7))
    ax = figure.subplots()
    _draw_track(ax, track, obstacles=obstacles)
    driving = steps[steps["episode_status"].isin(["in_progress", "off_track", "lap_complete", "crashed"])]
    extent_m = np.ptp(np.vstack([track.outer_border, track.inner_border]), axis=0)
    cells = ax.hexbin(
        driving["X"],
        driving["Y"],
        C=driving["reward"],
        reduce_C_function=np.mean,
        gridsize=max(10, int(extent_m[0] / 0.12)),
        cmap="viridis",
        mincnt=1,
        zorder=2,
        alpha=0.9,
    )
    figure.colorbar(cells, ax=ax, label="mean step reward", shrink=0.8)
    ax.set_title(f"Reward heatmap, {len(driving)} training steps")
    return _save(figure, path)


def crashes_on_track(
    steps: pd.DataFrame, crash_table: pd.DataFrame, track: Track, path: Path, obstacles: Sequence[ObjectPose] = ()
) -> Path:
    """Where the car crashed (every `crashed` row, coloured by iteration; evaluations as black crosses) beside the
    number of crashes per iteration: which obstacle catches the car, and whether that gets rarer."""
    figure = Figure(figsize=(15, 6), layout="constrained")
    map_ax, count_ax = figure.subplots(1, 2, width_ratios=[1.3, 1])
    _draw_track(map_ax, track, obstacles=obstacles)
    crashes = steps[steps["episode_status"] == "crashed"]
    training = crashes[crashes["phase"] == "training"]
    if len(training):
        points = map_ax.scatter(
            training["X"], training["Y"], c=training["iteration"], cmap="viridis", s=18, marker="x", zorder=3
        )
        figure.colorbar(points, ax=map_ax, label="iteration", shrink=0.8)
    evaluation = crashes[crashes["phase"] != "training"]
    if len(evaluation):
        map_ax.plot(
            evaluation["X"],
            evaluation["Y"],
            "x",
            color="black",
            markersize=8,
            markeredgewidth=2,
            label="evaluation",
            zorder=4,
        )
        map_ax.legend(loc="upper right", fontsize=8)
    map_ax.set_title(f"{len(crashes)} crashes ({len(obstacles)} fixed obstacles drawn)")
    for run, rows in crash_table.groupby("run"):
        label = "" if crash_table["run"].nunique() == 1 else f" ({run})"
        count_ax.bar(rows["iteration"], rows["crashes"], alpha=0.6, label=f"crashes{label}")
        count_ax.plot(
            rows["iteration"],
            100 * rows["crashed_episodes"] / rows["episodes"],
            "o-",
            color="tab:red",
            markersize=3,
            label=f"% of episodes with a crash{label}",
        )
    count_ax.set_xlabel("iteration")
    count_ax.set_ylabel("crashes / % of episodes")
    count_ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    count_ax.grid(alpha=0.3)
    count_ax.legend(loc="upper right", fontsize=8)
    count_ax.set_title("crashes per iteration (training)")
    return _save(figure, path)


def _action_labels(steps: pd.DataFrame) -> pd.Series:
    """Discrete action index -> 'steer° / speed' (every action, used or not); continuous actions binned into
    steering and speed ranges (only the bins that occur)."""
    action = pd.to_numeric(steps["action"], errors="coerce")
    if action.notna().all():
        names = steps.groupby(action)[["steer", "throttle"]].agg(lambda s: s.mode().iloc[0])
        labels = {a: f"{int(a)}: {row.steer:+.0f}° {row.throttle:.1f} m/s" for a, row in names.iterrows()}
        return action.map(labels).astype(pd.CategoricalDtype([labels[a] for a in sorted(labels)], ordered=True))
    steer_bins = pd.cut(steps["steer"], bins=5)
    speed_bins = pd.cut(steps["throttle"], bins=3)
    labels = [
        f"{s.left:+.0f}..{s.right:+.0f}° {v.left:.1f}..{v.right:.1f} m/s"
        for s in steer_bins.cat.categories
        for v in speed_bins.cat.categories
    ]
    combined = [
        f"{s.left:+.0f}..{s.right:+.0f}° {v.left:.1f}..{v.right:.1f} m/s"
        for s, v in zip(steer_bins, speed_bins, strict=True)
    ]
    used = [label for label in labels if label in set(combined)]
    return pd.Series(combined, index=steps.index, dtype=pd.CategoricalDtype(used, ordered=True))


def action_usage(
    steps: pd.DataFrame, waypoint: pd.Series, track: Track, sections: int, path: Path
) -> tuple[Path, pd.DataFrame]:
    """Share of each action per track section: e.g. whether the car brakes before a corner or steers on a straight.

    `waypoint` is each step's closest waypoint in the route file's order (see track_sections.forward_waypoint).
    """
    waypoint_section = section_of_waypoint(track, sections)
    driving = steps[steps["episode_status"] != "prepare"]
    waypoint = waypoint.loc[driving.index].clip(0, len(waypoint_section) - 1).astype(int)
    section = pd.Series(waypoint_section[waypoint.to_numpy()] + 1, index=driving.index, name="section")
    usage = pd.crosstab(section, _action_labels(driving), normalize="index", dropna=False).fillna(0.0)
    usage = usage.reindex(range(1, sections + 1), fill_value=0.0)

    figure = Figure(figsize=(15, 6), layout="constrained")
    map_ax, table_ax = figure.subplots(1, 2, width_ratios=[1, 1.5])
    _draw_track(map_ax, track)
    for number in range(sections):
        members = np.flatnonzero(waypoint_section == number)
        map_ax.plot(*track.center_line[members].T, linewidth=4, alpha=0.6, color=f"C{number % 10}")
        middle = track.center_line[members[len(members) // 2]]
        map_ax.annotate(
            str(number + 1),
            middle,
            ha="center",
            va="center",
            fontsize=9,
            fontweight="bold",
            bbox={"boxstyle": "circle", "facecolor": "white", "alpha": 0.9},
        )
    map_ax.plot(*track.center_line[0], "o", color="green", markersize=6)
    map_ax.set_title("track sections (● = waypoint 0)")
    image = table_ax.imshow(100 * usage.to_numpy(), aspect="auto", cmap="Blues", vmin=0)
    table_ax.set_yticks(range(sections), [str(s) for s in usage.index])
    table_ax.set_xticks(range(usage.shape[1]), usage.columns, rotation=60, ha="right", fontsize=8)
    table_ax.set_ylabel("section")
    for (row, column), share in np.ndenumerate(usage.to_numpy()):
        if share >= 0.005:
            table_ax.text(
                column,
                row,
                f"{100 * share:.0f}",
                ha="center",
                va="center",
                fontsize=7,
                color="white" if share > 0.5 * usage.to_numpy().max() else "black",
            )
    figure.colorbar(image, ax=table_ax, label="% of steps in the section")
    table_ax.set_title("action usage per section")
    return _save(figure, path), usage


def reward_comparison(lap_steps: pd.DataFrame, episode_totals: pd.DataFrame, path: Path, name: str) -> Path:
    """Logged vs candidate reward: step by step along one lap, and per episode for all of them."""
    figure = Figure(figsize=(13, 5), layout="constrained")
    lap_ax, episode_ax = figure.subplots(1, 2)
    lap_ax.plot(lap_steps["steps"], lap_steps["reward"], label="logged", linewidth=1.2)
    lap_ax.plot(lap_steps["steps"], lap_steps["new_reward"], label=name, linewidth=1.2, alpha=0.8)
    first = lap_steps.iloc[0]
    lap_ax.set_title(
        f"step reward along iteration {first['iteration']}, episode {first['episode']} "
        f"({lap_steps['progress'].max():.0f} %)",
        fontsize=10,
    )
    lap_ax.set_xlabel("step")
    lap_ax.set_ylabel("step reward")
    lap_ax.legend(fontsize=8)
    points = episode_ax.scatter(
        episode_totals["reward"],
        episode_totals["new_reward"],
        s=14,
        c=episode_totals["progress_pct"],
        cmap="viridis",
        vmin=0,
        vmax=100,
    )
    figure.colorbar(points, ax=episode_ax, label="progress (%)")
    episode_ax.set_xlabel("logged episode reward")
    episode_ax.set_ylabel(f"{name} episode reward")
    episode_ax.set_title("per episode", fontsize=10)
    for ax in (lap_ax, episode_ax):
        ax.grid(alpha=0.3)
    return _save(figure, path)
