"""hyperparameters.json: real files parse, SimApp defaults fill gaps, console ranges are enforced, ip/ output matches."""

from __future__ import annotations

import json
from dataclasses import fields

import pytest

from racer.shared.deepracer.hyperparameters import (
    Hyperparameters,
    HyperparametersError,
    hyperparameters_to_json_bytes,
    load_hyperparameters,
    parse_hyperparameters,
    resolved_hyperparameters,
)

DEEPRACER_KEYS = {
    "batch_size", "beta_entropy", "discount_factor", "e_greedy_value", "epsilon_steps", "exploration_type",
    "loss_type", "lr", "num_episodes_between_training", "num_epochs", "stack_size", "term_cond_avg_score",
    "term_cond_max_episodes", "sac_alpha",
}  # fmt: skip


def real_files(data_dir):
    files = sorted((data_dir / "config").glob("*hyperparameters*.json"))
    assert len(files) >= 5, files
    return files


def test_fields_are_the_deepracer_keys():
    assert {field.name for field in fields(Hyperparameters)} == DEEPRACER_KEYS


def test_simapp_defaults():
    defaults, warnings = parse_hyperparameters({})
    assert warnings == []
    assert defaults == Hyperparameters()
    assert (defaults.batch_size, defaults.discount_factor, defaults.num_epochs) == (64, 0.999, 10)
    assert (defaults.loss_type, defaults.exploration_type, defaults.lr) == ("mean squared error", "categorical", 0.0003)
    assert (defaults.term_cond_max_episodes, defaults.term_cond_avg_score, defaults.sac_alpha) == (
        100000,
        100000.0,
        0.2,
    )
    assert (defaults.beta_entropy, defaults.e_greedy_value, defaults.epsilon_steps) == (0.01, 0.05, 10000)
    assert (defaults.num_episodes_between_training, defaults.stack_size) == (20, 1)


def test_every_real_file_parses_to_its_values(deepracer_data):
    for path in real_files(deepracer_data):
        raw = json.loads(path.read_text())
        hyperparameters, warnings = load_hyperparameters(path)
        assert warnings == [], path.name
        for key, value in raw.items():
            parsed = getattr(hyperparameters, key)
            assert parsed == value and type(parsed) is type(value), (path.name, key, parsed, value)
        for key in DEEPRACER_KEYS - set(raw):
            assert getattr(hyperparameters, key) == getattr(Hyperparameters(), key)


def test_ip_hyperparameters_bytes_match_the_trainer_output(deepracer_data):
    """The console/DRfC trainers wrote these ip/ files from the same resolved dict (PPO)."""
    for name in (
        "console2022_ip_hyperparameters.json",
        "drfc1_ip_hyperparameters.json",
        "drfc3_ip_hyperparameters.json",
    ):
        path = deepracer_data / "config" / name
        hyperparameters, _ = load_hyperparameters(path)
        assert hyperparameters_to_json_bytes(hyperparameters) == path.read_bytes(), name


def test_resolved_dict_depends_on_the_algorithm():
    hyperparameters = Hyperparameters()
    ppo = resolved_hyperparameters(hyperparameters)
    sac = resolved_hyperparameters(hyperparameters, "sac")
    assert set(ppo) == DEEPRACER_KEYS - {"sac_alpha"}
    assert set(sac) == DEEPRACER_KEYS - {"beta_entropy", "num_epochs"}
    assert list(ppo) == sorted(ppo)
    assert json.loads(hyperparameters_to_json_bytes(hyperparameters, "sac")) == sac
    with pytest.raises(ValueError, match="allowed: clipped_ppo, sac"):
        resolved_hyperparameters(hyperparameters, "dqn")


def test_numbers_given_as_strings_are_accepted():
    hyperparameters, _ = parse_hyperparameters(
        {
            "batch_size": "128",
            "lr": "3e-4",
            "num_epochs": "5.0",
            "discount_factor": " 0.99 ",
            "term_cond_avg_score": "350",
        }
    )
    assert hyperparameters.batch_size == 128 and type(hyperparameters.batch_size) is int
    assert hyperparameters.lr == 0.0003
    assert hyperparameters.num_epochs == 5 and type(hyperparameters.num_epochs) is int
    assert hyperparameters.discount_factor == 0.99
    assert hyperparameters.term_cond_avg_score == 350.0 and type(hyperparameters.term_cond_avg_score) is float


def test_strings_are_normalised():
    hyperparameters, _ = parse_hyperparameters({"loss_type": "Huber", "exploration_type": " E-Greedy"})
    assert (hyperparameters.loss_type, hyperparameters.exploration_type) == ("huber", "e-greedy")


def test_unknown_keys_are_warnings_naming_file_and_key():
    hyperparameters, warnings = parse_hyperparameters(
        {"lr": 0.0001, "learning_rate": 0.1, "gamma": 0.9}, source="hp.json"
    )
    assert hyperparameters.lr == 0.0001
    assert len(warnings) == 2
    assert warnings[0].startswith("hp.json: learning_rate: unknown")
    assert warnings[1].startswith("hp.json: gamma: unknown")


BAD_VALUES = [
    ("batch_size", 100, "one of 32, 64, 128, 256, 512"),
    ("batch_size", 64.5, "not a whole number"),
    ("batch_size", True, "not a number"),
    ("beta_entropy", 1.5, "0 to 1"),
    ("beta_entropy", -0.1, "0 to 1"),
    ("discount_factor", 1.01, "0 to 1"),
    ("e_greedy_value", -1, "0 to 1"),
    ("epsilon_steps", 0, "at least 1"),
    ("exploration_type", "boltzmann", "one of categorical, e-greedy, additive_noise"),
    ("exploration_type", 3, "not a string"),
    ("loss_type", "l1", "one of huber, mean squared error"),
    ("lr", 0.01, "1e-08 to 0.001"),
    ("lr", 1e-9, "1e-08 to 0.001"),
    ("lr", "fast", "not a number"),
    ("lr", "nan", "not a finite number"),
    ("lr", None, "not a number"),
    ("num_episodes_between_training", 0, "1 to 100"),
    ("num_episodes_between_training", 101, "1 to 100"),
    ("num_epochs", 2, "3 to 10"),
    ("num_epochs", 11, "3 to 10"),
    ("stack_size", 9, "1 to 8"),
    ("term_cond_avg_score", "inf", "not a finite number"),
    ("term_cond_max_episodes", 0, "at least 1"),
    ("sac_alpha", 2.0, "0 to 1"),
]


@pytest.mark.parametrize(("key", "value", "allowed"), BAD_VALUES)
def test_out_of_range_values_name_file_key_and_range(key, value, allowed):
    with pytest.raises(HyperparametersError) as caught:
        parse_hyperparameters({"batch_size": 64, key: value}, source="custom_files/hyperparameters.json")
    message = str(caught.value)
    assert message.startswith(f"custom_files/hyperparameters.json: {key}: "), message
    assert allowed in message, message


def test_console_range_edges_are_accepted():
    hyperparameters, _ = parse_hyperparameters(
        {"lr": 1e-3, "num_epochs": 3, "num_episodes_between_training": 100, "discount_factor": 1.0, "batch_size": 512}
    )
    assert (hyperparameters.lr, hyperparameters.num_epochs, hyperparameters.batch_size) == (1e-3, 3, 512)


def test_top_level_must_be_an_object():
    with pytest.raises(HyperparametersError, match="^x.json: expected a JSON object"):
        parse_hyperparameters([], source="x.json")


def test_load_reports_malformed_json_with_line(tmp_path):
    path = tmp_path / "hyperparameters.json"
    path.write_text('{\n  "batch_size": 64,\n  "lr": 0.0003\n  "num_epochs": 3\n}')
    with pytest.raises(HyperparametersError) as caught:
        load_hyperparameters(path)
    assert str(caught.value).startswith(f"{path}: invalid JSON at line 4, column 3"), str(caught.value)


def test_load_names_the_file_for_range_errors(tmp_path):
    path = tmp_path / "hp.json"
    path.write_text(json.dumps({"num_epochs": 50}))
    with pytest.raises(HyperparametersError, match=f"^{path}: num_epochs: 50 is out of range; allowed: 3 to 10$"):
        load_hyperparameters(path)
