"""Evaluation with obstacles: a crash costs COLLISION_PENALTY (deepracer mode) or the put-back penalty (summit rule) and
counts as a reset; the job's params name the race type and its objects."""

from __future__ import annotations

import pytest

from racer.evaluation_worker.config import DeepRacerRules, SummitRules
from racer.shared.sim.objects.challenge import ChallengeConfig, ObjectPosition

from .conftest import run_scripted, simtrace_of

BOX_ON_THE_INNER_LANE = ChallengeConfig(race_type="OBJECT_AVOIDANCE", object_positions=(ObjectPosition(0.3, 1),))
"""The scripted car follows the centre line: 0.098 m either side of it, into the box (0.067 m left of the centre)."""


def test_deepracer_mode_crash_pauses_for_the_collision_penalty_and_counts(tmp_path):
    rules = DeepRacerRules(number_of_trials=1, number_of_resets=2, collision_penalty_s=1.0)
    report, _ = run_scripted(tmp_path, speed_mps=1.5, deepracer=rules, challenge=BOX_ON_THE_INNER_LANE)
    (lap,) = report.laps
    assert lap.crash_count >= 1
    rows = simtrace_of(tmp_path, report)
    first_crash = rows.index[rows.episode_status == "crashed"][0]
    assert 25.0 < rows.progress[first_crash] < 32.0  # the box stands at 30 % of the lap
    assert rows.pause_duration[first_crash] == pytest.approx(1.0)
    pauses = rows.episode_status[first_crash + 1 : first_crash + 20].tolist()
    assert pauses[:15] == ["pause"] * 15  # 1 s at 15 steps per second
    params = (tmp_path / report.keys["params"]).read_text()
    assert '"RACE_TYPE": "OBJECT_AVOIDANCE"' in params and '- "0.3,1"' in params


def test_summit_rule_counts_a_crash_as_a_put_back(tmp_path):
    rules = SummitRules(race_duration_s=20.0, reset_penalty_s=0.5, put_back="deepracer")
    report, _ = run_scripted(tmp_path, mode="race", speed_mps=1.5, summit=rules, challenge=BOX_ON_THE_INNER_LANE)
    first = report.laps[0]
    assert first.crash_count >= 1 and first.put_backs >= 1
    rows = simtrace_of(tmp_path, report)
    crash = rows.index[rows.episode_status == "crashed"][0]
    assert rows.pause_duration[crash] == pytest.approx(0.5)
