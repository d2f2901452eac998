"""DeepRacer's evaluation rules (deepracer-simapp v5.3.3 `bundle/markov/evaluation_worker.py`) with a scripted car, and
the metrics file against real ones."""

from __future__ import annotations

import json
import re

import pytest

from racer.evaluation_worker.config import DeepRacerRules, EvaluationConfigError
from racer.shared.deepracer.metrics import read_evaluation_metrics
from racer.shared.deepracer.simtrace import read_simtrace
from racer.shared.store import LocalStore
from tests.evaluation.conftest import run_scripted, simtrace_of


def test_each_trial_starts_at_the_line_and_ends_on_the_first_exit_without_resets(tmp_path):
    report, _ = run_scripted(
        tmp_path, exits={1: [40.0]}, deepracer=DeepRacerRules(number_of_trials=3, number_of_resets=0)
    )
    entries = json.loads((tmp_path / report.keys["metrics"]).read_bytes())["metrics"]
    assert [entry["episode_status"] for entry in entries] == ["Lap complete", "Off track", "Lap complete"]
    assert [entry["trial"] for entry in entries] == [1, 2, 3]
    assert [entry["completion_percentage"] for entry in entries][0::2] == [100, 100]
    assert 40 <= entries[1]["completion_percentage"] < 55
    assert [entry["off_track_count"] for entry in entries] == [0, 1, 0]
    assert all(entry["reset_count"] == entry["off_track_count"] for entry in entries)
    for entry in entries:  # elapsed is rounded from the clock difference, not from the two rounded times
        assert abs(entry["elapsed_time_in_milliseconds"] - (entry["metric_time"] - entry["start_time"])) <= 1
    assert entries[1]["start_time"] >= entries[0]["metric_time"]

    rows = simtrace_of(tmp_path, report)
    assert sorted(rows.episode.unique()) == [0, 1, 2]
    firsts = rows.groupby("episode").head(1)
    assert list(firsts.episode_status) == ["prepare"] * 3
    assert firsts.X.max() - firsts.X.min() < 1e-6 and firsts.Y.max() - firsts.Y.min() < 1e-6
    lasts = rows.groupby("episode").tail(1)
    assert list(lasts.episode_status) == ["lap_complete", "off_track", "lap_complete"]
    assert lasts.done.all() and rows.done.sum() == 3
    # Evaluation uses DeepRacer's evaluation reward (deepracer-simapp v5.3.3 `bundle/markov/defaults.py`): markers 1 /
    # 0.5 / 0.1 / 0.001, 0 on the prepare step.
    assert set(rows.reward.round(6)) <= {0.0, 1.0, 0.5, 0.1, 0.001}


def test_resets_pause_for_the_penalty_and_the_pause_is_part_of_the_lap_time(tmp_path):
    exits = {0: [30.0, 60.0]}
    rules = dict(number_of_trials=1, number_of_resets=2)
    free, _ = run_scripted(tmp_path / "free", exits=exits, deepracer=DeepRacerRules(**rules, off_track_penalty_s=0.0))
    held, _ = run_scripted(tmp_path / "held", exits=exits, deepracer=DeepRacerRules(**rules, off_track_penalty_s=2.0))
    for report in (free, held):
        assert [(lap.status, lap.off_track_count, lap.put_backs) for lap in report.laps] == [("lap_complete", 2, 2)]
    difference_s = held.laps[0].lap_time_s - free.laps[0].lap_time_s
    assert difference_s == pytest.approx(2 * 2.0, abs=0.25)

    rows = simtrace_of(tmp_path / "held", held)
    exits_rows = rows[rows.episode_status == "off_track"]
    assert list(exits_rows.pause_duration) == [2.0, 2.0] and not exits_rows.done.any()
    pauses = rows[rows.episode_status == "pause"]
    assert len(pauses) == 2 * 30
    assert (pauses.reward == 0.0).all()
    first_pause = pauses.pause_duration.iloc[:30].to_numpy()
    assert first_pause[0] == pytest.approx(2.0 - 1 / 15) and first_pause[-1] == pytest.approx(0.0, abs=1e-9)
    # The car waits where it was put back.
    assert pauses.X.iloc[:30].max() - pauses.X.iloc[:30].min() < 1e-3


def test_continuous_run_shares_the_reset_budget_and_reports_intermediate_laps_in_progress(tmp_path):
    rules = DeepRacerRules(number_of_trials=3, is_continuous=True, number_of_resets=2, off_track_penalty_s=0.5)
    report, _ = run_scripted(tmp_path, exits={0: [30.0, 60.0], 1: [40.0]}, deepracer=rules)
    entries = json.loads(report.metrics.to_bytes())["metrics"]
    # Lap 1 uses both resets; the first exit of lap 2 is one too many: the run ends there.
    assert [entry["episode_status"] for entry in entries] == ["In progress", "Off track"]
    assert [entry["off_track_count"] for entry in entries] == [2, 1]
    assert entries[0]["completion_percentage"] == 100
    assert entries[1]["start_time"] == entries[0]["metric_time"]

    rows = simtrace_of(tmp_path, report)
    assert (rows.episode_status == "prepare").sum() == 1
    crossing = rows[(rows.episode == 0)].iloc[-1]
    assert (crossing.episode_status, bool(crossing.done), crossing.progress) == ("in_progress", False, 100.0)
    assert rows.steps.is_monotonic_increasing  # one episode: steps keep counting across the line
    assert rows[rows.episode == 1].progress.iloc[0] < 5.0


def test_continuous_run_ends_with_lap_complete_after_the_last_trial(tmp_path):
    report, _ = run_scripted(tmp_path, deepracer=DeepRacerRules(number_of_trials=2, is_continuous=True))
    assert [lap.label for lap in report.laps] == ["In progress", "Lap complete"]
    assert report.laps[1].start_time_s == pytest.approx(report.laps[0].end_time_s)
    rows = simtrace_of(tmp_path, report)
    assert rows.episode_status.iloc[-1] == "lap_complete" and bool(rows.done.iloc[-1])


def test_metrics_file_has_deepracers_keys_order_and_types(tmp_path, deepracer_data):
    report, _ = run_scripted(
        tmp_path, exits={0: [50.0]}, deepracer=DeepRacerRules(number_of_trials=2, number_of_resets=2)
    )
    ours_raw = (tmp_path / report.keys["metrics"]).read_bytes()
    assert report.keys["metrics"].startswith("scripted-model/metrics/evaluation/evaluation-")
    ours = json.loads(ours_raw)
    real_files = sorted(deepracer_data.glob("metrics/*EvaluationMetrics*.json"))
    assert real_files
    for real_path in real_files:
        real = json.loads(real_path.read_bytes())
        assert list(ours) == list(real) == ["metrics"]
        real_entry = real["metrics"][0]
        for entry in ours["metrics"]:
            assert list(entry) == list(real_entry), real_path.name
            assert {key: type(value) for key, value in entry.items()} == {
                key: type(value) for key, value in real_entry.items()
            }
    # Same byte conventions as the SimApp's json.dumps (no indentation, no trailing newline); reads back.
    assert ours_raw == json.dumps(ours).encode()
    assert len(read_evaluation_metrics(ours_raw, source="ours")) == 2


def test_default_reset_budget_is_the_consoles_so_an_exit_costs_the_penalty_and_the_lap_goes_on(
    tmp_path, deepracer_data
):
    log = (deepracer_data / "logs" / "console2022_evaluation_robomaker.log").read_text()
    console_resets = int(re.search(r"\* /NUMBER_OF_RESETS: (\d+)", log).group(1))
    assert DeepRacerRules().number_of_resets == console_resets == 10000
    report, _ = run_scripted(tmp_path, exits={0: [30.0]}, deepracer=DeepRacerRules(number_of_trials=1))
    [lap] = report.laps
    assert (lap.status, lap.off_track_count, lap.put_backs) == ("lap_complete", 1, 1)
    rows = simtrace_of(tmp_path, report)
    assert (rows.episode_status == "pause").sum() == 30  # 2 s of OFF_TRACK_PENALTY at 15 steps/s


def test_reset_count_must_be_zero_or_at_least_two():
    with pytest.raises(EvaluationConfigError, match="NUMBER_OF_RESETS"):
        DeepRacerRules(number_of_resets=1)
    with pytest.raises(EvaluationConfigError, match="NUMBER_OF_TRIALS"):
        DeepRacerRules(number_of_trials=0)


def test_reversed_direction_in_another_world(tmp_path):
    forward, _ = run_scripted(tmp_path / "f", deepracer=DeepRacerRules(number_of_trials=1))
    backward, _ = run_scripted(
        tmp_path / "b", deepracer=DeepRacerRules(number_of_trials=1), reverse_dir=True, world="concrete"
    )
    assert forward.laps[0].completed and backward.laps[0].completed
    assert backward.summary["reverse_dir"] is True and backward.summary["world"] == "concrete"
    yaw_forward = simtrace_of(tmp_path / "f", forward).yaw.iloc[0]
    yaw_backward = simtrace_of(tmp_path / "b", backward).yaw.iloc[0]
    assert abs((yaw_forward - yaw_backward + 180.0) % 360.0 - 180.0) > 150.0


class RecordingStore(LocalStore):
    def __init__(self, root):
        super().__init__(root)
        self.puts: list[tuple[str, bytes]] = []

    def put_bytes(self, key, data):
        self.puts.append((key, data))
        super().put_bytes(key, data)


def test_metrics_file_is_rewritten_after_every_lap(tmp_path):
    store = RecordingStore(tmp_path)
    report, _ = run_scripted(
        tmp_path, exits={0: [10.0]}, deepracer=DeepRacerRules(number_of_trials=3, number_of_resets=0), store=store
    )
    metrics_puts = [json.loads(data)["metrics"] for key, data in store.puts if key == report.keys["metrics"]]
    assert [len(entries) for entries in metrics_puts] == [1, 2, 3, 3]
    assert metrics_puts[0][0]["episode_status"] == "Off track"


def _real_start_gaps_and_end_gaps(deepracer_data):
    """(prepare row tstamp - metrics start_time, metrics metric_time - last row tstamp) of the real evaluations, s."""
    pairs = [
        ("console2022_evaluation_0-iteration.csv", "console2022_EvaluationMetrics.json"),
        ("drfc1_evaluation_0-iteration.csv", "drfc1_EvaluationMetrics-20220709200242.json"),
    ]
    starts, ends = [], []
    for simtrace_name, metrics_name in pairs:
        path = deepracer_data / "simtrace" / simtrace_name
        rows = read_simtrace(path.read_bytes(), source=str(path))
        entries = json.loads((deepracer_data / "metrics" / metrics_name).read_bytes())["metrics"]
        for lap, entry in zip(rows.groupby("episode", sort=True), entries, strict=True):
            lap_rows = lap[1]
            if lap_rows.episode_status.iloc[0] == "prepare":
                starts.append(lap_rows.tstamp.iloc[0] - entry["start_time"] / 1000)
            ends.append(entry["metric_time"] / 1000 - lap_rows.tstamp.iloc[-1])
    return starts, ends


def test_time_stamps_are_taken_after_the_steps_physics_as_in_real_evaluations(tmp_path, deepracer_data):
    real_starts, real_ends = _real_start_gaps_and_end_gaps(deepracer_data)
    # Real files: the prepare row comes one step (~55-70 ms) after the episode start; the last row is the lap's end.
    assert len(real_starts) >= 3 and all(0.04 <= gap <= 0.09 for gap in real_starts)
    assert all(abs(gap) <= 0.01 for gap in real_ends)

    report, _ = run_scripted(tmp_path, deepracer=DeepRacerRules(number_of_trials=2))
    rows = simtrace_of(tmp_path, report)
    entries = json.loads((tmp_path / report.keys["metrics"]).read_bytes())["metrics"]
    for (_, lap_rows), entry, lap in zip(rows.groupby("episode", sort=True), entries, report.laps, strict=True):
        assert lap_rows.tstamp.iloc[0] - entry["start_time"] / 1000 == pytest.approx(1 / 15, abs=0.0011)
        assert entry["metric_time"] == round(lap_rows.tstamp.iloc[-1] * 1000)
        # The lap time counts every step the lap took, the prepare step included: one row = 1/15 s.
        assert lap.lap_time_s == pytest.approx(len(lap_rows) / 15, abs=1e-6)


def test_evaluation_finds_a_deepracer_track_by_name(tmp_path, deepracer_data, monkeypatch):
    monkeypatch.setenv("RACER_ROUTES_PATH", str(deepracer_data / "routes"))
    report, _ = run_scripted(tmp_path, track="reinvent_base", deepracer=DeepRacerRules(number_of_trials=1))
    assert report.laps[0].completed
    assert report.summary["track_length_m"] == pytest.approx(17.709159, abs=1e-6)
