"""`racer analyze SOURCE`: simtrace logs -> terminal tables, CSVs, PNGs and one HTML report."""

from __future__ import annotations

import re
from pathlib import Path

import click
import pandas as pd

from racer.analysis import aggregate
from racer.analysis.line_analysis import line_tables
from racer.analysis.pipeline import analyze
from racer.analysis.report import format_table
from racer.analysis.results import Analysis
from racer.analysis.run_line import LineBook
from racer.analysis.sources import TRAINING, SourceError
from racer.analysis.track_sections import TrackError
from racer.shared.deepracer.simtrace import SimtraceError
from racer.shared.sim.reward.function import RewardFunctionError
from racer.shared.store import StoreError

TERMINAL_ITERATIONS = 15
"""The terminal shows the last iterations only; the report and iterations.csv have all of them."""


def default_out_dir(source: str) -> Path:
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", source.removeprefix("s3://").rstrip("/").split("/")[-1]) or "run"
    return Path("analysis") / re.sub(r"\.(tar\.gz|tgz|tar|csv|log)$", "", name)


def parse_range(value: str | None) -> tuple[int, int | None] | None:
    """'27' -> (27, 27), '20-27' -> (20, 27), '20-' -> (20, None)."""
    if value is None:
        return None
    match = re.fullmatch(r"\s*(\d+)\s*(-\s*(\d*)\s*)?", value)
    if match is None:
        raise click.BadParameter(f"{value!r}: expected A, A-B or A- (iteration numbers)")
    first = int(match.group(1))
    last = first if match.group(2) is None else (int(match.group(3)) if match.group(3) else None)
    if last is not None and last < first:
        raise click.BadParameter(f"{value!r}: the range ends before it starts")
    return first, last


def _echo_table(title: str, table: pd.DataFrame, columns: list[str]) -> None:
    if len(table) == 0:
        return
    click.secho(f"\n{title}", bold=True)
    shown = format_table(table[[c for c in columns if c in table.columns]])
    click.echo(shown.to_string(index=False, na_rep="-"))


def print_summary(analysis: Analysis) -> None:
    episodes = analysis.episodes
    training = episodes[episodes["phase"] == TRAINING]
    click.echo(
        f"{len(analysis.files.simtraces)} simtrace files, {len(analysis.steps)} steps: "
        f"{len(training)} training episodes in {len(analysis.iterations)} iterations "
        f"({training['worker'].nunique()} worker(s)), {len(analysis.evaluation_laps)} evaluation laps "
        f"in {len(analysis.evaluations)} evaluation(s)."
    )
    for note in analysis.notes:
        click.secho(f"note: {note}", fg="yellow")
    _echo_table(
        f"Training iterations (last {TERMINAL_ITERATIONS})"
        if len(analysis.iterations) > TERMINAL_ITERATIONS
        else "Training iterations",
        analysis.iterations.tail(TERMINAL_ITERATIONS),
        [
            "iteration",
            "episodes",
            "reward_mean",
            "reward_std",
            "progress_mean_pct",
            "progress_std_pct",
            "completion_rate",
            "best_lap_time_s",
            "mean_lap_time_s",
        ],
    )
    if analysis.metrics_iterations is not None:
        _echo_table(
            "In-training evaluations (TrainingMetrics, last iterations)",
            analysis.metrics_iterations.tail(TERMINAL_ITERATIONS),
            [
                "iteration",
                "training_episodes",
                "training_progress_mean_pct",
                "evaluation_episodes",
                "evaluation_progress_mean_pct",
                "evaluation_completion_rate",
                "evaluation_best_lap_time_s",
            ],
        )
    if analysis.workers["worker"].nunique() > 1:
        _echo_table(
            "Training by worker",
            analysis.workers,
            ["worker", "episodes", "reward_mean", "progress_mean_pct", "completion_rate", "best_lap_time_s"],
        )
    _echo_table(
        "Fastest training laps",
        aggregate.best_laps(episodes, TRAINING, 5)[lambda t: t["lap_complete"]],
        [
            "iteration",
            "worker",
            "episode",
            "start_waypoint",
            "lap_time_s",
            "speed_mps",
            "throttle_mps",
            "reward",
            "steps",
        ],
    )
    _echo_table(
        "Evaluation laps",
        analysis.evaluation_laps,
        [
            "run",
            "lap",
            "lap_time_s",
            "simtrace_time_s",
            "time_from",
            "progress_pct",
            "status",
            "resets",
            "off_track",
            "crashed",
            "penalty_s",
        ],
    )
    tables = line_tables(analysis.line_comparison)
    if tables:
        _echo_table(
            "Evaluation laps against the racing line",
            tables["laps_against_line"],
            ["run", "lap", "lap_time_s", "line_lap_s", "ratio_to_bound", "loss_s", "line"],
        )
        _echo_table("Time lost per track section (s)", tables["section_losses"], list(tables["section_losses"].columns))


@click.command("analyze")
@click.argument("source")
@click.option(
    "--track",
    "track",
    metavar="NAME|PATH",
    help="Route by name or .npy path. Default: the run's WORLD_NAME, if that route is in the tracks folder.",
)
@click.option(
    "--tracks-dir",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    help="Folder of route .npy files to find track names in [default: the project's tracks/].",
)
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    help="Folder for report.html, PNGs and CSVs [default: ./analysis/<source name>].",
)
@click.option(
    "--reward-function",
    "reward_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="Candidate reward_function.py to replay over the logged training steps (needs the track).",
)
@click.option(
    "--iterations",
    "iterations",
    metavar="A[-B]",
    callback=lambda ctx, param, value: parse_range(value),
    help="Training iterations for the track pictures and the what-if: '27', '20-27' or '20-' "
    "(default: all; tables always show all).",
)
@click.option(
    "--sections",
    default=10,
    show_default=True,
    type=click.IntRange(2, 50),
    help="Number of equal-length track sections for the action-usage picture.",
)
@click.option(
    "--top",
    "top_laps",
    default=4,
    show_default=True,
    type=click.IntRange(1, 12),
    help="How many of the fastest laps to draw.",
)
@click.option("--no-pictures", is_flag=True, help="Tables and CSVs only (faster).")
@click.option(
    "--no-line",
    is_flag=True,
    help="Leave out the evaluation laps against the racing line (computing a line takes tens of seconds on a big "
    "track).",
)
def analyze_command(
    source: str,
    track: str | None,
    tracks_dir: Path | None,
    out_dir: Path | None,
    reward_path: Path | None,
    iterations: tuple[int, int | None] | None,
    sections: int,
    top_laps: int,
    no_pictures: bool,
    no_line: bool,
) -> None:
    """Analyse DeepRacer/racer simtrace logs. SOURCE is a model folder, a .tar.gz export, s3://bucket/prefix,
    a model prefix in RACER_STORE, one simtrace .csv, or a simulation .log with SIM_TRACE_LOG lines.

    Reads training and evaluation simtraces of any layout (DRfC single/multi-worker, console export, evaluations)
    and 15-19 column variants. Prints the key tables, writes CSVs, PNGs and a self-contained report.html.
    """
    out_dir = out_dir or default_out_dir(source)
    try:
        analysis = analyze(
            source,
            out_dir,
            track=track,
            tracks_dir=tracks_dir,
            reward_function=reward_path,
            iterations=iterations,
            sections=sections,
            top_laps=top_laps,
            pictures=not no_pictures,
            lines=None if no_line else LineBook(),
        )
    except (SourceError, SimtraceError, TrackError, StoreError, RewardFunctionError) as error:
        raise click.ClickException(str(error)) from error
    print_summary(analysis)
    if analysis.reward_comparison is not None:
        _echo_table(
            f"Reward what-if: {reward_path}",
            analysis.reward_comparison,
            ["iteration", "episodes", "reward_mean", "new_reward_mean", "episode_reward_correlation"],
        )
    click.echo(
        f"\nreport: {analysis.report_path}  (tables: {', '.join(p.name for p in analysis.tables_written.values())})"
    )
