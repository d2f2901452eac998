"""Race files in DeepRacer on AWS's LeaderboardDefinition names: parsing, and refusal naming file and key."""

from __future__ import annotations

import pytest
import yaml

from racer.race.entrant_evaluation import deepracer_rules, resolve_route
from racer.race.race_file import RaceFileError, read_race_file

GOOD = {
    "name": "club-cup",
    "trackConfig": {"trackId": "racer_oval", "trackDirection": "COUNTER_CLOCKWISE"},
    "raceType": "OBJECT_AVOIDANCE",
    "timingMethod": "AVG_LAP_TIME",
    "resettingBehaviorConfig": {"continuousLap": True, "offTrackPenaltySeconds": 3, "collisionPenaltySeconds": 6},
    "submissionTerminationConditions": {"minimumLaps": 2, "maximumLaps": 4, "maxTimeInMinutes": 5},
    "maxResets": 0,
    "objectAvoidanceConfig": {
        "numberOfObjects": 2,
        "objectPositions": [{"laneNumber": 1, "trackPercentage": 0.3}, {"laneNumber": -1, "trackPercentage": 0.6}],
    },
}


def write(tmp_path, data, name="race.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_full_definition_maps_onto_the_evaluation_job(tmp_path):
    race = read_race_file(write(tmp_path, GOOD))
    assert (race.name, race.track_id, race.track_direction) == ("club-cup", "racer_oval", "COUNTER_CLOCKWISE")
    assert (race.minimum_laps, race.maximum_laps, race.max_time_minutes) == (2, 4, 5.0)
    rules = deepracer_rules(race)
    assert rules.number_of_trials == 4 and rules.is_continuous and rules.number_of_resets == 0
    assert (rules.off_track_penalty_s, rules.collision_penalty_s) == (3.0, 6.0)
    setup = race.challenge_config()
    assert setup.race_type == "OBJECT_AVOIDANCE" and setup.num_obstacles == 2
    assert [(p.ndist, p.lane) for p in setup.object_positions] == [(0.3, 1), (0.6, -1)]
    assert resolve_route(race) == "racer_oval"


def test_defaults_and_a_bot_car_race_under_the_simapp_names(tmp_path):
    data = {
        "trackConfig": {"trackId": "racer_oval"},
        "raceType": "head_to_bot",
        "timingMethod": "TOTAL_TIME",
        "submissionTerminationConditions": {"minimumLaps": 1, "maximumLaps": 1},
        "NUMBER_OF_BOT_CARS": 2,
    }
    race = read_race_file(write(tmp_path, data, "My Race.yml"))
    assert race.name == "My-Race" and race.max_time_minutes == 20.0 and race.max_resets is None
    assert deepracer_rules(race).number_of_resets == 10000
    assert race.challenge_config().number_of_bot_cars == 2


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"color": "red"}, "color: unknown key"),
        ({"trackConfig": {"trackId": "racer_oval", "direction": "CW"}}, "trackConfig.direction: unknown key"),
        ({"trackConfig": {"trackId": "racer_oval", "trackDirection": "UP"}}, "trackConfig.trackDirection: 'UP'"),
        ({"raceType": "DRAG"}, "raceType: 'DRAG' is not one of"),
        ({"raceType": "F1", "objectAvoidanceConfig": None, "DONE_CONDITION": "first"}, "DONE_CONDITION: 'first'"),
        ({"timingMethod": "FASTEST"}, "timingMethod: 'FASTEST'"),
        ({"submissionTerminationConditions": {"minimumLaps": 3, "maximumLaps": 2}}, "maximumLaps: 2 is below"),
        ({"submissionTerminationConditions": {"minimumLaps": 1.5, "maximumLaps": 2}}, "minimumLaps: 1.5 is not"),
        ({"resettingBehaviorConfig": {"continuousLap": "yes"}}, "continuousLap: 'yes' is not true or false"),
        ({"resettingBehaviorConfig": {"offTrackPenaltySeconds": -1}}, "offTrackPenaltySeconds: -1 is outside"),
        ({"maxResets": 1}, "maxResets: 1 is not allowed"),
        (
            {
                "objectAvoidanceConfig": {
                    "numberOfObjects": 3,
                    "objectPositions": GOOD["objectAvoidanceConfig"]["objectPositions"],
                }
            },
            "2 positions for numberOfObjects 3",
        ),
        (
            {
                "objectAvoidanceConfig": {
                    "numberOfObjects": 1,
                    "objectPositions": [{"laneNumber": 0, "trackPercentage": 0.5}],
                }
            },
            "laneNumber: 0 is not a lane",
        ),
        (
            {"submissionTerminationConditions": {"minimumLaps": 1, "maximumLaps": 1, "maxTimeInMinutes": 0}},
            "maxTimeInMinutes: 0 is outside",
        ),
        ({"NUMBER_OF_WHEELS": 3}, "NUMBER_OF_WHEELS: unknown key"),
    ],
)
def test_a_bad_key_or_value_is_refused_naming_the_file_and_the_key(tmp_path, change, key):
    path = write(tmp_path, {**GOOD, **change})
    with pytest.raises(RaceFileError) as raised:
        read_race_file(path)
    assert str(raised.value).startswith(f"{path}: ") and key in str(raised.value)


def test_missing_keys_and_an_unknown_track_are_refused(tmp_path):
    for missing, key in (("trackConfig", "trackConfig: missing"), ("timingMethod", "timingMethod: missing")):
        data = {k: v for k, v in GOOD.items() if k != missing}
        with pytest.raises(RaceFileError, match=key):
            read_race_file(write(tmp_path, data))
    race = read_race_file(write(tmp_path, {**GOOD, "trackConfig": {"trackId": "no_such_track_anywhere"}}))
    with pytest.raises(RaceFileError, match="trackConfig.trackId"):
        resolve_route(race)
    with pytest.raises(RaceFileError, match="not valid YAML"):
        (tmp_path / "bad.yaml").write_text("a: [")
        read_race_file(tmp_path / "bad.yaml")
