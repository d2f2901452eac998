"""racer's dynamics randomisation (`RACER_DYNAMICS_RANDOMIZATION`, off by default): a new car every training episode.

DeepRacer's car is not one car: each generation of its simulator drives its own (`generations.py`, and
docs/car-and-camera.md), and a model trained in one is raced in the others. A policy meant to drive in all of them
trains on a mixture drawn around each generation's car: at every training reset one centre is picked with equal
chance among the generations' cars and the run's own car (`EnvConfig.car_dynamics`, when it is none of them), and the
constants the fits determine only loosely are scaled around it:

* the front and the rear axle's cornering stiffness, each on its own;
* the steering servo's time constant;
* the whole car's yaw inertia;

each by a log-uniform factor within `FIT_SPREAD_FACTOR` either way, the spread the leave-one-file-out fits of one
simulator's logs leave them (research/simapp6_fit/README.md, research/tyre_fit/README.md). What the sources fix (the
wheels' grip and rolling radius, the drive) stays the centre's. Independently, an episode's commands come one step
late with `COMMAND_DELAY_PROBABILITY`.

An earlier draw took every constant from independent ranges spanning all the profiles (up to dd5e5e0); it met a car
like `simtrace-fit` only at the corner of four ranges, and models trained with it lost `simapp5` (docs/transfer.md).

MuJoCo-free: `draw_dynamics` only computes the values; `episode_car.EpisodeCar` applies them to the env's compiled
model (`Car.retune`) and delays the command.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from racer.shared.sim.car.dynamics import CarDynamics
from racer.shared.sim.generations.catalog import GENERATIONS

FIT_SPREAD_FACTOR = 1.5
"""How far (×, either way) a drawn car's loosely fitted constants go from its centre's. The folds of the two fitted
generation cars put them within about this factor of the shipped values: `simapp6-fit` front 58-80 N/rad around 79,
servo 0.040-0.076 s around 0.066, yaw inertia 0.099-0.133 kg·m² around 0.133; `simtrace-fit` front 37-61 around 51,
yaw inertia 0.27-0.42 around 0.475. The rear axles (75-172 around 162; 42-144 around 105) spread further."""
COMMAND_DELAY_PROBABILITY = 0.5
"""Chance that an episode's commands come one step late."""


@dataclass(frozen=True)
class EpisodeDynamics:
    """One episode's car: its dynamics, the centre it was drawn around, and its command delay in steps (0 or 1)."""

    car: CarDynamics
    centre: CarDynamics
    command_delay_steps: int


def mixture_centres(run_car: CarDynamics) -> tuple[CarDynamics, ...]:
    """The cars the draw centres on: every generation's car, then the run's own when it is none of them."""
    centres = tuple(generation.car for generation in GENERATIONS.values())
    return centres if run_car in centres else (*centres, run_car)


def _scaled(rng: np.random.Generator, value: float) -> float:
    spread = math.log(FIT_SPREAD_FACTOR)
    return float(value * math.exp(rng.uniform(-spread, spread)))


def draw_dynamics(run_car: CarDynamics, rng: np.random.Generator) -> EpisodeDynamics:
    """One training episode's car, drawn around one of `mixture_centres(run_car)`. The same generator state gives the
    same car (six draws per episode, in a fixed order)."""
    centres = mixture_centres(run_car)
    centre = centres[int(rng.integers(len(centres)))]
    tyres = replace(
        centre.tyres,
        front_cornering_stiffness_n_per_rad=_scaled(rng, centre.tyres.front_cornering_stiffness_n_per_rad),
        rear_cornering_stiffness_n_per_rad=_scaled(rng, centre.tyres.rear_cornering_stiffness_n_per_rad),
    )
    car = CarDynamics(
        tyres,
        steering_time_constant_s=_scaled(rng, centre.steering_time_constant_s),
        yaw_inertia_kgm2=_scaled(rng, centre.yaw_inertia_kgm2),
    )
    delayed = bool(rng.uniform() < COMMAND_DELAY_PROBABILITY)
    return EpisodeDynamics(car, centre, 1 if delayed else 0)
