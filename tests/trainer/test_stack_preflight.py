"""The preflight knows the frame stack: a clone whose source has another stack_size is refused before anything
starts (both values, both files), and the network-size check measures the network with the stacked channels."""

from __future__ import annotations

import json

import pytest

from racer.shared.config import LocalStoreSettings
from racer.shared.model_layout import ModelLayout
from racer.shared.policy.network_size import SizeFindings
from racer.shared.run_settings import RunOptions
from racer.shared.store import open_store
from racer.shared.user_errors import CloneError
from racer.trainer import preflight as preflight_module
from racer.trainer.preflight import load_model_metadata, load_network, preflight
from tests.trainer.test_custom_network import custom_network_files


def with_stack_size(folder, stack_size: int) -> None:
    hyperparameters = json.loads((folder / "hyperparameters.json").read_text())
    (folder / "hyperparameters.json").write_text(json.dumps({**hyperparameters, "stack_size": stack_size}))


def test_a_clone_with_another_stack_size_is_refused_naming_both_values_and_files(tmp_path):
    folder = custom_network_files(tmp_path, network=None, name="DEEP_CONVOLUTIONAL_NETWORK_SHALLOW")
    with_stack_size(folder, 2)
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    source = ModelLayout("source")
    store.put_bytes(source.model_metadata, (folder / "model_metadata.json").read_bytes())
    store.put_bytes(source.hyperparameters, json.dumps({"batch_size": 64, "stack_size": 1}).encode())
    ours = folder / "hyperparameters.json"
    with pytest.raises(
        CloneError, match=rf"stack_size 2 in {ours} vs 1 in source/ip/hyperparameters.json \(ours vs theirs\)"
    ):
        preflight(folder, RunOptions(1, "racer_oval", ("base",)), pretrained_prefix="source", store=store)
    store.put_bytes(source.hyperparameters, json.dumps({"batch_size": 64, "stack_size": 2}).encode())
    preflight(
        folder, RunOptions(1, "racer_oval", ("base",)), pretrained_prefix="source", store=store
    )  # the same stack: fine


def test_the_size_check_builds_the_network_with_the_stacked_channels(tmp_path, monkeypatch):
    folder = custom_network_files(tmp_path)
    measured = []

    def findings(config, source):
        measured.append(config)
        return SizeFindings(1, 0.0, (), ())

    monkeypatch.setattr(preflight_module, "network_size_findings", findings)
    load_network(folder, load_model_metadata(folder / "model_metadata.json"), 3)
    camera = next(spec for spec in measured[0].inputs if spec.kind == "camera")
    assert camera.shape[2] == 3 and measured[0].stack_size == 3
