"""TrainingMetrics / EvaluationMetrics JSON: real files read, re-serialise byte-for-byte, agree with the simtraces."""

from __future__ import annotations

import json

import pytest

from racer.shared.deepracer.episode_status import EpisodeStatus
from racer.shared.deepracer.metrics import (
    EVALUATION_METRICS_KEYS,
    TRAINING_METRICS_KEYS,
    EvaluationMetrics,
    EvaluationMetricsEntry,
    MetricsError,
    TrainingMetrics,
    TrainingMetricsEntry,
    read_evaluation_metrics,
    read_training_metrics,
    sim_time_to_ms,
)
from racer.shared.deepracer.simtrace import read_simtrace


def training_files(data_dir):
    files = sorted((data_dir / "metrics").glob("*TrainingMetrics*.json"))
    assert len(files) >= 3, files
    return files


def evaluation_files(data_dir):
    files = sorted((data_dir / "metrics").glob("*EvaluationMetrics*.json"))
    assert len(files) >= 2, files
    return files


def test_real_training_metrics_round_trip_byte_for_byte(deepracer_data):
    for path in training_files(deepracer_data):
        raw = json.loads(path.read_bytes())
        metrics = read_training_metrics(path)
        assert len(metrics) == len(raw["metrics"])
        assert metrics.version == raw["version"] == 2.0
        assert metrics.best_model_metric == raw["best_model_metric"]
        assert metrics.to_bytes() == path.read_bytes(), path.name


def test_real_evaluation_metrics_round_trip_byte_for_byte(deepracer_data):
    for path in evaluation_files(deepracer_data):
        raw = json.loads(path.read_bytes())
        metrics = read_evaluation_metrics(path)
        assert len(metrics) == len(raw["metrics"])
        assert set(json.loads(metrics.to_bytes())) == set(raw) == {"metrics"}
        assert metrics.to_bytes() == path.read_bytes(), path.name


def test_written_entries_have_the_real_key_order_and_types(deepracer_data):
    training = TrainingMetricsEntry.from_episode(
        total_reward=25.6, start_time_s=20.149, end_time_s=22.471, episode=1, trial=1, phase="training",
        progress_pct=14.9, status=EpisodeStatus.OFF_TRACK,
    )  # fmt: skip
    evaluation = EvaluationMetricsEntry.from_lap(
        progress_pct=100, start_time_s=6.149, end_time_s=22.617, status=EpisodeStatus.LAP_COMPLETE, trial=1
    )
    pairs = [
        (training.to_dict(), training_files(deepracer_data), TRAINING_METRICS_KEYS),
        (evaluation.to_dict(), evaluation_files(deepracer_data), EVALUATION_METRICS_KEYS),
    ]
    for written, files, keys in pairs:
        assert tuple(written) == keys
        for path in files:
            for real in json.loads(path.read_bytes())["metrics"]:
                assert list(real) == list(written), path.name
                assert {k: type(v) for k, v in real.items()} == {k: type(v) for k, v in written.items()}


def test_conversions_follow_the_simapp():
    entry = TrainingMetricsEntry.from_episode(
        total_reward=25.5001, start_time_s=20.1494, end_time_s=22.4716, episode=3, trial=2, phase="evaluation",
        progress_pct=99.99, status=EpisodeStatus.OFF_TRACK,
    )  # fmt: skip
    assert entry.reward_score == 26  # round
    assert entry.completion_percentage == 99  # truncation
    assert (entry.start_time_ms, entry.metric_time_ms) == (20149, 22472)
    assert entry.elapsed_time_ms == 2322  # rounded difference of the clocks, not 22472 - 20149
    assert entry.to_dict()["episode_status"] == "Off track"
    assert sim_time_to_ms(4438.1724) == 4438172
    with pytest.raises(ValueError, match="allowed: training, evaluation"):
        TrainingMetricsEntry.from_episode(
            total_reward=0, start_time_s=0, end_time_s=1, episode=1, trial=1, phase="test", progress_pct=0,
            status=EpisodeStatus.OFF_TRACK,
        )  # fmt: skip
    lap = EvaluationMetricsEntry.from_lap(
        progress_pct=100, start_time_s=37.288, end_time_s=68.172, status="lap_complete", trial=1, off_track_count=1,
        crash_count=2,
    )  # fmt: skip
    assert (lap.reset_count, lap.elapsed_time_ms, lap.episode_status) == (3, 30884, EpisodeStatus.LAP_COMPLETE)


def test_training_metrics_agree_with_the_simtrace_of_the_same_run(deepracer_data):
    """Console 2022: every training episode of iterations 0 and 1 matches its simtrace rows."""
    metrics = read_training_metrics(deepracer_data / "metrics" / "console2022_TrainingMetrics.json")
    by_episode = {entry.episode: entry for entry in metrics.entries if entry.phase == "training"}
    checked = 0
    for name in ("console2022_training_0-iteration.csv", "console2022_training_1-iteration.csv"):
        frame = read_simtrace(deepracer_data / "simtrace" / name)
        for episode, rows in frame.groupby("episode"):
            last = rows.iloc[-1]
            expected = TrainingMetricsEntry.from_episode(
                total_reward=float(rows["reward"].sum()),
                start_time_s=float(rows["tstamp"].iloc[0]),
                end_time_s=float(last["tstamp"]),
                episode=episode + 1,
                trial=episode % 20 + 1,
                phase="training",
                progress_pct=float(last["progress"]),
                status=EpisodeStatus(last["episode_status"]),
            )
            real = by_episode[episode + 1]
            assert real.reward_score == expected.reward_score
            assert real.completion_percentage == expected.completion_percentage
            assert real.episode_status == expected.episode_status
            # the metric is stamped at or just after the last simtrace row (the sim clock may have advanced)
            assert 0 <= real.metric_time_ms - expected.metric_time_ms <= 100
            assert real.trial == expected.trial
            # the episode is reset ~1 step before its first (prepare) row is written
            assert 0 < expected.start_time_ms - real.start_time_ms <= 100
            checked += 1
    assert checked == 40


def test_accumulating_and_serialising():
    metrics = TrainingMetrics(best_model_metric="laptime")
    metrics.append(
        TrainingMetricsEntry.from_episode(
            total_reward=10.4,
            start_time_s=1.0,
            end_time_s=2.5,
            episode=1,
            trial=1,
            phase="training",
            progress_pct=12.7,
            status=EpisodeStatus.OFF_TRACK,
        )  # fmt: skip
    )
    data = json.loads(metrics.to_bytes())
    assert list(data) == ["metrics", "version", "best_model_metric"]
    assert data["version"] == 2.0 and data["best_model_metric"] == "laptime"
    assert data["metrics"][0]["completion_percentage"] == 12
    assert read_training_metrics(metrics.to_bytes()).entries == metrics.entries
    evaluation = EvaluationMetrics()
    evaluation.append(
        EvaluationMetricsEntry.from_lap(progress_pct=45.2, start_time_s=0, end_time_s=9.9, status="off_track", trial=1)
    )
    assert read_evaluation_metrics(evaluation.to_bytes()).entries == evaluation.entries
    assert len(evaluation) == 1
    with pytest.raises(ValueError, match="best_model_metric 'speed'"):
        TrainingMetrics(best_model_metric="speed")


GOOD_TRAINING = {
    "reward_score": 26, "metric_time": 22471, "start_time": 20149, "elapsed_time_in_milliseconds": 2322,
    "episode": 1, "trial": 1, "phase": "training", "completion_percentage": 14, "episode_status": "Off track",
}  # fmt: skip
GOOD_EVALUATION = {
    "completion_percentage": 100, "metric_time": 22617, "start_time": 6149, "elapsed_time_in_milliseconds": 16468,
    "episode_status": "Lap complete", "crash_count": 0, "immobilized_count": 0, "off_track_count": 0,
    "reversed_count": 0, "reset_count": 0, "trial": 1,
}  # fmt: skip


def body(entries, **top):
    return json.dumps({"metrics": entries, **top}).encode()


BAD_TRAINING = [
    (body([GOOD_TRAINING, {**GOOD_TRAINING, "phase": "testing"}]), "metrics[1].phase: 'testing'"),
    (body([{**GOOD_TRAINING, "episode_status": "Finished"}]), "metrics[0].episode_status: 'Finished'"),
    (body([{**GOOD_TRAINING, "reward_score": 25.6}]), "metrics[0].reward_score: 25.6 is not an integer"),
    (body([{**GOOD_TRAINING, "trial": True}]), "metrics[0].trial: True is not an integer"),
    (body([{k: v for k, v in GOOD_TRAINING.items() if k != "episode"}]), "metrics[0]: missing key 'episode'"),
    (body(["x"]), "metrics[0]: expected a JSON object"),
    (body({"a": 1}), "metrics: expected a list"),
    (json.dumps({"version": 2.0}).encode(), "metrics: missing"),
    (body([], best_model_metric="speed"), "best_model_metric: 'speed'"),
    (body([], version="2.0"), "version: '2.0' is not a number"),
    (b"[1]", "expected a JSON object at the top level"),
    (b'{"metrics": [}', "invalid JSON at line 1, column 14"),
]


@pytest.mark.parametrize(("data", "words"), BAD_TRAINING)
def test_bad_training_metrics_name_file_and_field(data, words):
    with pytest.raises(MetricsError) as caught:
        read_training_metrics(data, source="metrics/TrainingMetrics.json")
    message = str(caught.value)
    assert message.startswith("metrics/TrainingMetrics.json: "), message
    assert words in message, message


BAD_EVALUATION = [
    (body([{**GOOD_EVALUATION, "off_track_count": -1}]), "metrics[0].off_track_count: -1 is negative"),
    (body([{**GOOD_EVALUATION, "trial": "1"}]), "metrics[0].trial: '1' is not an integer"),
    (body([GOOD_EVALUATION, {**GOOD_EVALUATION, "episode_status": "lap_complete"}]), "metrics[1].episode_status"),
]


@pytest.mark.parametrize(("data", "words"), BAD_EVALUATION)
def test_bad_evaluation_metrics_name_file_and_field(data, words):
    with pytest.raises(MetricsError) as caught:
        read_evaluation_metrics(data, source="eval.json")
    assert str(caught.value).startswith("eval.json: "), str(caught.value)
    assert words in str(caught.value)


def test_reading_from_a_path_names_the_path(tmp_path):
    path = tmp_path / "TrainingMetrics.json"
    path.write_text('{"metrics": [1]}')
    with pytest.raises(MetricsError, match=f"^{path}: metrics\\[0\\]"):
        read_training_metrics(path)


def test_file_without_version_round_trips(tmp_path):
    data = json.dumps({"metrics": [GOOD_TRAINING]}).encode()
    metrics = read_training_metrics(data)
    assert metrics.version is None and metrics.best_model_metric is None
    assert metrics.to_bytes() == data
