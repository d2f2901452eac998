"""The fast-lap recipe racer ships (racer/defaults/racing/{discrete,continuous}): custom files the trainer takes with no
warning, a reward DeepRacer on AWS would accept (`racer reward test`: no error, no warning) on several tracks, and
action spaces that follow the rule docs/racing.md gives for them, checked against the car model."""

from __future__ import annotations

import json
import math

import pytest
from click.testing import CliRunner

from racer.defaults import FAST_LAP_CUSTOM_FILES
from racer.racing_line import CarLimits
from racer.reward.cli import reward_group
from racer.shared.deepracer.model_metadata import load_model_metadata
from racer.shared.run_settings import RunOptions
from racer.shared.sim.car import vehicle as car
from racer.shared.sim.generations.catalog import generation
from racer.trainer.preflight import preflight

SPACES = ("discrete", "continuous")
DEEPRACER_ON_AWS_CAR = CarLimits.of_car(generation("simapp6").car, world="base")
"""The car the action spaces are derived for: DeepRacer on AWS's (the `simapp6` generation's), on μ 0.5."""


@pytest.mark.parametrize("space", SPACES)
def test_the_trainer_takes_the_recipe_without_a_warning(space):
    report = preflight(FAST_LAP_CUSTOM_FILES[space], RunOptions(num_workers=4, track="racer_oval"))
    assert report.warnings == ()
    assert (report.model_metadata.continuous_action_space is not None) == (space == "continuous")
    assert report.hyperparameters.num_episodes_between_training == 20


@pytest.mark.parametrize("space", SPACES)
@pytest.mark.parametrize(("track", "direction"), [("racer_oval", None), ("2022_reinvent_champ", "counter-clockwise")])
def test_racer_reward_test_passes_with_no_warning(space, track, direction):
    folder = FAST_LAP_CUSTOM_FILES[space]
    args = ["test", str(folder / "reward_function.py"), "--model-metadata", str(folder / "model_metadata.json")]
    args += ["--track", track] + (["--direction", direction] if direction else [])
    result = CliRunner().invoke(reward_group, args)
    assert result.exit_code == 0, result.output
    assert "0 error(s), 0 warning(s)" in result.output


def test_both_spaces_share_the_reward_and_the_hyperparameters():
    for name in ("reward_function.py", "hyperparameters.json"):
        texts = {(FAST_LAP_CUSTOM_FILES[space] / name).read_text() for space in SPACES}
        assert len(texts) == 1, f"{name} differs between the fast-lap recipe's folders"


def _lateral_accel_mps2(command_mps: float, steering_deg: float) -> float:
    """A steady turn at this action: the car rolls at the command × the rolling ratio on a circle tan δ / L."""
    speed = command_mps * DEEPRACER_ON_AWS_CAR.top_speed_mps / car.MAX_SPEED_MPS
    return speed**2 * math.tan(math.radians(abs(steering_deg))) / car.WHEELBASE_M


def test_each_discrete_action_steers_as_far_as_the_grip_holds_at_its_speed():
    """docs/racing.md: every action is a turn the tyres hold, at the largest whole degree they hold (or full lock)."""
    actions = load_model_metadata(FAST_LAP_CUSTOM_FILES["discrete"] / "model_metadata.json").discrete_actions
    grip = DEEPRACER_ON_AWS_CAR.lateral_accel_mps2
    for action in actions:
        assert _lateral_accel_mps2(action.speed_mps, action.steering_angle_deg) <= grip, action
        if action.steering_angle_deg != 0 and abs(action.steering_angle_deg) < car.MAX_STEERING_DEG:
            assert _lateral_accel_mps2(action.speed_mps, abs(action.steering_angle_deg) + 1) > grip, action
    speeds = sorted({action.speed_mps for action in actions}, reverse=True)
    assert speeds[0] == car.MAX_SPEED_MPS
    radii = [speed**2 / grip for speed in speeds]  # each speed's tightest turn: about half the one before
    assert all(0.4 <= inner / outer <= 0.65 for outer, inner in zip(radii, radii[1:], strict=False))


def test_the_slowest_speed_is_where_full_lock_comes_within_the_grip():
    """Slower than the speed at which full lock is within the grip turns no tighter: the lowest speed (both spaces)
    is that speed, rounded down to 0.1 m/s."""
    full_lock_mps = math.sqrt(DEEPRACER_ON_AWS_CAR.lateral_accel_mps2 / DEEPRACER_ON_AWS_CAR.max_curvature_per_m)
    full_lock_command = full_lock_mps * car.MAX_SPEED_MPS / DEEPRACER_ON_AWS_CAR.top_speed_mps
    continuous = json.loads((FAST_LAP_CUSTOM_FILES["continuous"] / "model_metadata.json").read_text())["action_space"]
    discrete = load_model_metadata(FAST_LAP_CUSTOM_FILES["discrete"] / "model_metadata.json").discrete_actions
    for slowest in (continuous["speed"]["low"], min(action.speed_mps for action in discrete)):
        assert slowest <= full_lock_command < slowest + 0.1
    assert continuous["speed"]["high"] == car.MAX_SPEED_MPS
    assert continuous["steering_angle"] == {"low": -car.MAX_STEERING_DEG, "high": car.MAX_STEERING_DEG}
