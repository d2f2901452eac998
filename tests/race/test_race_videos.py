"""A time trial with videos on: every raced entrant's three videos land in videos/ and the page links them (the
worker once died on a helper defined below its `__main__` block, which only runs with videos)."""

from __future__ import annotations

import json

import pytest
import yaml
from click.testing import CliRunner

from racer.race.cli import race_command
from racer.shared.store import LocalStore
from tests.race.test_real_race import RACE, save_model


@pytest.mark.slow
def test_time_trial_with_videos_moves_each_entrants_three_videos_beside_the_board(tmp_path):
    store = LocalStore(tmp_path / "store")
    save_model(store, "alpha", 0)
    race_file = tmp_path / "tiny.yaml"
    race_file.write_text(yaml.safe_dump(RACE))
    out = tmp_path / "out"
    result = CliRunner().invoke(
        race_command,
        [str(race_file), "alpha", "--workers", "1", "--video", "--out", str(out)],
        env={"RACER_STORE": str(tmp_path / "store"), "MUJOCO_GL": "egl"},
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    (row,) = json.loads((out / "leaderboard.json").read_text())["leaderboard"]
    assert row["dnfReason"] is None or "evaluation died" not in row["dnfReason"], row["dnfReason"]
    assert sorted(row["videos"]) == ["camera-45degree", "camera-incar", "camera-topview"]
    page = (out / "leaderboard.html").read_text()
    for name in row["videos"].values():
        assert (out / "videos" / name).stat().st_size > 0 and f'href="videos/{name}"' in page
    assert "raceVideos" not in json.loads((out / "leaderboard.json").read_text())  # a time trial has no field view
