"""The MuJoCo car follows commands like DeepRacer's: speed tracking, steering, grip per world, version units."""

from __future__ import annotations

import itertools
import math

import mujoco
import numpy as np
import pytest

from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.sim.car.dynamics import GAZEBO_DYNAMICS, SIMTRACE_FIT_DYNAMICS
from racer.shared.sim.car.vehicle import (
    COMMAND_WHEEL_RADIUS_M,
    WHEELBASE_M,
    Car,
    clip_command,
    command_wheel_radius_m,
    vertical_fov_deg,
)
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv


def _drive(env: DeepRacerEnv, speed_mps: float, steering_deg: float, seconds: float) -> tuple[float, float]:
    """(planar speed, yaw rate) after driving a command from rest, far from the track (flat floor everywhere)."""
    model, data, car = env.model, env.data, env.car
    car.teleport(model, data, 0.0, -20.0, 0.0)
    car.command(data, speed_mps, steering_deg)
    car.step(model, data, int(seconds * 15) * env.config.physics_substeps)
    return car.speed_mps(data), float(data.qvel[car.dof_adr + 5])


@pytest.fixture(scope="module")
def envs():
    created = {
        world: DeepRacerEnv(EnvConfig(world=world, car_dynamics=GAZEBO_DYNAMICS))
        for world in ("base", "carpet", "wood")
    }
    yield created
    for env in created.values():
        env.close()


@pytest.fixture(scope="module")
def fitted_env():
    """The base world with the car fitted on the real simtraces (`SIMTRACE_FIT_DYNAMICS`), which the calibration
    tests below pin; the env's default car is judged closed loop with real policies (test_real_policies.py)."""
    env = DeepRacerEnv(EnvConfig(world="base", car_dynamics=SIMTRACE_FIT_DYNAMICS))
    yield env
    env.close()


def test_geometry_and_mass():
    env = DeepRacerEnv(EnvConfig())
    try:
        model = env.model
        # The URDF's masses (deepracer-simapp v5.3.3 `bundle/urdf/deepracer/deepracer_single_cam.urdf`): chassis 5.0 kg,
        # four wheels of 0.34055 kg, two hinges of 0.1 kg.
        assert model.body_subtreemass[model.body("car").id] == pytest.approx(5.0 + 4 * 0.34055 + 2 * 0.1, abs=1e-6)
        wheels = {name: model.body(name).pos for name in ("left_rear_wheel", "right_rear_wheel")}
        hinge = model.body("left_steering_hinge").pos
        assert hinge[0] - wheels["left_rear_wheel"][0] == pytest.approx(WHEELBASE_M, abs=1e-9)
        assert wheels["left_rear_wheel"][1] - wheels["right_rear_wheel"][1] == pytest.approx(0.1621, abs=1e-4)
        camera = model.camera("front_camera")
        assert tuple(camera.pos) == pytest.approx((0.14529, 0.0, 0.13033))
        assert camera.fovy[0] == pytest.approx(vertical_fov_deg())
        assert math.tan(math.radians(camera.fovy[0]) / 2) * 4 / 3 == pytest.approx(math.tan(1.13 / 2))
        assert 1.0 / (model.opt.timestep * env.config.physics_substeps) == pytest.approx(15.0)
    finally:
        env.close()


ROLLING = GAZEBO_DYNAMICS.tyres.rolling_radius_m / COMMAND_WHEEL_RADIUS_M
"""The default car rolls at the commanded speed (1.0); the simtrace fit covers ≈ 1.12 × it, as the real runs do
(test_held_speed_matches_real_simtraces)."""


@pytest.mark.parametrize("speed_mps", [0.5, 1.5, 4.0])
def test_straight_line_speed_tracks_the_command(envs, speed_mps):
    speed, yaw_rate = _drive(envs["carpet"], speed_mps, 0.0, 1.5)
    assert speed == pytest.approx(speed_mps * ROLLING, rel=0.03)
    assert abs(yaw_rate) < 1e-3


def test_default_car_rolls_at_the_commanded_speed():
    assert ROLLING == 1.0


def test_held_speed_matches_real_simtraces(deepracer_data, fitted_env):
    """Distance per time while 1 m/s is held (any steering, ≥ 6 rows) in real runs vs the fitted car at 0° and 30°."""
    import numpy as np

    from racer.shared.deepracer.simtrace import read_simtrace

    real = []
    for path in sorted((deepracer_data / "simtrace").glob("*.csv")):
        rows = read_simtrace(path.read_bytes(), source=str(path))
        for _, group in rows.groupby("episode", sort=False):
            xy, t = group[["X", "Y"]].to_numpy(float), group.tstamp.to_numpy(float)
            throttle, status = group.throttle.to_numpy(float), group.episode_status.to_numpy()
            for i in range(7, len(group) - 1):
                if np.all(throttle[i - 6 : i + 1] == 1.0) and np.all(status[i - 6 : i + 2] == "in_progress"):
                    real.append(math.dist(xy[i + 1], xy[i]) / (t[i] - t[i - 1]))
    assert len(real) > 1000
    straight, _ = _drive(fitted_env, 1.0, 0.0, 1.0)
    turning, _ = _drive(fitted_env, 1.0, 30.0, 1.0)
    assert abs((straight + turning) / 2 - float(np.median(real))) < 0.05, (straight, turning, np.median(real))


def test_steering_turns_left_for_positive_angles(envs):
    speed, yaw_rate = _drive(envs["carpet"], 0.5, 30.0, 1.0)
    radius = speed / yaw_rate
    kinematic = WHEELBASE_M / math.tan(math.radians(30.0))
    assert yaw_rate > 0
    assert kinematic * 0.9 < radius < kinematic * 2.0  # all four wheels at one speed scrub: some understeer
    _, right = _drive(envs["carpet"], 0.5, -30.0, 1.0)
    assert right == pytest.approx(-yaw_rate, rel=0.02)


def _compiled_yaw_inertia_kgm2(env: DeepRacerEnv) -> float:
    """The whole car's inertia about the vertical through its origin, summed over the compiled MuJoCo bodies: what the
    profile's `yaw_inertia_kgm2` must become once the chassis, wheels and hinges are built."""
    model = env.model
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    car_id = model.body("car").id
    origin_xy = data.xpos[car_id][:2]
    total = 0.0
    for body in range(model.nbody):
        if model.body_rootid[body] != model.body_rootid[car_id]:
            continue
        rotation = data.ximat[body].reshape(3, 3)
        about_com = rotation @ np.diag(model.body_inertia[body]) @ rotation.T
        dx, dy = data.xipos[body][:2] - origin_xy
        total += about_com[2, 2] + model.body_mass[body] * (dx * dx + dy * dy)
    return total


def test_the_gazebo_car_has_the_urdf_yaw_inertia_and_turns_near_kinematically(envs, fitted_env):
    """GAZEBO_DYNAMICS: the URDF's inertia about the vertical, and stiff equal axles, so a moderate turn follows the
    wheels (the simtrace fit's soft front axle understeers: a wider circle)."""
    from racer.shared.sim.car.dynamics import URDF_YAW_INERTIA_KGM2
    from racer.shared.sim.car.vehicle import urdf_yaw_inertia_kgm2

    assert URDF_YAW_INERTIA_KGM2 == pytest.approx(urdf_yaw_inertia_kgm2(), abs=1e-6)
    env = envs["base"]
    assert _compiled_yaw_inertia_kgm2(env) == pytest.approx(URDF_YAW_INERTIA_KGM2, rel=1e-3)
    assert _compiled_yaw_inertia_kgm2(fitted_env) == pytest.approx(SIMTRACE_FIT_DYNAMICS.yaw_inertia_kgm2, rel=1e-3)
    car_id = env.model.body("car").id
    chassis_izz = env.model.body_inertia[car_id][2]
    assert chassis_izz == pytest.approx(0.05865, rel=0.05)  # the URDF chassis' izz (MuJoCo may rotate axes)
    kinematic = WHEELBASE_M / math.tan(math.radians(10.0))
    speed, yaw_rate = _drive(env, 1.0, 10.0, 1.5)
    assert kinematic < speed / yaw_rate < 1.1 * kinematic
    speed, yaw_rate = _drive(fitted_env, 1.0, 10.0, 1.5)
    assert speed / yaw_rate > 1.3 * kinematic


def _heading_change_in_turn(env: DeepRacerEnv, speed_mps: float, steering_deg: float, turn_s: float = 0.4) -> float:
    """Yaw change during a turn entered at steady speed: less tyre grip, less rotation."""
    model, data, car = env.model, env.data, env.car
    car.teleport(model, data, 0.0, -20.0, 0.0)
    car.command(data, speed_mps, 0.0)
    car.step(model, data, 15 * env.config.physics_substeps)
    yaw_before = car.pose(data).yaw_rad
    car.command(data, speed_mps, steering_deg)
    car.step(model, data, int(turn_s * 15) * env.config.physics_substeps)
    return car.pose(data).yaw_rad - yaw_before


def test_less_grip_on_wood_than_carpet_in_a_fast_turn(envs):
    for speed_mps, steering_deg in ((2.0, 20.0), (3.0, 30.0)):
        carpet = _heading_change_in_turn(envs["carpet"], speed_mps, steering_deg)
        wood = _heading_change_in_turn(envs["wood"], speed_mps, steering_deg)
        assert 0 < wood < carpet


def test_commands_are_clipped_and_old_models_use_their_wheel_radius():
    assert clip_command(5.0, 45.0) == (4.0, 30.0)
    assert clip_command(0.0, -45.0) == (0.1, -30.0)
    assert command_wheel_radius_m(5.0) == 0.035 and command_wheel_radius_m(2.0) == 0.0277
    assert command_wheel_radius_m(1.0) == 0.1
    v1 = parse_model_metadata(
        {"action_space": [{"steering_angle": 0, "speed": 1.0}, {"steering_angle": 10, "speed": 1.0}]}
    )
    env = DeepRacerEnv(EnvConfig(model_metadata=v1))
    try:
        speed, _ = _drive(env, 1.0, 0.0, 1.5)
        assert speed == pytest.approx(0.35 * ROLLING, rel=0.05)
        assert tuple(env.model.camera("front_camera").pos) == pytest.approx((0.2, 0.0, 0.164))  # pre-v3 mount
    finally:
        env.close()


def test_car_indices_cover_the_free_joint_and_wheels():
    env = DeepRacerEnv(EnvConfig())
    try:
        car = Car(env.model)
        assert len(car.car_dofs) == 6 + 4 + 2 and len(car.wheel_actuators) == 4
    finally:
        env.close()


def test_acceleration_after_prepare_matches_real_simtraces(deepracer_data):
    """Speed between the first rows of an episode (throttle 1 m/s) as in the real console/DRfC training runs."""
    import csv
    from collections import defaultdict

    import numpy as np

    episodes = defaultdict(list)
    for path in sorted((deepracer_data / "simtrace").glob("*training*.csv")):
        with path.open(newline="") as handle:
            for row in csv.DictReader(handle):
                episodes[(path.name, row["episode"])].append(row)
    real = []
    for rows in episodes.values():
        if len(rows) >= 6 and all(float(r["throttle"]) == 1.0 for r in rows[1:4]):
            xy = np.array([(float(r["X"]), float(r["Y"])) for r in rows[:5]])
            t = np.array([float(r["tstamp"]) for r in rows[:5]])
            real.append(np.hypot(*np.diff(xy, axis=0).T) / np.diff(t))
    assert len(real) >= 20
    real_mean = np.mean(real, axis=0)

    metadata = parse_model_metadata(
        {
            "action_space": [{"steering_angle": 0, "speed": 1.0}, {"steering_angle": 10, "speed": 1.0}],
            "sensor": ["FRONT_FACING_CAMERA"],
            "version": "5",
        }
    )
    env = DeepRacerEnv(EnvConfig(model_metadata=metadata, track="racer_circuit", car_dynamics=GAZEBO_DYNAMICS))
    try:
        env.reset(seed=0)
        rows = [env.step(0)[-1]["simtrace"] for _ in range(5)]
    finally:
        env.close()
    ours = [
        math.hypot(b["X"] - a["X"], b["Y"] - a["Y"]) / (b["tstamp"] - a["tstamp"]) for a, b in itertools.pairwise(rows)
    ]
    assert ours[0] < 0.01 and real_mean[0] < 0.01  # the prepare step sends zero
    np.testing.assert_allclose(ours[1:], real_mean[1:], atol=0.06)


def _real_yaw_rates_holding_left_30(deepracer_data) -> list[float]:
    """Yaw rate (rad/s) between rows while +30° at 1 m/s has been held for 3-6 rows, from real training runs."""
    import csv
    from collections import defaultdict

    episodes = defaultdict(list)
    for path in sorted((deepracer_data / "simtrace").glob("*training*.csv")):
        with path.open(newline="") as handle:
            for row in csv.DictReader(handle):
                episodes[(path.name, row["episode"])].append(row)
    rates = []
    for rows in episodes.values():
        held = 0
        for i, (row, nxt) in enumerate(itertools.pairwise(rows)):
            held = held + 1 if float(row["steer"]) == 30.0 and float(row["throttle"]) == 1.0 else 0
            if 3 <= held <= 6 and i > 5:
                dyaw = (float(nxt["yaw"]) - float(row["yaw"]) + 180.0) % 360.0 - 180.0
                rates.append(math.radians(dyaw) / (float(nxt["tstamp"]) - float(row["tstamp"])))
    return rates


def test_turning_rate_matches_real_simtraces(deepracer_data, fitted_env):
    import numpy as np

    real = _real_yaw_rates_holding_left_30(deepracer_data)
    assert len(real) > 100
    env = fitted_env  # the real runs are on reinvent_base, DeepRacer's tyre μ 0.5 = our base world
    model, data, car = env.model, env.data, env.car
    car.teleport(model, data, 0.0, -20.0, 0.0)
    car.command(data, 1.0, 0.0)
    car.step(model, data, 15 * env.config.physics_substeps)
    car.command(data, 1.0, 30.0)
    yaws = []
    for _ in range(8):
        yaws.append(car.pose(data).yaw_rad)
        car.step(model, data, env.config.physics_substeps)
    ours = np.diff(np.unwrap(yaws)) * 15.0
    assert abs(float(np.median(ours[3:])) - float(np.median(real))) < 0.3, (ours, np.median(real))
