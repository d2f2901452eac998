"""The time-to-lap benchmark's race-type set-ups: every recipe is a valid hyperparameters.json and reaches the
trainer."""

from __future__ import annotations

import pytest

from benchmarks.time_to_lap_race_types import RACE_TYPE_SETUPS, time_to_lap_hyperparameters
from racer.options.challenge import challenge_params_from_options
from racer.shared.deepracer.hyperparameters import parse_hyperparameters


@pytest.mark.parametrize("race_type", sorted(RACE_TYPE_SETUPS))
@pytest.mark.parametrize("algorithm", ["clipped_ppo", "sac"])
def test_every_recipe_is_a_valid_hyperparameters_file(race_type, algorithm):
    data = time_to_lap_hyperparameters(race_type, algorithm, None)
    hyperparameters, warnings = parse_hyperparameters(data, source=f"{race_type} recipe")
    assert warnings == []
    assert hyperparameters.num_episodes_between_training == 20
    if algorithm == "clipped_ppo":
        for key, value in RACE_TYPE_SETUPS[race_type].hyperparameters:
            assert getattr(hyperparameters, key) == value
    else:  # the recipes are PPO's: SAC keeps the SimApp's defaults
        assert set(data) == {"num_episodes_between_training"}


def test_every_race_type_uses_the_three_epoch_recipe_and_head_to_bot_the_highest_rate():
    for race_type in ("time-trial", "object-avoidance"):
        data = time_to_lap_hyperparameters(race_type, "clipped_ppo", None)
        assert data == {"num_episodes_between_training": 20, "num_epochs": 3, "discount_factor": 0.99}
    oa = time_to_lap_hyperparameters("object-avoidance", "clipped_ppo", 8)
    assert oa["num_episodes_between_training"] == 8  # --episodes-per-iteration wins over the recipe
    assert "lr" not in oa  # DeepRacer's 0.0003: the rate the time-trial and object-avoidance benchmarks lapped with
    assert time_to_lap_hyperparameters("head-to-bot", "clipped_ppo", None)["lr"] == 0.001


@pytest.mark.parametrize("race_type", ["object-avoidance", "head-to-bot"])
def test_the_challenge_params_parse_as_the_trainer_reads_them(race_type):
    params = RACE_TYPE_SETUPS[race_type].challenge_params
    race_type_key = dict(params)["RACE_TYPE"]
    others = tuple(f"{key}={value}" for key, value in params if key != "RACE_TYPE")
    assert dict(challenge_params_from_options(race_type_key, others)) == dict(params)
