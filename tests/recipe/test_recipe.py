"""`racer recipe` (racer.recipe): the folder it writes trains without a warning, its reward passes `racer reward test`
with no error and no warning and imports only math, its action space is within DeepRacer on AWS's limits and holds
the actions the line needs, and a bad --out or a road too narrow for the car is refused by name.

The lines are the bound's with one coarse optimiser stage (about 10 s a track): the rules under test do not depend
on how close the line came to the optimum."""

from __future__ import annotations

import ast
import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from racer.racing_line import CarLimits, racing_line
from racer.recipe.action_space import discrete_space, mix_distances, mix_span, tolerances
from racer.recipe.cli import recipe_command
from racer.recipe.folder import RECIPE_FILES, Car, recipe_from_line, write_recipe
from racer.recipe.line_needs import drive_time_constant_s, line_needs, steady_steering_deg
from racer.recipe.reward_source import waypoint_table
from racer.reward.check import check_reward_file
from racer.reward.probes import Pose, params_at
from racer.shared.deepracer.model_metadata import load_model_metadata
from racer.shared.run_settings import RunOptions
from racer.shared.sim.car import vehicle as car
from racer.shared.sim.generations.catalog import generation
from racer.shared.sim.reward.function import load_reward_function
from racer.shared.sim.tracks.track import Track
from racer.trainer.preflight import preflight

CAR = Car(dynamics=generation("simapp6").car, generation="simapp6", car_profile="", world="base")
COARSE = (0.8,)


@pytest.fixture(scope="module", params=["racer_oval", "reinvent_base"])
def made(request, tmp_path_factory):
    """(route, line, {space: folder}) for one track."""
    route = Track.load(request.param)
    line = racing_line(route, CarLimits.of_car(CAR.dynamics, world=CAR.world), control_spacings_m=COARSE)
    folders = {}
    for space in ("discrete", "continuous"):
        folders[space] = tmp_path_factory.mktemp(f"{request.param}-{space}") / "recipe"
        write_recipe(recipe_from_line(route, CAR, line, space), folders[space])
    return route, line, folders


@pytest.mark.parametrize("space", ["discrete", "continuous"])
def test_the_folder_trains_without_a_warning_and_its_reward_passes_the_reward_test(made, space):
    route, _, folders = made
    folder = folders[space]
    assert sorted(path.name for path in folder.iterdir()) == sorted(RECIPE_FILES)
    assert json.loads((folder / "preset.json").read_text()) == {"anneal_lr": True}
    metadata = load_model_metadata(folder / "model_metadata.json")
    report = check_reward_file(folder / "reward_function.py", route, metadata=metadata)
    assert report.errors == [] and report.warnings == [], report.format()
    checked = preflight(folder, RunOptions(num_workers=4, track="racer_circuit"))  # workers.json names the route
    assert checked.warnings == ()
    assert checked.preset is not None and checked.preset.anneal_lr
    assert {worker.track for worker in checked.workers} == {route.name}
    assert checked.workers[0].world == "base"  # worker 0 evaluates in the line's world
    assert "wood" not in {worker.world for worker in checked.workers}  # less grip than the line's: it would not hold


def test_the_reward_imports_math_only_and_refuses_another_track_by_name(made):
    route, _, folders = made
    path = folders["discrete"] / "reward_function.py"
    tree = ast.parse(path.read_text())
    imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
    assert imported == {"math"} and not [node for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)]
    other = Track.load("racer_circuit")
    report = check_reward_file(path, other, quick=True)
    assert report.errors and f"racing line of {route.name}" in report.errors[0].message


def test_the_reward_pays_the_line_at_its_speed_more_than_off_it_or_slower(made):
    route, line, folders = made
    reward = load_reward_function(folders["discrete"] / "reward_function.py")
    params = params_at(route, Pose(0.4, 0.0, 0.0, (0.0, 1.0)), [])
    x, y, target = waypoint_table(route, _needs(line))[params["closest_waypoints"][0]]
    on_line = reward({**params, "x": x, "y": y, "speed": target})
    assert on_line > reward({**params, "x": x, "y": y, "speed": target / 2})
    assert on_line > reward({**params, "x": x + 0.25 * params["track_width"], "y": y, "speed": target})
    assert reward({**params, "is_offtrack": True}) == pytest.approx(1e-3)


def test_a_lap_at_half_the_line_s_pace_earns_half_as_much(made):
    """Each term is s^2 a step at a share s of the line's pace, and such a lap takes 1/s times the steps."""
    route, line, folders = made
    reward = load_reward_function(folders["discrete"] / "reward_function.py")
    module = {
        node.targets[0].id: ast.literal_eval(node.value)
        for node in ast.parse((folders["discrete"] / "reward_function.py").read_text()).body
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name) and node.targets[0].id.isupper()
    }
    params = params_at(route, Pose(0.4, 0.0, 0.0, (0.0, 1.0)), [])
    x, y, target = waypoint_table(route, _needs(line))[params["closest_waypoints"][0]]

    def step(share: float) -> float:
        steps = 40.0
        progress = share * module["LINE_PROGRESS_PER_STEP"] * steps
        return reward({**params, "x": x, "y": y, "speed": share * target, "steps": steps, "progress": progress})

    assert step(1.0) == pytest.approx(2.0, rel=1e-3)  # pace 1 and the line at its speed
    assert step(0.5) == pytest.approx(step(1.0) / 4, rel=1e-3)  # x 2 the steps: half the lap's pay
    lap_steps = module["LAP_STEPS"]
    done = {**params, "x": x, "y": y, "speed": target, "progress": 100.0}
    bonus_fast = reward({**done, "steps": float(lap_steps)}) - reward({**done, "progress": 99.9, "steps": lap_steps})
    assert bonus_fast == pytest.approx(lap_steps, rel=0.01)
    slow_end = reward({**done, "steps": 2.0 * lap_steps}) - reward({**done, "progress": 99.9, "steps": 2.0 * lap_steps})
    assert slow_end == pytest.approx(lap_steps / 2, rel=0.01)


def test_two_actions_close_enough_serve_the_needs_between_them():
    """A mix is the segment between two centres no farther apart than the car's lags smooth."""
    span = mix_span(CAR.dynamics)
    lag_s = min(CAR.dynamics.steering_time_constant_s, drive_time_constant_s(CAR.dynamics))
    assert span == pytest.approx(2 / math.tanh(1 / 15 / (2 * lag_s)))
    assert 4.0 < span < 4.6  # simapp6: both lags about one control period
    assert mix_span(generation("2019").car) < span  # a quicker servo smooths less
    centres = np.array([[0.0, 0.0], [4.0, 0.0]])
    between = np.array([[2.0, 0.0], [2.0, 0.5], [5.0, 0.0]])
    assert mix_distances(between, centres, span) == pytest.approx([0.0, 0.5, 1.0])
    assert mix_distances(between, centres, 3.0) == pytest.approx([2.0, np.hypot(2.0, 0.5), 1.0])  # too far apart


def test_the_discrete_space_is_within_deepracer_on_aws_limits_and_holds_the_line_s_needs(made):
    _, line, folders = made
    actions = load_model_metadata(folders["discrete"] / "model_metadata.json").discrete_actions
    assert 2 <= len(actions) <= 30
    assert all(0.1 <= a.speed_mps <= 4.0 and abs(a.steering_angle_deg) <= 30.0 for a in actions)
    assert (actions[0].steering_angle_deg, actions[0].speed_mps) == (0.0, 4.0)  # straight at the top speed
    needs = _needs(line)
    widest = max(abs(a.steering_angle_deg) for a in actions)
    assert widest == pytest.approx(min(np.abs(needs.steering_deg).max(), 30.0), abs=0.06)  # the line's extremes
    assert {a.steering_angle_deg for a in actions} == {-a.steering_angle_deg for a in actions}  # both ways
    space = discrete_space(needs, CAR.dynamics)
    assert space.worst_distance <= 1.0 or len(space.actions) >= 28  # every step within a tolerance, or the limit
    speed_tol, accel_tol = tolerances(needs)
    assert speed_tol == pytest.approx(needs.held.brake_accel_mps2 / 15 / needs.rolling_ratio)
    assert accel_tol == pytest.approx(needs.held.lateral_accel_mps2 * (1 / math.tanh(1) - 1))
    continuous = json.loads((folders["continuous"] / "model_metadata.json").read_text())["action_space"]
    load_model_metadata(folders["continuous"] / "model_metadata.json")
    assert continuous["speed"]["high"] == 4.0 and 0.5 <= continuous["speed"]["low"] < 4.0
    assert 0 < continuous["steering_angle"]["high"] == -continuous["steering_angle"]["low"] <= 30.0


def test_the_steering_is_the_wheelbase_s_angle_plus_the_slip_difference():
    """A neutral car (equal axles) steers the wheelbase's angle; simapp6's soft front axle needs more, more so
    faster at the same turn."""
    curvature, slow, fast = np.array([1.0]), np.array([0.5]), np.array([1.9])
    kinematic = math.degrees(math.atan(car.WHEELBASE_M))
    neutral = generation("2019").car  # gazebo: 300 N/rad on both axles
    assert steady_steering_deg(curvature, slow, neutral, "base")[0] == pytest.approx(kinematic, abs=0.05)
    assert kinematic < steady_steering_deg(curvature, slow, CAR.dynamics, "base")[0]
    assert (
        steady_steering_deg(curvature, slow, CAR.dynamics, "base")[0]
        < (steady_steering_deg(curvature, fast, CAR.dynamics, "base")[0])
    )


def test_an_existing_out_is_refused_without_force(tmp_path):
    out = tmp_path / "recipe"
    out.mkdir()
    result = CliRunner().invoke(recipe_command, ["racer_oval", "--out", str(out)])
    assert result.exit_code == 1 and "exists" in result.output and "--force" in result.output


def test_a_road_too_narrow_for_the_car_is_refused_naming_the_track(tmp_path):
    angles = np.linspace(0.0, 2.0 * math.pi, 121)
    angles[-1] = 0.0
    ring = np.column_stack((np.cos(angles), np.sin(angles)))
    path = tmp_path / "narrow_ring.npy"
    np.save(path, np.hstack((2.0 * ring, 1.92 * ring, 2.08 * ring)))  # 0.16 m: narrower than the car
    result = CliRunner().invoke(recipe_command, [str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1
    assert "narrow_ring" in result.output and "does not fit" in result.output
    assert not (tmp_path / "out").exists()


def _needs(line):
    return line_needs(line, CAR.dynamics)
