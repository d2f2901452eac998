"""The car an episode drives: the run's own (`EnvConfig.car_dynamics`), or with dynamics randomisation one drawn at
every training reset (`dynamics_randomization.draw_dynamics`) whose commands may come one step late."""

from __future__ import annotations

import numpy as np

from racer.shared.sim.car.dynamics import CarDynamics
from racer.shared.sim.car.dynamics_randomization import draw_dynamics
from racer.shared.sim.car.vehicle import Car
from racer.shared.sim.scene._mujoco import mujoco

_DYNAMICS_RNG_STREAM = 23
"""Seeds the dynamics randomisation apart from the env's other draws, so turning it on changes no other draw."""


class EpisodeCar:
    """Which car drives the current episode, and which command reaches it each step."""

    def __init__(self, car: Car, model: mujoco.MjModel, run_car: CarDynamics, randomized: bool) -> None:
        self._car = car
        self._model = model
        self._run_car = run_car
        self._randomized = randomized
        self.dynamics = run_car
        self.command_delay_steps = 0
        self._delayed_command = (0.0, 0.0)
        self._rng = np.random.default_rng()

    def seed(self, seed: int) -> None:
        self._rng = np.random.default_rng((seed, _DYNAMICS_RNG_STREAM))

    def start(self, evaluation: bool) -> None:
        """A new episode: with randomisation, draw a training episode's car, or go back to the run's car for an
        evaluation (which measures the checkpoint on the run's own car, as `racer evaluate` does) and retune the
        compiled model and the tyres; no late command is left over from the last episode."""
        if self._randomized:
            episode = None if evaluation else draw_dynamics(self._run_car, self._rng)
            car = self._run_car if episode is None else episode.car
            if car != self.dynamics:
                self._car.retune(self._model, car.tyres, car.steering_time_constant_s, car.yaw_inertia_kgm2)
                self.dynamics = car
            self.command_delay_steps = 0 if episode is None else episode.command_delay_steps
        self._delayed_command = (0.0, 0.0)

    def command(self, wanted: tuple[float, float], drives: bool) -> tuple[float, float]:
        """(speed, steering) that reaches the car this step: `wanted`, or the previous step's with a command delay;
        zero while paused, when the car is held and no late command is kept for after."""
        if not drives:
            self._delayed_command = (0.0, 0.0)
            return 0.0, 0.0
        if self.command_delay_steps:
            wanted, self._delayed_command = self._delayed_command, wanted
        return wanted
