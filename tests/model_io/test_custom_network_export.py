"""`racer model export` refuses a model with your own network (network.json) with the reason: no TensorFlow frozen
graph for it yet, and DeepRacer on AWS imports only its three built-in networks."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from racer.cli import main
from racer.model_io.destinations import FolderDestination
from racer.model_io.tensorflow.errors import CustomNetworkExportError
from racer.model_io.transfer import export_model
from racer.shared.model_layout import ModelLayout
from racer.shared.store import LocalStore
from tests.policy.test_network_file import ACTIONS, BATCHNORM


def store_with_custom_model(tmp_path) -> LocalStore:
    store = LocalStore(tmp_path / "store")
    layout = ModelLayout("own")
    metadata = {"action_space": ACTIONS, "sensor": ["FRONT_FACING_CAMERA"], "neural_network": BATCHNORM["name"]}
    store.put_bytes(layout.model_metadata, json.dumps({**metadata, "version": "5"}).encode())
    store.put_bytes(layout.network, json.dumps(BATCHNORM).encode())
    return store


@pytest.mark.parametrize(
    ("layout", "reason"),
    [("racer", "cannot write its TensorFlow frozen graph"), ("droa", "DeepRacer on AWS imports only its three")],
)
def test_export_refuses_a_custom_network_with_the_reason(tmp_path, layout, reason):
    store = store_with_custom_model(tmp_path)
    with pytest.raises(CustomNetworkExportError, match=rf"'EXTRA_CONV_BATCHNORM' is your own .*{reason}"):
        export_model(store, "own", FolderDestination(tmp_path / "out"), layout=layout)
    assert not (tmp_path / "out").exists()


def test_the_cli_says_why(tmp_path):
    store_with_custom_model(tmp_path)
    result = CliRunner().invoke(
        main, ["model", "export", "own", str(tmp_path / "out"), "--store", str(tmp_path / "store")]
    )
    assert result.exit_code != 0
    assert "is your own (network.json)" in result.output


@pytest.mark.parametrize(
    ("layout", "reason"),
    [("racer", "not yet proven"), ("droa", "single-frame models only")],
)
def test_export_refuses_stacked_frames_with_the_reason(tmp_path, layout, reason):
    store = LocalStore(tmp_path / "store")
    model = ModelLayout("stacked")
    metadata = {"action_space": ACTIONS, "sensor": ["FRONT_FACING_CAMERA"], "version": "5"}
    store.put_bytes(model.model_metadata, json.dumps(metadata).encode())
    store.put_bytes(model.hyperparameters, json.dumps({"stack_size": 2}).encode())
    with pytest.raises(CustomNetworkExportError, match=rf"2 stacked .*{reason}"):
        export_model(store, "stacked", FolderDestination(tmp_path / "out"), layout=layout)
    assert not (tmp_path / "out").exists()
    result = CliRunner().invoke(
        main, ["model", "export", "stacked", str(tmp_path / "out"), "--store", str(tmp_path / "store")]
    )
    assert result.exit_code != 0 and "stack_size" in result.output
