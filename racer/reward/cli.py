"""`racer reward test REWARD.py`: check a reward function over a whole track before training with it."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import click

from racer.options.track import direction_option, track_option
from racer.shared.sim.objects.challenge import RACE_TYPES


@click.group("reward")
def reward_group() -> None:
    """Check reward functions."""


@reward_group.command("test")
@click.argument("reward_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@track_option()
@click.option(
    "--race-type",
    type=click.Choice(RACE_TYPES, case_sensitive=False),
    default="TIME_TRIAL",
    show_default=True,
    help="OBJECT_AVOIDANCE adds obstacles, HEAD_TO_BOT bot cars (the objects_* params).",
)
@click.option(
    "--model-metadata",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    help="model_metadata.json whose action space is tried (default: racer's 10 discrete actions).",
)
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None, help="Draw the reward (PNG).")
@click.option("--budget", type=float, default=6.0, show_default=True, help="Seconds the calls may take at most.")
@direction_option
def test_command(
    reward_file: Path,
    track: str,
    race_type: str,
    model_metadata: Path | None,
    plot: Path | None,
    budget: float,
) -> None:
    """Call REWARD_FILE's reward_function on params over the whole track (across its width, off it, headings around
    the track direction and reversed, each action, the race type's objects) and report every exception (file, line,
    params), every return that is not a finite number within ±1e5, a mean call slower than 1 ms, and, as warnings,
    what DeepRacer on AWS's validator rejects. Exit status 1 on any error."""
    from racer.reward.check import check_reward_file, reward_map
    from racer.shared.deepracer.model_metadata import ModelMetadataError, load_model_metadata
    from racer.shared.sim.tracks.track import Track, TrackError

    start = time.perf_counter()
    try:
        route = Track.load(track)
        metadata = load_model_metadata(model_metadata) if model_metadata else None
    except (TrackError, ModelMetadataError) as error:
        raise click.ClickException(str(error)) from error
    report = check_reward_file(reward_file, route, race_type.upper(), metadata, time_budget_s=budget)
    click.echo(report.format())
    if plot is not None and report.calls:
        click.echo(f"plot: {reward_map(reward_file, route, race_type.upper(), metadata, plot)}")
    click.echo(f"{'FAILED' if report.errors else 'OK'} in {time.perf_counter() - start:.1f} s")
    sys.exit(1 if report.errors else 0)
