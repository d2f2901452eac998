"""HEAD_TO_MODEL and F1 races: every entrant in one multi-car evaluation, the board by finishing order (F1) or the
timing method (head-to-model), crashes between cars in the rows, and a broken entrant's row."""

from __future__ import annotations

import json

import pytest
import yaml
from click.testing import CliRunner

from racer.race.cli import race_command
from racer.race.leaderboard import standings_from_results
from racer.race.race_file import RaceFileError, parse_race
from racer.shared.store import LocalStore
from tests.race.test_real_race import save_model

F1 = {
    "name": "tiny-f1",
    "trackConfig": {"trackId": "racer_oval"},
    "raceType": "F1",
    "timingMethod": "TOTAL_TIME",
    "resettingBehaviorConfig": {"offTrackPenaltySeconds": 1},
    "submissionTerminationConditions": {"minimumLaps": 1, "maximumLaps": 1, "maxTimeInMinutes": 0.5},
    "maxResets": 0,
}


def test_race_file_takes_head_to_model_and_f1_with_the_simapps_keys():
    definition = parse_race({**F1, "DONE_CONDITION": "ANY", "START_POS_OFFSET": 0.5}, "f1.yaml", "f1")
    rules = definition.multi_car_rules()
    assert (rules.race_type, rules.laps, rules.done_condition, rules.start_pos_offset_m) == ("F1", 1, "any", 0.5)
    assert rules.max_race_s == 30.0
    assert parse_race(definition.to_dict(), "f1.yaml", "f1") == definition
    assert parse_race({**F1, "raceType": "HEAD_TO_MODEL"}, "h.yaml", "h").multi_car_rules().waits_for_all is False
    with pytest.raises(RaceFileError, match="NUMBER_OF_BOT_CARS: given for raceType F1"):
        parse_race({**F1, "NUMBER_OF_BOT_CARS": 2}, "f1.yaml", "f1")
    with pytest.raises(RaceFileError, match="DONE_CONDITION"):
        parse_race({**F1, "raceType": "TIME_TRIAL", "DONE_CONDITION": "all"}, "t.yaml", "t")
    with pytest.raises(RaceFileError, match="START_POS_OFFSET"):
        parse_race({**F1, "START_POS_OFFSET": 2}, "f1.yaml", "f1")


def _car(name, place, finished, finish_ms, completed, raced, crashes=0):
    lap = {
        "completion_percentage": 100 if finished else 50,
        "elapsed_time_in_milliseconds": 9000,
        "crash_count": crashes,
    }
    return {
        "entrant": name,
        "metrics": [lap],
        "multi_car": {
            "finishingPlace": place,
            "finished": finished,
            "finishTimeMs": finish_ms,
            "completedLaps": completed,
            "laps": 1,
            "racedPct": raced,
        },
    }


def test_f1_board_is_the_finishing_order_with_dnf_rows_and_broken_entrants_last():
    definition = parse_race(F1, "f1.yaml", "f1")
    results = [
        _car("slow", 2, True, 20000, 1, 100.0),
        {"entrant": "broken", "reason": "racer model import failed", "code": "FILE_DOES_NOT_EXIST"},
        _car("stuck", 3, False, None, 0, 40.0, crashes=2),
        _car("fast", 1, True, 15000, 1, 100.0),
    ]
    standings = standings_from_results(definition, results)
    assert [(s.entrant, s.rank) for s in standings] == [("fast", 1), ("slow", 2), ("stuck", None), ("broken", None)]
    assert standings[0].score_ms == 15000
    assert "did not finish: 0 of 1 laps" in standings[2].dnf_reason
    assert standings[2].stats.collisionCount == 2
    assert standings[3].error_code == "FILE_DOES_NOT_EXIST"


def _race(tmp_path, race, entrants, run="one"):
    race_file = tmp_path / f"{race['name']}.yaml"
    race_file.write_text(yaml.safe_dump(race))
    out = tmp_path / run
    result = CliRunner().invoke(
        race_command,
        [str(race_file), *entrants, "--seed", "3", "--no-video", "--out", str(out)],
        env={"RACER_STORE": str(tmp_path / "store"), "MUJOCO_GL": "egl"},
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    return (out / "leaderboard.csv").read_text(), json.loads((out / "leaderboard.json").read_text()), result.output


@pytest.mark.slow
def test_f1_race_of_three_untrained_cars_a_nan_one_and_a_broken_folder(tmp_path):
    # Untrained networks leave the track often; with the console's reset budget two of them finish the one lap in
    # the minute, the third does not. The NaN car is taken out and the race runs again without it.
    store = LocalStore(tmp_path / "store")
    for seed, name in enumerate(("alpha", "beta", "gamma")):
        save_model(store, name, seed)
    save_model(store, "nanny", 5, nan=True)
    broken = tmp_path / "broken-folder"
    broken.mkdir()
    (broken / "notes.txt").write_text("not a model")
    race = {**F1, "maxResets": 10000}
    race["submissionTerminationConditions"] = {"minimumLaps": 1, "maximumLaps": 1, "maxTimeInMinutes": 1}
    entrants = ["alpha", "beta", "nanny", "gamma", str(broken)]
    csv_one, board, output = _race(tmp_path, race, entrants)
    csv_two, _, _ = _race(tmp_path, race, entrants, run="two")
    assert csv_one == csv_two  # one seed, one board
    rows = {row["entrant"]: row for row in board["leaderboard"]}
    order = [row["entrant"] for row in board["leaderboard"]]
    raced = [row for row in board["leaderboard"] if "multiCar" in row]
    assert [row["multiCar"]["finishingPlace"] for row in raced] == [1, 2, 3]  # the board is the finishing order
    finishers = [row for row in raced if row["rank"] is not None]
    assert [row["rank"] for row in finishers] == list(range(1, len(finishers) + 1)) and finishers
    assert [row["rankingScore"] for row in finishers] == sorted(row["rankingScore"] for row in finishers)
    for row in raced:
        assert row["collisionCount"] is not None
        assert row["rank"] is not None or row["dnfReason"].startswith("did not finish")
    assert "NaN" in rows["nanny"]["dnfReason"] and "multiCar" not in rows["nanny"]
    assert rows["broken-folder"]["errorCode"] and rows["broken-folder"]["dnfReason"]
    assert set(order[-2:]) == {"nanny", "broken-folder"}
    assert "FINISH_TIME" in output


@pytest.mark.slow
def test_head_to_model_race_of_two_is_ranked_by_the_timing_method(tmp_path):
    store = LocalStore(tmp_path / "store")
    save_model(store, "alpha", 0)
    save_model(store, "beta", 1)
    race = {**F1, "name": "tiny-h2m", "raceType": "HEAD_TO_MODEL", "timingMethod": "BEST_LAP_TIME"}
    _, board, _ = _race(tmp_path, race, ["alpha", "beta"])
    rows = board["leaderboard"]
    assert {row["entrant"] for row in rows} == {"alpha", "beta"}
    for row in rows:
        assert row["multiCar"]["raceType"] == "HEAD_TO_MODEL"
        assert "collisionCount" in row
        assert row["rank"] is not None or "minimumLaps" in row["dnfReason"]
