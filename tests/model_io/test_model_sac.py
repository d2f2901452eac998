"""A SAC model goes through export -> validate -> import like a PPO one; its car bundle outputs the deterministic
action first; cloning it into a PPO model (or the other way) is refused before anything is written."""

from __future__ import annotations

import json
import tarfile

import numpy as np
import onnxruntime
import pytest
import torch

from racer.model_io import FolderDestination, export_model, import_model, validate_location
from racer.shared.config import LocalStoreSettings, ServiceSettings
from racer.shared.deepracer.hyperparameters import hyperparameters_to_json_bytes, load_hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.factory import build_network_for_metadata
from racer.shared.policy.sac_networks import SACNetworks
from racer.shared.run_settings import RunOptions
from racer.shared.store import LocalStore
from racer.shared.user_errors import CloneError
from racer.trainer.training_loop import Trainer, TrainerOptions
from tests.conftest import write_custom_files
from tests.model_io.model_io_builders import real_files

SAC_METADATA = {
    "action_space": {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 1, "high": 2}},
    "action_space_type": "continuous",
    "training_algorithm": "sac",
    "sensor": ["FRONT_FACING_CAMERA"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_DEEP",
    "version": "5",
}


def frames(count: int, seed: int) -> list[dict[str, np.ndarray]]:
    rng = np.random.default_rng(seed)
    return [{"FRONT_FACING_CAMERA": rng.integers(0, 256, (120, 160, 1), dtype=np.uint8)} for _ in range(count)]


@pytest.fixture
def sac_store(tmp_path, deepracer_data):
    store = LocalStore(tmp_path / "store")
    metadata = parse_model_metadata(SAC_METADATA, "SAC_METADATA")
    checkpoints = CheckpointStore(store, "sac")
    checkpoints.put_model_metadata(metadata)
    hyperparameters, _ = load_hyperparameters(deepracer_data / "config" / "dots_hyperparameters_sac.json")
    store.put_bytes("sac/ip/hyperparameters.json", hyperparameters_to_json_bytes(hyperparameters, "sac"))
    store.put_bytes("sac/reward_function.py", real_files().reward_function)
    store.put_bytes("sac/training_params.yaml", real_files().training_params)
    networks = {}
    for number in range(2):
        torch.manual_seed(number)
        network = build_network_for_metadata(metadata)
        checkpoints.save(number, 100 * number, network, None, metadata, hyperparameters)
        networks[number] = network.eval()
    checkpoints.record_evaluation("1_Step-100.ckpt", 60.0, 1.0)
    return store, networks


def test_a_sac_model_exports_validates_and_imports(sac_store, tmp_path):
    store, networks = sac_store
    exported = tmp_path / "exported"
    result = export_model(store, "sac", FolderDestination(exported))
    assert result.ok, (result.report.problems, result.problems)
    report, source = validate_location(str(exported))
    assert report.ok, [problem.render() for problem in report.problems]

    other = LocalStore(tmp_path / "other")
    assert import_model(source, other, "imported").ok
    imported = CheckpointStore(other, "imported")
    policy = imported.load_inference_policy(imported.select("best"))
    for observation in frames(5, seed=3):
        with torch.no_grad():
            expected = (
                networks[1]
                .policy_output({"FRONT_FACING_CAMERA": torch.from_numpy(observation["FRONT_FACING_CAMERA"][None])})[0]
                .numpy()
            )
        np.testing.assert_allclose(policy.act(observation, greedy=True)[0], expected, atol=1e-5)
    assert isinstance(imported.load_policy("1_Step-100.ckpt"), SACNetworks)

    with tarfile.open(exported / "model.tar.gz") as bundle:
        onnx_bytes = bundle.extractfile("agent/model.onnx").read()
    session = onnxruntime.InferenceSession(onnx_bytes, providers=["CPUExecutionProvider"])
    assert [output.name for output in session.get_outputs()] == ["policy", "policy_mean", "policy_log_std"]
    image = frames(1, seed=4)[0]["FRONT_FACING_CAMERA"][None].astype(np.float32)
    action, mean, _log_std = session.run(None, {"FRONT_FACING_CAMERA": image})
    np.testing.assert_allclose(action, np.tanh(mean), atol=1e-6)  # the car reads the first output: the mean action


@pytest.mark.parametrize("ours", ["clipped_ppo", "sac"])
def test_cloning_across_algorithms_is_refused(sac_store, tmp_path, ours, redis_settings):
    store, _ = sac_store
    custom = write_custom_files(tmp_path / "custom", min_eval_trials=None)
    metadata = json.loads((custom / "model_metadata.json").read_text())
    if ours == "sac":
        metadata = dict(SAC_METADATA)
        store.put_bytes(
            "ppo/model/model_metadata.json", json.dumps({**SAC_METADATA, "training_algorithm": "clipped_ppo"}).encode()
        )
    (custom / "model_metadata.json").write_text(json.dumps(metadata))
    source = "sac" if ours == "clipped_ppo" else "ppo"
    settings = ServiceSettings(redis=redis_settings, store=LocalStoreSettings(store.root))
    trainer = Trainer(
        settings,
        TrainerOptions(
            model_prefix="clone",
            custom_files=custom,
            run=RunOptions(num_workers=1, track="racer_oval", worlds=("base",)),
            pretrained_prefix=source,
        ),
    )
    with pytest.raises(CloneError, match="training_algorithm: cannot clone .*SAC clones only SAC"):
        trainer.setup()
    assert not (store.root / "clone").exists()  # refused before anything of the new model was written


def test_sac_clones_sac(sac_store, tmp_path, redis_settings):
    store, networks = sac_store
    custom = write_custom_files(tmp_path / "custom", min_eval_trials=None)
    (custom / "model_metadata.json").write_text(json.dumps(SAC_METADATA))
    settings = ServiceSettings(redis=redis_settings, store=LocalStoreSettings(store.root))
    trainer = Trainer(
        settings,
        TrainerOptions(
            model_prefix="clone",
            custom_files=custom,
            run=RunOptions(num_workers=1, track="racer_oval", worlds=("base",)),
            pretrained_prefix="sac",
            sac_replay_memory_mb=16,
        ),
    )
    assert trainer.setup() == 0
    for (key, cloned), original in zip(
        trainer.network.state_dict().items(), networks[1].state_dict().values(), strict=True
    ):
        assert torch.equal(cloned, original), key  # the last checkpoint's weights, target V included
    assert CheckpointStore(store, "clone").latest_name() == "0_Step-0.ckpt"
