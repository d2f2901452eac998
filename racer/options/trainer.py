"""The trainer's own knobs: `racer train` passes them on unchanged to `racer trainer`, and the benches that train
take them too."""

from __future__ import annotations

from collections.abc import Callable

import click

from racer.options.generation import car_profile_option, generation_option
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
"""`--device`: racer.trainer.device resolves it."""

precision_option = click.option(
    "--precision",
    type=click.Choice(PRECISION_NAMES),
    default=DEFAULT_PRECISION.value,
    show_default=True,
    help="What the trainer's towers compute in during updates. bf16 is about twice as fast on CPUs with native "
    "bf16 (AVX512-BF16, AMX) but learns differently (docs/benchmarks.md); fp32 learns the same on every CPU.",
)

dynamics_randomization_option = click.option(
    "--dynamics-randomization",
    type=bool,
    default=False,
    show_default=True,
    help="RACER_DYNAMICS_RANDOMIZATION for every worker: a car drawn around a generation's car every episode.",
)


def trainer_run_options(command: Callable) -> Callable:
    """--device, --precision, --generation, --car-profile and --dynamics-randomization."""
    for option in reversed(
        (device_option, precision_option, generation_option, car_profile_option, dynamics_randomization_option)
    ):
        command = option(command)
    return command
