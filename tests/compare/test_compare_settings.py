"""A run's settings as one table and what differs between runs (racer.compare.settings), on real DeepRacer files."""

from __future__ import annotations

import json

from racer.compare.settings import describe_action_space, read_run_settings, settings_table
from racer.shared.store import LocalStore


def test_a_setting_differs_when_any_run_has_another_value_or_none():
    table = settings_table(
        [
            {"hyperparameters.json: lr": "0.0003", "hyperparameters.json: batch_size": "64", "only in a": "x"},
            {"hyperparameters.json: lr": "0.001", "hyperparameters.json: batch_size": "64"},
            {"hyperparameters.json: batch_size": "64", "hyperparameters.json: lr": "0.0003"},
        ]
    )
    rows = {row.name: row for row in table}
    assert [row.name for row in table] == ["hyperparameters.json: lr", "hyperparameters.json: batch_size", "only in a"]
    assert rows["hyperparameters.json: lr"].differs and rows["hyperparameters.json: lr"].values[1] == "0.001"
    assert not rows["hyperparameters.json: batch_size"].differs
    assert rows["only in a"].differs and rows["only in a"].values == ("x", None, None)
    assert not any(row.differs for row in settings_table([{"a": "1"}, {"a": "1"}]))


def test_action_spaces_read_as_steering_and_speed(deepracer_data):
    discrete = json.loads((deepracer_data / "config" / "drfc1_model_metadata.json").read_text())["action_space"]
    text = describe_action_space(discrete)
    assert text.startswith("14 actions: -30° 1 m/s; -30° 2 m/s; -20° 1 m/s") and text.endswith("30° 2 m/s")
    continuous = json.loads((deepracer_data / "config" / "drfc_defaults_model_metadata_cont.json").read_text())
    low_high = continuous["action_space"]
    expected = (
        f"steering {low_high['steering_angle']['low']:g}..{low_high['steering_angle']['high']:g}°, "
        f"speed {low_high['speed']['low']:g}..{low_high['speed']['high']:g} m/s"
    )
    assert describe_action_space(low_high) == expected
    assert describe_action_space("odd") == "odd"


def test_a_deepracer_run_folders_settings(tmp_path, deepracer_data):
    """DeepRacer's own files as DRfC leaves them in a model folder: the SimApp's sample training_params (the keys
    naming the run's storage left out), hyperparameters and model_metadata, a second worker's file where it differs."""
    store = LocalStore(tmp_path)
    config = deepracer_data / "config"
    store.put_bytes("m/training_params.yaml", (config / "simapp_sample-training_params.yaml").read_bytes())
    store.put_bytes("m/training_params_1.yaml", b"WORLD_NAME: Vegas_track\nCAR_COLOR: Red\n")
    store.put_bytes("m/ip/hyperparameters.json", (config / "drfc1_ip_hyperparameters.json").read_bytes())
    store.put_bytes("m/model/model_metadata.json", (config / "drfc1_model_metadata.json").read_bytes())
    reward = (deepracer_data / "reward_functions" / "drfc1_follow_center_line.py").read_bytes()
    store.put_bytes("m/reward_function.py", reward)
    workers = {1: {"WORLD_NAME": "Vegas_track", "CAR_COLOR": "Red"}}
    settings = read_run_settings(store, "m", workers, {"max_episodes": 1000, "max_minutes": None})
    values = settings.values
    assert values["training_params.yaml: WORLD_NAME"] == "Vegas_track"
    assert values["training_params.yaml: RACE_TYPE"] == "TIME_TRIAL"
    assert not any("S3" in name or "ARN" in name for name in values), [n for n in values if "S3" in n]
    assert values["training_params_1.yaml: CAR_COLOR"] == "Red"
    assert "training_params_1.yaml: WORLD_NAME" not in values  # the same as worker 0's
    hyperparameters = json.loads((config / "drfc1_ip_hyperparameters.json").read_text())
    for key, value in hyperparameters.items():
        assert values[f"hyperparameters.json: {key}"] == (value if isinstance(value, str) else repr(value))
    assert values["model_metadata.json: action_space"].startswith("14 actions:")
    assert values["model_metadata.json: neural_network"] == "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW"
    assert values["reward_function.py"].endswith(f"{len(reward.decode().splitlines())} lines")
    assert settings.reward_function == reward.decode("utf-8-sig")
    assert values["stop: max episodes"] == "1000" and values["stop: max minutes"] == "none"
    assert settings.notes == ()


def test_a_file_that_cannot_be_read_is_a_note_naming_it(tmp_path):
    store = LocalStore(tmp_path)
    store.put_bytes("m/ip/hyperparameters.json", b'{\n  "lr": 0.001,\n  "batch_size": ,\n}')
    store.put_bytes("m/model/model_metadata.json", b"[1, 2]")
    store.put_bytes("m/training_params.yaml", b"WORLD_NAME: [oval, {a: 1}]\n")
    settings = read_run_settings(store, "m")
    notes = "\n".join(settings.notes)
    assert "m/ip/hyperparameters.json: not JSON" in notes and "line 3" in notes
    assert "m/model/model_metadata.json: expected a JSON object, found list" in notes
    assert "m/training_params.yaml: WORLD_NAME" in notes
    assert settings.values == {}
