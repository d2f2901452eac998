"""`--drfc` for `racer train` and `racer evaluate`: the experiment's settings become the command's options.

An option given on the command line beside `--drfc` wins over the env files (and over worker-N.env, for every
worker); every other option the experiment sets takes the experiment's value. Each decorator wraps its command as
racer.options.track's `--direction` does, so the commands themselves only gain one decorator line.
"""

from __future__ import annotations

import functools
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
from click.core import ParameterSource

from racer.drfc.evaluation import read_evaluation
from racer.drfc.experiment import Env
from racer.drfc.shell_env import DrfcFileError
from racer.drfc.training import DrfcTraining, read_training, run_worker_params, write_custom_files
from racer.options.challenge import challenge_params_from_options
from racer.options.track import resolved_track_name
from racer.shared.config import drfc_dir, generation_name
from racer.shared.sim.objects.challenge import CHALLENGE_KEYS

__all__ = ["drfc_evaluate_option", "drfc_train_option"]

TRAIN_HELP = (
    "Train a DeepRacer-for-Cloud experiment as it is: a folder with run.env (system.env, worker-N.env and "
    "custom_files/ beside it), or its run.env. Options given here as well override the env files, for every worker "
    "(docs/coming-from-drfc.md)."
)
EVALUATE_HELP = (
    "Evaluate as DeepRacer-for-Cloud's dr-start-evaluation would: the model, track, race and DR_EVAL_* settings of "
    "this experiment folder (or run.env). Options given here as well override the env files."
)
GIVEN = (ParameterSource.COMMANDLINE, ParameterSource.ENVIRONMENT, ParameterSource.PROMPT)


def _given() -> set[str]:
    """The options the user gave (not defaults)."""
    context = click.get_current_context()
    return {name for name in context.params if context.get_parameter_source(name) in GIVEN}


def _take(kwargs: dict[str, Any], given: set[str], name: str, value: Any, variable: str, env: Env) -> None:
    """Set option `name` to the experiment's `value` unless the user gave it, checked by the option's own type
    (its range or choices), a refusal naming the variable and the line that set it."""
    if name in given or value is None:
        return
    context = click.get_current_context()
    param = next(p for p in context.command.params if p.name == name)
    try:
        kwargs[name] = param.type_cast_value(context, value)
    except click.BadParameter as error:
        assignment = env.get(variable)
        where = f"{assignment.where}: {variable}={assignment.value}" if assignment is not None else variable
        raise click.ClickException(f"{where}: {error.message} (it stands for {param.opts[0]})") from None


def _generation(experiment_generation: str | None, given: set[str]) -> str | None:
    """DR_SIMAPP_VERSION's generation, unless --generation or RACER_GENERATION chose one."""
    if "generation" in given or generation_name() is not None:
        return None
    return experiment_generation


def _say(command: str, lines: list[str]) -> None:
    for line in lines:
        click.echo(f"racer {command} --drfc: {line}", err=True)


def _reports(warnings: tuple[str, ...], notes: tuple[str, ...]) -> list[str]:
    """Warnings first: lines DRfC reads otherwise than they look; then the notes."""
    return [*(f"warning: {warning}" for warning in warnings), *(f"note: {note}" for note in notes)]


def drfc_train_option(command: Callable[..., Any]) -> Callable[..., Any]:
    """Add `--drfc PATH` to `racer train` (its `track`, `direction`, `custom_files`, ... parameters)."""

    @click.option("--drfc", type=click.Path(exists=True, path_type=Path), default=None, help=TRAIN_HELP)
    @functools.wraps(command)
    def wrapper(*args: Any, drfc: Path | None = None, **kwargs: Any) -> Any:
        if drfc is None:
            return command(*args, **kwargs)
        given = _given()
        try:
            training = read_training(drfc, kwargs["num_workers"] if "num_workers" in given else None, drfc_dir())
        except DrfcFileError as error:
            raise click.ClickException(str(error)) from error
        overrides, challenge_replaced = _train_overrides(training, kwargs, given)
        source = kwargs["custom_files"] if "custom_files" in given else None
        try:
            workers = run_worker_params(training, source or training.experiment.custom_files, overrides,
                                        challenge_replaced)  # fmt: skip
        except DrfcFileError as error:
            raise click.ClickException(str(error)) from error
        env = training.experiment.env
        for name, value, variable in (
            ("model_prefix", training.model_prefix, "DR_LOCAL_S3_MODEL_PREFIX"),
            ("num_workers", training.num_workers, "DR_WORKERS"),
            ("pretrained_prefix", training.pretrained_prefix, "DR_LOCAL_S3_PRETRAINED_PREFIX"),
            ("pretrained_checkpoint", training.pretrained_checkpoint, "DR_LOCAL_S3_PRETRAINED_CHECKPOINT"),
            ("viewer_port", training.viewer_port, "DR_WEBVIEWER_PORT"),
            ("generation", _generation(training.generation, given), "DR_SIMAPP_VERSION"),
        ):
            _take(kwargs, given, name, value, variable, env)
        kwargs.update(track=workers[0]["WORLD_NAME"], direction=None, race_type=None, race_param=())
        summary = _summary(training, workers, kwargs, source)
        _say("train", [*summary, *_reports(training.experiment.warnings, training.notes)])
        with tempfile.TemporaryDirectory(prefix="racer-drfc-") as scratch:  # lives as long as the run
            kwargs["custom_files"] = write_custom_files(training, Path(scratch), workers, source)
            return command(*args, **kwargs)

    return wrapper


def _train_overrides(
    training: DrfcTraining, kwargs: dict[str, Any], given: set[str]
) -> tuple[list[dict[str, str]], bool]:
    """Per worker, the training_params the command line sets; and whether it chose the race type."""
    overrides: list[dict[str, str]] = [{} for _ in range(training.num_workers)]
    if "track" in given or "direction" in given:
        for worker_id, params in enumerate(training.worker_params):
            track = kwargs["track"] if "track" in given else params["WORLD_NAME"]
            overrides[worker_id]["WORLD_NAME"] = resolved_track_name(track, kwargs.get("direction"))
    challenge_replaced = "race_type" in given
    if challenge_replaced:
        pairs = challenge_params_from_options(kwargs["race_type"], kwargs["race_param"])
    else:
        pairs = tuple(_race_param(item) for item in kwargs["race_param"])
    for worker in overrides:
        worker.update(pairs)
    return overrides, challenge_replaced


def _race_param(item: str) -> tuple[str, str]:
    """One --race-param KEY=VALUE, to go over the experiment's race settings (checked there, per worker)."""
    key, equals, value = item.partition("=")
    key = key.strip().upper()
    if not equals or key not in CHALLENGE_KEYS or key == "RACE_TYPE":
        raise click.BadParameter(f"{item!r}: expected KEY=VALUE with KEY one of {', '.join(CHALLENGE_KEYS[1:])}",
                                 param_hint="--race-param")  # fmt: skip
    return key, value.strip()


def _summary(
    training: DrfcTraining, workers: list[dict[str, str]], kwargs: dict[str, Any], source: Path | None
) -> list[str]:
    """What the run will be, with the options given beside --drfc applied."""
    experiment = training.experiment
    clone = kwargs.get("pretrained_prefix")
    lines = [
        f"read {', '.join(str(path) for path in experiment.files)}; model {kwargs['model_prefix']!r}, "
        f"{len(workers)} worker(s), generation {kwargs.get('generation')}"
        + (f", cloning {clone!r} ({kwargs['pretrained_checkpoint']})" if clone else "")
    ]
    if source is not None:
        lines.append(f"custom files from {source} (--custom-files)")
    else:
        renamed = [
            f"{name} is {path.relative_to(experiment.folder)}"
            for name, path in training.custom_file_sources.items()
            if path != experiment.custom_files / name
        ]
        lines.append(f"custom files from {experiment.custom_files}" + (f" ({', '.join(renamed)})" if renamed else ""))
    for worker_id, params in enumerate(workers):
        reverse = ", reversed" if params.get("REVERSE_DIR") == "True" else ""
        drfc_worker = (
            f" (DRfC's worker {worker_id + 1}: worker-{worker_id + 1}.env)"
            if worker_id and experiment.multi_config
            else ""
        )
        lines.append(f"worker {worker_id}{drfc_worker}: track {params['WORLD_NAME']}{reverse}, {params['RACE_TYPE']}")
    return lines


def drfc_evaluate_option(command: Callable[..., Any]) -> Callable[..., Any]:
    """Add `--drfc PATH` to `racer evaluate`."""

    @click.option("--drfc", type=click.Path(exists=True, path_type=Path), default=None, help=EVALUATE_HELP)
    @functools.wraps(command)
    def wrapper(*args: Any, drfc: Path | None = None, **kwargs: Any) -> Any:
        if drfc is None:
            return command(*args, **kwargs)
        given = _given()
        try:
            evaluation = read_evaluation(drfc, drfc_dir())
        except DrfcFileError as error:
            raise click.ClickException(str(error)) from error
        env = evaluation.experiment.env
        for name, value, variable in (
            ("model_prefix", evaluation.model_prefix, "DR_LOCAL_S3_MODEL_PREFIX"),
            ("checkpoint", evaluation.checkpoint, "DR_EVAL_CHECKPOINT"),
            ("reverse", evaluation.reverse, "DR_EVAL_REVERSE_DIRECTION"),
            ("trials", evaluation.trials, "DR_EVAL_NUMBER_OF_TRIALS"),
            ("continuous", evaluation.continuous, "DR_EVAL_IS_CONTINUOUS"),
            ("resets", evaluation.resets, "DR_EVAL_MAX_RESETS"),
            ("off_track_penalty", evaluation.off_track_penalty_s, "DR_EVAL_OFF_TRACK_PENALTY"),
            ("collision_penalty", evaluation.collision_penalty_s, "DR_COLLISION_PENALTY"),
            ("video", evaluation.video, "DR_EVAL_SAVE_MP4"),
            ("opponents", evaluation.opponents, "DR_EVAL_OPP_S3_MODEL_PREFIX"),
            ("generation", _generation(evaluation.generation, given), "DR_SIMAPP_VERSION"),
        ):
            _take(kwargs, given, name, value, variable, env)
        if "track" not in given and "direction" not in given:
            kwargs["track"] = evaluation.track
        if "race_type" not in given:
            mine = dict(evaluation.race_params)
            mine.update(_race_param(item) for item in kwargs["race_param"])
            kwargs.update(race_type=evaluation.race_type, race_param=tuple(f"{k}={v}" for k, v in mine.items()))
        summary = (
            f"model {kwargs['model_prefix']!r} ({kwargs['checkpoint']}) on {kwargs['track']}, "
            f"{evaluation.race_type or 'HEAD_TO_MODEL against ' + ', '.join(kwargs['opponents'])}, generation "
            f"{kwargs.get('generation')}"
        )
        _say("evaluate", [summary, *_reports(evaluation.experiment.warnings, evaluation.notes)])
        return command(*args, **kwargs)

    return wrapper
