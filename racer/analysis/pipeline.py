"""From a source to tables, pictures and the HTML report; the CLI is a thin shell around `analyze`.

The tables and what was made of them are an `Analysis` (racer.analysis.results); the run's track is found by
racer.analysis.run_track, the report's contents are chosen by racer.analysis.report_contents.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

from racer.analysis import action_distributions, aggregate, evaluation_times, plots, training_metrics, whatif
from racer.analysis.line_analysis import compare_with_line, line_tables
from racer.analysis.line_picture import best_lap_over_line
from racer.analysis.loading import load_steps
from racer.analysis.obstacle_layout import obstacle_layout
from racer.analysis.report_contents import build_report
from racer.analysis.results import Analysis, for_pictures, on_track
from racer.analysis.run_line import LineBook
from racer.analysis.run_track import resolve_track
from racer.analysis.sources import EVALUATION, TRAINING, SimtraceFiles, open_source
from racer.analysis.track_sections import TrackError, forward_waypoint, reversed_episodes
from racer.shared.deepracer.metrics import MetricsError

NEEDS_TRACK = "the reward what-if rebuilds params from the track: give --track NAME|PATH.npy"


def build_tables(
    files: SimtraceFiles,
    track_arg: str | None = None,
    tracks_dir: Path | None = None,
    *,
    track_required: bool = False,
    show_progress: bool = True,
) -> Analysis:
    notes: list[str] = []
    # The track first: a wrong --track fails before the long read.
    track, track_workers = resolve_track(files, track_arg, tracks_dir, notes)
    if track is None and track_required:
        raise TrackError(NEEDS_TRACK)
    steps = load_steps(files, progress=show_progress)
    episodes = aggregate.episodes(steps)
    metrics_iterations = read_metrics(files, notes)
    reversed_by_episode = None
    if track is not None:
        logged_length_m = float(on_track(steps, track_workers)["track_len"].median())
        if abs(logged_length_m - track.length_m) > 0.005 * track.length_m:
            notes.append(
                f"The simtraces say the track is {logged_length_m:.2f} m long, but {track.name} is "
                f"{track.length_m:.2f} m: probably the wrong track for this run."
            )
        reversed_by_episode = reversed_episodes(on_track(steps, track_workers), track)
        if reversed_by_episode.any():
            notes.append(
                f"{int(reversed_by_episode.sum())} of {len(reversed_by_episode)} episodes were driven in the "
                "reverse direction of the route (told by their closest_waypoint)."
            )
    layout = obstacle_layout(files.params_yaml, track)
    notes.extend(layout.notes)
    laps = evaluation_times.timed_laps(files, aggregate.evaluation_laps(episodes), notes)
    return Analysis(
        files=files,
        layout=layout,
        steps=steps,
        episodes=episodes,
        iterations=aggregate.iterations(episodes),
        iterations_by_worker=aggregate.iterations(episodes, per_worker=True),
        workers=aggregate.workers(episodes),
        evaluation_laps=laps,
        evaluations=evaluation_times.evaluations(laps),
        track=track,
        notes=notes,
        reversed_episodes=reversed_by_episode,
        track_workers=track_workers,
        metrics_iterations=metrics_iterations,
    )


def read_metrics(files: SimtraceFiles, notes: list[str]) -> pd.DataFrame | None:
    """The TrainingMetrics iteration tables of the source (one `source` per file); unreadable files become notes,
    since the simtrace analysis stands without them."""
    tables = []
    for name, data in sorted(files.training_metrics.items()):
        try:
            tables.append(training_metrics.read_iteration_table(data, name).assign(source=name))
        except MetricsError as error:
            notes.append(f"TrainingMetrics left out: {error}")
    return pd.concat(tables, ignore_index=True) if tables else None


def draw_pictures(analysis: Analysis, out_dir: Path, *, sections: int, top_laps: int) -> None:
    print("drawing pictures", file=sys.stderr)
    if len(analysis.iterations):
        analysis.pictures["training_progress"] = plots.training_progress(
            analysis.iterations,
            analysis.iterations_by_worker,
            out_dir / "training_progress.png",
            metrics_table=analysis.metrics_iterations,
        )
    steps = for_pictures(analysis.steps, analysis)
    training_steps = steps[steps["phase"] == TRAINING]
    if len(training_steps) and action_distributions.is_continuous(training_steps):  # needs no track
        analysis.pictures["action_distributions"] = action_distributions.action_distributions(
            training_steps, out_dir / "action_distributions.png"
        )
    if analysis.track is None:
        return
    track = analysis.track
    obstacles = analysis.layout.obstacles
    if analysis.has_crashes or obstacles:
        analysis.pictures["crashes"] = plots.crashes_on_track(
            steps, analysis.iterations, track, out_dir / "crashes.png", obstacles
        )
    best_training = aggregate.best_laps(for_pictures(analysis.episodes, analysis), TRAINING, top_laps)
    if len(best_training):
        title = (
            "Fastest training laps"
            if best_training["lap_complete"].all()
            else "Furthest training episodes (no lap completed)"
        )
        analysis.pictures["best_laps"] = plots.laps_by_speed(
            analysis.steps, best_training, track, out_dir / "best_laps.png", f"{title} (speed colour)", obstacles
        )
        analysis.pictures["reward_heatmap"] = plots.reward_heatmap(
            training_steps, track, out_dir / "reward_heatmap.png", obstacles
        )
        waypoint = forward_waypoint(training_steps, analysis.reversed_episodes, track)
        picture, _ = plots.action_usage(training_steps, waypoint, track, sections, out_dir / "action_usage.png")
        analysis.pictures["action_usage"] = picture
    evaluation = analysis.episodes[analysis.episodes["phase"] == EVALUATION]
    if len(evaluation):  # the laps' times as the report's tables give them (evaluation_times), in the same order
        laps = analysis.evaluation_laps
        evaluation = evaluation.assign(lap_time_s=laps["lap_time_s"].to_numpy(), time_s=laps["time_s"].to_numpy())
        shown = evaluation.sort_values(["run", "start_tstamp_s"]).head(6)
        analysis.pictures["evaluation_laps"] = plots.laps_by_speed(
            analysis.steps,
            shown,
            track,
            out_dir / "evaluation_laps.png",
            "Evaluation laps (speed colour)",
            obstacles,
        )


def write_tables(analysis: Analysis, out_dir: Path) -> None:
    """CSV copies of every table, for spreadsheets and notebooks."""
    for name in (
        "episodes",
        "iterations",
        "iterations_by_worker",
        "workers",
        "evaluation_laps",
        "evaluations",
        "metrics_iterations",
    ):
        table = getattr(analysis, name)
        if table is not None and len(table):
            path = out_dir / f"{name}.csv"
            table.to_csv(path, index=False)
            analysis.tables_written[name] = path
    for name, table in line_tables(analysis.line_comparison).items():
        path = out_dir / f"{name}.csv"
        table.to_csv(path, index=False)
        analysis.tables_written[name] = path


def compare_reward(
    analysis: Analysis, reward_path: Path, out_dir: Path, *, picture: bool, show_progress: bool = True
) -> None:
    """The reward what-if: table (and CSV), plus its picture."""
    if analysis.track is None:
        raise TrackError(NEEDS_TRACK)
    new_reward = whatif.replay_reward(
        for_pictures(analysis.steps, analysis),
        analysis.track,
        reward_path,
        reversed_by_episode=analysis.reversed_episodes,
        show_progress=show_progress,
    )
    compared, by_iteration = whatif.compare(analysis.steps, new_reward, analysis.episodes)
    analysis.reward_comparison = by_iteration
    by_iteration.to_csv(out_dir / "reward_whatif.csv", index=False)
    analysis.tables_written["reward_whatif"] = out_dir / "reward_whatif.csv"
    if picture:
        analysis.pictures["reward_comparison"] = plots.reward_comparison(
            whatif.lap_steps(analysis.steps, new_reward, analysis.episodes),
            compared,
            out_dir / "reward_whatif.png",
            Path(reward_path).name,
        )


def analyze(
    source: str,
    out_dir: Path,
    *,
    track: str | None = None,
    tracks_dir: Path | None = None,
    reward_function: Path | None = None,
    iterations: tuple[int, int | None] | None = None,
    sections: int = 10,
    top_laps: int = 4,
    pictures: bool = True,
    show_progress: bool = True,
    lines: LineBook | None = None,
) -> Analysis:
    """Everything `racer analyze` writes: CSV tables, PNGs, the optional reward what-if and report.html.

    `lines`: where the evaluation laps' racing lines come from (one computation per route, car and world); None:
    no line comparison."""
    files = open_source(source)
    analysis = build_tables(
        files, track, tracks_dir, track_required=reward_function is not None, show_progress=show_progress
    )
    if iterations is not None:
        analysis.picture_iterations = iterations
        last = "the last" if iterations[1] is None else str(iterations[1])
        analysis.notes.append(
            f"Track pictures and the reward what-if use training iterations {iterations[0]} to "
            f"{last}; the tables use all of them."
        )
    out_dir.mkdir(parents=True, exist_ok=True)
    if lines is not None and len(analysis.evaluation_laps):
        if show_progress:
            print("the evaluation laps against the racing line (computing a line takes a while)", file=sys.stderr)
        analysis.line_comparison = compare_with_line(analysis, lines, sections)
        analysis.notes.extend(analysis.line_comparison.notes)
    write_tables(analysis, out_dir)
    if pictures:
        draw_pictures(analysis, out_dir, sections=sections, top_laps=top_laps)
        best = analysis.line_comparison.best() if analysis.line_comparison is not None else None
        if best is not None:
            analysis.pictures["best_lap_over_line"] = best_lap_over_line(best, out_dir / "best_lap_over_line.png")
    if reward_function is not None:
        compare_reward(analysis, reward_function, out_dir, picture=pictures, show_progress=show_progress)
    build_report(analysis, out_dir)
    return analysis
