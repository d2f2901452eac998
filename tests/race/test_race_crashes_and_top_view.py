"""A head-to-model race where the rear car runs into the front one: the board's crash counts are the cars'
evaluation results, and the race's one top view of all cars is written, linked and readable.

The cars are untrained networks with one action each (both of a model's two actions the same), so whatever the
network outputs the car drives it: `creeper` straight at 0.3 m/s from the line (outer lane), `rammer` 0.3 m behind
it on the inner lane, full right lock at 1 m/s, into the creeper's lane and the creeper.
"""

from __future__ import annotations

import dataclasses
import json

import cv2
import pytest
import torch
import yaml
from click.testing import CliRunner

from racer.race.cli import race_command
from racer.race.videos import ALL_CARS_TOP_VIEW
from racer.shared.deepracer.model_description import DiscreteAction
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.networks import build_actor_critic
from racer.shared.sim.config import DEFAULT_MODEL_METADATA
from racer.shared.store import LocalStore

pytestmark = pytest.mark.slow

RAM = {
    "name": "ram",
    "trackConfig": {"trackId": "racer_oval"},
    "raceType": "HEAD_TO_MODEL",
    "timingMethod": "BEST_LAP_TIME",
    "submissionTerminationConditions": {"minimumLaps": 1, "maximumLaps": 1, "maxTimeInMinutes": 0.25},
    "START_POS_OFFSET": 0.3,
}


def one_action_model(store: LocalStore, prefix: str, steering_deg: float, speed_mps: float) -> None:
    metadata = dataclasses.replace(
        DEFAULT_MODEL_METADATA, discrete_actions=(DiscreteAction(steering_deg, speed_mps),) * 2
    )
    checkpoints = CheckpointStore(store, prefix)
    checkpoints.put_model_metadata(metadata)
    torch.manual_seed(0)
    checkpoints.save(0, 0, build_actor_critic(metadata), model_metadata=metadata)


def _ram_race(tmp_path, video: bool):
    store = LocalStore(tmp_path / "store")
    one_action_model(store, "creeper", 0.0, 0.3)
    one_action_model(store, "rammer", -30.0, 1.0)
    race_file = tmp_path / "ram.yaml"
    race_file.write_text(yaml.safe_dump(RAM))
    out = tmp_path / "out"
    result = CliRunner().invoke(
        race_command,
        [str(race_file), "creeper", "rammer", "--out", str(out), "--video" if video else "--no-video"],
        env={"RACER_STORE": str(tmp_path / "store"), "MUJOCO_GL": "egl"},
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    return store, out, json.loads((out / "leaderboard.json").read_text())


def test_the_boards_crash_counts_are_the_cars_evaluation_results(tmp_path):
    store, out, board = _ram_race(tmp_path, video=False)
    rows = {row["entrant"]: row for row in board["leaderboard"]}
    assert rows["rammer"]["collisionCount"] > 0  # the car behind is at fault
    assert rows["creeper"]["collisionCount"] == 0
    csv_rows = {line.split(",")[1]: line.split(",") for line in (out / "leaderboard.csv").read_text().splitlines()}
    column = csv_rows["entrant"].index("collisionCount")
    for name, row in rows.items():
        # the evaluation's own files under the car's model prefix, as racer evaluate writes them
        (metrics_key,) = [key for key in store.list_keys(f"{name}/metrics/") if key.endswith(".json")]
        laps = json.loads(store.get_bytes(metrics_key))["metrics"]
        crashes = sum(int(lap["crash_count"]) for lap in laps)
        car = out / "multi-car" / "evaluation" / f"car-{row['multiCar']['gridPlace'] - 1}"
        (simtrace,) = car.glob("evaluation-*/evaluation-simtrace/*.csv")
        crashed_rows = sum(1 for line in simtrace.read_text().splitlines() if ",crashed," in line)
        assert row["collisionCount"] == row["multiCar"]["crashCount"] == crashes == crashed_rows, name
        assert int(csv_rows[name][column]) == crashes


def test_a_multi_car_race_writes_one_top_view_of_all_cars_and_links_it(tmp_path):
    _, out, board = _ram_race(tmp_path, video=True)
    assert board["raceVideos"] == {"allCarsTopView": ALL_CARS_TOP_VIEW}
    video = cv2.VideoCapture(str(out / "videos" / ALL_CARS_TOP_VIEW))
    try:
        frames = int(video.get(cv2.CAP_PROP_FRAME_COUNT))
        ok, frame = video.read()
    finally:
        video.release()
    assert frames > 0 and ok and frame.shape[:2] == (360, 480)
    page = (out / "leaderboard.html").read_text()
    assert f'href="videos/{ALL_CARS_TOP_VIEW}"' in page and "<video" in page
    assert "continuousLap true (every multi-car race drives its laps on)" in page  # the file leaves it false
    for name in ("creeper", "rammer"):  # each car's own videos are still there
        assert (out / "videos" / f"{name}-camera-topview.mp4").is_file()
