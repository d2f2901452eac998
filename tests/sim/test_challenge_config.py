"""ChallengeConfig: DeepRacer's keys and defaults, round trips through training_params, and options that name bad keys."""

from __future__ import annotations

import click
import pytest

from racer.options.challenge import challenge_params_from_options
from racer.shared.run_settings import challenge_option_args
from racer.shared.sim.objects.challenge import ChallengeConfig, ObjectPosition


def test_defaults_are_the_simapps():
    challenge = ChallengeConfig()
    assert (challenge.race_type, challenge.number_of_obstacles, challenge.min_distance_between_obstacles) == (
        "TIME_TRIAL",
        0,
        2.0,
    )
    assert (challenge.obstacle_type, challenge.bot_car_speed_mps, challenge.lower_lane_change_time_s) == (
        "box_obstacle",
        0.2,
        3.0,
    )
    assert (
        challenge.upper_lane_change_time_s,
        challenge.lane_change_distance_m,
        challenge.min_distance_between_bot_cars_m,
    ) == (
        5.0,
        1.0,
        2.0,
    )
    assert (challenge.enable_mercy_reset, challenge.max_resets_after_crash, challenge.penalty_seconds) == (
        False,
        3,
        2.0,
    )
    assert not challenge.has_objects


def test_training_params_round_trip_and_the_yaml_list_form():
    challenge = ChallengeConfig(
        race_type="OBJECT_AVOIDANCE",
        object_positions=(ObjectPosition(0.23, -1), ObjectPosition(0.46, 1)),
        number_of_bot_cars=1,
        is_lane_change=True,
        enable_mercy_reset=True,
    )
    params = challenge.to_training_params()
    assert params["OBJECT_POSITIONS"] == ["0.23,-1", "0.46,1"] and params["IS_LANE_CHANGE"] == "True"
    assert ChallengeConfig.from_training_params(params) == challenge
    assert (
        ChallengeConfig.from_training_params({**params, "OBJECT_POSITIONS": "0.23,-1;0.46,1"}) == challenge
    )  # DRfC's form
    assert challenge.num_obstacles == 2  # OBJECT_POSITIONS overrides NUMBER_OF_OBSTACLES


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"RACE_TYPE": "F1"}, "RACE_TYPE: F1 puts several trained cars on the track"),
        ({"RACE_TYPE": "SPRINT"}, "RACE_TYPE: 'SPRINT' is not one of"),
        ({"RACE_TYPE": "HEAD_TO_BOT", "NUMBER_OF_BOT_CARS": "2.5"}, "NUMBER_OF_BOT_CARS: '2.5' is not a whole number"),
        (
            {"RACE_TYPE": "HEAD_TO_BOT", "NUMBER_OF_BOT_CARS": "1", "IS_LANE_CHANGE": "yes"},
            "IS_LANE_CHANGE: 'yes' is not",
        ),
        (
            {"RACE_TYPE": "HEAD_TO_BOT", "NUMBER_OF_BOT_CARS": "1", "UPPER_LANE_CHANGE_TIME": "1"},
            "UPPER_LANE_CHANGE_TIME: 1.0 s is below LOWER_LANE_CHANGE_TIME",
        ),
        ({"RACE_TYPE": "OBJECT_AVOIDANCE", "OBJECT_POSITIONS": "0.2,2"}, "OBJECT_POSITIONS: 0.2,2: each entry"),
        ({"NUMBER_OF_OBSTACLES": "3"}, "RACE_TYPE: TIME_TRIAL with"),
    ],
)
def test_bad_values_name_their_key(params, message):
    with pytest.raises(ValueError, match=message):
        ChallengeConfig.from_training_params(params)


def test_command_line_options_are_checked_and_passed_on():
    pairs = challenge_params_from_options(
        "object-avoidance", ("number_of_obstacles=3", "RANDOMIZE_OBSTACLE_LOCATIONS=True")
    )
    assert pairs == (
        ("RACE_TYPE", "OBJECT_AVOIDANCE"),
        ("NUMBER_OF_OBSTACLES", "3"),
        ("RANDOMIZE_OBSTACLE_LOCATIONS", "True"),
    )
    assert challenge_option_args(pairs) == [
        "--race-type",
        "OBJECT_AVOIDANCE",
        "--race-param",
        "NUMBER_OF_OBSTACLES=3",
        "--race-param",
        "RANDOMIZE_OBSTACLE_LOCATIONS=True",
    ]
    assert challenge_params_from_options(None, ()) == ()
    with pytest.raises(click.BadParameter, match="NOT_A_KEY=1"):
        challenge_params_from_options("head-to-bot", ("NOT_A_KEY=1",))
    with pytest.raises(click.BadParameter, match="BOT_CAR_SPEED: 9.0 m/s is outside"):
        challenge_params_from_options("head-to-bot", ("NUMBER_OF_BOT_CARS=1", "BOT_CAR_SPEED=9"))
