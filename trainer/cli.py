"""`racer trainer`: the trainer process alone (the embedded `racer train` and docker compose both run it)."""

from __future__ import annotations

import logging
from pathlib import Path

import click

from racer.options.challenge import challenge_options, challenge_params_from_options
from racer.options.track import direction_option, track_option
from racer.options.trainer import trainer_run_options
from racer.options.training import (
    custom_files_option,
    max_episodes_option,
    max_minutes_option,
    model_prefix_option,
    overlap_option,
    pretrained_checkpoint_option,
    pretrained_prefix_option,
    seed_option,
    workers_option,
    worlds_option,
)
from racer.shared.config import settings_from_env
from racer.shared.user_errors import user_error_types


@click.command(name="trainer")
@model_prefix_option(required=True)
@custom_files_option(required=True)
@workers_option
@track_option()
@worlds_option
@max_episodes_option
@max_minutes_option
@pretrained_prefix_option
@pretrained_checkpoint_option
@seed_option
@click.option(
    "--max-memory-steps",
    type=click.IntRange(min=0),
    default=None,
    help="Transitions one iteration trains on; later episodes are dropped as in DeepRacer. Default: "
    "MAX_MEMORY_STEPS, else DeepRacer's 10000 (shallow network) / 3000 (others); 0 = no cap.",
)
@click.option(
    "--domain-randomization",
    type=bool,
    default=False,
    show_default=True,
    help="ENABLE_DOMAIN_RANDOMIZATION for every worker (random light colours per episode, as DeepRacer).",
)
@click.option(
    "--car-randomization",
    type=bool,
    default=False,
    show_default=True,
    help="racer's RACER_CAR_RANDOMIZATION for every worker (tint, blur, noise, camera jitter).",
)
@click.option(
    "--sac-replay-memory-mb",
    type=click.FloatRange(1.0),
    default=1024.0,
    show_default=True,
    help="SAC: memory for the trainer's replay ring (1 GiB holds ~55,000 single-camera transitions).",
)
@click.option(
    "--sac-updates-per-transition",
    type=click.FloatRange(0.0, min_open=True),
    default=None,
    help="SAC: gradient steps per transition received [default: preset.json's updates_per_transition, else 1 as "
    "DeepRacer; both given and different is refused].",
)
@click.option(
    "--preflight-passed",
    is_flag=True,
    hidden=True,
    help="The launcher (racer train) has run the preflight on these custom files: read them without checking again.",
)
@overlap_option
@trainer_run_options
@challenge_options
@direction_option
def trainer_command(
    model_prefix,
    custom_files,
    num_workers,
    track,
    worlds,
    max_episodes,
    max_minutes,
    pretrained_prefix,
    pretrained_checkpoint,
    seed,
    max_memory_steps,
    domain_randomization,
    car_randomization,
    dynamics_randomization,
    car_profile,
    generation,
    sac_replay_memory_mb,
    sac_updates_per_transition,
    device,
    precision,
    race_type,
    race_param,
    overlap,
    preflight_passed,
) -> None:
    """Run the trainer (clipped PPO or SAC, as model_metadata.json says): Redis and the store come from
    RACER_REDIS_URL / RACER_STORE. The custom files are checked before anything connects."""
    from racer.shared.config import max_memory_steps_from_env
    from racer.shared.run_settings import RunOptions
    from racer.trainer.device import DeviceError, resolve_device
    from racer.trainer.precision import Precision
    from racer.trainer.training_loop import TrainerOptions, run_trainer

    try:  # before anything connects
        torch_device = resolve_device(device)
    except DeviceError as error:
        raise click.UsageError(str(error)) from error
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    run = RunOptions(
        num_workers=num_workers,
        track=track,
        worlds=tuple(w.strip() for w in worlds.split(",") if w.strip()),
        domain_randomization=domain_randomization,
        car_randomization=car_randomization,
        car_profile=car_profile,
        generation=generation,
        dynamics_randomization=dynamics_randomization,
        challenge_params=challenge_params_from_options(race_type, race_param),
        overlap=overlap,
    )
    try:
        memory_cap = max_memory_steps if max_memory_steps is not None else max_memory_steps_from_env()
    except ValueError as error:
        raise click.ClickException(str(error)) from error
    try:  # before anything connects; the trainer logs the warnings
        report = checked_custom_files(custom_files, run, preflight_passed)
        sac_updates_per_transition_or_conflict(sac_updates_per_transition, report.preset, custom_files)
    except user_error_types() as error:
        raise click.ClickException(str(error)) from error
    options = TrainerOptions(
        model_prefix=model_prefix,
        custom_files=custom_files,
        run=run,
        max_episodes=max_episodes,
        max_minutes=max_minutes,
        seed=seed,
        pretrained_prefix=pretrained_prefix,
        pretrained_checkpoint=pretrained_checkpoint,
        max_memory_steps=memory_cap,
        sac_replay_memory_mb=sac_replay_memory_mb,
        sac_updates_per_transition=sac_updates_per_transition,
        precision=Precision(precision),
        device=torch_device,
        preflight=report,
    )
    try:
        run_trainer(settings_from_env(), options)
    except user_error_types() as error:
        raise click.ClickException(str(error)) from error


def sac_updates_per_transition_or_conflict(option: float | None, preset, custom_files: Path) -> None:
    """Refuse `--sac-updates-per-transition` against a different preset.json `updates_per_transition` before
    anything connects (the learner factory checks it again)."""
    from racer.trainer.preset import PRESET_FILE, PresetError, sac_updates_per_transition

    try:
        sac_updates_per_transition(option, preset, str(Path(custom_files) / PRESET_FILE))
    except PresetError as error:
        raise click.ClickException(str(error)) from error


def checked_custom_files(custom_files: Path, run, preflight_passed: bool):
    """The preflight's report on the custom files: the preflight itself, or, when the launcher (`racer train`) has
    run it already (`--preflight-passed`), the files read without checking them again. Either way a run checks its
    custom files once."""
    from racer.trainer.preflight import preflight, read_checked_files

    if preflight_passed:
        return read_checked_files(custom_files, run)
    return preflight(custom_files, run)
