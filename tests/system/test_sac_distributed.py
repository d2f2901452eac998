"""SAC end to end, beyond DeepRacer's one worker: a real redis-server and MinIO, the trainer and two rollout workers
in two worlds as processes, then `racer evaluate` drives the trained model's deterministic action."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from racer.evaluation_worker.cli import evaluate_command
from racer.shared.config import RedisSettings, ServiceSettings
from racer.shared.deepracer.simtrace import read_simtrace
from racer.shared.store import open_store
from tests.conftest import write_custom_files
from tests.system.test_distributed_training import CHECKPOINT_NAME, SystemRun, checkpoint_numbers, iteration_records

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # trainers and workers as processes

SAC_METADATA = {
    "action_space": {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 1, "high": 2}},
    "action_space_type": "continuous",
    "training_algorithm": "sac",
    "sensor": ["FRONT_FACING_CAMERA"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "version": "5",
}


@pytest.fixture
def sac_system(redis_server, s3_settings, tmp_path):
    custom = write_custom_files(tmp_path / "custom_files")
    (custom / "model_metadata.json").write_text(json.dumps(SAC_METADATA))
    # As users have SAC hyperparameters (dots_hyperparameters_sac.json), with 2 episodes per iteration.
    (custom / "hyperparameters.json").write_text(
        json.dumps(
            {
                "batch_size": 64,
                "discount_factor": 0.999,
                "exploration_type": "additive_noise",
                "loss_type": "mean squared error",
                "lr": 0.0003,
                "num_episodes_between_training": 2,
                "sac_alpha": 0.2,
            }
        )
    )
    settings = ServiceSettings(redis=RedisSettings(url=redis_server.url, connect_timeout_s=10), store=s3_settings)
    run = SystemRun(settings, "sac-e2e", custom, tmp_path / "logs")
    yield run
    run.stop_all()


def test_sac_with_two_workers_in_two_worlds_trains_and_evaluates(sac_system, tmp_path):
    store = open_store(sac_system.settings.store)
    sac_system.start_trainer(4, "--sac-updates-per-transition", "0.05", "--sac-replay-memory-mb", "64")
    sac_system.start_worker(0)
    sac_system.start_worker(1)
    assert sac_system.wait_trainer(600) == 0, sac_system.log_text("trainer")[-3000:]

    prefix = sac_system.prefix
    assert checkpoint_numbers(store, prefix) == [0, 1, 2]
    pointer = store.get_bytes(f"{prefix}/model/.coach_checkpoint").decode().strip()
    assert CHECKPOINT_NAME.match(pointer) and pointer.startswith("2_Step-")
    manifest = json.loads(store.get_bytes(f"{prefix}/model/{pointer}.json"))
    assert manifest["policy_config"]["training_algorithm"] == "sac"
    assert json.loads(store.get_bytes(f"{prefix}/ip/hyperparameters.json"))["sac_alpha"] == 0.2
    assert store.exists(f"{prefix}/model/model_2.onnx")
    best_last = json.loads(store.get_bytes(f"{prefix}/model/deepracer_checkpoints.json"))
    assert CHECKPOINT_NAME.match(best_last["last_checkpoint"]["name"])
    records = iteration_records(store, prefix)
    assert [r["episodes"] for r in records] == [2, 2]
    assert set(records[-1]["worlds"]) == {"base", "carpet"}
    trainer_log = sac_system.log_text("trainer")
    assert "SAC replay memory: " in trainer_log
    assert len(re.findall(r"Policy training> Policy loss=[-\d.e]+, Q loss=", trainer_log)) == 2
    for worker_id in (0, 1):  # continuous actions in the simtrace: "[<steer> <speed>]" within the ranges
        rows = read_simtrace(store.get_bytes(f"{prefix}/{worker_id}/training-simtrace/1-iteration.csv"))
        assert rows["steer"].between(-30, 30).all() and rows["throttle"].between(1, 2).all()
        assert rows["action"].astype(str).str.startswith("[").all()

    result = CliRunner().invoke(
        evaluate_command,
        ["--model-prefix", prefix, "--trials", "1", "--video-size", "160x120", "--out", str(tmp_path / "eval")],
        env={
            "RACER_STORE": f"s3://{store.settings.bucket}",
            "S3_ENDPOINT_URL": store.settings.endpoint_url,
            "AWS_ACCESS_KEY_ID": store.settings.access_key_id,
            "AWS_SECRET_ACCESS_KEY": store.settings.secret_access_key,
        },
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    simtraces = list(Path(tmp_path / "eval").rglob("0-iteration.csv"))
    assert simtraces, result.output
    driven = read_simtrace(simtraces[0])
    assert len(driven) > 1 and driven["action"].astype(str).str.startswith("[").all()
