"""The options of a training run: `racer train` takes them and hands them on to `racer trainer` and `racer rollout`,
and the benches that train take them too. Each is defined once, so the commands cannot drift apart."""

from __future__ import annotations

from pathlib import Path

import click

from racer.defaults import DEFAULT_CUSTOM_FILES
from racer.shared.config import OVERLAP_VARIABLE, overlap_setting
from racer.shared.sim.scene.worlds import WORLD_NAMES

DEFAULT_WORKERS = 4
"""Rollout workers of a training run on any machine: one per world. Not the core count: which worker plays which
episode shapes the run, and a default may not make runs differ between machines."""

DEFAULT_ENVS_PER_WORKER = 4
"""Per-frame inference cost falls steeply from batch 1 to 4 and less after (README, Benchmarks): the dense layer's
weights are read once per call. With the default 4 workers and 20 episodes per iteration more envs per worker would
mostly sit idle (an iteration has fewer episodes than 4 x 8 env slots), so 4 stays the default."""

workers_option = click.option(
    "--workers",
    "num_workers",
    type=click.IntRange(1, 32),
    default=DEFAULT_WORKERS,
    show_default=True,
    help="Rollout workers, one per world in turn. The default is the same on every machine, so a seed gives the "
    "same kind of run everywhere; on more than 4 cores raise it to use them (the run then plays its episodes on "
    "other workers and so differs, though it learns the same way).",
)
envs_option = click.option(
    "--envs",
    "envs_per_worker",
    type=click.IntRange(1, 64),
    default=DEFAULT_ENVS_PER_WORKER,
    show_default=True,
    help="Envs each worker steps at once, all actions from one batched forward pass.",
)
worlds_option = click.option(
    "--worlds", default=",".join(WORLD_NAMES), show_default=True, help="Worlds given to workers in turn."
)
max_episodes_option = click.option(
    "--max-episodes",
    type=int,
    default=None,
    help="Stop after this many training episodes (default: hyperparameters' term_cond_max_episodes).",
)
max_minutes_option = click.option("--max-minutes", type=float, default=None, help="Stop after this much wall time.")
pretrained_prefix_option = click.option(
    "--pretrained-prefix", default=None, help="Clone: start from this model's checkpoint."
)
pretrained_checkpoint_option = click.option(
    "--pretrained-checkpoint",
    type=click.Choice(["last", "best"]),
    default="last",
    show_default=True,
    help="Which checkpoint of --pretrained-prefix to start from.",
)
seed_option = click.option(
    "--seed",
    type=int,
    default=0,
    show_default=True,
    help="Seeds what the command draws at random (networks, episodes, sensor noise).",
)


def default_overlap() -> bool:
    """`--overlap`'s default: RACER_OVERLAP (True/1 or False/0/empty), else strict."""
    try:
        return overlap_setting()
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--overlap") from error


overlap_option = click.option(
    "--overlap",
    is_flag=True,
    default=default_overlap,
    show_default=f"{OVERLAP_VARIABLE}, else off",
    help="Workers keep playing while the trainer updates: iteration k+1 is queued as soon as k's episodes are in, "
    "played with checkpoint k, and trained with each episode's own log-probabilities (docs/training.md, Overlap). "
    "Without it, DeepRacer's strict alternation; an overlapped run is not reproducible for a seed.",
)
"""`--overlap`: RunOptions.overlap, the run's setting the trainer and the workers follow."""

MODEL_PREFIX_HELP = "Model name: its prefix in the store (a training run's name)."
CUSTOM_FILES_HELP = "Folder with reward_function.py, model_metadata.json, hyperparameters.json [, workers.json]."


def model_prefix_option(required: bool = False, default_text: str | None = None):
    """`--model-prefix NAME` (`default_text`: what a command that does not require it does without it)."""
    if required:
        return click.option("--model-prefix", required=True, help=MODEL_PREFIX_HELP)
    return click.option("--model-prefix", default=None, show_default=default_text or False, help=MODEL_PREFIX_HELP)


def custom_files_option(required: bool = False):
    """`--custom-files DIR`: racer's example files unless the command requires it."""
    kind = click.Path(exists=True, file_okay=False, path_type=Path)
    if required:
        return click.option("--custom-files", type=kind, required=True, help=CUSTOM_FILES_HELP)
    return click.option(
        "--custom-files",
        type=kind,
        default=DEFAULT_CUSTOM_FILES,
        show_default="the example files installed with racer, racer/defaults/custom_files",
        help=CUSTOM_FILES_HELP,
    )
