"""`--drfc`: the experiment's settings become the command's options; options given beside it win, for every worker.

The decorators are tried on probe commands with the same options as `racer train` / `racer evaluate` (the last
tests hold the real commands to those names), which record what they are called with instead of training."""

from __future__ import annotations

import json
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from racer.drfc.evaluation import read_evaluation
from racer.drfc.options import drfc_evaluate_option, drfc_train_option
from racer.evaluation_worker.cli import evaluate_command
from racer.local.cli import train_command
from racer.options.challenge import challenge_options
from racer.options.generation import generation_option
from racer.options.track import direction_option
from tests.drfc.conftest import write_experiment

TRAIN_OPTIONS = {
    "model_prefix", "custom_files", "num_workers", "track", "direction", "pretrained_prefix", "pretrained_checkpoint",
    "viewer_port", "race_type", "race_param", "generation",
}  # fmt: skip
EVALUATE_OPTIONS = {
    "model_prefix", "checkpoint", "track", "direction", "reverse", "trials", "continuous", "resets",
    "off_track_penalty", "collision_penalty", "video", "opponents", "race_type", "race_param", "generation",
}  # fmt: skip

RUN = (
    "DR_WORLD_NAME=reinvent_base\n"
    "DR_TRAIN_MULTI_CONFIG=True\n"
    "DR_WORKERS=2\n"
    "DR_RACE_TYPE=OBJECT_AVOIDANCE\n"
    "DR_OA_NUMBER_OF_OBSTACLES=4\n"
    "DR_LOCAL_S3_MODEL_PREFIX=drfc-model\n"
    "DR_LOCAL_S3_PRETRAINED=True\n"
    "DR_LOCAL_S3_PRETRAINED_PREFIX=older-model\n"
    "DR_LOCAL_S3_PRETRAINED_CHECKPOINT=best\n"
    "DR_WEBVIEWER_PORT=8200\n"
    "DR_TRAIN_CHANGE_START_POSITION=True\n"
    "DR_TRAIN_ALTERNATE_DRIVING_DIRECTION=False\n"
    "DR_TRAIN_ROUND_ROBIN_ADVANCE_DIST=0.05\n"
    "DR_ENABLE_DOMAIN_RANDOMIZATION=False\n"
    "DR_EVAL_NUMBER_OF_TRIALS=2\n"
    "DR_EVAL_IS_CONTINUOUS=False\n"
    "DR_EVAL_MAX_RESETS=0\n"
    "DR_EVAL_OFF_TRACK_PENALTY=3.0\n"
    "DR_EVAL_COLLISION_PENALTY=2.0\n"
    "DR_EVAL_CHECKPOINT=best\n"
    "DR_EVAL_REVERSE_DIRECTION=True\n"
    "DR_EVAL_SAVE_MP4=True\n"
)


@pytest.fixture
def experiment(tmp_path) -> Path:
    folder = write_experiment(tmp_path / "exp", RUN, workers={2: "DR_WORLD_NAME=Oval_track\nDR_RACE_TYPE=TIME_TRIAL\n"})
    (folder / "custom_files" / "workers.json").write_text(json.dumps({"RACER_EVAL_MAX_STEPS": 300}))
    return folder


def train_probe() -> tuple[click.Command, dict]:
    seen: dict = {}

    @click.command()
    @drfc_train_option
    @click.option("--model-prefix", default=None)
    @click.option("--custom-files", type=click.Path(path_type=Path), default=Path("racer-defaults"))
    @click.option("--workers", "num_workers", type=click.IntRange(1, 32), default=4)  # as racer train's
    @click.option("--track", default="racer_oval")
    @click.option("--pretrained-prefix", default=None)
    @click.option("--pretrained-checkpoint", default="last")
    @click.option("--viewer-port", type=int, default=8100)
    @generation_option
    @challenge_options
    @direction_option
    def probe(**kwargs):
        seen.update(kwargs)
        seen["workers"] = json.loads((kwargs["custom_files"] / "workers.json").read_text())["workers"]
        seen["files"] = sorted(p.name for p in kwargs["custom_files"].iterdir())

    return probe, seen


def evaluate_probe() -> tuple[click.Command, dict]:
    seen: dict = {}

    @click.command()
    @drfc_evaluate_option
    @click.option("--model-prefix", default=None)
    @click.option("--checkpoint", default="best")
    @click.option("--track", default="racer_oval")
    @click.option("--reverse/--no-reverse", default=False)
    @click.option("--trials", type=int, default=3)
    @click.option("--continuous/--no-continuous", default=None)
    @click.option("--resets", type=int, default=10000)
    @click.option("--off-track-penalty", type=float, default=2.0)
    @click.option("--collision-penalty", type=float, default=5.0)
    @click.option("--video/--no-video", default=True)
    @click.option("--opponent", "opponents", multiple=True)
    @generation_option
    @challenge_options
    @direction_option
    def probe(**kwargs):
        seen.update(kwargs)

    return probe, seen


def test_train_takes_the_experiment_and_writes_per_worker_settings(experiment):
    probe, seen = train_probe()
    result = CliRunner().invoke(probe, ["--drfc", str(experiment)])
    assert result.exit_code == 0, result.output
    assert (seen["model_prefix"], seen["num_workers"], seen["viewer_port"]) == ("drfc-model", 2, 8200)
    assert (seen["pretrained_prefix"], seen["pretrained_checkpoint"]) == ("older-model", "best")
    assert seen["track"] == "reinvent_base" and seen["race_type"] is None and seen["race_param"] == ()
    assert seen["files"] == ["hyperparameters.json", "model_metadata.json", "reward_function.py", "workers.json"]
    first, second = seen["workers"]
    assert (first["WORLD_NAME"], first["RACE_TYPE"], first["NUMBER_OF_OBSTACLES"]) == (
        "reinvent_base",
        "OBJECT_AVOIDANCE",
        "4",
    )
    assert (second["WORLD_NAME"], second["RACE_TYPE"]) == ("Oval_track", "TIME_TRIAL")
    assert first["RACER_EVAL_MAX_STEPS"] == second["RACER_EVAL_MAX_STEPS"] == "300"  # the experiment's workers.json
    assert "worker 1 (DRfC's worker 2: worker-2.env): track Oval_track, TIME_TRIAL" in result.output


def test_options_given_beside_drfc_win_for_every_worker(experiment, tmp_path):
    own = tmp_path / "mine"
    own.mkdir()
    for name in ("reward_function.py", "model_metadata.json", "hyperparameters.json"):
        (own / name).write_bytes((experiment / "custom_files" / name).read_bytes())
    (own / "network.json").write_text("{}")
    probe, seen = train_probe()
    args = ["--drfc", str(experiment), "--model-prefix", "mine", "--workers", "1", "--track", "Bowtie_track",
            "--custom-files", str(own), "--viewer-port", "0", "--race-param", "NUMBER_OF_OBSTACLES=2"]  # fmt: skip
    result = CliRunner().invoke(probe, args)
    assert result.exit_code == 0, result.output
    assert (seen["model_prefix"], seen["num_workers"], seen["viewer_port"]) == ("mine", 1, 0)
    assert "network.json" in seen["files"]
    (only,) = seen["workers"]  # --workers 1 stands for DR_WORKERS: no worker-2.env
    assert (only["WORLD_NAME"], only["RACE_TYPE"], only["NUMBER_OF_OBSTACLES"]) == (
        "Bowtie_track",
        "OBJECT_AVOIDANCE",
        "2",
    )
    assert seen["track"] == "Bowtie_track"
    assert "model 'mine', 1 worker(s)" in result.output and f"custom files from {own} (--custom-files)" in result.output


def test_an_explicit_race_type_replaces_the_experiments_race(experiment):
    probe, seen = train_probe()
    result = CliRunner().invoke(probe, ["--drfc", str(experiment), "--race-type", "time-trial"])
    assert result.exit_code == 0, result.output
    assert [(w["RACE_TYPE"], w.get("NUMBER_OF_OBSTACLES")) for w in seen["workers"]] == [("TIME_TRIAL", None)] * 2


def test_a_race_param_that_does_not_fit_a_worker_names_it(experiment):
    probe, _seen = train_probe()
    result = CliRunner().invoke(probe, ["--drfc", str(experiment), "--race-param", "NUMBER_OF_BOT_CARS=2"])
    assert result.exit_code == 1
    assert "worker 1, from the DRfC files" in result.output and "NUMBER_OF_BOT_CARS" in result.output  # TIME_TRIAL


def test_a_malformed_line_stops_before_the_command_runs(experiment):
    (experiment / "worker-2.env").write_text("DR_WORLD_NAME=Oval_track\nDR_RACE_TYPE TIME_TRIAL\n")
    probe, seen = train_probe()
    result = CliRunner().invoke(probe, ["--drfc", str(experiment)])
    assert result.exit_code == 1 and seen == {}
    assert f"{experiment / 'worker-2.env'}:2:" in result.output


def test_evaluate_takes_dr_eval_settings_and_options_win(experiment):
    probe, seen = evaluate_probe()
    result = CliRunner().invoke(probe, ["--drfc", str(experiment), "--trials", "1", "--no-video"])
    assert result.exit_code == 0, result.output
    assert (seen["model_prefix"], seen["checkpoint"], seen["track"]) == ("drfc-model", "best", "reinvent_base")
    assert (seen["trials"], seen["video"], seen["continuous"], seen["resets"]) == (1, False, False, 0)
    assert (seen["reverse"], seen["off_track_penalty"]) == (True, 3.0)
    assert (
        seen["collision_penalty"] == 5.0
    )  # DR_COLLISION_PENALTY's default: DRfC never reads DR_EVAL_COLLISION_PENALTY
    assert "DR_EVAL_COLLISION_PENALTY=2.0 has no effect" in result.output
    assert seen["race_type"] == "OBJECT_AVOIDANCE"
    assert "NUMBER_OF_OBSTACLES=4" in seen["race_param"] and "RESET_BEHIND_DIST=1.0" in seen["race_param"]


def test_the_simapp_version_picks_the_generation_unless_racer_is_told_one(experiment, monkeypatch):
    monkeypatch.delenv("RACER_GENERATION", raising=False)
    (experiment / "system.env").write_text("DR_SIMAPP_VERSION=5.3.3-gpu\n")
    for probe_and_seen in (train_probe(), evaluate_probe()):
        probe, seen = probe_and_seen
        result = CliRunner().invoke(probe, ["--drfc", str(experiment)])
        assert result.exit_code == 0, result.output
        assert seen["generation"] == "simapp5" and "generation simapp5" in result.output
        result = CliRunner().invoke(probe, ["--drfc", str(experiment), "--generation", "2019"])
        assert seen["generation"] == "2019", result.output
    monkeypatch.setenv("RACER_GENERATION", "simapp6")
    probe, seen = train_probe()
    result = CliRunner().invoke(probe, ["--drfc", str(experiment)])
    assert seen["generation"] == "simapp6", result.output
    (experiment / "system.env").write_text("DR_SIMAPP_VERSION=latest\n")
    monkeypatch.delenv("RACER_GENERATION")
    result = CliRunner().invoke(probe, ["--drfc", str(experiment)])
    assert "DR_SIMAPP_VERSION=latest: not a SimApp version" in result.output


def test_a_value_out_of_the_options_range_names_its_variable_and_line(experiment):
    run = (experiment / "run.env").read_text().replace("DR_WORKERS=2", "DR_WORKERS=40")
    (experiment / "run.env").write_text(run.replace("DR_TRAIN_MULTI_CONFIG=True", "DR_TRAIN_MULTI_CONFIG=False"))
    probe, seen = train_probe()
    result = CliRunner().invoke(probe, ["--drfc", str(experiment)])
    assert result.exit_code == 1 and seen == {}
    assert f"{experiment / 'run.env'}:3: DR_WORKERS=40: 40 is not in the range 1<=x<=32" in result.output
    assert "it stands for --workers" in result.output


def test_head_to_model_evaluates_against_the_opponent_prefix(tmp_path):
    folder = write_experiment(
        tmp_path / "exp", "DR_RACE_TYPE=HEAD_TO_MODEL\nDR_EVAL_OPP_S3_MODEL_PREFIX=rival\nDR_COLLISION_PENALTY=1.5\n"
    )
    evaluation = read_evaluation(folder)
    assert evaluation.opponents == ("rival",) and evaluation.race_type is None
    assert evaluation.collision_penalty_s == 1.5
    assert (evaluation.trials, evaluation.continuous, evaluation.resets) == (5, True, 0)  # prepare-config's defaults


def test_the_real_commands_have_the_options_the_decorators_set():
    assert TRAIN_OPTIONS <= {p.name for p in train_command.params}
    workers = next(p for p in train_command.params if p.name == "num_workers")
    assert (workers.type.min, workers.type.max) == (1, 32)  # train_probe's --workers
    assert EVALUATE_OPTIONS <= {p.name for p in evaluate_command.params}
    assert "drfc" in {p.name for p in train_command.params} and "drfc" in {p.name for p in evaluate_command.params}
