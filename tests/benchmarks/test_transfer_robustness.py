"""`python -m benchmarks transfer --robustness`: each perturbation reaches the env it names (start, camera, lights) and the
table judges every cell against its goal."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from benchmarks import transfer as transfer_bench
from benchmarks.transfer import transfer_bench_command
from benchmarks.transfer_robustness import PERTURBATIONS, Perturbation, goal_laps
from racer.shared.sim.car.vehicle import CAMERA_PITCH_DOWN_RAD, CAMERA_POS_M
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv


def test_the_fixed_set_and_its_goals():
    names = [p.name for p in PERTURBATIONS]
    assert len(names) == len(set(names)) == 11 and names[0] == "as it stands"
    assert PERTURBATIONS[0].config(EnvConfig(generation="2019")) == EnvConfig(generation="2019")
    assert goal_laps(PERTURBATIONS[0], 10) == 9 and all(goal_laps(p, 10) == 8 for p in PERTURBATIONS[1:])


def test_a_perturbation_moves_the_camera_and_scales_the_lights_of_the_generations_look():
    config = EnvConfig(generation="2019")
    moved = Perturbation("both", camera_up_m=0.005, camera_pitch_down_rad=math.radians(1.0)).config(config)
    assert moved.look.camera_pos_m == pytest.approx((CAMERA_POS_M[0], 0.0, CAMERA_POS_M[2] + 0.005))
    assert moved.look.camera_pitch_down_rad == pytest.approx(CAMERA_PITCH_DOWN_RAD + math.radians(1.0))
    assert moved.look.lighting == config.look.lighting and moved.car_dynamics == config.car_dynamics
    lit = Perturbation("lit", light_factor=1.15).config(config)
    assert lit.look.lighting.render_scale == pytest.approx(1.15 * config.look.lighting.render_scale)
    envs = {name: DeepRacerEnv(c) for name, c in (("base", config), ("moved", moved), ("lit", lit))}
    try:
        camera = {name: env.model.camera("front_camera") for name, env in envs.items()}
        assert camera["moved"].pos[2] == pytest.approx(camera["base"].pos[2] + 0.005)
        lights = {name: env.model.light_diffuse.copy() for name, env in envs.items()}
        np.testing.assert_allclose(lights["lit"], 1.15 * lights["base"], rtol=1e-5)
    finally:
        for env in envs.values():
            env.close()


def test_a_start_offset_moves_and_turns_the_evaluation_start_and_a_training_start_refuses_it():
    env = DeepRacerEnv(EnvConfig(generation="2019"))
    try:
        env.reset(options={"evaluation": True, "start_ndist": 0.0})
        x, y, yaw = env.track.pose_at(0.0, "center")
        pose = env.car.pose(env.data)
        env.reset(options={"evaluation": True, "start_ndist": 0.0, "start_offset": (0.05, math.radians(5.0))})
        moved = env.car.pose(env.data)
        left = np.array([-math.sin(yaw), math.cos(yaw)])
        shift = np.array([moved.origin_x_m - pose.origin_x_m, moved.origin_y_m - pose.origin_y_m])
        assert shift @ left == pytest.approx(0.05, abs=1e-6) and math.remainder(
            moved.yaw_rad - pose.yaw_rad, math.tau
        ) == pytest.approx(math.radians(5.0), abs=1e-6)
        with pytest.raises(ValueError, match="'start_offset' is for evaluation episodes"):
            env.reset(options={"start_offset": (0.05, 0.0)})
    finally:
        env.close()


def test_the_table_has_a_row_per_perturbation_and_says_where_the_goal_is_missed(monkeypatch, deepracer_data):
    seen = []

    def drive(model, config, starts, start_offset=(0.0, 0.0)):
        seen.append((config.generation, start_offset))
        laps = starts if config.look.lighting.gain == 1.0 else 0  # the light perturbations lose every lap
        return {"laps": laps, "starts": starts, "mean_progress": 100.0 * laps / starts, "progress_per_start": []}

    monkeypatch.setattr(transfer_bench, "drive", drive)
    args = ["--robustness", "--starts", "2", "--data", str(deepracer_data)]
    result = CliRunner().invoke(transfer_bench_command, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    report = json.loads([line for line in result.stdout.splitlines() if line.startswith("{")][-1])
    (table,) = report["tables"]
    assert (table["generation"], table["car_profile"], table["goal_met"]) == ("2019", "gazebo", False)
    rows = {row["perturbation"]: row["drives"] for row in table["perturbations"]}
    assert list(rows) == [p.name for p in PERTURBATIONS]
    missed = {name for name, cells in rows.items() if not all(cell["goal_met"] for cell in cells.values())}
    assert missed == {"lights +15 %", "lights -15 %"}
    assert {offset for _, offset in seen} == {(p.start_left_m, p.start_turn_rad) for p in PERTURBATIONS}
    assert "| start 5 cm left |" in result.stderr
