"""The car profiles built from DeepRacer's SimApp source (`simapp5-ros1`, `simapp6-ros2`): their numbers follow from
the source facts by the documented formulas, agree with racer's car geometry, and are registered by name."""

from __future__ import annotations

import math

import pytest

from racer.shared.sim.car import simapp_profiles as simapp
from racer.shared.sim.car import vehicle as car_geometry
from racer.shared.sim.car.dynamics import (
    CAR_DYNAMICS,
    CAR_PROFILE_NAMES,
    SIMAPP5_ROS1_DYNAMICS,
    SIMAPP6_ROS2_DYNAMICS,
    car_profile,
)


def test_profiles_are_registered_and_unknown_names_fail():
    assert CAR_PROFILE_NAMES[:2] == ("gazebo", "simtrace-fit")
    assert car_profile("simapp5-ros1") is SIMAPP5_ROS1_DYNAMICS
    assert car_profile("simapp6-ros2") is SIMAPP6_ROS2_DYNAMICS
    with pytest.raises(ValueError, match="RACER_CAR_PROFILE.*'simapp-ros3'.*simapp5-ros1, simapp6-ros2"):
        car_profile("simapp-ros3")
    assert len(set(CAR_DYNAMICS.values())) == len(CAR_DYNAMICS)


def test_urdf_facts_agree_with_racers_car_geometry():
    assert simapp.urdf_mass_kg() == pytest.approx(car_geometry.TOTAL_MASS_KG)
    assert simapp.WHEEL_MASS_KG == car_geometry.WHEEL_MASS_KG and simapp.HINGE_MASS_KG == car_geometry.HINGE_MASS_KG
    rear, front = simapp.WHEEL_POSITIONS_M[0], simapp.WHEEL_POSITIONS_M[2]
    assert rear == (car_geometry.REAR_AXLE_X_M, car_geometry.REAR_HALF_TRACK_M)
    assert front == (car_geometry.FRONT_AXLE_X_M, car_geometry.FRONT_HALF_TRACK_M)
    assert simapp.HINGE_LIMIT_RAD == car_geometry.STEERING_LIMIT_RAD
    assert simapp.COMMAND_WHEEL_RADIUS_M == car_geometry.command_wheel_radius_m(3.0)
    # racer models a wheel's own yaw inertia as a sphere's; the URDF's izz differs by 0.4 g·m² of 80
    assert SIMAPP5_ROS1_DYNAMICS.yaw_inertia_kgm2 == pytest.approx(car_geometry.urdf_yaw_inertia_kgm2(), rel=0.01)
    # v6.0.5's camera_link mass sits where racer mounts the camera (from the same joint chain)
    assert simapp.V6_EXTRA_LINKS[1][2] == pytest.approx(car_geometry.CAMERA_POS_M[0], abs=1e-4)
    assert simapp.ROS2_MASS_KG == pytest.approx(6.5622 + 2 * 0.34055 + 0.3)
    # the heavier ROS 2 car turns as its inertia / mass says: 0.0951 kg·m² for 7.54 kg, on racer's 6.56 kg body
    raw = simapp.urdf_yaw_inertia_kgm2(simapp.V6_EXTRA_LINKS)
    assert raw == pytest.approx(0.0951, abs=5e-4)
    ratio = SIMAPP6_ROS2_DYNAMICS.yaw_inertia_kgm2 / car_geometry.TOTAL_MASS_KG
    assert ratio == pytest.approx(raw / simapp.ROS2_MASS_KG)


def _step_response_time_s(advance, dt_s: float) -> float:
    """Time for a unit step response to reach 1 − 1/e."""
    t, angle = 0.0, 0.0
    while angle < 1.0 - math.exp(-1.0):
        angle = advance(angle)
        t += dt_s
    return t


def test_ros1_servo_is_the_hinge_pd_lag():
    """p 1 N·m/rad, d 0.5 N·m·s/rad on the hinge and its wheel: integrated at 10 µs it reaches 63 % in d/p = 0.5 s."""
    j, p, d, dt = simapp.hinge_axis_inertia_kgm2(), simapp.HINGE_P_NM_PER_RAD, simapp.HINGE_D_NMS_PER_RAD, 1e-5
    assert j == pytest.approx(4e-6 + 0.00026046)
    rate = [0.0]

    def advance(angle: float) -> float:
        rate[0] += dt * (p * (1.0 - angle) - d * rate[0]) / j
        return angle + dt * rate[0]

    assert _step_response_time_s(advance, dt) == pytest.approx(SIMAPP5_ROS1_DYNAMICS.steering_time_constant_s, rel=0.01)
    assert SIMAPP5_ROS1_DYNAMICS.steering_time_constant_s == pytest.approx(d / p, rel=0.002)


def test_ros2_servo_is_gz_ros2_controls_position_loop_at_60_hz():
    """Each 1/60 s update commands the joint velocity 0.1 × 60 × error: 10 % of the error per update."""
    tau = SIMAPP6_ROS2_DYNAMICS.steering_time_constant_s
    steps = _step_response_time_s(lambda angle: angle + simapp.GZ_POSITION_GAIN * (1.0 - angle), 1.0 / 60.0) * 60
    assert steps == 10  # 1 − 0.9^10 = 0.651, the first update past 1 − 1/e
    assert 9 / 60 < tau < 10 / 60 and 1.0 - 0.9 ** (tau * 60) == pytest.approx(1.0 - math.exp(-1.0))


def test_source_tyres_and_drive():
    for profile in (SIMAPP5_ROS1_DYNAMICS, SIMAPP6_ROS2_DYNAMICS):
        tyres = profile.tyres
        assert tyres.front_peak_grip == tyres.rear_peak_grip == 1.0  # Coulomb μ 0.5 × the axle's load
        assert tyres.front_cornering_stiffness_n_per_rad == tyres.rear_cornering_stiffness_n_per_rad
        assert tyres.rolling_radius_m == simapp.WHEEL_MESH_RADIUS_M == 0.036
        assert tyres.max_drive_force_n / (car_geometry.TOTAL_MASS_KG * 9.81) == pytest.approx(simapp.WHEEL_MU)
    # the wheels' own P loops are stiffer than racer's tyre update resolves: racer's drive is the update's limit
    assert simapp.wheel_drive_stiffness_n_per_mps() == pytest.approx(3.0 / 0.036**2)
    assert simapp.wheel_drive_stiffness_n_per_mps() > SIMAPP5_ROS1_DYNAMICS.tyres.drive_stiffness_n_per_mps


def test_the_mujoco_car_follows_the_profiles_servo_and_speed(make_env):
    for profile in (SIMAPP5_ROS1_DYNAMICS, SIMAPP6_ROS2_DYNAMICS):
        env = make_env(car_dynamics=profile)
        model, data, car = env.model, env.data, env.car
        car.teleport(model, data, 0.0, -20.0, 0.0)
        car.command(data, 1.0, 10.0)
        car.step(model, data, round(profile.steering_time_constant_s / model.opt.timestep))
        hinges = [data.qpos[model.joint(name).qposadr[0]] for name in car_geometry.STEERING_JOINTS]
        assert [angle / math.radians(10.0) for angle in hinges] == pytest.approx([1 - math.exp(-1)] * 2, abs=0.04)
        car.step(model, data, 30 * env.config.physics_substeps)  # 2 s at 1 m/s
        assert car.speed_mps(data) == pytest.approx(0.036 / 0.035, abs=0.01)
