"""racer's dynamics randomisation (`RACER_DYNAMICS_RANDOMIZATION`, off by default): a new car every training episode.

DeepRacer's car is not one car (docs/car-and-camera.md): the Gazebo classic SimApp, the gz-sim SimApp
and the physical car differ in grip, servo, inertia, speed and latency. The car profiles in `car_dynamics` (the
hand-chosen `gazebo`, the open-loop `simtrace-fit`, and `simapp5-ros1` / `simapp6-ros2` built from the SimApps'
source) bracket what racer knows of them, and a policy meant to drive in all of them trains on a car drawn at every
reset across the range between the profiles and a little around them (`DynamicsRandomizationRanges`; a test checks
that every registered profile lies inside):

* tyre cornering stiffness: the axles' mean (geometric) and their balance (front / rear), so both the stiff neutral
  car of `gazebo` (300 / 300 N/rad) and the soft understeering one of `simtrace-fit` (50.9 / 104.9) are inside;
* the whole car's yaw inertia, from below the URDF's (0.080 kg·m²) to above the fit's (0.475);
* the steering servo's time constant, from the fitted 0.0166 s to beyond the ROS 1 SimApp's 0.5 s hinge PD;
* the rolling radius: the car covers from just under the commanded speed to beyond the fit's 1.12×;
* a command delay of 0 or 1 step: in a delayed episode each step drives the previous step's command;
* the tyres' peak grip, both axles alike, from the source-built profiles' rigid μ 0.5 (1) to beyond `gazebo`'s 1.96.

The drive (stiffness and force cap) stays the profile's. MuJoCo-free: `draw_dynamics` only computes the values; the env
applies them to its compiled model (`Car.retune`) and delays the command itself (`env.py`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from racer.shared.sim.car_dynamics import CarDynamics

COMMANDED_ROLLING_RADIUS_M = 0.035
"""The wheel radius the SimApp divides speed by: rolling at it, the car covers the commanded speed."""


@dataclass(frozen=True)
class DynamicsRandomizationRanges:
    """The ranges each episode's car is drawn from (log-uniform for the scale-like ones, uniform otherwise)."""

    cornering_stiffness_n_per_rad: tuple[float, float] = (60.0, 500.0)
    """Geometric mean of the front and rear axles' cornering stiffness, log-uniform (simtrace-fit 73, gazebo 300, the
    simapp profiles 394)."""
    front_rear_balance: tuple[float, float] = (0.45, 1.15)
    """Front / rear cornering stiffness, log-uniform (simtrace-fit 0.485: understeer; gazebo 1: neutral)."""
    yaw_inertia_kgm2: tuple[float, float] = (0.07, 0.5)
    """The whole car's yaw inertia, log-uniform (gazebo: the URDF's 0.080; simapp 0.080 / 0.083; simtrace-fit 0.475)."""
    steering_time_constant_s: tuple[float, float] = (0.011, 0.6)
    """The steering servo's time constant, log-uniform (gazebo and simtrace-fit 0.0166 s, simapp6-ros2 0.158 s,
    simapp5-ros1 0.50 s)."""
    speed_factor: tuple[float, float] = (0.97, 1.15)
    """Rolling radius / 0.035 m, uniform: the speed the car covers per commanded m/s (gazebo 1, simapp 1.029 on the
    0.036 m wheel mesh, simtrace-fit 1.12)."""
    command_delay_probability: float = 0.5
    """Chance that an episode's commands come one step late."""
    peak_grip: tuple[float, float] = (0.85, 2.3)
    """Peak lateral force / (μ × the axle's load), both axles alike, log-uniform (gazebo and simtrace-fit 1.96, the
    simapp profiles 1.0). Without it a policy trained around `gazebo` never met the ROS 1 car's grip, one of the two
    source facts that cost real policies their laps there (docs/car-and-camera.md)."""


DYNAMICS_RANDOMIZATION_RANGES = DynamicsRandomizationRanges()


@dataclass(frozen=True)
class EpisodeDynamics:
    """One episode's car: its dynamics and its command delay in steps (0 or 1)."""

    car: CarDynamics
    command_delay_steps: int


def _log_uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(math.exp(rng.uniform(math.log(bounds[0]), math.log(bounds[1]))))


def draw_dynamics(
    base: CarDynamics, rng: np.random.Generator, ranges: DynamicsRandomizationRanges = DYNAMICS_RANDOMIZATION_RANGES
) -> EpisodeDynamics:
    """One episode's car drawn from `ranges`; what the ranges leave out (the drive) stays `base`'s. The same generator
    state gives the same car (seven draws per episode, in a fixed order)."""
    stiffness = _log_uniform(rng, ranges.cornering_stiffness_n_per_rad)
    balance = _log_uniform(rng, ranges.front_rear_balance)
    yaw_inertia = _log_uniform(rng, ranges.yaw_inertia_kgm2)
    time_constant = _log_uniform(rng, ranges.steering_time_constant_s)
    speed_factor = float(rng.uniform(*ranges.speed_factor))
    delayed = bool(rng.uniform() < ranges.command_delay_probability)
    peak_grip = _log_uniform(rng, ranges.peak_grip)
    tyres = replace(
        base.tyres,
        front_cornering_stiffness_n_per_rad=stiffness * math.sqrt(balance),
        rear_cornering_stiffness_n_per_rad=stiffness / math.sqrt(balance),
        front_peak_grip=peak_grip,
        rear_peak_grip=peak_grip,
        rolling_radius_m=COMMANDED_ROLLING_RADIUS_M * speed_factor,
    )
    car = CarDynamics(tyres, steering_time_constant_s=time_constant, yaw_inertia_kgm2=yaw_inertia)
    return EpisodeDynamics(car, 1 if delayed else 0)
