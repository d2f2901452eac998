"""`racer model export --for droa` refuses a model with your own network (network.json) or stacked frames, with the
reason: DeepRacer on AWS imports only its three built-in networks, fed single frames. racer's own export writes
their TensorFlow files (tests/model_io/test_custom_graph_export.py)."""

from __future__ import annotations

import json

from click.testing import CliRunner

from racer.cli import main
from racer.model_io.destinations import FolderDestination
from racer.model_io.import_export import export_model
from racer.model_io.tensorflow.errors import CustomNetworkExportError
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


def test_droa_export_refuses_a_custom_network_with_the_reason(tmp_path):
    store = store_with_custom_model(tmp_path)
    try:
        export_model(store, "own", FolderDestination(tmp_path / "out"), layout="droa")
    except CustomNetworkExportError as error:
        assert "'EXTRA_CONV_BATCHNORM' is your own" in str(error)
        assert "DeepRacer on AWS imports only its three" in str(error)
    else:
        raise AssertionError("a custom network was exported for DeepRacer on AWS")
    assert not (tmp_path / "out").exists()
    result = CliRunner().invoke(
        main, ["model", "export", "own", str(tmp_path / "out"), "--store", str(tmp_path / "store"), "--for", "droa"]
    )
    assert result.exit_code != 0
    assert "is your own (network.json)" in result.output


def test_droa_export_refuses_stacked_frames_with_the_reason(tmp_path):
    store = LocalStore(tmp_path / "store")
    model = ModelLayout("stacked")
    metadata = {"action_space": ACTIONS, "sensor": ["FRONT_FACING_CAMERA"], "version": "5"}
    store.put_bytes(model.model_metadata, json.dumps(metadata).encode())
    store.put_bytes(model.hyperparameters, json.dumps({"stack_size": 2}).encode())
    result = CliRunner().invoke(
        main,
        ["model", "export", "stacked", str(tmp_path / "out"), "--store", str(tmp_path / "store"), "--for", "droa"],
    )
    assert result.exit_code != 0
    assert "2 stacked camera frames" in result.output and "feeds it single frames" in result.output
    assert not (tmp_path / "out").exists()
