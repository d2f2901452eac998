"""racer.shared.run_settings: one builder from a worker's settings to its EnvConfig, for rollout and evaluation.

A new EnvConfig field must come from a WorkerSettings field, from the job, or be listed as NOT_FROM_SETTINGS; a new
WorkerSettings field must travel through training_params.yaml into the env (or be worker-only, `env=None`)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from racer.evaluation_worker.config import DeepRacerRules, EvaluationConfig, SummitRules
from racer.rollout_worker.worker_files import load_worker_files, training_env_config
from racer.shared.config import LocalStoreSettings
from racer.shared.deepracer.training_params import training_params_to_yaml
from racer.shared.model_layout import ModelLayout
from racer.shared.run_settings import NOT_FROM_SETTINGS, JobSettings, env_config, settings_fields
from racer.shared.sim.car.dynamics import SIMTRACE_FIT_DYNAMICS, car_profile
from racer.shared.sim.config import DEFAULT_MODEL_METADATA, EnvConfig
from racer.shared.sim.generations.catalog import generation
from racer.shared.sim.objects.challenge import ChallengeConfig
from racer.shared.store import open_store
from racer.shared.worker_settings import SETTING, WorkerSettings

OBSTACLES = ChallengeConfig.from_training_params({"RACE_TYPE": "OBJECT_AVOIDANCE", "NUMBER_OF_OBSTACLES": "3"})

NOT_DEFAULT: dict[str, object] = {
    "world": "wood",
    "track": "racer_bean",
    "reverse_dir": True,
    "alternate_driving_direction": True,
    "change_start_position": False,
    "round_robin_advance_dist": 0.1,
    "start_position_offset": 0.25,
    "min_eval_trials": 2,
    "best_model_metric": "laptime",
    "number_of_resets": 3,
    "off_track_penalty_s": 1.5,
    "collision_penalty_s": 3.0,
    "number_of_reverse_counts": 20,
    "eval_spread_starts": True,
    "eval_max_steps": 300,
    "eval_continuous": True,
    "domain_randomization": True,
    "car_randomization": True,
    "dynamics_randomization": True,
    "generation": "2019",
    "car_profile": "simtrace-fit",
    "simapp_dir": "/opt/simapp/bundle",
    "challenge": OBSTACLES,
}
"""A value unlike the default (of WorkerSettings and of EnvConfig) for every WorkerSettings field."""


def env_fields() -> set[str]:
    return {item.name for item in dataclasses.fields(EnvConfig)}


def test_every_env_config_field_comes_from_the_settings_the_job_or_is_listed_as_not_from_settings():
    from_settings = set(settings_fields())
    from_job = {item.name for item in dataclasses.fields(JobSettings)}
    listed = set(NOT_FROM_SETTINGS)
    assert not (from_settings & from_job) and not (from_settings & listed) and not (from_job & listed)
    unaccounted = env_fields() - from_settings - from_job - listed
    assert not unaccounted, f"EnvConfig fields no run setting sets and NOT_FROM_SETTINGS does not list: {unaccounted}"
    assert from_settings | from_job | listed == env_fields()  # nothing maps to a field EnvConfig does not have


def test_every_worker_setting_has_its_own_training_params_key_and_a_test_value():
    keys = [item.metadata[SETTING].key for item in dataclasses.fields(WorkerSettings)]
    assert len(keys) == len(set(keys))
    assert set(NOT_DEFAULT) == {item.name for item in dataclasses.fields(WorkerSettings)}


def test_every_setting_travels_through_training_params_yaml_into_the_env():
    """WorkerSettings -> training_params.yaml text -> WorkerSettings -> EnvConfig, each field off its default."""
    from racer.shared.deepracer.training_params import parse_training_params
    from racer.shared.sim.objects.challenge import param_text

    settings = WorkerSettings(**NOT_DEFAULT)
    text = training_params_to_yaml(settings.to_training_params("model", 2))
    params = {key: param_text(value) for key, value in parse_training_params(text).values.items()}
    read = WorkerSettings.from_training_params(params, "training_params.yaml")
    assert read == settings
    config = env_config(read, JobSettings())
    default = EnvConfig()
    expected = {
        "car_dynamics": SIMTRACE_FIT_DYNAMICS,
        "simapp_dir": Path("/opt/simapp/bundle"),
    }
    for env_field, name in settings_fields().items():
        want = expected.get(env_field, NOT_DEFAULT[name])
        assert getattr(config, env_field) == want, env_field
        assert getattr(config, env_field) != getattr(default, env_field), f"{env_field}: the test value is the default"
    same_generation = EnvConfig(generation=NOT_DEFAULT["generation"])  # the look follows the generation
    for name in NOT_FROM_SETTINGS:
        assert getattr(config, name) == getattr(same_generation, name), name
    assert config.look == generation("2019").look != default.look


def upload_run(tmp_path: Path, settings: WorkerSettings) -> Path:
    """A model folder in a local store as the trainer writes it."""
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    layout = ModelLayout("model")
    metadata = {
        "action_space": [{"steering_angle": a, "speed": 1.0} for a in (-30.0, 0.0, 30.0)],
        "sensor": ["FRONT_FACING_CAMERA"],
        "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
        "training_algorithm": "clipped_ppo",
        "action_space_type": "discrete",
        "version": "5",
    }
    store.put_bytes(layout.model_metadata, json.dumps(metadata).encode())
    store.put_bytes(layout.hyperparameters, json.dumps({"batch_size": 32}).encode())
    store.put_bytes(layout.reward_function, b"def reward_function(params):\n    return 1.0\n")
    store.put_bytes(
        layout.training_params(0), training_params_to_yaml(settings.to_training_params("model", 1)).encode()
    )
    return tmp_path / "store"


@pytest.mark.parametrize("mode", ["deepracer", "race"])
def test_rollout_and_evaluation_build_the_same_env_from_the_same_settings(tmp_path, mode):
    """The same world, car, race and reset budget: the rollout worker (from the store's training_params) and the
    evaluation worker get one EnvConfig, apart from what the job sets (reward, reset rules)."""
    evaluation = EvaluationConfig(
        model_prefix="model",
        mode=mode,
        track="racer_bean",
        world="wood",
        reverse_dir=True,
        deepracer=DeepRacerRules(number_of_resets=3, off_track_penalty_s=1.5, collision_penalty_s=3.0),
        summit=SummitRules(resets_per_lap=3, reset_penalty_s=1.5, put_back="where_it_left"),
        challenge=OBSTACLES,
        car_profile="simtrace-fit",
        generation="simapp5",
    )
    penalty = {"deepracer": (1.5, 3.0), "race": (1.5, 1.5)}[mode]
    worker = WorkerSettings(
        world="wood",
        track="racer_bean",
        reverse_dir=True,
        number_of_resets=3,
        off_track_penalty_s=penalty[0],
        collision_penalty_s=penalty[1],
        car_profile="simtrace-fit",
        generation="simapp5",
        challenge=OBSTACLES,
    )
    store = open_store(LocalStoreSettings(root=upload_run(tmp_path, worker)))
    run = load_worker_files(store, "model", 0, tmp_path / "worker")
    rollout = training_env_config(run)
    settings, job = evaluation.run_settings(run.model_metadata)
    assert settings == run.worker
    evaluated = env_config(settings, job)
    assert evaluated.car_dynamics == car_profile("simtrace-fit") and evaluated.challenge == OBSTACLES
    assert evaluated.generation == rollout.generation == "simapp5"
    job_fields = {item.name for item in dataclasses.fields(JobSettings)}
    assert dataclasses.replace(rollout, **{name: getattr(evaluated, name) for name in job_fields}) == evaluated
    assert rollout.reward_function_path == run.reward_function_path and evaluated.reward_function_path is None
    if mode == "race":
        assert (evaluated.reset_position, evaluated.reverse_penalty_s, evaluated.immobilized_penalty_s) == (
            "where_it_left",
            1.5,
            1.5,
        )
    else:
        assert (evaluated.reset_position, evaluated.reverse_penalty_s) == ("deepracer", None)
    assert run.model_metadata != DEFAULT_MODEL_METADATA  # the stored model, not the default, reached both envs
    assert rollout.model_metadata == evaluated.model_metadata == run.model_metadata


def test_racer_overlap_is_read_as_a_boolean_and_anything_else_is_refused():
    from racer.shared.config import overlap_setting

    assert [overlap_setting({"RACER_OVERLAP": v}) for v in ("True", "1", " yes ", "false", "0", "")] == [
        True,
        True,
        True,
        False,
        False,
        False,
    ]
    assert overlap_setting({}) is False
    with pytest.raises(ValueError, match="RACER_OVERLAP='maybe'"):
        overlap_setting({"RACER_OVERLAP": "maybe"})


def test_overlap_option_takes_its_default_from_racer_overlap(monkeypatch):
    from click.testing import CliRunner

    from racer.trainer.cli import trainer_command

    monkeypatch.setenv("RACER_OVERLAP", "nonsense")
    result = CliRunner().invoke(trainer_command, ["--model-prefix", "m", "--custom-files", ".", "--max-episodes", "1"])
    assert result.exit_code == 2 and "RACER_OVERLAP='nonsense'" in result.output, result.output
