"""What report.html shows and in which order: each picture next to the table it summarises, the long tables last
(racer.analysis.report writes the HTML)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from racer.analysis import aggregate
from racer.analysis.line_analysis import line_tables
from racer.analysis.report import Report, write_html
from racer.analysis.results import Analysis
from racer.analysis.sources import TRAINING

HTML_EPISODES = 200
"""Episode rows shown in the report; a long run has thousands, the CSV has them all."""


_PICTURE_TEXT = {
    "training_progress": (
        "Training progress",
        "Mean ± std of episode reward and progress per iteration, share of "
        "episodes that completed a lap, best lap time; dashed: the in-training evaluations of "
        "TrainingMetrics, when present.",
    ),
    "best_laps": (
        "Fastest training laps on the track",
        "Driven path coloured by speed (distance / time over 1/3 s); green dot = start, red cross = off track, crash, "
        "immobilized or reversed.",
    ),
    "evaluation_laps": (
        "Evaluation laps on the track",
        "Driven path coloured by speed; green dot = start of the lap, red cross = where a reset happened.",
    ),
    "reward_heatmap": ("Reward heatmap", "Mean step reward of all training steps in each cell of the track."),
    "crashes": (
        "Crashes",
        "Left: every crashed row on the track (training coloured by iteration, evaluation as black crosses) and the "
        "run's fixed obstacles (collision rectangles). Right: crashes per training iteration and the share of "
        "episodes with one.",
    ),
    "action_usage": ("Action usage per track section", "Share of the steps in each section that used each action."),
    "action_distributions": (
        "Continuous actions",
        "Commanded steering and speed of the training steps: histograms "
        "for early, middle and late iterations, and steering against speed.",
    ),
    "best_lap_over_line": (
        "The best evaluation lap over the racing line",
        "Left: the lap's path coloured by the time it lost to the line per metre of line (red: slower, blue: "
        "faster), the line dashed, each section's loss boxed. Right: the loss per section and per corner. Below: the "
        "lap's speed along the line (the simtrace's distance per step) and the line's.",
    ),
    "reward_comparison": (
        "Reward what-if",
        "Logged reward and the candidate's along the fastest lap, and episode "
        "totals of both for every training episode.",
    ),
}


def build_report(analysis: Analysis, out_dir: Path) -> Path:
    """report.html: each picture next to the table it summarises, the long tables last."""
    report = Report(title="racer analysis", source=analysis.files.description, notes=list(analysis.notes))
    metrics = analysis.metrics_iterations if analysis.metrics_iterations is not None else pd.DataFrame()
    training = analysis.episodes[analysis.episodes["phase"] == TRAINING]
    comparison = analysis.reward_comparison if analysis.reward_comparison is not None else pd.DataFrame()
    sections = [
        ("table", "Training iterations", analysis.iterations, "All workers together."),
        ("picture", "training_progress"),
        (
            "table",
            "Training by worker",
            analysis.workers if analysis.workers["worker"].nunique() > 1 else pd.DataFrame(),
            "One row per worker (world).",
        ),
        (
            "table",
            "In-training evaluations (TrainingMetrics)",
            metrics,
            "From DeepRacer's TrainingMetrics JSON (worker 0): training episodes and the greedy evaluation episodes run "
            "after each checkpoint; its times include the prepare step.",
        ),
        (
            "table",
            "Fastest training laps",
            aggregate.best_laps(training, TRAINING, 10),
            "Complete laps, fastest first (when no lap was completed: the episodes that got furthest).",
        ),
        (
            "table",
            "Crashes by iteration",
            _crash_table(analysis),
            "Training episodes with a collision (status crashed) per iteration; obstacle_crash_counter is the "
            "simtrace column's largest value (resets behind the same obstacle in a row).",
        ),
        ("picture", "crashes"),
        ("picture", "best_laps"),
        ("picture", "reward_heatmap"),
        ("picture", "action_usage"),
        ("picture", "action_distributions"),
        ("table", "Evaluations", analysis.evaluations, "One row per evaluation run."),
        (
            "table",
            "Evaluation laps",
            analysis.evaluation_laps,
            "Per lap: time, progress, resets and penalty time. lap_time_s and time_s are DeepRacer's, from the reset "
            "(time_from EvaluationMetrics: the run's metrics file, as racer evaluate and the console show them); "
            "simtrace_time_s is the simtrace's span from its prepare row, one step shorter on a lap from a standing "
            "start (time_from simtrace: no metrics file, the span is all there is).",
        ),
        ("picture", "evaluation_laps"),
        *_line_sections(analysis),
        ("picture", "best_lap_over_line"),
        ("table", "Reward what-if by iteration", comparison, "Logged reward and the candidate's, per iteration."),
        ("picture", "reward_comparison"),
        (
            "table",
            "Training episodes (latest)",
            training.tail(HTML_EPISODES),
            f"The last {HTML_EPISODES} training episodes; every episode is in episodes.csv.",
        ),
    ]
    for kind, key, *rest in sections:
        if kind == "picture" and key in analysis.pictures:
            heading, caption = _PICTURE_TEXT[key]
            report.add_picture(heading, analysis.pictures[key], caption)
        elif kind == "table" and len(rest[0]):
            report.add_table(key, rest[0], rest[1])
    analysis.report_path = write_html(report, out_dir / "report.html")
    return analysis.report_path


def _crash_table(analysis: Analysis) -> pd.DataFrame:
    """Per training iteration: episodes, crashes, episodes with a crash (empty for a run without any)."""
    if not analysis.has_crashes and not analysis.layout.obstacles:
        return pd.DataFrame()
    columns = ["run", "iteration", "episodes", "crashes", "crashed_episodes"]
    table = analysis.iterations[columns].copy()
    table["crashed_episodes_pct"] = 100.0 * table["crashed_episodes"] / table["episodes"]
    training = analysis.episodes[analysis.episodes["phase"] == TRAINING]
    if "obstacle_crash_counter" in training:
        counter = (
            training.groupby(["run", "iteration"])["obstacle_crash_counter"].max().rename("obstacle_crash_counter")
        )
        table = table.merge(counter.reset_index(), on=["run", "iteration"], how="left")
    return table


def _line_sections(analysis: Analysis) -> list[tuple]:
    """The laps-against-the-line tables, each with what it is."""
    tables = line_tables(analysis.line_comparison)
    if not tables:
        return []
    thresholds = "; ".join(
        f"{run}: {kappa:.3f} /m, radius {1 / kappa:.2f} m"
        for run, kappa in sorted(analysis.line_comparison.corner_threshold_per_m.items())
    )
    return [
        (
            "table",
            "Laps against the line",
            tables["laps_against_line"],
            "Each complete evaluation lap against the car's racing line on the same track (racer.racing_line: the "
            "fastest line found for the run's car in its world). line_lap_s is the line's flying lap, ratio_to_bound "
            "the lap over it; line_three_lap_average_s the line's best 3 laps from a standing start. The lap time is "
            "the table above's (time_from says whose).",
        ),
        (
            "table",
            "Time lost per track section",
            tables["section_losses"],
            "The report's track sections (equal lengths of centre line from waypoint 0) mapped onto the line: the "
            "line's time there and each lap's loss (its time there minus the line's; the lap's rows projected onto "
            "the line by distance). A lap's section losses add up to its lap time minus the line's flying lap; the "
            "first section carries the standing start.",
        ),
        (
            "table",
            "Time lost per corner",
            tables["corner_losses"],
            "Corners are the stretches where the line's curvature exceeds a_lat / (v_top - a_drive × 1/15 s)²: "
            "there the car's lateral grip holds it below its top speed by more than one control period's "
            "acceleration (bending less is free: the line's straights lie on a_lat / v_top²). "
            f"Threshold {thresholds}. start_m and end_m are distances along the line from the start line.",
        ),
    ]
