"""The trainer options that `racer train` passes on unchanged to `racer trainer`: one definition for both commands."""

from __future__ import annotations

from collections.abc import Callable

import click

from racer.options.generation import CAR_PROFILE_HELP, GENERATION_HELP, generation_option
from racer.shared.sim.car.dynamics import CAR_PROFILE_NAMES
from racer.trainer.device import DEFAULT_DEVICE, DEVICE_NAMES
from racer.trainer.precision import DEFAULT_PRECISION, PRECISION_NAMES

device_option = click.option(
    "--device",
    type=click.Choice(DEVICE_NAMES),
    default=DEFAULT_DEVICE,
    show_default=True,
    help="Where the trainer's networks and updates run: auto is the GPU when torch finds one (CUDA), else the CPU; "
    "cuda without one is refused before anything starts. The workers always act on the CPU.",
)
"""`--device`: racer train, racer trainer and the benches that train (racer.trainer.device resolves it)."""


def trainer_run_options(command: Callable) -> Callable:
    """--device, --precision, --generation, --car-profile and --dynamics-randomization."""
    options = (
        device_option,
        click.option(
            "--precision",
            type=click.Choice(PRECISION_NAMES),
            default=DEFAULT_PRECISION.value,
            show_default=True,
            help="What the trainer's towers compute in during updates. bf16 is about twice as fast on CPUs with native "
            "bf16 (AVX512-BF16, AMX) but learns differently (docs/benchmarks.md); fp32 learns the same on every CPU.",
        ),
        generation_option(
            help_text=f"RACER_GENERATION for every worker (workers.json may set it per worker). {GENERATION_HELP}"
        ),
        click.option(
            "--car-profile",
            type=click.Choice(("", *CAR_PROFILE_NAMES)),
            default="",
            help=f"RACER_CAR_PROFILE for every worker (workers.json may set it per worker). {CAR_PROFILE_HELP}",
        ),
        click.option(
            "--dynamics-randomization",
            type=bool,
            default=False,
            show_default=True,
            help="RACER_DYNAMICS_RANDOMIZATION for every worker: a car drawn around a generation's car every episode.",
        ),
    )
    for option in reversed(options):
        command = option(command)
    return command
