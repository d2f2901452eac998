"""`racer train`'s command line: the options of a local run (racer.local.run runs it)."""

from __future__ import annotations

import sys
from datetime import datetime
from pathlib import Path

import click

from racer.defaults import DEFAULT_CUSTOM_FILES
from racer.drfc.options import drfc_train_option
from racer.local.run import LocalRunPlan, run_local_training
from racer.options.challenge import challenge_options, challenge_params_from_options
from racer.options.track import TRACK_HELP, direction_option
from racer.rollout_worker.envs import DEFAULT_ENVS_PER_WORKER, DEFAULT_WORKERS
from racer.shared.config import LocalStoreSettings, settings_from_env
from racer.shared.run_settings import RunOptions
from racer.shared.sim.config import DEFAULT_TRACK
from racer.shared.sim.scene.worlds import WORLD_NAMES as WORLDS
from racer.trainer.device import DeviceError, resolve_device
from racer.trainer.run_options import trainer_run_options


@click.command(name="train")
@drfc_train_option
@click.option("--model-prefix", default=None, help="Model name (store prefix). Default: racer-<date>-<time>.")
@click.option(
    "--custom-files",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    default=DEFAULT_CUSTOM_FILES,
    show_default="the example files installed with racer, racer/defaults/custom_files",
    help="Folder with reward_function.py, model_metadata.json, hyperparameters.json.",
)
@click.option(
    "--workers",
    "num_workers",
    type=click.IntRange(1, 32),
    default=DEFAULT_WORKERS,
    show_default=True,
    help="Rollout workers, one per world in turn. The default is the same on every machine, so a seed gives the "
    "same kind of run everywhere; on more than 4 cores raise it to use them (the run then plays its episodes on "
    "other workers and so differs, though it learns the same way).",
)
@click.option(
    "--envs",
    "envs_per_worker",
    type=click.IntRange(1, 64),
    default=DEFAULT_ENVS_PER_WORKER,
    show_default=True,
    help="Envs each worker steps at once, all actions from one batched forward pass.",
)
@click.option("--worlds", default=",".join(WORLDS), show_default=True, help="Worlds given to workers in turn.")
@click.option("--track", default=DEFAULT_TRACK, show_default=True, help=TRACK_HELP)
@click.option(
    "--max-episodes",
    type=int,
    default=None,
    help="Stop after this many training episodes (default: hyperparameters' term_cond_max_episodes).",
)
@click.option("--max-minutes", type=float, default=None, help="Stop after this much wall time.")
@click.option("--minio", "use_minio", is_flag=True, help="Store in a local MinIO server instead of a directory.")
@click.option("--pretrained-prefix", default=None, help="Clone: start from this model's checkpoint.")
@click.option("--pretrained-checkpoint", type=click.Choice(["last", "best"]), default="last", show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
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
    device,
    precision,
    car_profile,
    generation,
    dynamics_randomization,
    race_type,
    race_param,
) -> None:
    """Train with the embedded default: Redis, store, trainer and rollout workers as local processes."""
    try:  # a GPU asked for and absent is refused before anything starts
        resolve_device(device)
    except DeviceError as error:
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
        trainer_options=("--precision", precision, "--device", device),
    )
    sys.exit(run_local_training(plan, base_settings))
