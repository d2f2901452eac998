"""DeepRacer-for-Cloud's tools keep working on racer's runs: a short real training and an evaluation written to a real
MinIO open, unchanged, in deepracer-utils 1.5.6 (the community's analysis library, as DRfC's notebooks use it):
its S3FileHandler sees a DRfC single-worker model folder, DeepRacerLog loads both simtraces and TrainingMetrics the
training metrics, and what they hold is what racer wrote."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from deepracer.logs import AnalysisUtils, DeepRacerLog, LogFolderType, S3FileHandler, TrainingMetrics

from racer.evaluation_worker.cli import evaluate_command
from racer.shared import model_layout
from racer.shared.config import RedisSettings, ServiceSettings
from racer.shared.deepracer.metrics import read_evaluation_metrics, read_training_metrics
from racer.shared.deepracer.simtrace import read_simtrace
from racer.shared.model_layout import ModelLayout, evaluation_metrics_timestamp
from racer.shared.store import open_store
from tests.conftest import write_custom_files
from tests.system.test_distributed_training import SystemRun, iteration_records

PREFIX = "rl-deepracer-racer"
EPISODES_PER_ITERATION = 2
ITERATIONS = 2
TRIALS = 2
SIMTRACE_COLUMNS = {"x", "y", "steps", "progress", "speed", "steering_angle", "reward", "on_track", "episode_status"}
"""deepracer-utils' names for the simtrace columns its analysis uses (it renames X, Y, throttle, steer, ...)."""


def test_evaluation_metrics_keys_of_both_forms_are_recognised():
    assert evaluation_metrics_timestamp("metrics/evaluation/evaluation-20260102030405.json") == "20260102030405"
    assert evaluation_metrics_timestamp("metrics/EvaluationMetrics-20220709200242.json") == "20220709200242"
    assert evaluation_metrics_timestamp("metrics/TrainingMetrics.json") is None
    assert evaluation_metrics_timestamp("metrics/training/training-20260102030405.json") is None
    assert (
        ModelLayout(PREFIX)
        .evaluation("evaluation-20260102030405")
        .key(model_layout.evaluation_metrics("20260102030405"))
        == f"{PREFIX}/metrics/evaluation/evaluation-20260102030405.json"
    )


@pytest.fixture
def trained_and_evaluated(redis_server, s3_settings, tmp_path):
    """Two iterations of one worker (DeepRacer's single-worker layout), then `racer evaluate` of the last checkpoint."""
    settings = ServiceSettings(redis=RedisSettings(url=redis_server.url, connect_timeout_s=10), store=s3_settings)
    custom_files = write_custom_files(tmp_path / "custom_files")
    run = SystemRun(settings, PREFIX, custom_files, tmp_path / "logs", workers=1)
    try:
        run.start_trainer(EPISODES_PER_ITERATION * ITERATIONS)
        run.start_worker(0)
        assert run.wait_trainer(600) == 0, run.log_text("trainer")[-3000:]
    finally:
        run.stop_all()
    credentials = {
        "S3_ENDPOINT_URL": s3_settings.endpoint_url,
        "AWS_ACCESS_KEY_ID": s3_settings.access_key_id,
        "AWS_SECRET_ACCESS_KEY": s3_settings.secret_access_key,
    }
    evaluation = CliRunner().invoke(
        evaluate_command,
        ["--model-prefix", PREFIX, "--checkpoint", "last", "--trials", str(TRIALS), "--resets", "0"]
        + ["--track", "racer_oval", "--no-video", "--no-mcap"],
        env={"RACER_STORE": f"s3://{s3_settings.bucket}", **credentials},
        catch_exceptions=False,
    )
    assert evaluation.exit_code == 0, evaluation.output
    return open_store(s3_settings), s3_settings


@pytest.fixture
def deepracer_utils_credentials(s3_settings, monkeypatch):
    """deepracer-utils makes its own boto3 clients: the credentials come from the environment, as on a DRfC host."""
    monkeypatch.setenv("AWS_ACCESS_KEY_ID", s3_settings.access_key_id)
    monkeypatch.setenv("AWS_SECRET_ACCESS_KEY", s3_settings.secret_access_key)
    monkeypatch.setenv("AWS_DEFAULT_REGION", s3_settings.region)


@pytest.mark.slow
@pytest.mark.heavy  # a trainer and a rollout worker as processes
def test_deepracer_utils_opens_a_racer_run_in_minio(trained_and_evaluated, deepracer_utils_credentials):
    store, s3 = trained_and_evaluated
    keys = {key.removeprefix(PREFIX + "/") for key in store.list_keys(PREFIX + "/")}
    training_csvs = sorted(k for k in keys if k.startswith("training-simtrace/"))
    assert training_csvs == [f"training-simtrace/{i}-iteration.csv" for i in range(ITERATIONS)]
    evaluation_metrics = [k for k in keys if evaluation_metrics_timestamp(k) is not None]
    assert len(evaluation_metrics) == 1 and evaluation_metrics[0].startswith("metrics/evaluation/evaluation-")
    timestamp = evaluation_metrics_timestamp(evaluation_metrics[0])
    evaluation_csv = f"evaluation-{timestamp}/evaluation-simtrace/0-iteration.csv"
    assert evaluation_csv in keys and not any(k.startswith("metrics/EvaluationMetrics-") for k in keys)
    for key in ("reward_function.py", "training_params.yaml", "ip/hyperparameters.json", "model/model_metadata.json"):
        assert key in keys, key

    # The model folder as DeepRacerLog sees it, through deepracer-utils' own S3 handler.
    handler = S3FileHandler(bucket=s3.bucket, prefix=PREFIX, s3_endpoint_url=s3.endpoint_url)
    training = DeepRacerLog(filehandler=handler)
    assert handler.type == LogFolderType.DRFC_MODEL_SINGLE_WORKERS
    training.load_training_trace()
    df = training.dataframe()
    ours = {i: read_simtrace(store.get_bytes(f"{PREFIX}/{key}"), source=key) for i, key in enumerate(training_csvs)}
    assert len(df) == sum(len(rows) for rows in ours.values())
    assert SIMTRACE_COLUMNS | {"iteration", "worker", "unique_episode"} <= set(df.columns)
    assert sorted(df.iteration.unique()) == list(range(ITERATIONS)) and set(df.worker) == {0}
    for iteration, rows in ours.items():
        assert sorted(df[df.iteration == iteration].episode.unique()) == sorted(rows.episode.unique())
    assert df.unique_episode.nunique() == EPISODES_PER_ITERATION * ITERATIONS
    every_progress = np.concatenate([rows.progress.to_numpy() for rows in ours.values()])
    np.testing.assert_array_equal(np.sort(df.progress.to_numpy()), np.sort(every_progress))
    assert df.progress.max() <= 100
    metadata = json.loads(store.get_bytes(f"{PREFIX}/model/model_metadata.json"))
    assert training.action_space() == metadata["action_space"]
    assert training.agent_and_network()["network"] == metadata["neural_network"]
    assert training.hyperparameters()["num_episodes_between_training"] == EPISODES_PER_ITERATION

    # Its episodes are racer's TrainingMetrics.json's, in order: completion_percentage is int() of the last step's
    # progress (deepracer-simapp s3_metrics.py), the aggregation's `progress` the episode's highest.
    per_episode = AnalysisUtils.simulation_agg(df, secondgroup="unique_episode")
    assert len(per_episode) == EPISODES_PER_ITERATION * ITERATIONS
    racer_metrics = read_training_metrics(store.get_bytes(f"{PREFIX}/metrics/TrainingMetrics.json"), source="tm")
    racer_training = [e for e in racer_metrics.entries if e.phase == "training"]
    final_progress = df.groupby("unique_episode").progress.last()  # deepracer-utils sorts by episode and step
    assert [int(p) for p in final_progress] == [e.completion_percentage for e in racer_training]
    assert (per_episode.progress.to_numpy() >= final_progress.to_numpy()).all()  # its `progress` is the episode's max

    # TrainingMetrics reads `<model>/metrics/TrainingMetrics.json` (its default pattern) from the bucket.
    metrics = TrainingMetrics(s3.bucket, model_name=PREFIX, s3_endpoint_url=s3.endpoint_url)
    assert len(metrics.getTraining()) == len(racer_training) == EPISODES_PER_ITERATION * ITERATIONS
    assert len(metrics.getEvaluation()) == len(racer_metrics.entries) - len(racer_training) > 0
    records = iteration_records(store, PREFIX)
    assert sorted(metrics.getTraining().iteration.unique()) == [r["iteration"] for r in records]
    # Entry by entry, as racer wrote them; completion may be below 0 (a car that backs away from the start line: the
    # SimApp's progress is negative there too, rollout_agent_ctrl.py), never above 100.
    assert metrics.metrics.completion.tolist() == [e.completion_percentage for e in racer_metrics.entries]
    assert metrics.metrics.time.tolist() == [e.elapsed_time_ms / 1000 for e in racer_metrics.entries]
    assert metrics.metrics.completion.max() <= 100

    # The evaluation: DeepRacerLog finds `evaluation-<14 digits>/` and names the stream by its timestamp.
    evaluation = DeepRacerLog(
        filehandler=S3FileHandler(bucket=s3.bucket, prefix=PREFIX, s3_endpoint_url=s3.endpoint_url)
    )
    evaluation.load_evaluation_trace()
    edf = evaluation.dataframe()
    our_evaluation = read_simtrace(store.get_bytes(f"{PREFIX}/{evaluation_csv}"), source=evaluation_csv)
    assert len(edf) == len(our_evaluation) and set(edf.stream) == {timestamp}
    assert SIMTRACE_COLUMNS <= set(edf.columns)
    np.testing.assert_array_equal(np.sort(edf.progress.to_numpy()), np.sort(our_evaluation.progress.to_numpy()))
    per_trial = AnalysisUtils.simulation_agg(edf, firstgroup="stream", is_eval=True)
    laps = read_evaluation_metrics(store.get_bytes(f"{PREFIX}/{evaluation_metrics[0]}"), source="evaluation metrics")
    assert len(per_trial) == len(laps.entries) == TRIALS
    final_progress = edf.groupby("episode").progress.last()
    assert [int(p) for p in final_progress] == [e.completion_percentage for e in laps.entries]
