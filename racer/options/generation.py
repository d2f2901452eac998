"""`--generation`, `--car-profile` and `--world`: the click options of every command that builds a car (train, trainer,
evaluate, race, the benches), defined once so their help and override rule read the same everywhere."""

from __future__ import annotations

import click

from racer.shared.config import GENERATION_VARIABLE, generation_name
from racer.shared.sim.car.dynamics import CAR_PROFILE_NAMES
from racer.shared.sim.generations.catalog import DEFAULT_GENERATION, GENERATION_NAMES
from racer.shared.sim.scene.worlds import WORLD_NAMES

GENERATION_HELP = (
    "The DeepRacer simulator to stand in for, its look (walls, lights, camera) and car together: 2019 (Gazebo "
    "classic, the 2018-2019 console), simapp5 (ROS 1 SimApp v5.3.3: console until 2025, DRfC 5) or simapp6 (ROS 2 "
    f"SimApp v6.0.5: DeepRacer on AWS, DRfC 6). Default: {GENERATION_VARIABLE}, else {DEFAULT_GENERATION}. A "
    "training run gives it to every worker (workers.json may set it per worker); a model's training_params record "
    "the one it trained in. --car-profile replaces its car, --world picks the floor (docs/car-and-camera.md)."
)
CAR_PROFILE_HELP = (
    "A car profile instead of the generation's car (RACER_CAR_PROFILE; a training run gives it to every worker, "
    "workers.json may set it per worker; a study's choice: the generation's car is the one its data and files give). "
    "Empty: the generation's car."
)


def default_generation() -> str:
    """`--generation`'s default: RACER_GENERATION, else racer's default generation."""
    return generation_name() or DEFAULT_GENERATION


generation_option = click.option(
    "--generation",
    type=click.Choice(GENERATION_NAMES),
    default=default_generation,
    show_default=f"{GENERATION_VARIABLE}, else {DEFAULT_GENERATION}",
    help=GENERATION_HELP,
)
"""`--generation NAME`: RACER_GENERATION's generation, else racer's default."""

car_profile_option = click.option(
    "--car-profile",
    type=click.Choice(("", *CAR_PROFILE_NAMES)),
    default="",
    help=CAR_PROFILE_HELP,
)
"""`--car-profile NAME`: "" (the default) keeps the generation's car."""


def world_option(default: str = "base"):
    """`--world NAME`: the floor the car drives on (its tyre grip differs by world)."""
    return click.option(
        "--world",
        type=click.Choice(WORLD_NAMES),
        default=default,
        show_default=True,
        help="The world (floor) the car drives in: its tyre grip differs by world.",
    )
