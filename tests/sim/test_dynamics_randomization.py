"""racer's dynamics randomisation (RACER_DYNAMICS_RANDOMIZATION): a car drawn at every reset, seeded like the scene
randomisation, around each generation's car, applied to the compiled model, and off by default."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from racer.shared.sim.car.dynamics import (
    GAZEBO_DYNAMICS,
    SIMAPP5_ROS1_DYNAMICS,
    SIMAPP6_FIT_DYNAMICS,
    SIMTRACE_FIT_DYNAMICS,
)
from racer.shared.sim.car.dynamics_randomization import FIT_SPREAD_FACTOR, draw_dynamics, mixture_centres
from racer.shared.sim.car.vehicle import chassis_inertia_kgm2, steering_kv
from racer.shared.sim.generations.catalog import GENERATIONS


def test_draws_are_seeded_and_spread_around_each_generations_car():
    first = [draw_dynamics(GAZEBO_DYNAMICS, np.random.default_rng(7)) for _ in range(2)]
    assert first[0] == first[1]
    rng = np.random.default_rng(0)
    draws = [draw_dynamics(SIMAPP6_FIT_DYNAMICS, rng) for _ in range(600)]
    assert len({draw.car for draw in draws}) == len(draws)
    generation_cars = {generation.car for generation in GENERATIONS.values()}
    assert set(mixture_centres(SIMAPP6_FIT_DYNAMICS)) == generation_cars and len(generation_cars) == 3
    counts = {centre: sum(draw.centre == centre for draw in draws) for centre in generation_cars}
    assert all(150 < count < 250 for count in counts.values()), counts
    low, high = 1 / FIT_SPREAD_FACTOR - 1e-9, FIT_SPREAD_FACTOR + 1e-9
    ratios = {"front": [], "rear": [], "servo": [], "inertia": []}
    for draw in draws:
        tyres, centre = draw.car.tyres, draw.centre.tyres
        ratios["front"].append(tyres.front_cornering_stiffness_n_per_rad / centre.front_cornering_stiffness_n_per_rad)
        ratios["rear"].append(tyres.rear_cornering_stiffness_n_per_rad / centre.rear_cornering_stiffness_n_per_rad)
        ratios["servo"].append(draw.car.steering_time_constant_s / draw.centre.steering_time_constant_s)
        ratios["inertia"].append(draw.car.yaw_inertia_kgm2 / draw.centre.yaw_inertia_kgm2)
        # what the sources fix stays the centre's
        assert (
            replace(
                tyres,
                front_cornering_stiffness_n_per_rad=centre.front_cornering_stiffness_n_per_rad,
                rear_cornering_stiffness_n_per_rad=centre.rear_cornering_stiffness_n_per_rad,
            )
            == centre
        )
        assert draw.command_delay_steps in (0, 1)
    for name, values in ratios.items():
        assert low <= min(values) and max(values) <= high, name
        # spread both ways, log-uniformly: about a quarter of the draws beyond each half-factor
        assert np.mean(np.array(values) > math.sqrt(FIT_SPREAD_FACTOR)) > 0.18, name
        assert np.mean(np.array(values) < 1 / math.sqrt(FIT_SPREAD_FACTOR)) > 0.18, name
    assert 0.4 < np.mean([draw.command_delay_steps for draw in draws]) < 0.6


def test_a_run_car_that_is_no_generations_is_a_centre_too():
    assert mixture_centres(SIMAPP5_ROS1_DYNAMICS)[-1] == SIMAPP5_ROS1_DYNAMICS
    assert len(mixture_centres(SIMAPP5_ROS1_DYNAMICS)) == len(GENERATIONS) + 1
    rng = np.random.default_rng(1)
    centres = {draw_dynamics(SIMAPP5_ROS1_DYNAMICS, rng).centre for _ in range(100)}
    assert SIMAPP5_ROS1_DYNAMICS in centres and len(centres) == 4


def test_off_by_default_the_env_drives_the_profiles_car(make_env):
    env = make_env(car_dynamics=GAZEBO_DYNAMICS)
    inertia, servo = env.model.body_inertia.copy(), env.model.actuator_biasprm.copy()
    for seed in (0, 1):
        env.reset(seed=seed)
        assert env.car_dynamics == GAZEBO_DYNAMICS and env.command_delay_steps == 0
        assert env.car.tyres.params == GAZEBO_DYNAMICS.tyres
    np.testing.assert_array_equal(env.model.body_inertia, inertia)
    np.testing.assert_array_equal(env.model.actuator_biasprm, servo)


def test_seeded_resets_give_the_same_cars_and_the_model_drives_them(make_env):
    envs = [make_env(dynamics_randomization=True, car_dynamics=SIMTRACE_FIT_DYNAMICS) for _ in range(2)]
    sequences = []
    for env in envs:
        env.reset(seed=5)
        cars = [(env.car_dynamics, env.command_delay_steps)]
        for _ in range(3):
            env.reset()
            cars.append((env.car_dynamics, env.command_delay_steps))
        sequences.append(cars)
    assert sequences[0] == sequences[1]
    assert len({car for car, _ in sequences[0]}) == 4
    env = envs[0]
    env.reset(seed=6)
    assert env.car_dynamics != sequences[0][0][0]
    car = env.car_dynamics
    body = env.car.body_id
    np.testing.assert_allclose(env.model.body_inertia[body], chassis_inertia_kgm2(car.yaw_inertia_kgm2))
    np.testing.assert_allclose(
        env.model.actuator_biasprm[env.car.steering_actuators, 2], -steering_kv(car.steering_time_constant_s)
    )
    assert env.car.tyres.params == car.tyres
    # drawn around one generation's car: its drive stays that car's
    assert car.tyres.drive_stiffness_n_per_mps in {
        generation.car.tyres.drive_stiffness_n_per_mps for generation in GENERATIONS.values()
    }


def test_a_delayed_episode_drives_each_step_with_the_previous_command(make_env):
    env = make_env(dynamics_randomization=True)
    for seed in range(50):
        env.reset(seed=seed)
        if env.command_delay_steps:
            break
    assert env.command_delay_steps == 1
    servo = env.car.steering_actuators[0]
    env.step(0)  # prepare: no command
    assert env.data.ctrl[servo] == 0.0
    env.step(0)  # the first run step drives the prepare step's (zero) command
    assert env.data.ctrl[servo] == 0.0
    env.step(4)  # now action 0's command (-30 degrees), action 4 waits
    assert math.degrees(env.data.ctrl[servo]) == pytest.approx(-30.0)
    env.step(4)
    assert math.degrees(env.data.ctrl[servo]) == pytest.approx(30.0)


def test_an_evaluation_episode_drives_the_profiles_own_car_between_randomised_ones(make_env):
    """Evaluation measures the checkpoint on the run's car (as `racer evaluate` does); training goes on drawing."""
    env = make_env(dynamics_randomization=True, car_dynamics=GAZEBO_DYNAMICS)
    inertia, servo = env.model.body_inertia.copy(), env.model.actuator_biasprm.copy()
    env.reset(seed=3)
    drawn = env.car_dynamics
    assert drawn != GAZEBO_DYNAMICS
    env.reset(options={"evaluation": True})
    assert env.car_dynamics == GAZEBO_DYNAMICS and env.command_delay_steps == 0
    assert env.car.tyres.params == GAZEBO_DYNAMICS.tyres
    # retuned from the profile's figures, not copied: the compiled model's rounded inertia differs in the 5th digit
    np.testing.assert_allclose(env.model.body_inertia, inertia, rtol=1e-4)
    np.testing.assert_allclose(env.model.actuator_biasprm, servo, rtol=1e-6)
    env.reset()
    assert env.car_dynamics not in (GAZEBO_DYNAMICS, drawn)
