"""`racer bench race` at its smallest: the two Gazebo checkpoints and the bench's broken folder, one lap each, timed
as a race with two workers and as `racer evaluate` one after another; the board must be full."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from racer.benches.race import race_bench_command

pytestmark = pytest.mark.slow


def test_smallest_race_bench_prints_both_rates_and_a_full_board():
    result = CliRunner().invoke(
        race_bench_command, ["--quick", "--entrants", "3", "--workers", "2"], catch_exceptions=False
    )
    assert result.exit_code == 0, result.output
    report = json.loads([line for line in result.stdout.splitlines() if line.startswith("{")][-1])
    assert report["benchmark"] == "race" and report["entrants"] == 3 and report["workers"] == 2
    assert report["track"] == "reinvent_base" and report["laps"] == 1
    assert report["race_s"] > 0 and report["sequential_s"] > 0
    assert report["race_entrants_per_min"] == pytest.approx(3 * 60 / report["race_s"], rel=0.02)
    assert report["ratio"] == pytest.approx(report["sequential_s"] / report["race_s"], rel=0.02)
    board = report["board"]
    assert board["full"] and board["rows"] == 3
    assert board["broken_row"]["dnfReason"] and board["broken_row"]["errorCode"]
    assert board["entrants_with_three_videos"] == 2  # videos on: both Gazebo checkpoints' in-car, top and follow
    assert board["ranked"] == 2  # each laps re:Invent 2018 in about 10 s
    assert report["same_laps_as_racer_evaluate"]  # one seed: the race's laps are racer evaluate's
