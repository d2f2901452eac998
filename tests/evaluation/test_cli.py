"""`racer evaluate` on a stored model (a freshly initialised network), against a local folder and a real MinIO."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch
from click.testing import CliRunner

from racer.evaluation_worker.cli import evaluate_command
from racer.shared.deepracer.metrics import read_evaluation_metrics
from racer.shared.deepracer.simtrace import read_simtrace
from racer.shared.policy.best_and_last import CheckpointRecord
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.networks import build_actor_critic
from racer.shared.sim.config import DEFAULT_MODEL_METADATA
from racer.shared.store import LocalStore, ObjectStore, S3Store

PREFIX = "cli-model"


def save_model(store: ObjectStore, count: int = 1) -> list[str]:
    checkpoints = CheckpointStore(store, PREFIX)
    checkpoints.put_model_metadata(DEFAULT_MODEL_METADATA)
    names = []
    for number in range(count):
        torch.manual_seed(number)
        names.append(
            checkpoints.save(
                number, 100 * number, build_actor_critic(DEFAULT_MODEL_METADATA), model_metadata=DEFAULT_MODEL_METADATA
            )
        )
    return names


def invoke(store_location: str, *args: str, extra_env: dict[str, str] | None = None):
    env = {"RACER_STORE": store_location, **(extra_env or {})}
    return CliRunner().invoke(evaluate_command, ["--model-prefix", PREFIX, *args], env=env, catch_exceptions=False)


def files_of(store: ObjectStore, output: str) -> dict[str, str]:
    keys = {}
    for line in output.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[1].startswith(PREFIX + "/"):
            keys[parts[0]] = parts[1]
    assert keys, output
    for key in keys.values():
        assert store.exists(key), key
    return keys


@pytest.mark.slow
def test_race_on_a_local_store_prints_the_table_and_writes_every_file(tmp_path):
    store = LocalStore(tmp_path / "store")
    save_model(store)
    result = invoke(
        str(tmp_path / "store"),
        "--mode",
        "race",
        "--race-minutes",
        "0.15",
        "--video-size",
        "160x120",
        "--out",
        str(tmp_path / "out"),
    )
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert any(line.startswith("lap   1:") for line in lines)  # per-lap progress lines
    header = next(
        index for index, line in enumerate(lines) if line.split()[:5] == ["lap", "time", "(s)", "resets", "progress"]
    )
    assert "Time Up" in result.output.split("\n", header + 1)[-1]
    keys = files_of(store, result.output)
    assert set(keys) == {
        "metrics",
        "simtrace",
        "summary",
        "params",
        "camera-incar",
        "camera-topview",
        "camera-45degree",
        "mcap",
    }
    summary = json.loads(store.get_bytes(keys["summary"]))
    assert summary["mode"] == "race" and summary["checkpoint"] == "0_Step-0.ckpt"
    assert summary["rules"]["race_duration_s"] == 9.0 and summary["rules"]["resets_per_lap"] == 3
    rows = read_simtrace(store.get_bytes(keys["simtrace"]), source="simtrace")
    assert rows.episode_status.iloc[-1] == "time_up"
    assert summary["timings"]["video_frames"]["camera-45degree"] == len(rows)
    assert (tmp_path / "out" / keys["summary"].removeprefix(PREFIX + "/")).is_file()


def test_deepracer_evaluation_against_minio(s3_settings):
    store = S3Store(s3_settings)
    save_model(store)
    extra = {
        "S3_ENDPOINT_URL": s3_settings.endpoint_url,
        "AWS_ACCESS_KEY_ID": s3_settings.access_key_id,
        "AWS_SECRET_ACCESS_KEY": s3_settings.secret_access_key,
    }
    result = invoke(
        f"s3://{s3_settings.bucket}",
        "--trials",
        "2",
        "--resets",
        "0",
        "--no-video",
        "--mcap",
        "--checkpoint",
        "last",
        extra_env=extra,
    )
    assert result.exit_code == 0, result.output
    keys = files_of(store, result.output)
    assert set(keys) == {"metrics", "simtrace", "summary", "params", "mcap"}
    metrics = read_evaluation_metrics(store.get_bytes(keys["metrics"]), source=keys["metrics"])
    assert [entry.trial for entry in metrics.entries] == [1, 2]
    rows = read_simtrace(store.get_bytes(keys["simtrace"]), source="simtrace")
    assert sorted(rows.episode.unique()) == [0, 1]
    assert store.size(keys["mcap"]) > 1000


def test_best_checkpoint_comes_from_deepracer_checkpoints_json(tmp_path):
    store = LocalStore(tmp_path / "store")
    names = save_model(store, count=2)
    CheckpointStore(store, PREFIX).write_best_and_last(
        CheckpointRecord(names[0], 50.0, 1.0), CheckpointRecord(names[1], 10.0, 2.0)
    )
    result = invoke(str(tmp_path / "store"), "--trials", "1", "--resets", "0", "--no-video", "--no-mcap")
    assert result.exit_code == 0, result.output
    summary = json.loads(store.get_bytes(files_of(store, result.output)["summary"]))
    assert (summary["checkpoint"], summary["checkpoint_requested"]) == (names[0], "best")
    named = invoke(
        str(tmp_path / "store"), "--trials", "1", "--resets", "0", "--no-video", "--no-mcap", "--checkpoint", names[1]
    )
    assert named.exit_code == 0, named.output
    assert json.loads(store.get_bytes(files_of(store, named.output)["summary"]))["checkpoint"] == names[1]


def test_the_car_profile_reaches_the_env_and_the_evaluation_params(tmp_path, monkeypatch):
    from racer.evaluation_worker import runner
    from racer.shared.deepracer.training_params import parse_training_params
    from racer.shared.sim.car.dynamics import SIMTRACE_FIT_DYNAMICS

    store = LocalStore(tmp_path / "store")
    save_model(store)
    configs, env_type = [], runner.DeepRacerEnv
    monkeypatch.setattr(runner, "DeepRacerEnv", lambda config, **kw: configs.append(config) or env_type(config, **kw))
    result = invoke(
        str(tmp_path / "store"), "--trials", "1", "--no-video", "--no-mcap", "--car-profile", "simtrace-fit"
    )
    assert result.exit_code == 0, result.output
    assert [config.car_dynamics for config in configs] == [SIMTRACE_FIT_DYNAMICS]
    keys = files_of(store, result.output)
    assert json.loads(store.get_bytes(keys["summary"]))["car_profile"] == "simtrace-fit"
    params = parse_training_params(store.get_bytes(keys["params"]).decode(), source="evaluation_params.yaml")
    assert params.values["RACER_CAR_PROFILE"] == "simtrace-fit"
    bad = invoke(str(tmp_path / "store"), "--car-profile", "f1")
    assert bad.exit_code == 2 and "--car-profile" in bad.output and "'gazebo', 'simtrace-fit'" in bad.output


def test_the_generation_reaches_the_env_and_the_evaluation_params(tmp_path, monkeypatch):
    """`--generation` picks the look and the car of the evaluation's env, and the outputs record it."""
    from racer.evaluation_worker import runner
    from racer.shared.deepracer.training_params import parse_training_params
    from racer.shared.sim.generations.catalog import generation

    store = LocalStore(tmp_path / "store")
    save_model(store)
    configs, env_type = [], runner.DeepRacerEnv
    monkeypatch.setattr(runner, "DeepRacerEnv", lambda config, **kw: configs.append(config) or env_type(config, **kw))
    result = invoke(str(tmp_path / "store"), "--trials", "1", "--no-video", "--no-mcap", "--generation", "2019")
    assert result.exit_code == 0, result.output
    assert [(c.generation, c.look, c.car_dynamics) for c in configs] == [
        ("2019", generation("2019").look, generation("2019").car)
    ]
    keys = files_of(store, result.output)
    assert json.loads(store.get_bytes(keys["summary"]))["generation"] == "2019"
    params = parse_training_params(store.get_bytes(keys["params"]).decode(), source="evaluation_params.yaml")
    assert (params.values["RACER_GENERATION"], params.values["RACER_CAR_PROFILE"]) == ("2019", "")
    bad = invoke(str(tmp_path / "store"), "--generation", "2020")
    assert bad.exit_code == 2 and "--generation" in bad.output and "'2019', 'simapp5', 'simapp6'" in bad.output


def test_bad_input_gives_one_clear_line(tmp_path):
    store = LocalStore(tmp_path / "store")
    save_model(store)
    missing = invoke(str(tmp_path / "store"), "--checkpoint", "7_Step-700.ckpt", "--no-video", "--no-mcap")
    assert missing.exit_code == 1 and "7_Step-700.ckpt" in missing.output and "Traceback" not in missing.output
    resets = invoke(str(tmp_path / "store"), "--resets", "1")
    assert resets.exit_code == 1 and "NUMBER_OF_RESETS" in resets.output
    empty = invoke(str(tmp_path / "empty"), "--no-video")
    assert empty.exit_code == 1 and ".coach_checkpoint" in empty.output
    track = invoke(str(tmp_path / "store"), "--track", "no_such_track", "--no-video", "--no-mcap")
    assert track.exit_code == 1 and "no_such_track" in track.output
    size = invoke(str(tmp_path / "store"), "--video-size", "big")
    assert size.exit_code == 2 and "WIDTHxHEIGHT" in size.output
    assert not list(Path(tmp_path / "store").glob(f"{PREFIX}/evaluation-*"))


def test_resets_option_defaults_to_the_consoles_number_of_resets():
    option = next(param for param in evaluate_command.params if param.name == "resets")
    assert option.default == 10000  # console2022_evaluation_robomaker.log: NUMBER_OF_RESETS '10000'


def test_opponent_runs_a_head_to_model_evaluation_of_stored_models(tmp_path):
    store = LocalStore(tmp_path / "store")
    save_model(store)
    opponent = CheckpointStore(store, "opponent-model")
    opponent.put_model_metadata(DEFAULT_MODEL_METADATA)
    torch.manual_seed(5)
    opponent.save(0, 0, build_actor_critic(DEFAULT_MODEL_METADATA), model_metadata=DEFAULT_MODEL_METADATA)
    result = invoke(
        str(tmp_path / "store"),
        "--opponent",
        "opponent-model",
        "--trials",
        "1",
        "--resets",
        "0",
        "--no-video",
        "--no-mcap",
    )
    assert result.exit_code == 0, result.output
    assert "HEAD_TO_MODEL: 1 lap(s)" in result.output
    summaries = [line.split()[1] for line in result.output.splitlines() if line.strip().endswith("summary.json")]
    assert len(summaries) == 2, result.output
    places = sorted(json.loads(store.get_bytes(key))["multi_car"]["finishing_place"] for key in summaries)
    assert places == [1, 2]
    same = invoke(str(tmp_path / "store"), "--opponent", PREFIX, "--no-video", "--no-mcap")
    assert same.exit_code != 0 and "its own model" in same.output


def test_opponent_with_videos_writes_the_top_view_of_all_cars(tmp_path):
    store = LocalStore(tmp_path / "store")
    save_model(store)
    opponent = CheckpointStore(store, "opponent-model")
    opponent.put_model_metadata(DEFAULT_MODEL_METADATA)
    torch.manual_seed(5)
    opponent.save(0, 0, build_actor_critic(DEFAULT_MODEL_METADATA), model_metadata=DEFAULT_MODEL_METADATA)
    out = tmp_path / "local"
    args = ["--opponent", "opponent-model", "--trials", "1", "--resets", "0", "--no-mcap", "--out", str(out)]
    result = invoke(str(tmp_path / "store"), *args)
    assert result.exit_code == 0, result.output
    (key,) = [line.split()[-1] for line in result.output.splitlines() if "all cars from above:" in line]
    assert key.startswith(f"{PREFIX}/evaluation-") and key.endswith("/camera-allcars/0-video.mp4")
    local = out / "car-0" / key.removeprefix(f"{PREFIX}/")
    assert local.read_bytes() == store.get_bytes(key) and local.stat().st_size > 1000
