"""The tyre model (tyres.py) and retuning a compiled car to other dynamics constants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.fidelity.simtrace_replay import CarReplay, load_segments
from racer.shared.sim.car.dynamics import SIMTRACE_FIT_DYNAMICS
from racer.shared.sim.car.tyres import GRAVITY_MPS2, TyreParams
from racer.shared.sim.car.vehicle import REAR_AXLE_X_M, STEERING_JOINTS, WHEELBASE_M
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv


def test_params_must_be_positive_and_the_error_names_the_field():
    with pytest.raises(ValueError, match="TyreParams.rear_peak_grip"):
        TyreParams(rear_peak_grip=0.0)


def _sliding_sideways_force(world: str, steering_deg: float = 0.0) -> np.ndarray:
    """The chassis force the tyres give when the car slides sideways at 2 m/s, hinges at `steering_deg`."""
    env = DeepRacerEnv(EnvConfig(world=world))
    try:
        model, data, car = env.model, env.data, env.car
        car.teleport(model, data, 0.0, -20.0, 0.0)
        data.qvel[car.dof_adr + 1] = 2.0  # world +y = the car's left
        for joint in STEERING_JOINTS:
            adr = model.joint(joint).qposadr[0]
            data.qpos[adr] = math.radians(steering_deg)
        car.tyres.apply(data)
        return data.xfrc_applied[car.body_id].copy()
    finally:
        env.close()


def test_lateral_force_saturates_at_grip_times_the_worlds_mu_times_the_axle_load():
    params = EnvConfig().car_dynamics.tyres
    weight_n = 6.5622 * GRAVITY_MPS2
    front_load, rear_load = weight_n * -REAR_AXLE_X_M / WHEELBASE_M, weight_n * (1 + REAR_AXLE_X_M / WHEELBASE_M)
    for world, mu in (("carpet", 0.65), ("wood", 0.42)):
        force = _sliding_sideways_force(world)
        # Both axles at a slip angle of atan(2 / 0.3) ≈ 81°: far into the saturated part, pushing back to the right.
        slip = math.atan2(2.0, params.min_slip_speed_mps)
        expected = 0.0
        for grip, load, stiffness in (
            (params.front_peak_grip, front_load, params.front_cornering_stiffness_n_per_rad),
            (params.rear_peak_grip, rear_load, params.rear_cornering_stiffness_n_per_rad),
        ):
            peak = grip * mu * load
            expected -= peak * math.tanh(stiffness * slip / peak)
            assert peak * math.tanh(stiffness * slip / peak) > 0.9 * peak
        assert force[1] == pytest.approx(expected, rel=1e-6)
        assert abs(force[0]) < 1e-9 and force[2:5].tolist() == [0.0, 0.0, 0.0]


def test_front_force_acts_across_the_steered_wheels():
    straight, steered = _sliding_sideways_force("base"), _sliding_sideways_force("base", 20.0)
    # Turned 20° left, the front tyre pushes along its own axis, to the wheels' right: that leans forward (+x).
    assert steered[0] > 1.0 and straight[0] == pytest.approx(0.0, abs=1e-9)
    assert steered[1] > straight[1]  # and the front's push to the right is smaller: its slip angle is 20° less


def test_retune_changes_the_compiled_car_in_place(deepracer_data):
    segment = load_segments([deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"])[0]
    replay = CarReplay(deepracer_data / "routes" / "reinvent_base.npy")
    fit = SIMTRACE_FIT_DYNAMICS
    try:
        shipped, _ = replay.run(segment)
        replay.car.retune(replay.model, fit.tyres, 0.1, 0.078)  # slow servo, the URDF's yaw inertia
        other, _ = replay.run(segment)
        replay.car.retune(replay.model, fit.tyres, fit.steering_time_constant_s, fit.yaw_inertia_kgm2)
        again, _ = replay.run(segment)
    finally:
        replay.close()
    np.testing.assert_allclose(again, shipped, atol=1e-4)
    assert np.max(np.hypot(*(other - shipped).T)) > 0.01
