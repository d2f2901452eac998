"""From a source to tables, pictures and the HTML report; the CLI is a thin shell around `analyze`."""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd
import yaml

from racer.analysis import action_distributions, aggregate, plots, training_metrics, whatif
from racer.analysis.loading import load_steps
from racer.analysis.race_layout import RaceLayout, race_layout
from racer.analysis.report import Report, write_html
from racer.analysis.sources import EVALUATION, TRAINING, RunFiles, open_source
from racer.analysis.track_sections import Track, TrackError, forward_waypoint, load_track, reversed_episodes
from racer.shared.deepracer.metrics import MetricsError

NEEDS_TRACK = "the reward what-if rebuilds params from the track: give --track NAME|PATH.npy"
HTML_EPISODES = 200
"""Episode rows shown in the report; a long run has thousands, the CSV has them all."""


@dataclass
class Analysis:
    files: RunFiles
    steps: pd.DataFrame
    episodes: pd.DataFrame
    iterations: pd.DataFrame
    iterations_by_worker: pd.DataFrame
    workers: pd.DataFrame
    evaluation_laps: pd.DataFrame
    evaluations: pd.DataFrame
    track: Track | None
    notes: list[str] = field(default_factory=list)
    pictures: dict[str, Path] = field(default_factory=dict)
    tables_written: dict[str, Path] = field(default_factory=dict)
    report_path: Path | None = None
    reward_comparison: pd.DataFrame | None = None
    reversed_episodes: pd.Series | None = None
    """Per episode, whether it was driven on the reversed route (only known with a track)."""
    track_workers: set[int] | None = None
    """Training workers that drove `track` (None = all of them)."""
    metrics_iterations: pd.DataFrame | None = None
    """Per iteration from TrainingMetrics JSON (training and in-training evaluation), when the source has it."""
    picture_iterations: tuple[int, int | None] | None = None
    """(first, last or None = to the end): training iterations the track pictures and the what-if use."""
    layout: RaceLayout = field(default_factory=RaceLayout)
    """Race type and fixed obstacles from the run's params yaml (drawn on the track maps)."""

    @property
    def has_crashes(self) -> bool:
        return bool((self.steps["episode_status"] == "crashed").any())


def run_tracks(files: RunFiles) -> dict[int | str, str]:
    """WORLD_NAME by who used it: worker i (training_params.yaml = worker 0, training_params_<i>.yaml = worker i)
    or "evaluation" (eval_params*.yaml, evaluation_params*.yaml)."""
    tracks: dict[int | str, str] = {}
    for name, data in sorted(files.params_yaml.items()):
        try:
            params = yaml.safe_load(data)
        except yaml.YAMLError as error:
            print(f"warning: {name}: not readable yaml ({error}); ignored", file=sys.stderr)
            continue
        world = params.get("WORLD_NAME") if isinstance(params, dict) else None
        if not world:
            continue
        filename = Path(name).name
        worker = re.match(r"training_params(?:_(\d+))?\.ya?ml$", filename)
        role = (int(worker.group(1) or 0)) if worker else EVALUATION
        tracks.setdefault(role, str(world))
    return tracks


def resolve_track(
    files: RunFiles, track_arg: str | None, tracks_dir: Path | None, notes: list[str]
) -> tuple[Track | None, set[int] | None]:
    """(track, training workers that drove it; None = all).

    --track wins and is used for every worker. Otherwise the run's own WORLD_NAME (worker 0's first), if a route
    of that name is in the tracks folder; workers that trained on another track are left out of the pictures.
    """
    tracks = run_tracks(files)
    by_worker = {role: name for role, name in tracks.items() if isinstance(role, int)}
    several = len(set(by_worker.values())) > 1
    if track_arg:
        if several:
            notes.append(
                f"The workers trained on several tracks ({_listing(by_worker)}); all are drawn on {track_arg}."
            )
        return load_track(track_arg, tracks_dir), None  # an explicit track that cannot be loaded is an error
    if not tracks:
        notes.append(
            "No track given (--track NAME|PATH.npy) and none named by the run: tables only, no track pictures."
        )
        return None, None
    world = by_worker[min(by_worker)] if by_worker else tracks[EVALUATION]
    try:
        track = load_track(world, tracks_dir)
    except TrackError:
        notes.append(
            f"The run was on track {world!r}, which is not in the tracks folder; give its route with "
            "--track PATH.npy (or --tracks-dir): tables only, no track pictures."
        )
        return None, None
    notes.append(f"Track {world!r} taken from the run's params yaml.")
    if not several:
        return track, None
    others = {worker: name for worker, name in by_worker.items() if name != world}
    notes.append(
        f"Workers on other tracks ({_listing(others)}) are left out of the track pictures and the reward "
        "what-if; analyse them with --track."
    )
    return track, {worker for worker, name in by_worker.items() if name == world}


def _listing(by_worker: dict[int, str]) -> str:
    return ", ".join(f"worker {worker}: {name}" for worker, name in sorted(by_worker.items()))


def build_tables(
    files: RunFiles,
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
    layout = race_layout(files.params_yaml, track)
    notes.extend(layout.notes)
    return Analysis(
        files=files,
        layout=layout,
        steps=steps,
        episodes=episodes,
        iterations=aggregate.iterations(episodes),
        iterations_by_worker=aggregate.iterations(episodes, per_worker=True),
        workers=aggregate.workers(episodes),
        evaluation_laps=aggregate.evaluation_laps(episodes),
        evaluations=aggregate.evaluations(episodes),
        track=track,
        notes=notes,
        reversed_episodes=reversed_by_episode,
        track_workers=track_workers,
        metrics_iterations=metrics_iterations,
    )


def read_metrics(files: RunFiles, notes: list[str]) -> pd.DataFrame | None:
    """The TrainingMetrics iteration tables of the source (one `source` per file); unreadable files become notes,
    since the simtrace analysis stands without them."""
    tables = []
    for name, data in sorted(files.training_metrics.items()):
        try:
            tables.append(training_metrics.read_iteration_table(data, name).assign(source=name))
        except MetricsError as error:
            notes.append(f"TrainingMetrics left out: {error}")
    return pd.concat(tables, ignore_index=True) if tables else None


def on_track(table: pd.DataFrame, track_workers: set[int] | None) -> pd.DataFrame:
    """Rows (steps or episodes) driven on the analysis track: evaluations, and training workers on that track."""
    if track_workers is None:
        return table
    return table[(table["phase"] != TRAINING) | table["worker"].isin(track_workers)]


def for_pictures(table: pd.DataFrame, analysis: Analysis) -> pd.DataFrame:
    """Rows the track pictures and the reward what-if use: on the track, and in the chosen training iterations."""
    table = on_track(table, analysis.track_workers)
    if analysis.picture_iterations is None:
        return table
    first, last = analysis.picture_iterations
    chosen = table["iteration"].between(first, last if last is not None else table["iteration"].max())
    return table[(table["phase"] != TRAINING) | chosen]


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
    if len(evaluation):
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
        ("table", "Evaluation laps", analysis.evaluation_laps, "Per lap: time, progress, resets and penalty time."),
        ("picture", "evaluation_laps"),
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
) -> Analysis:
    """Everything `racer analyze` writes: CSV tables, PNGs, the optional reward what-if and report.html."""
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
    write_tables(analysis, out_dir)
    if pictures:
        draw_pictures(analysis, out_dir, sections=sections, top_laps=top_laps)
    if reward_function is not None:
        compare_reward(analysis, reward_function, out_dir, picture=pictures, show_progress=show_progress)
    build_report(analysis, out_dir)
    return analysis
