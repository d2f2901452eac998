"""Episode, iteration and evaluation tables on the real DeepRacer simtraces, checked against an independent reading
of the CSVs (csv module) and against the metrics JSON files DeepRacer wrote for the same runs."""

from __future__ import annotations

import json
import math
import tarfile

import pytest

from racer.analysis import aggregate
from racer.analysis.loading import load_steps
from racer.analysis.sources import SourceError, classify, open_source

PREPARE_STEP_MAX_S = 2 / 15
"""The prepare step DeepRacer's episode clock includes is at most two 15 Hz camera frames long."""


def tables(source):
    files = open_source(str(source))
    episodes = aggregate.episodes(load_steps(files, progress=False))
    return files, episodes


@pytest.mark.parametrize(
    ("key", "expected"),
    [
        ("training-simtrace/3-iteration.csv", ("training", ".", 0, 3)),
        ("model/2/training-simtrace/14-iteration.csv", ("training", "model", 2, 14)),
        ("sim-trace/training/training-simtrace/27-iteration.csv", ("training", ".", 0, 27)),
        (
            "m/evaluation-20220709200242/evaluation-simtrace/0-iteration.csv",
            ("evaluation", "m/evaluation-20220709200242", 0, 0),
        ),
        (
            "sim-trace/evaluation/2022-abc/evaluation-simtrace/0-iteration.csv",
            ("evaluation", "sim-trace/evaluation/2022-abc", 0, 0),
        ),
        ("training-simtrace/notes.csv", None),
        ("model/model_metadata.json", None),
    ],
)
def test_layout_keys_are_classified(key, expected):
    assert classify(key) == expected


def test_console_export_counts_completions_and_best_lap(console_export, read_csv_episodes):
    files, episodes = tables(console_export)
    training = episodes[episodes["phase"] == "training"]
    assert sorted(training["iteration"].unique()) == [0, 1, 27]
    for iteration in (0, 1, 27):
        expected = read_csv_episodes(console_export / f"sim-trace/training/training-simtrace/{iteration}-iteration.csv")
        mine = training[training["iteration"] == iteration].set_index("episode")
        assert sorted(mine.index) == sorted(expected)
        assert mine["lap_complete"].sum() == sum(e.complete for e in expected.values())
        for number, episode in expected.items():
            assert mine.loc[number, "progress_pct"] == pytest.approx(episode.progress)
            assert mine.loc[number, "time_s"] == pytest.approx(episode.time_s, abs=1e-9)
            assert mine.loc[number, "reward"] == pytest.approx(episode.reward)
            assert mine.loc[number, "steps"] == len(episode.rows)
            assert mine.loc[number, "start_waypoint"] == int(episode.rows[0]["closest_waypoint"])
        complete_times = [e.time_s for e in expected.values() if e.complete]
        summary = aggregate.iterations(episodes).set_index("iteration").loc[iteration]
        assert summary["episodes"] == len(expected)
        assert summary["completion_rate"] == pytest.approx(len(complete_times) / len(expected))
        if complete_times:
            assert summary["best_lap_time_s"] == pytest.approx(min(complete_times), abs=1e-9)
        else:
            assert math.isnan(summary["best_lap_time_s"])
    # Some laps did complete in iteration 27, so the best-lap check above is not vacuous.
    assert training["lap_complete"].sum() > 0


@pytest.mark.parametrize(("fixture", "metrics_name"), [("console_export", "console2022"), ("drfc_single", "drfc1")])
def test_training_episodes_match_deepracer_training_metrics(request, deepracer_data, fixture, metrics_name):
    """TrainingMetrics.json (written by DeepRacer for the same run): int(progress) and int(round(reward)) per episode."""
    _, episodes = tables(request.getfixturevalue(fixture))
    metrics = json.loads((deepracer_data / f"metrics/{metrics_name}_TrainingMetrics.json").read_text())["metrics"]
    by_episode = {m["episode"] - 1: m for m in metrics if m["phase"] == "training"}  # JSON counts from 1
    training = episodes[episodes["phase"] == "training"]
    assert len(training) > 0
    for row in training.itertuples():
        logged = by_episode[row.episode]
        assert logged["completion_percentage"] == int(row.progress_pct)
        assert logged["reward_score"] == int(round(row.reward))
        assert (logged["episode_status"] == "Lap complete") == row.lap_complete
        # DeepRacer's clock also counts the prepare step, which simulation_agg leaves out (real files: 0.04-0.12 s).
        assert 0 < logged["elapsed_time_in_milliseconds"] / 1000 - row.time_s <= PREPARE_STEP_MAX_S


@pytest.mark.parametrize(
    ("fixture", "metrics_file"),
    [
        ("console_export", "console2022_EvaluationMetrics.json"),
        ("drfc_single", "drfc1_EvaluationMetrics-20220709200242.json"),
    ],
)
def test_evaluation_laps_match_deepracer_evaluation_metrics(request, deepracer_data, fixture, metrics_file):
    _, episodes = tables(request.getfixturevalue(fixture))
    laps = aggregate.evaluation_laps(episodes)
    metrics = json.loads((deepracer_data / "metrics" / metrics_file).read_text())["metrics"]
    assert len(laps) == len(metrics)
    for lap, logged in zip(laps.itertuples(), metrics, strict=True):
        assert lap.lap == logged["trial"]
        assert int(lap.progress_pct) == logged["completion_percentage"]
        assert lap.resets == logged["reset_count"]
        assert -1e-9 <= logged["elapsed_time_in_milliseconds"] / 1000 - lap.lap_time_s <= PREPARE_STEP_MAX_S
    summary = aggregate.evaluations(episodes).iloc[0]
    assert summary["best_lap_time_s"] == pytest.approx(laps["lap_time_s"].min())
    assert summary["laps_complete"] == sum(m["completion_percentage"] == 100 for m in metrics)


def test_continuous_evaluation_laps_after_the_first_time_like_deepracer(drfc_single, deepracer_data):
    """In a continuous evaluation laps 2.. have no prepare step, and then the times agree to the millisecond."""
    _, episodes = tables(drfc_single)
    laps = aggregate.evaluation_laps(episodes)
    metrics = json.loads((deepracer_data / "metrics/drfc1_EvaluationMetrics-20220709200242.json").read_text())[
        "metrics"
    ]
    for lap, logged in list(zip(laps.itertuples(), metrics, strict=True))[1:]:
        assert round(lap.lap_time_s * 1000) == logged["elapsed_time_in_milliseconds"]


def test_multi_worker_layout_keeps_workers_apart(drfc_multi, read_csv_episodes):
    files, episodes = tables(drfc_multi)
    assert {(f.worker, f.iteration) for f in files.simtraces} == {(0, 0), (0, 1), (1, 0)}
    workers = aggregate.workers(episodes).set_index("worker")
    worker1 = read_csv_episodes(drfc_multi / "1/training-simtrace/0-iteration.csv")
    worker0 = {
        **read_csv_episodes(drfc_multi / "0/training-simtrace/0-iteration.csv"),
        **read_csv_episodes(drfc_multi / "0/training-simtrace/1-iteration.csv"),
    }
    assert workers.loc[1, "episodes"] == len(worker1)
    assert workers.loc[0, "episodes"] == len(worker0)
    assert workers.loc[0, "laps_complete"] == sum(e.complete for e in worker0.values())
    # Both workers number their episodes from 0: the per-worker iteration table must not merge them.
    per_worker = aggregate.iterations(episodes, per_worker=True)
    assert len(per_worker[per_worker["iteration"] == 0]) == 2
    assert aggregate.iterations(episodes).set_index("iteration").loc[0, "episodes"] == len(worker1) + sum(
        1 for e in read_csv_episodes(drfc_multi / "0/training-simtrace/0-iteration.csv")
    )


def test_tar_gz_export_gives_the_same_tables_as_the_folder(console_export, tmp_path):
    archive = tmp_path / "logs.tar.gz"
    with tarfile.open(archive, "w:gz") as tar:
        tar.add(console_export, arcname="./")
    _, from_folder = tables(console_export)
    files, from_archive = tables(archive)
    assert all("!" in f.name for f in files.simtraces)  # archive members are named as archive!member
    assert from_archive.drop(columns=["run"]).equals(from_folder.drop(columns=["run"]))


def test_model_prefix_in_the_configured_local_store(drfc_single, tmp_path, monkeypatch):
    store_root = tmp_path / "store"
    (store_root / "my-model").parent.mkdir(parents=True)
    drfc_single.rename(store_root / "my-model")
    monkeypatch.setenv("RACER_STORE", str(store_root))
    files, episodes = tables("my-model")
    assert len(files.simtraces) == 3
    assert set(episodes["phase"]) == {"training", "evaluation"}


def test_a_source_without_simtraces_is_a_clear_error(tmp_path):
    (tmp_path / "empty" / "model").mkdir(parents=True)
    with pytest.raises(SourceError, match="no simtrace CSV found"):
        open_source(str(tmp_path / "empty"))


def test_a_single_csv_is_placed_from_its_name(deepracer_data, read_csv_episodes):
    training = deepracer_data / "simtrace/console2022_training_27-iteration.csv"
    files, episodes = tables(training)
    assert [(f.phase, f.iteration) for f in files.simtraces] == [("training", 27)]
    assert len(episodes) == len(read_csv_episodes(training))
    files, episodes = tables(deepracer_data / "simtrace/drfc1_evaluation_0-iteration.csv")
    assert files.simtraces[0].phase == "evaluation"
    assert len(aggregate.evaluation_laps(episodes)) == 3


def test_training_metrics_give_the_in_training_evaluations(console_export, deepracer_data):
    """The console export's metrics/training/<job>.json: iterations and their greedy evaluation episodes.
    Checked by an independent rule: this run has 20 training episodes per iteration, and evaluation entries repeat
    the number of the last training episode before them."""
    from racer.analysis.pipeline import build_tables

    raw = (deepracer_data / "metrics/console2022_TrainingMetrics.json").read_bytes()
    target = console_export / "metrics/training/training-20220611205309.json"
    target.parent.mkdir(parents=True)
    target.write_bytes(raw)
    analysis = build_tables(open_source(str(console_export)), show_progress=False)
    table = analysis.metrics_iterations.set_index("iteration")

    expected: dict[tuple[int, str], list[int]] = {}
    for entry in json.loads(raw)["metrics"]:
        expected.setdefault(((entry["episode"] - 1) // 20, entry["phase"]), []).append(entry["completion_percentage"])
    assert list(table.index) == sorted({iteration for iteration, _ in expected})
    for (iteration, phase), progress in expected.items():
        assert table.loc[iteration, f"{phase}_episodes"] == len(progress)
        assert table.loc[iteration, f"{phase}_progress_mean_pct"] == pytest.approx(sum(progress) / len(progress))
    # Where simtraces exist, both sources count the same training episodes.
    for row in analysis.iterations.itertuples():
        assert table.loc[row.iteration, "training_episodes"] == row.episodes


def test_unreadable_training_metrics_become_a_note(drfc_single):
    from racer.analysis.pipeline import build_tables

    (drfc_single / "metrics").mkdir()
    (drfc_single / "metrics/TrainingMetrics.json").write_text('{"metrics": [{"phase": "training"}]}')
    analysis = build_tables(open_source(str(drfc_single)), show_progress=False)
    assert analysis.metrics_iterations is None
    assert any("TrainingMetrics left out" in note and "TrainingMetrics.json" in note for note in analysis.notes)
    assert len(analysis.iterations) == 2
