"""DRfC's own templates (2eb1a1f1 defaults/template-*.env, in the shared data) map without error, every DR_* variable
in them is in racer's table, and what racer cannot honour is reported once, by name."""

from __future__ import annotations

import re
import shutil

import pytest

from racer.drfc.evaluation import read_evaluation
from racer.drfc.training import read_training
from racer.drfc.variables import VARIABLES, Use
from tests.drfc.conftest import TEMPLATE_KINDS, write_experiment

pytestmark = pytest.mark.usefixtures("deepracer_data")


@pytest.fixture
def template_experiment(tmp_path, drfc_templates):
    """The templates as a fresh DRfC checkout has them (system.env with init.sh's placeholders), custom files."""
    folder = write_experiment(tmp_path / "drfc", drfc_templates["run"].read_text())
    shutil.copyfile(drfc_templates["system"], folder / "system.env")
    return folder


def test_every_dr_variable_of_the_templates_is_in_the_table(drfc_templates):
    named = set()
    for kind in TEMPLATE_KINDS:
        named |= set(re.findall(r"\bDR_[A-Z0-9_]+", drfc_templates[kind].read_text()))  # commented-out ones too
    assert len(named) > 90
    assert named - {v.name for v in VARIABLES} == set()


def test_the_table_names_each_variable_once_with_a_use_for_each_command():
    names = [v.name for v in VARIABLES]
    assert len(names) == len(set(names))
    for entry in VARIABLES:
        assert entry.racer.strip() and isinstance(entry.train, Use) and isinstance(entry.evaluate, Use)
        assert entry.inert == () or Use.NOT_HONOURED in (entry.train, entry.evaluate), entry.name


def test_the_templates_train_and_evaluate(template_experiment):
    training = read_training(template_experiment)
    assert training.model_prefix == "rl-deepracer-sagemaker" and training.num_workers == 1
    (worker,) = training.worker_params
    assert worker["WORLD_NAME"] == "reinvent_base" and worker["RACE_TYPE"] == "TIME_TRIAL"
    assert worker["MIN_EVAL_TRIALS"] == "5" and worker["BEST_MODEL_METRIC"] == "progress"
    assert training.pretrained_prefix is None and training.viewer_port == 8100
    evaluation = read_evaluation(template_experiment)
    assert (evaluation.trials, evaluation.continuous, evaluation.resets) == (3, True, 100)
    assert (evaluation.checkpoint, evaluation.video, evaluation.track) == ("last", False, "reinvent_base")
    assert (evaluation.off_track_penalty_s, evaluation.collision_penalty_s) == (5.0, 5.0)


def test_the_worker_template_sets_the_second_worker(template_experiment, drfc_templates):
    with (template_experiment / "run.env").open("a") as run_env:
        run_env.write("\nDR_TRAIN_MULTI_CONFIG=True\n")
    system = (template_experiment / "system.env").read_text().replace("DR_WORKERS=1", "DR_WORKERS=2")
    (template_experiment / "system.env").write_text(system)
    shutil.copyfile(drfc_templates["worker"], template_experiment / "worker-2.env")
    training = read_training(template_experiment)
    assert [w["WORLD_NAME"] for w in training.worker_params] == ["reinvent_base", "reInvent2019_track"]
    assert training.experiment.multi_config


def test_what_racer_cannot_honour_is_reported_once_by_name(template_experiment):
    with (template_experiment / "run.env").open("a") as run_env:
        run_env.write("\nDR_TRAIN_MULTI_CONFIG=True\nDR_WORKERS=2\nDR_FAVOURITE_COLOUR=blue\n")
    (template_experiment / "worker-2.env").write_text(
        "DR_WORLD_NAME=Oval_track\nDR_CAMERA_SUB_ENABLE=True\nDR_CAMERA_MAIN_ENABLE=True\nDR_GUI_ENABLE=True\n"
    )
    system = (template_experiment / "system.env").read_text()
    system = system.replace("DR_DOCKER_STYLE=<DOCKER_STYLE>", "DR_DOCKER_STYLE=swarm")
    (template_experiment / "system.env").write_text(system + "DR_SAGEMAKER_CUDA_DEVICES=0\nDR_TRAIN_RTF=1.0\n")
    notes = read_training(template_experiment).notes
    text = "\n".join(notes)
    for name in (
        "DR_DOCKER_STYLE",
        "DR_CAMERA_SUB_ENABLE",  # False in system.env, True in worker-2.env
        "DR_CAMERA_MAIN_ENABLE",
        "DR_CAMERA_KVS_ENABLE",
        "DR_SAGEMAKER_CUDA_DEVICES",
        "DR_TRAIN_RTF",
        "DR_FAVOURITE_COLOUR",
        "DR_GUI_ENABLE",  # not a per-worker variable: no effect from worker-2.env, said as such
    ):
        assert len(re.findall(rf"\b{name}\b", text)) == 1, (name, notes)
    assert "DR_GUI_ENABLE" in next(n for n in notes if n.startswith("no effect, as in DRfC"))
    gpu = next(n for n in notes if "DR_SAGEMAKER_CUDA_DEVICES" in n)
    assert gpu.startswith("not honoured: DR_SAGEMAKER_CUDA_DEVICES=0:") and "--device" in gpu
    assert "DR_CAMERA_SUB_ENABLE=True" in text  # the value that asks for it, not system.env's False
    for quiet in (
        "DR_CAR_COLOR",
        "DR_CAR_NAME",
        "DR_HOST_X",
        "DR_EVAL_SAVE_MP4",
        "DR_UPLOAD_S3_PREFIX",
        "DR_WORLD_NAME",
    ):
        assert quiet not in text, quiet  # no effect, inert, not read by training, or honoured
    evaluate_text = "\n".join(read_evaluation(template_experiment).notes)
    assert "DR_SAGEMAKER_CUDA_DEVICES" not in evaluate_text  # DRfC's evaluation runs no SageMaker
    assert "DR_TRAIN_RTF" not in evaluate_text and "DR_DOCKER_STYLE" in evaluate_text
