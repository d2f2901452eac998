"""Your own network through the trainer: preflight refuses a bad or missing network.json before anything starts
(naming both files, or the layer and field), one iteration trains and stores network.json beside
model_metadata.json, and a clone with a different network is refused naming the difference."""

from __future__ import annotations

import json
import shutil

import pytest

from racer.shared.config import LocalStoreSettings
from racer.shared.model_layout import ModelLayout
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.run_settings import RunOptions
from racer.shared.store import open_store
from racer.shared.user_errors import CloneError, RunConfigError, user_error_types
from racer.trainer.preflight import check_clone_source, preflight
from tests.policy.test_network_file import BATCHNORM
from tests.trainer.test_preflight import (
    DEFAULT_HYPERPARAMETERS,
    DEFAULT_METADATA,
    custom_files_from,
    train_one_iteration,
)


def custom_network_files(tmp_path, network: dict | None = BATCHNORM, name: str = "EXTRA_CONV_BATCHNORM"):
    folder = custom_files_from(tmp_path, DEFAULT_METADATA, DEFAULT_HYPERPARAMETERS)
    metadata = json.loads((folder / "model_metadata.json").read_text())
    (folder / "model_metadata.json").write_text(json.dumps({**metadata, "neural_network": name}))
    if network is not None:
        (folder / "network.json").write_text(json.dumps(network))
    return folder


def test_preflight_refuses_a_missing_or_bad_network_file_naming_the_files(tmp_path):
    folder = custom_network_files(tmp_path, network=None)
    with pytest.raises(
        user_error_types(), match=r"model_metadata.json: neural_network: 'EXTRA_CONV_BATCHNORM' .*network"
    ):
        preflight(folder, RunOptions(1, "racer_oval", ("base",)))
    bad = json.loads(json.dumps(BATCHNORM))
    bad["middleware"][0]["units"] = 0
    (folder / "network.json").write_text(json.dumps(bad))
    with pytest.raises(RunConfigError, match=rf"^{folder / 'network.json'}: middleware\[0\]: units: 0"):
        preflight(folder, RunOptions(1, "racer_oval", ("base",)))


def test_a_custom_network_trains_an_iteration_and_is_stored_with_the_model(tmp_path, redis_settings):
    folder = custom_network_files(tmp_path)
    schedule = {"type": "linear", "initial_value": 1.0, "final_value": 0.5, "decay_steps": 1000}
    preset = {"clip_gradients": 5.0, "value_loss_weight": 0.5, "clipping_decay_schedule": schedule}
    (folder / "preset.json").write_text(json.dumps(preset))
    report = preflight(folder, RunOptions(1, "racer_oval", ("base",)))
    assert report.network is not None and report.network.name == "EXTRA_CONV_BATCHNORM"
    train_one_iteration(folder, report, tmp_path, redis_settings)  # set-up, one episode, update, checkpoint 1
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    assert store.get_bytes(ModelLayout("pair").network) == (folder / "network.json").read_bytes()
    assert store.get_bytes(ModelLayout("pair").preset) == (folder / "preset.json").read_bytes()
    checkpoints = CheckpointStore(store, "pair")
    assert checkpoints.load_policy().config.network == report.network  # what `racer evaluate` rebuilds
    stored = checkpoints.read_info(checkpoints.latest_name()).extra["preset"]
    assert stored["clip_gradients"] == 5.0 and stored["clipping_decay_schedule"] == schedule


def test_a_clone_with_a_different_network_is_refused_naming_the_difference(tmp_path):
    folder = custom_network_files(tmp_path)
    report = preflight(folder, RunOptions(1, "racer_oval", ("base",)))
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    source = ModelLayout("source")
    store.put_bytes(source.model_metadata, (folder / "model_metadata.json").read_bytes())
    wider = json.loads(json.dumps(BATCHNORM))
    wider["middleware"][0]["units"] = 1024
    store.put_bytes(source.network, json.dumps(wider).encode())
    with pytest.raises(CloneError, match=r"its network differs .* at middleware\[0\]\.units: 128 vs 1024"):
        check_clone_source(store, "source", report.model_metadata, "ours/model_metadata.json", report.network)
    store.put_bytes(source.network, json.dumps(BATCHNORM).encode())
    check_clone_source(store, "source", report.model_metadata, "ours/model_metadata.json", report.network)
    shutil.rmtree(tmp_path / "store")
