"""`racer evaluate`: evaluate a stored model with DeepRacer's evaluation rules or the 4-minute summit rule.

The store comes from RACER_STORE (a directory or s3://bucket with S3_ENDPOINT_URL for MinIO), as for every racer
process. Output layout: see `racer.evaluation_worker.outputs`.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import click

from racer.drfc.options import drfc_evaluate_option
from racer.evaluation_worker.config import CONSOLE_NUMBER_OF_RESETS, MODES
from racer.options.challenge import challenge_options, challenge_params_from_options
from racer.options.generation import car_profile_option, generation_option
from racer.options.model import checkpoint_option
from racer.options.track import direction_option, track_option
from racer.options.training import model_prefix_option, seed_option
from racer.shared.sim.config import RESET_POSITIONS
from racer.shared.sim.scene.worlds import WORLD_NAMES


def _video_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise click.BadParameter(
            f"expected WIDTHxHEIGHT such as 480x360, got {text!r}", param_hint="--video-size"
        ) from None
    return width, height


@click.command(name="evaluate")
@drfc_evaluate_option
@model_prefix_option()
@checkpoint_option
@click.option(
    "--mode",
    type=click.Choice(MODES),
    default="deepracer",
    show_default=True,
    help="deepracer: NUMBER_OF_TRIALS laps with DeepRacer's rules; race: the 4-minute, 3-resets-per-lap rule.",
)
@track_option()
@click.option("--world", type=click.Choice(WORLD_NAMES), default="base", show_default=True)
@click.option(
    "--reverse/--no-reverse", default=False, show_default=True, help="Drive the route the other way (REVERSE_DIR)."
)
@click.option(
    "--trials", type=click.IntRange(min=1), default=3, show_default=True, help="NUMBER_OF_TRIALS (deepracer mode)."
)
@click.option(
    "--continuous/--no-continuous",
    default=None,
    help="IS_CONTINUOUS: laps run into each other. Default: off in deepracer mode, on with --mode race.",
)
@click.option(
    "--resets",
    type=click.IntRange(min=0),
    default=CONSOLE_NUMBER_OF_RESETS,
    show_default=True,
    help="NUMBER_OF_RESETS (deepracer mode): put-backs before a rule ends the trial; 0 or >= 2 "
    "(default: the console's value, so an exit costs the penalty and the lap goes on).",
)
@click.option(
    "--off-track-penalty",
    type=click.FloatRange(min=0.0),
    default=2.0,
    show_default=True,
    help="OFF_TRACK_PENALTY seconds (deepracer mode; also the reversed penalty).",
)
@click.option(
    "--collision-penalty",
    type=click.FloatRange(min=0.0),
    default=5.0,
    show_default=True,
    help="COLLISION_PENALTY seconds after a crash into an obstacle or a bot car (deepracer mode).",
)
@click.option(
    "--race-minutes",
    type=click.FloatRange(min=0.0, min_open=True),
    default=4.0,
    show_default=True,
    help="The summit rule's duration in simulated minutes (--mode race).",
)
@click.option(
    "--race-resets-per-lap",
    type=click.IntRange(min=0),
    default=3,
    show_default=True,
    help="Put-backs allowed per lap; the next exit ends the lap attempt (--mode race).",
)
@click.option(
    "--race-reset-penalty",
    type=click.FloatRange(min=0.0),
    default=2.0,
    show_default=True,
    help="Seconds the car is held after a put-back (--mode race, the marshal's time); the clock keeps running.",
)
@click.option(
    "--race-put-back",
    type=click.Choice(RESET_POSITIONS),
    default="where_it_left",
    show_default=True,
    help="Where a put-back sets the car (--mode race): where it last had four wheels on the road, half a "
    "step back (the seed's rule), or DeepRacer's respawn spot.",
)
@click.option("--video/--no-video", default=True, show_default=True, help="MP4s: in-car, top view, 45-degree follow.")
@click.option(
    "--video-size", default="480x360", show_default=True, help="Top and follow video size, WIDTHxHEIGHT (<= 640x480)."
)
@click.option("--mcap/--no-mcap", default=True, show_default=True, help="An MCAP recording for Foxglove.")
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Also keep a local copy of the outputs here (same layout as under the model prefix).",
)
@seed_option
@generation_option
@car_profile_option
@click.option(
    "--opponent",
    "opponents",
    multiple=True,
    help="Another model (store prefix) on the track at once: a HEAD_TO_MODEL race, the SimApp's single-file start "
    "(this model first), crashes between cars; --trials laps each, continuous. Repeatable.",
)
@click.option(
    "--multi-car-type",
    type=click.Choice(["head-to-model", "f1"]),
    default="head-to-model",
    show_default=True,
    help="With --opponent: head-to-model (the race ends when the first car is done) or f1 (finished cars park, "
    "the race runs until every car is done; places by finishing order).",
)
@challenge_options
@direction_option
def evaluate_command(
    model_prefix,
    checkpoint,
    mode,
    track,
    world,
    reverse,
    trials,
    continuous,
    resets,
    off_track_penalty,
    collision_penalty,
    race_minutes,
    race_resets_per_lap,
    race_reset_penalty,
    race_put_back,
    video,
    video_size,
    mcap,
    out_dir,
    seed,
    car_profile,
    generation,
    opponents,
    multi_car_type,
    race_type,
    race_param,
) -> None:
    """Evaluate a model from the store (RACER_STORE) and write metrics, simtrace, videos and an MCAP next to it.

    --model-prefix names the model (required, unless --drfc does); --seed seeds the sensor noise, the sim clock
    starts at 0."""
    if not model_prefix:
        raise click.UsageError("Missing option '--model-prefix' (or --drfc, whose DR_LOCAL_S3_MODEL_PREFIX names it).")
    from racer.evaluation_worker.config import (
        DeepRacerRules,
        EvaluationConfig,
        EvaluationConfigError,
        SummitRules,
        VideoOptions,
    )
    from racer.evaluation_worker.multi_car import MultiCarError
    from racer.evaluation_worker.runner import EvaluationSession
    from racer.evaluation_worker.video import VideoError
    from racer.shared.config import settings_from_env
    from racer.shared.policy.manifest import CheckpointError
    from racer.shared.sim.objects.challenge import ChallengeConfig
    from racer.shared.store import open_store
    from racer.shared.user_errors import user_error_types

    width_px, height_px = _video_size(video_size)
    challenge = ChallengeConfig.from_training_params(dict(challenge_params_from_options(race_type, race_param)))
    try:
        config = EvaluationConfig(
            model_prefix=model_prefix,
            mode=mode,
            checkpoint=checkpoint,
            track=track,
            world=world,
            reverse_dir=reverse,
            deepracer=DeepRacerRules(
                number_of_trials=trials,
                is_continuous=bool(continuous),
                number_of_resets=resets,
                off_track_penalty_s=off_track_penalty,
                collision_penalty_s=collision_penalty,
            ),
            summit=SummitRules(
                race_duration_s=race_minutes * 60.0,
                resets_per_lap=race_resets_per_lap,
                reset_penalty_s=race_reset_penalty,
                put_back=race_put_back,
                continuous=True if continuous is None else continuous,
            ),
            video=VideoOptions(enabled=video, width_px=width_px, height_px=height_px),
            mcap=mcap,
            seed=seed,
            challenge=challenge,
            car_profile=car_profile,
            generation=generation,
        )
        store = open_store(settings_from_env().store)
        if opponents:
            _evaluate_multi_car(store, config, opponents, multi_car_type, out_dir)
            return
        session = EvaluationSession(store, config, out_dir=out_dir)
        report = session.run(log=click.echo)
    except (EvaluationConfigError, CheckpointError, VideoError, MultiCarError, *user_error_types()) as error:
        raise click.ClickException(str(error)) from error
    click.echo("")
    click.echo(report.table)
    timings = report.summary["timings"]
    click.echo(
        f"{timings['steps']} steps, {timings['sim_time_s']:.1f} s simulated in {timings['wall_time_s']:.1f} s "
        f"({timings['steps_per_s']} steps/s)"
    )
    click.echo(f"files in {store.describe()}:")
    for name, key in report.keys.items():
        click.echo(f"  {name:<16} {key}")
    if report.local_dir is not None:
        click.echo(f"local copy: {report.local_dir}")


def _evaluate_multi_car(store, config, opponents, multi_car_type, out_dir) -> None:
    """`--opponent`: this model and the opponents race together (`multi_car_session`)."""
    import dataclasses

    from racer.evaluation_worker.multi_car import MultiCarError, MultiCarRules
    from racer.evaluation_worker.multi_car_session import run_multi_car_evaluation
    from racer.evaluation_worker.multi_car_video import ALL_CARS_VIEW
    from racer.evaluation_worker.video import VIDEO_FILE

    if config.mode != "deepracer":
        raise MultiCarError("--opponent races in --mode deepracer (the SimApp's multi-car evaluation)")
    if config.challenge.has_objects:
        raise MultiCarError("--opponent: a multi-car race has no obstacles or bot cars (leave --race-type unset)")
    configs = [config] + [dataclasses.replace(config, model_prefix=name) for name in opponents]
    names = [c.model_prefix.strip("/") for c in configs]
    if len(set(names)) != len(names):
        raise MultiCarError(f"--opponent: each car needs its own model, got {names}")
    rules = MultiCarRules("F1" if multi_car_type == "f1" else "HEAD_TO_MODEL", laps=config.deepracer.number_of_trials)
    with tempfile.TemporaryDirectory(prefix="racer-all-cars-") as scratch:
        top_view = Path(scratch) / VIDEO_FILE if config.video.enabled else None
        reports, _result = run_multi_car_evaluation(
            store, configs, rules, out_dir=out_dir, log=click.echo, top_view=top_view
        )
        click.echo(f"files in {store.describe()}:")
        for name, report in zip(names, reports, strict=True):
            click.echo(f"  {name}: {report.keys['summary']}")
        if top_view is not None and top_view.is_file():  # beside the first car's videos, as a view of its own
            layout = reports[0].layout
            relative = layout.video(ALL_CARS_VIEW)
            store.put_bytes(layout.key(relative), top_view.read_bytes())
            if out_dir is not None:
                (out_dir / "car-0" / relative).parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(top_view, out_dir / "car-0" / relative)
            click.echo(f"  all cars from above: {layout.key(relative)}")
