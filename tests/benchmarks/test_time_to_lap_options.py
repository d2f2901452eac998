"""`python -m benchmarks time-to-lap --hyperparameter KEY=VALUE`: read as hyperparameters.json entries, refused before a run."""

from __future__ import annotations

import tempfile

import click
import pytest
from click.testing import CliRunner

from benchmarks.time_to_lap import hyperparameter_overrides, time_to_lap_command


def test_pairs_become_hyperparameters_json_entries():
    overrides = hyperparameter_overrides(["sac_alpha=0.05", "lr=1e-3", "loss_type=huber", "batch_size=32"])
    assert overrides == {"sac_alpha": 0.05, "lr": 0.001, "loss_type": "huber", "batch_size": 32}


@pytest.mark.parametrize(
    ("pair", "named"),
    [("sac_alpha=1.5", "sac_alpha"), ("learning_rate=0.001", "learning_rate"), ("lr", "'lr' is not KEY=VALUE")],
)
def test_bad_pairs_are_refused_with_the_key(pair, named):
    with pytest.raises(click.BadParameter, match=named):
        hyperparameter_overrides([pair])


def test_the_command_refuses_a_bad_pair_before_anything_starts(tmp_path, monkeypatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # where the command would make its run folder
    result = CliRunner().invoke(
        time_to_lap_command, ["--track", "reinvent_base", "--hyperparameter", "discount_factor=2"]
    )
    assert result.exit_code == 2
    assert "discount_factor" in result.output and "out of range" in result.output
    assert list(tmp_path.iterdir()) == []  # no run folder was made


def test_a_network_file_reaches_the_run_and_a_bad_layer_is_refused_by_name(tmp_path, monkeypatch, deepracer_data):
    """--network copies the file into the run's custom files: the preflight reads it and names the bad layer."""
    network = tmp_path / "network.json"
    network.write_text(
        '{"name": "BAD_KERNEL", "input_embedders": {"FRONT_FACING_CAMERA": '
        '[{"type": "Conv2d", "num_filters": 8, "kernel_size": 0, "strides": 1}]}, "middleware": []}'
    )
    runs = tmp_path / "runs"
    runs.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(runs))
    result = CliRunner().invoke(
        time_to_lap_command,
        ["--track", "reinvent_base", "--network", str(network), "--time-limit-minutes", "0.1", "--workers", "1"]
        + ["--data", str(deepracer_data)],
    )
    assert result.exit_code != 0
    assert "network.json" in result.output and "kernel_size" in result.output, result.output
