"""`python -m benchmarks transfer`: real DeepRacer policies drive racer's simulator, closed loop (the figure that decides).

A model trained in DeepRacer's Gazebo simulator drives well in racer only if racer's camera, world and car are close
enough to what it learnt on. So every model folder under `--models` (default: the `models/` of `--data`, DeepRacer's
own files: a real model trained in DeepRacer's simulator) goes through `racer model import`'s own path (its frozen graphs become racer
checkpoints) and each checkpoint drives re:Invent 2018 greedily from `--starts` evenly spaced starts under evaluation
rules without resets, in each generation, world, render path and car asked for (`--generation`, repeatable, default
`2019`: the simulator those checkpoints were trained in; `--car-profile`, repeatable, replaces the generation's car);
the bench prints laps and mean progress per checkpoint. A change to the car, the camera or the look that costs a lap
or more than 3 points of mean progress on a shared checkpoint in `2019` does not land (docs/transfer.md).

`--racer-model` adds the reverse check: a racer model's greedy steering side on DeepRacer's 92 Gazebo frames (left /
straight / right shares) and how often its side agrees with each real checkpoint's (`transfer_reverse_check.py`). The
models come in through `real_models.py` and drive through `transfer_drive.py`.

`--matrix` trains a model per generation (or car profile), with and without dynamics randomisation, and drives each
in every generation (`transfer_matrix.py`). `--robustness` drives the real checkpoints under a fixed set of small
perturbations of the start, the camera and the lights and prints the table (`transfer_robustness.py`).
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import click
import torch

from benchmarks.deepracer_data import REINVENT_2018_ROUTE, data_folder, data_option
from benchmarks.real_models import RealModel, import_real_models, model_folders
from benchmarks.transfer_drive import drive
from benchmarks.transfer_matrix import (
    DEFAULT_MINUTES,
    TRAIN_GENERATIONS,
    TRAIN_WORLDS,
    DriveCar,
    run_matrix,
)
from benchmarks.transfer_reverse_check import run_reverse_check
from benchmarks.transfer_robustness import run_robustness
from benchmarks.workdir import cpu_description
from racer.options.training import seed_option, workers_option
from racer.shared.sim.car.dynamics import CAR_PROFILE_NAMES, car_profile
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.generations.catalog import GENERATION_NAMES, generation
from racer.shared.sim.scene.worlds import WORLD_NAMES

JUDGING_GENERATION = "2019"
"""The generation the landing rule drives the shared checkpoints in: the simulator they were trained in."""


@click.command(name="transfer")
@click.option(
    "--models",
    "models_root",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    default=None,
    help="A folder of DeepRacer models (model_metadata.json beside model_<N>.pb or model.pb), searched recursively. "
    "Default: models/ of --data.",
)
@click.option(
    "--track",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    help="A route .npy. Default: re:Invent 2018 from --data.",
)
@click.option("--world", type=click.Choice(WORLD_NAMES), multiple=True, default=("base",), show_default=True)
@click.option("--render", type=click.Choice(["default", "full"]), multiple=True, default=("default",))
@click.option(
    "--generation",
    "generation_names",
    type=click.Choice(GENERATION_NAMES),
    multiple=True,
    default=(JUDGING_GENERATION,),
    show_default=True,
    help="Drive in this generation, its look and car (RACER_GENERATION); repeat to drive in each one given. "
    "--matrix: the generations its models are driven in (default: every one).",
)
@click.option(
    "--car-profile",
    "car_profile_names",
    type=click.Choice(CAR_PROFILE_NAMES),
    multiple=True,
    default=(),
    help="Drive with this car profile instead of each generation's car (RACER_CAR_PROFILE); repeatable. Default: "
    "the generation's car.",
)
@click.option("--starts", type=click.IntRange(1, 100), default=10, show_default=True)
@click.option(
    "--racer-model",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    default=None,
    help="A racer model folder (racer-data/MODEL): its steering shares and sign agreement on the Gazebo frames.",
)
@click.option(
    "--matrix",
    is_flag=True,
    help="Instead: train a model per --train-generation (and --train-profile) with and without dynamics "
    "randomisation (the reverse-check setup) and drive each in every generation (or each --generation / "
    "--car-profile given); one JSON matrix.",
)
@click.option(
    "--train-generation",
    "train_generation_names",
    type=click.Choice(GENERATION_NAMES),
    multiple=True,
    default=TRAIN_GENERATIONS,
    show_default=True,
    help="--matrix: train in this generation (repeatable).",
)
@click.option(
    "--train-profile",
    "train_profile_names",
    type=click.Choice(CAR_PROFILE_NAMES),
    multiple=True,
    default=(),
    help="--matrix: train with this car profile instead of the generation's car (repeatable).",
)
@click.option(
    "--train-world",
    "train_world_names",
    type=click.Choice(WORLD_NAMES),
    multiple=True,
    default=TRAIN_WORLDS,
    show_default=True,
    help="--matrix: the worlds its workers train in, worker i in the i-th (cycling), as racer train spreads them "
    "(repeatable; racer train's default is all four).",
)
@click.option(
    "--minutes",
    type=click.FloatRange(min=0.05),
    default=DEFAULT_MINUTES,
    show_default=True,
    help="--matrix: per model.",
)
@workers_option
@click.option(
    "--randomization",
    type=click.Choice(["both", "on", "off"]),
    default="both",
    show_default=True,
    help="--matrix: train with dynamics randomisation, without, or both.",
)
@click.option(
    "--keep-models",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="--matrix: copy each trained model folder here (the bench's own folder is removed at the end).",
)
@seed_option
@click.option(
    "--robustness",
    is_flag=True,
    help="Instead: drive each real checkpoint in each --generation (base world, or the first --world) as it stands "
    "and under each small perturbation (start 5 cm to a side or turned 5 degrees, camera 5 mm up or down or pitched "
    "1 degree, lights 15 % brighter or dimmer); the table on stderr, one JSON line.",
)
@data_option
@click.pass_context
def transfer_bench_command(
    ctx,
    models_root,
    track,
    world,
    render,
    generation_names,
    car_profile_names,
    starts,
    racer_model,
    matrix,
    train_generation_names,
    train_profile_names,
    train_world_names,
    minutes,
    num_workers,
    randomization,
    keep_models,
    seed,
    robustness,
    data_dir,
) -> None:
    """Real DeepRacer checkpoints drive racer, closed loop: laps and mean progress per checkpoint, one JSON line.

    With --matrix, --workers and --seed are each model's training run's."""
    torch.set_num_threads(1)
    started = time.monotonic()
    data = data_folder(data_dir)
    models_root = models_root or data / "models"
    track = track or data / REINVENT_2018_ROUTE
    profiles = tuple(car_profile_names) or ("",)
    if matrix:
        explicit = ctx.get_parameter_source("generation_names") != click.core.ParameterSource.DEFAULT
        drive_generations = tuple(generation_names) if explicit else GENERATION_NAMES
        result = run_matrix(
            data,
            track,
            drive,
            train_generations=tuple(train_generation_names),
            train_profiles=tuple(train_profile_names) or ("",),
            drive_cars=tuple(DriveCar(name, profile) for name in drive_generations for profile in profiles),
            minutes=minutes,
            starts=starts,
            workers=num_workers,
            seed=seed,
            randomizations={"both": (False, True), "on": (True,), "off": (False,)}[randomization],
            keep_models=keep_models,
            train_worlds=tuple(train_world_names),
        )
        click.echo(json.dumps(result))
        return
    folders = model_folders(models_root)
    if not folders:
        raise click.ClickException(f"{models_root}: no DeepRacer model folder (model_metadata.json with .pb graphs)")
    with tempfile.TemporaryDirectory(prefix="racer-transfer-") as store_root:
        real = import_real_models(folders, Path(store_root))
    if robustness:
        result = {"benchmark": "transfer-robustness", "cpu": cpu_description(), "track": str(track), "starts": starts}
        for generation_name, profile in [(name, profile or generation(name).car_profile) for name in generation_names
                                         for profile in profiles]:  # fmt: skip

            def config_of(
                model: RealModel, generation_name: str = generation_name, profile: str = profile
            ) -> EnvConfig:
                return EnvConfig(
                    track=track,
                    world=world[0],
                    model_metadata=model.metadata,
                    generation=generation_name,
                    car_dynamics=car_profile(profile),
                )

            table = run_robustness(real, config_of, drive, starts)
            result.setdefault("tables", []).append(
                {"generation": generation_name, "world": world[0], "car_profile": profile, **table}
            )
        result["wall_s"] = round(time.monotonic() - started, 1)
        click.echo(json.dumps(result))
        return
    result: dict = {"benchmark": "transfer", "cpu": cpu_description(), "track": str(track), "drives": []}
    cars = [(name, profile or generation(name).car_profile) for name in generation_names for profile in profiles]
    for model in real:
        for world_name in world:
            for render_mode in render:
                for generation_name, profile in cars:
                    config = EnvConfig(
                        track=track,
                        world=world_name,
                        model_metadata=model.metadata,
                        render_full_resolution=render_mode == "full",
                        generation=generation_name,
                        car_dynamics=car_profile(profile),
                    )
                    figures = drive(model, config, starts)
                    print(
                        f"transfer bench: {model.label} {generation_name}/{world_name}/{render_mode}/{profile}: "
                        f"{figures['laps']}/{starts} laps, mean progress {figures['mean_progress']} %",
                        file=sys.stderr,
                        flush=True,
                    )
                    result["drives"].append(
                        {"model": model.label, "generation": generation_name, "world": world_name,
                         "render": render_mode, "car_profile": profile, **figures}
                    )  # fmt: skip
    if racer_model is not None:
        result["reverse_check"] = run_reverse_check(racer_model, real, data, track, world[0])
    result["wall_s"] = round(time.monotonic() - started, 1)
    click.echo(json.dumps(result))
