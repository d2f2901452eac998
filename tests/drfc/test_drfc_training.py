"""`racer train --drfc` on a two-worker multi-config experiment, for real (Redis, trainer, workers): each worker's
track reaches its training_params yaml; then `racer evaluate --drfc` evaluates the model as DR_EVAL_* says."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest
import yaml

from racer.shared.model_layout import ModelLayout
from tests.drfc.conftest import write_experiment
from tests.system.test_local_run import processes_mentioning

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # trainers and workers as processes

SYSTEM = "DR_WORKERS=2\nDR_SIMAPP_VERSION=5.3.3-cpu\nDR_DOCKER_STYLE=swarm\n"
RUN = (
    "DR_WORLD_NAME=reinvent_base\n"
    "DR_RACE_TYPE=TIME_TRIAL\n"
    "DR_CAR_NAME=FastCar\n"
    "DR_DISPLAY_NAME=$DR_CAR_NAME\n"
    "DR_TRAIN_MULTI_CONFIG=True\n"
    "DR_TRAIN_CHANGE_START_POSITION=True\n"
    "DR_TRAIN_REVERSE_DIRECTION=False\n"
    "DR_TRAIN_ALTERNATE_DRIVING_DIRECTION=False\n"
    "DR_TRAIN_START_POSITION_OFFSET=0.0\n"
    "DR_TRAIN_ROUND_ROBIN_ADVANCE_DIST=0.05\n"
    "DR_ENABLE_DOMAIN_RANDOMIZATION=False\n"
    "DR_TRAIN_MIN_EVAL_TRIALS=1\n"
    "DR_TRAIN_BEST_MODEL_METRIC=reward\n"
    "DR_LOCAL_S3_MODEL_PREFIX=drfc-model\n"
    "DR_EVAL_NUMBER_OF_TRIALS=1\n"
    "DR_EVAL_MAX_RESETS=0\n"
    "DR_EVAL_CHECKPOINT=last\n"
    "DR_EVAL_SAVE_MP4=False\n"
)
WORKER_2 = "DR_WORLD_NAME=Oval_track\nDR_TRAIN_REVERSE_DIRECTION=True\n"


def racer(tmp_path, *args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, RACER_STORE=str(tmp_path / "store"), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    env.pop("RACER_GENERATION", None)  # DR_SIMAPP_VERSION picks it
    return subprocess.run(
        [sys.executable, "-m", "racer.cli", *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        timeout=900,
    )


def test_a_drfc_experiment_trains_each_worker_on_its_track_and_evaluates(tmp_path):
    folder = write_experiment(tmp_path / "experiment", RUN, system=SYSTEM, workers={2: WORKER_2})
    # racer's own key beside DRfC's files: a short cap on worker 0's evaluation episodes (tests/conftest.py says why)
    (folder / "custom_files" / "workers.json").write_text(json.dumps({"RACER_EVAL_MAX_STEPS": 300}))

    trained = racer(tmp_path, "train", "--drfc", str(folder), "--max-episodes", "4", "--worlds", "base,wood",
                    "--viewer-port", "0")  # fmt: skip
    output = trained.stdout + trained.stderr
    assert trained.returncode == 0, output[-4000:]
    assert "worker 1 (DRfC's worker 2: worker-2.env): track Oval_track, reversed, TIME_TRIAL" in output
    assert "generation simapp5" in output  # DR_SIMAPP_VERSION 5.3.3
    assert output.count("DR_DOCKER_STYLE") == 1, output[-4000:]

    model = tmp_path / "store" / "drfc-model"
    layout = ModelLayout("drfc-model")
    first = yaml.safe_load((tmp_path / "store" / layout.training_params(0)).read_text())
    second = yaml.safe_load((tmp_path / "store" / layout.training_params(1)).read_text())
    assert (first["WORLD_NAME"], first["REVERSE_DIR"], first["RACER_WORLD"]) == ("reinvent_base", "False", "base")
    assert (second["WORLD_NAME"], second["REVERSE_DIR"], second["RACER_WORLD"]) == ("Oval_track", "True", "wood")
    for params in (first, second):
        assert params["MIN_EVAL_TRIALS"] == "1" and params["BEST_MODEL_METRIC"] == "reward"
        assert params["RACER_EVAL_MAX_STEPS"] == "300" and params["RACER_GENERATION"] == "simapp5"
    assert (model / "model" / ".finished").is_file()

    evaluated = racer(tmp_path, "evaluate", "--drfc", str(folder), "--no-mcap")
    output = evaluated.stdout + evaluated.stderr
    assert evaluated.returncode == 0, output[-4000:]
    (summary_path,) = model.glob("evaluation-*/summary.json")
    summary = json.loads(summary_path.read_text())
    assert summary["track"] == "reinvent_base" and summary["model_prefix"] == "drfc-model"
    assert summary["checkpoint_requested"] == "last"
    assert summary["generation"] == "simapp5"
    assert summary["rules"]["number_of_trials"] == 1 and summary["rules"]["number_of_resets"] == 0
    assert summary["rules"]["is_continuous"] is True  # DR_EVAL_IS_CONTINUOUS unset: prepare-config.py's True
    assert not list(model.glob("**/*.mp4"))  # DR_EVAL_SAVE_MP4=False
    time.sleep(1)
    assert processes_mentioning(str(tmp_path)) == []
