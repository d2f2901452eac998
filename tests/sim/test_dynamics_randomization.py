"""racer's dynamics randomisation (RACER_DYNAMICS_RANDOMIZATION): a car drawn at every reset, seeded like the scene
randomisation, within the stated ranges, applied to the compiled model, and off by default."""

from __future__ import annotations

import math

import numpy as np
import pytest

from racer.shared.sim.car import chassis_inertia_kgm2, steering_kv
from racer.shared.sim.car_dynamics import CAR_DYNAMICS, GAZEBO_DYNAMICS, SIMTRACE_FIT_DYNAMICS
from racer.shared.sim.dynamics_randomization import DYNAMICS_RANDOMIZATION_RANGES, draw_dynamics


def _within(value: float, bounds: tuple[float, float]) -> bool:
    return bounds[0] - 1e-9 <= value <= bounds[1] + 1e-9


def test_draws_are_seeded_within_the_ranges_and_span_both_profiles():
    ranges = DYNAMICS_RANDOMIZATION_RANGES
    first = [draw_dynamics(GAZEBO_DYNAMICS, np.random.default_rng(7)) for _ in range(2)]
    assert first[0] == first[1]
    rng = np.random.default_rng(0)
    draws = [draw_dynamics(GAZEBO_DYNAMICS, rng) for _ in range(400)]
    assert len({draw.car for draw in draws}) == len(draws)
    for draw in draws:
        tyres = draw.car.tyres
        front, rear = tyres.front_cornering_stiffness_n_per_rad, tyres.rear_cornering_stiffness_n_per_rad
        assert _within(math.sqrt(front * rear), ranges.cornering_stiffness_n_per_rad)
        assert _within(front / rear, ranges.front_rear_balance)
        assert _within(draw.car.yaw_inertia_kgm2, ranges.yaw_inertia_kgm2)
        assert _within(draw.car.steering_time_constant_s, ranges.steering_time_constant_s)
        assert _within(tyres.rolling_radius_m / 0.035, ranges.speed_factor)
        assert draw.command_delay_steps in (0, 1)
        assert tyres.front_peak_grip == tyres.rear_peak_grip and _within(tyres.front_peak_grip, ranges.peak_grip)
        # what the ranges leave out stays the profile's
        assert (tyres.drive_stiffness_n_per_mps, tyres.max_drive_force_n) == (
            GAZEBO_DYNAMICS.tyres.drive_stiffness_n_per_mps,
            GAZEBO_DYNAMICS.tyres.max_drive_force_n,
        )
    assert 0.35 < np.mean([draw.command_delay_steps for draw in draws]) < 0.65
    # the range is between the cars and around them: every generation's car and the source-built profiles (not the
    # console2020-fit study car, whose soft axles at <= 1 m/s no generation drives)
    from racer.shared.sim.generations import GENERATIONS

    covered = {generation.car_profile for generation in GENERATIONS.values()} | {"simapp5-ros1", "simapp6-ros2"}
    assert covered <= set(CAR_DYNAMICS) and len(covered) == 5
    for profile in (CAR_DYNAMICS[name] for name in sorted(covered)):
        tyres = profile.tyres
        assert _within(
            math.sqrt(tyres.front_cornering_stiffness_n_per_rad * tyres.rear_cornering_stiffness_n_per_rad),
            ranges.cornering_stiffness_n_per_rad,
        )
        assert _within(
            tyres.front_cornering_stiffness_n_per_rad / tyres.rear_cornering_stiffness_n_per_rad,
            ranges.front_rear_balance,
        )
        assert _within(profile.yaw_inertia_kgm2, ranges.yaw_inertia_kgm2)
        assert _within(profile.steering_time_constant_s, ranges.steering_time_constant_s)
        assert _within(tyres.rolling_radius_m / 0.035, ranges.speed_factor)
        assert _within(tyres.front_peak_grip, ranges.peak_grip) and _within(tyres.rear_peak_grip, ranges.peak_grip)
    # the grip reaches both the ROS 1 car's and the default's
    grips = [draw.car.tyres.front_peak_grip for draw in draws]
    assert min(grips) < 1.1 and max(grips) > 1.9


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
    # drawn around this profile: its drive stays
    assert car.tyres.drive_stiffness_n_per_mps == SIMTRACE_FIT_DYNAMICS.tyres.drive_stiffness_n_per_mps


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
