"""`racer train`'s command line: the options of a local run (racer.local.run runs it)."""

from __future__ import annotations

import sys
from datetime import datetime
from pathlib import Path

import click

from racer.drfc.options import drfc_train_option
from racer.local.run import LocalRunPlan, run_local_training
from racer.options.challenge import challenge_options, challenge_params_from_options
from racer.options.renderer import renderer_option
from racer.options.track import direction_option, track_option
from racer.options.trainer import trainer_run_options
from racer.options.training import (
    custom_files_option,
    envs_option,
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
from racer.shared.config import LocalStoreSettings, settings_from_env
from racer.shared.run_settings import RunOptions
from racer.shared.sim.scene.renderer import RendererError, choose_renderer
from racer.trainer.device import DeviceError, resolve_device


@click.command(name="train")
@drfc_train_option
@model_prefix_option(default_text="racer-<date>-<time>")
@custom_files_option()
@workers_option
@envs_option
@worlds_option
@track_option()
@max_episodes_option
@max_minutes_option
@click.option("--minio", "use_minio", is_flag=True, help="Store in a local MinIO server instead of a directory.")
@pretrained_prefix_option
@pretrained_checkpoint_option
@seed_option
@click.option(
    "--viewer-port",
    type=click.IntRange(0, 65535),
    default=8100,
    show_default=True,
    help="Port of the live web page (camera streams, curves, evaluations); 0: no page.",
)
@click.option(
    "--viewer-host",
    default="127.0.0.1",
    show_default=True,
    help="Address the page listens on; the default is reachable from this machine only.",
)
@renderer_option
@overlap_option
@trainer_run_options
@challenge_options
@direction_option
def train_command(
    model_prefix,
    custom_files,
    num_workers,
    envs_per_worker,
    worlds,
    track,
    max_episodes,
    max_minutes,
    use_minio,
    pretrained_prefix,
    pretrained_checkpoint,
    seed,
    viewer_port,
    viewer_host,
    renderer,
    device,
    precision,
    car_profile,
    generation,
    dynamics_randomization,
    race_type,
    race_param,
    overlap,
) -> None:
    """Train with the embedded default: Redis, store, trainer and rollout workers as local processes."""
    try:  # a GPU asked for and absent is refused before anything starts
        resolve_device(device)
    except DeviceError as error:
        raise click.UsageError(str(error)) from error
    try:  # likewise a renderer this machine lacks
        choose_renderer(renderer)
    except RendererError as error:
        raise click.UsageError(str(error)) from error
    base_settings = settings_from_env()
    model_prefix = model_prefix or datetime.now().strftime("racer-%Y%m%d-%H%M%S")
    store_root = base_settings.store.root if isinstance(base_settings.store, LocalStoreSettings) else Path("racer-data")
    run = RunOptions(
        num_workers=num_workers,
        track=track,
        worlds=tuple(w.strip() for w in worlds.split(",") if w.strip()),
        car_profile=car_profile,
        generation=generation,
        dynamics_randomization=dynamics_randomization,
        challenge_params=challenge_params_from_options(race_type, race_param),
        overlap=overlap,
    )
    plan = LocalRunPlan(
        model_prefix=model_prefix,
        custom_files=custom_files.resolve(),
        run=run,
        max_episodes=max_episodes,
        max_minutes=max_minutes,
        use_minio=use_minio,
        log_dir=Path(store_root) / ".runs" / model_prefix,
        seed=seed,
        pretrained_prefix=pretrained_prefix,
        pretrained_checkpoint=pretrained_checkpoint,
        viewer_host=viewer_host,
        viewer_port=viewer_port or None,
        envs_per_worker=envs_per_worker,
        renderer=renderer,
        trainer_options=("--precision", precision, "--device", device),
    )
    sys.exit(run_local_training(plan, base_settings))
