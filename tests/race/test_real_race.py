"""A short real race: two tiny untrained racer models, one whose network gives NaN, one that is not there.

Nothing is trained: the models are freshly initialised networks saved the way tests/evaluation/test_cli.py does.
With maxResets 0 the first exit ends the one lap, so every evaluation is a few simulated seconds.
"""

from __future__ import annotations

import json

import pytest
import torch
import yaml
from click.testing import CliRunner

from racer.race.cli import race_command
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.networks import build_actor_critic
from racer.shared.sim.config import DEFAULT_MODEL_METADATA
from racer.shared.store import LocalStore

RACE = {
    "name": "tiny-cup",
    "trackConfig": {"trackId": "racer_oval"},
    "raceType": "TIME_TRIAL",
    "timingMethod": "BEST_LAP_TIME",
    "resettingBehaviorConfig": {"continuousLap": False, "offTrackPenaltySeconds": 1},
    "submissionTerminationConditions": {"minimumLaps": 1, "maximumLaps": 1, "maxTimeInMinutes": 0.5},
    "maxResets": 0,
}


def save_model(store: LocalStore, prefix: str, seed: int, nan: bool = False) -> None:
    checkpoints = CheckpointStore(store, prefix)
    checkpoints.put_model_metadata(DEFAULT_MODEL_METADATA)
    torch.manual_seed(seed)
    network = build_actor_critic(DEFAULT_MODEL_METADATA)
    if nan:
        with torch.no_grad():
            for parameter in network.parameters():
                parameter.fill_(float("nan"))
    checkpoints.save(0, 0, network, model_metadata=DEFAULT_MODEL_METADATA)


@pytest.mark.slow
def test_two_entrants_race_a_broken_one_gets_its_row_and_one_seed_gives_one_board(tmp_path):
    store_root = tmp_path / "store"
    store = LocalStore(store_root)
    save_model(store, "alpha", 0)
    save_model(store, "beta", 1)
    save_model(store, "nanny", 2, nan=True)
    race_file = tmp_path / "tiny.yaml"
    race_file.write_text(yaml.safe_dump(RACE))
    boards = []
    for run in ("one", "two"):
        out = tmp_path / run
        result = CliRunner().invoke(
            race_command,
            [str(race_file), "alpha", "beta", "nanny", "ghost", "--workers", "2", "--seed", "7", "--no-video"]
            + ["--out", str(out)],
            env={"RACER_STORE": str(store_root), "MUJOCO_GL": "egl"},
            catch_exceptions=False,
        )
        assert result.exit_code == 0, result.output
        boards.append(((out / "leaderboard.csv").read_text(), json.loads((out / "leaderboard.json").read_text())))
        assert (out / "leaderboard.html").is_file()
    assert boards[0][0] == boards[1][0]
    entries = {entry["entrant"]: entry for entry in boards[0][1]["leaderboard"]}
    second = {entry["entrant"]: entry for entry in boards[1][1]["leaderboard"]}
    assert set(entries) == {"alpha", "beta", "nanny", "ghost"}
    for name in ("alpha", "beta"):  # untrained: they raced their lap and left the track
        assert len(entries[name]["laps"]) == 1 and entries[name]["lapCount"] == 1, entries[name]
        assert entries[name]["laps"] == second[name]["laps"]  # the lap times and counts, not only the board
    assert "NaN" in entries["nanny"]["dnfReason"]
    assert entries["ghost"]["errorCode"] == "FILE_DOES_NOT_EXIST"
    assert boards[0][1]["race"]["submissionTerminationConditions"]["maximumLaps"] == 1
