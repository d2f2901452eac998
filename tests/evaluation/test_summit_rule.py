"""The summit rule with a scripted car that leaves the track at planned places (racer_oval, 13.5 m, ~7.6 s a lap)."""

from __future__ import annotations

import json

import pytest

from racer.evaluation_worker.config import EvaluationConfigError, SummitRules
from tests.evaluation.conftest import run_scripted, simtrace_of

STEP_S = 1.0 / 15.0


def test_three_put_backs_per_lap_and_the_fourth_exit_ends_the_attempt(tmp_path):
    exits = {0: [20.0, 45.0, 70.0], 1: [15.0, 30.0, 50.0, 80.0]}
    rules = SummitRules(race_duration_s=26.0, reset_penalty_s=0.0, put_back="deepracer")
    report, policy = run_scripted(tmp_path, mode="race", exits=exits, summit=rules)
    laps = report.laps
    assert policy.done >= {(0, p) for p in exits[0]} | {(1, p) for p in exits[1]}

    first, second, third = laps[0], laps[1], laps[2]
    assert (first.status, first.put_backs, first.off_track_count) == ("lap_complete", 3, 3)
    assert first.lap_time_s is not None and first.completed
    # The 4th exit ends the attempt: off_track, not put back, the lap's progress is where it left (planned 80 %).
    assert (second.status, second.put_backs, second.off_track_count) == ("off_track", 3, 4)
    assert 80.0 <= second.progress_pct < 95.0 and second.lap_time_s is None
    assert third.put_backs == 0

    rows = simtrace_of(tmp_path, report)
    exits_lap0 = rows[(rows.episode == 0) & (rows.episode_status == "off_track")]
    assert list(exits_lap0.done) == [False, False, False]
    for planned, progress in zip(exits[0], exits_lap0.progress, strict=True):
        assert planned <= progress < planned + 15.0, (planned, progress)
    exits_lap1 = rows[(rows.episode == 1) & (rows.episode_status == "off_track")]
    assert list(exits_lap1.done) == [False, False, False, True]

    # After a put-back the car continues from where it left (progress keeps its value, docs/evaluation.md).
    for index in exits_lap0.index:
        assert rows.progress[index + 1] == pytest.approx(rows.progress[index], abs=3.0)
    # The attempt after the 4th exit starts again at the line, with a prepare step.
    lap2 = rows[rows.episode == 2]
    assert lap2.episode_status.iloc[0] == "prepare"
    lap0_start = rows.iloc[0]
    assert (lap2.X.iloc[0], lap2.Y.iloc[0]) == pytest.approx((lap0_start.X, lap0_start.Y), abs=1e-6)
    # A completed lap runs straight into the next one: no prepare row, the clock is continuous.
    lap1 = rows[rows.episode == 1]
    assert lap1.episode_status.iloc[0] != "prepare"
    assert second.start_time_s == pytest.approx(first.end_time_s)


def test_the_time_limit_ends_the_race_mid_lap(tmp_path):
    duration_s = 11.0
    report, _ = run_scripted(tmp_path, mode="race", summit=SummitRules(race_duration_s=duration_s))
    rows = simtrace_of(tmp_path, report)
    start_s = report.summit.race_start_s
    assert rows.tstamp.iloc[0] == pytest.approx(start_s + STEP_S)  # the prepare row is stamped after its physics
    assert rows.episode_status.iloc[-1] == "time_up" and bool(rows.done.iloc[-1])
    assert rows.tstamp.iloc[-1] - start_s > duration_s
    assert rows.tstamp.iloc[-2] - start_s <= duration_s + 1e-6
    assert rows.tstamp.iloc[-1] - start_s < duration_s + 2 * STEP_S
    assert (rows.episode_status == "time_up").sum() == 1

    completed = [lap for lap in report.laps if lap.completed]
    last = report.laps[-1]
    assert len(completed) >= 1 and last.status == "time_up"
    assert 0.0 < last.progress_pct < 100.0
    summary = report.summary
    assert summary["laps_completed"] == len(completed)
    assert summary["best_lap_time_s"] == pytest.approx(min(lap.lap_time_s for lap in completed), abs=1e-3)
    assert summary["total_progress_pct"] == pytest.approx(100.0 * len(completed) + last.progress_pct, abs=1e-2)
    assert summary["race"]["ended_by"] == "time_up"
    # The time-up entry does not count as a trial (SimApp), every completed lap does.
    entries = json.loads(report.metrics.to_bytes())["metrics"]
    assert [entry["episode_status"] for entry in entries] == ["Lap complete"] * len(completed) + ["Time Up"]
    assert [entry["trial"] for entry in entries] == list(range(1, len(completed) + 1)) + [len(completed)]


def test_put_back_penalty_holds_the_car_while_the_race_clock_runs(tmp_path):
    exits = {0: [30.0]}
    fast, _ = run_scripted(
        tmp_path / "a", mode="race", exits=exits, summit=SummitRules(race_duration_s=9.0, reset_penalty_s=0.0)
    )
    held, _ = run_scripted(
        tmp_path / "b", mode="race", exits=exits, summit=SummitRules(race_duration_s=9.0, reset_penalty_s=1.0)
    )
    rows = simtrace_of(tmp_path / "b", held)
    assert (simtrace_of(tmp_path / "a", fast).episode_status == "pause").sum() == 1  # a put-back takes one step
    pauses = rows[rows.episode_status == "pause"]
    assert len(pauses) == 15
    assert (pauses.reward == 0.0).all()
    assert list(pauses.pause_duration) == sorted(pauses.pause_duration, reverse=True)
    # The held car has covered less of the track when the same rule's clock runs out.
    assert held.summary["total_progress_pct"] < fast.summary["total_progress_pct"] - 3.0


def test_race_settings_are_checked():
    with pytest.raises(EvaluationConfigError, match="race-resets-per-lap"):
        SummitRules(resets_per_lap=-1)
    with pytest.raises(EvaluationConfigError, match="race-minutes"):
        SummitRules(race_duration_s=0.0)


def test_race_without_continuous_laps_restarts_every_lap_at_the_line(tmp_path):
    report, _ = run_scripted(tmp_path, mode="race", summit=SummitRules(race_duration_s=17.0, continuous=False))
    rows = simtrace_of(tmp_path, report)
    assert report.laps[0].completed and report.laps[1].completed
    firsts = rows.groupby("episode").head(1)
    assert list(firsts.episode_status) == ["prepare"] * len(report.laps)
    assert firsts.X.max() - firsts.X.min() < 1e-6
    lap_ends = rows[rows.episode_status == "lap_complete"]
    assert lap_ends.done.all()


def _lap_times(report) -> list[float]:
    return [lap.lap_time_s for lap in report.laps if lap.completed]


def test_an_off_track_shortcut_never_shortens_a_lap(tmp_path):
    """A put-back must not beat driving the lap: the car cuts across the infield (a chord to the centre line 1.5-5 m
    further on), is put back where it left the road (the seed's rule) after the marshal's 2 s, and is slower than
    driving clean. (The env-level test in tests/sim/test_env_rules.py shows the spot gives back what a cut gained.)"""
    rules = SummitRules(race_duration_s=25.0)
    assert (rules.reset_penalty_s, rules.put_back) == (2.0, "where_it_left")
    clean, _ = run_scripted(tmp_path / "clean", mode="race", summit=rules)
    clean_best = min(_lap_times(clean))
    cut_laps = []
    for shortcut_m, start_pct in ((1.5, 10.0), (3.0, 35.0), (5.0, 60.0)):
        exits = {0: [start_pct], 1: [start_pct]}
        cut, _ = run_scripted(
            tmp_path / f"cut-{shortcut_m}", mode="race", summit=rules, exits=exits, shortcut_m=shortcut_m
        )
        cut_laps += [lap.lap_time_s for lap in cut.laps if lap.completed and lap.put_backs > 0]
    assert len(cut_laps) >= 3
    assert min(cut_laps) > clean_best + 1.5


def test_the_put_back_spot_is_where_the_car_left_half_a_step_back(tmp_path):
    report, _ = run_scripted(tmp_path, mode="race", exits={0: [40.0]}, summit=SummitRules(race_duration_s=9.0))
    rows = simtrace_of(tmp_path, report)
    exit_index = rows.index[rows.episode_status == "off_track"][0]
    before = rows.loc[:exit_index]
    last_on_road = before[before.all_wheels_on_track].iloc[-1]
    pause = rows.loc[exit_index + 1]
    assert pause.episode_status == "pause"
    # Put back behind the last point with four wheels on the road, never ahead of it (0.14 m front-of-car offset
    # plus half a step at most 0.15 m), pointing along the track.
    assert last_on_road.progress - 3.0 < pause.progress <= last_on_road.progress
    assert pause.all_wheels_on_track and pause.pause_duration == pytest.approx(2.0 - STEP_S)
