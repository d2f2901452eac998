"""Your own network (network.json): parsing and refusal naming the layer and the field, DeepRacer's networks unchanged
when written as a network file, batch-norm / tanh / dropout layers, the size check, and the checkpoint round trip."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
import torch

from racer.model_io.tensorflow.coach_layout import tower_layers
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy import network_size
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.network_file import (
    NetworkFileError,
    network_difference,
    network_for_metadata,
    parse_network_file,
)
from racer.shared.policy.network_size import network_size_findings
from racer.shared.policy.networks import ActorCritic, PolicyConfig, policy_config_from_metadata
from racer.shared.store import LocalStore

SHALLOW_AS_FILE = {
    "name": "MY_SHALLOW",
    "input_embedders": {
        "FRONT_FACING_CAMERA": [
            {"type": "Conv2d", "num_filters": 32, "kernel_size": 8, "strides": 4},
            {"type": "Conv2d", "num_filters": 64, "kernel_size": 4, "strides": 2},
            {"type": "Conv2d", "num_filters": 64, "kernel_size": 3, "strides": 1},
        ],
        "LIDAR": [{"type": "Dense", "units": 256}, {"type": "Dense", "units": 256}],
    },
    "middleware": [{"type": "Dense", "units": 512}],
}
BATCHNORM = {
    "name": "EXTRA_CONV_BATCHNORM",
    "input_embedders": {
        "FRONT_FACING_CAMERA": [
            {"type": "Conv2d", "num_filters": 16, "kernel_size": 8, "strides": 4, "batchnorm": True},
            {"type": "Conv2d", "num_filters": 32, "kernel_size": 4, "strides": 2, "batchnorm": True},
            {"type": "Conv2d", "num_filters": 32, "kernel_size": 3, "strides": 2},
            {"type": "Dense", "units": 64, "activation": "tanh", "dropout": 0.1},
        ],
    },
    "middleware": [
        {"type": "Dense", "units": 128, "batchnorm": True},
        {"type": "Dense", "units": 64, "activation": "none"},
    ],
}
ACTIONS = [{"steering_angle": angle, "speed": 1.0} for angle in (-30, 0, 30)]


def metadata(network: str, sensors=("FRONT_FACING_CAMERA",)):
    return parse_model_metadata(
        {"action_space": ACTIONS, "sensor": list(sensors), "neural_network": network, "version": "5"}
    )


def batch(config: PolicyConfig, size: int = 3, seed: int = 0) -> dict[str, torch.Tensor]:
    rng = np.random.default_rng(seed)
    return {
        spec.name: torch.from_numpy(rng.integers(0, 256, size=(size, *spec.shape), dtype=np.uint8))
        if spec.kind == "camera"
        else torch.from_numpy(rng.uniform(0.15, 1, size=(size, *spec.shape)).astype(np.float32))
        for spec in config.inputs
    }


def test_a_network_file_parses_and_round_trips():
    network = parse_network_file(BATCHNORM)
    assert network.name == "EXTRA_CONV_BATCHNORM"
    assert network.embedder("FRONT_FACING_CAMERA")[0].batchnorm
    assert network.embedder("FRONT_FACING_CAMERA")[3].activation == "tanh"
    assert parse_network_file(network.to_dict()) == network
    config = policy_config_from_metadata(metadata("EXTRA_CONV_BATCHNORM"), network)
    assert PolicyConfig.from_dict(json.loads(json.dumps(config.to_dict()))) == config


def _with(path: tuple, value) -> dict:
    data = copy.deepcopy(BATCHNORM)
    target = data
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return data


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        (("input_embedders", "FRONT_FACING_CAMERA", 2, "kernel_size"), 0, r"FRONT_FACING_CAMERA\[2\]: kernel_size: 0"),
        (("input_embedders", "FRONT_FACING_CAMERA", 1, "activation"), "gelu", r"CAMERA\[1\]: activation: 'gelu'"),
        (("input_embedders", "FRONT_FACING_CAMERA", 0, "batchnorm"), "yes", r"CAMERA\[0\]: batchnorm: 'yes'"),
        (("input_embedders", "FRONT_FACING_CAMERA", 3, "dropout"), 1.5, r"CAMERA\[3\]: dropout: 1.5"),
        (("input_embedders", "FRONT_FACING_CAMERA", 3, "filters"), 3, r"CAMERA\[3\]: filters: not a Dense field"),
        (("input_embedders", "FRONT_FACING_CAMERA", 3, "type"), "Conv2d", r"CAMERA\[3\]: units: not a Conv2d field"),
        (("input_embedders", "FRONT_FACING_CAMERA", 0, "type"), "LSTM", r"CAMERA\[0\]: type: 'LSTM'"),
        (
            ("input_embedders", "LIDAR"),
            [{"type": "Conv2d", "num_filters": 1, "kernel_size": 1, "strides": 1}],
            r"input_embedders.LIDAR\[0\]: type: Conv2d is not allowed",
        ),  # fmt: skip
        (("input_embedders", "RADAR"), [], r"input_embedders.RADAR: not a DeepRacer sensor"),
        (("middleware", 1, "units"), -4, r"middleware\[1\]: units: -4 is not a positive integer"),
        (("name",), "DEEP_CONVOLUTIONAL_NETWORK", r"name: .* one of DeepRacer's built-in networks"),
        (("layers",), [], r"layers: not a network file field"),
    ],
)
def test_a_bad_network_file_is_refused_naming_the_layer_and_the_field(path, value, message):
    with pytest.raises(NetworkFileError, match=rf"^network.json: .*{message}"):
        parse_network_file(_with(path, value))


def test_a_dense_layer_before_a_conv_is_refused():
    data = _with(("input_embedders", "FRONT_FACING_CAMERA", 1), {"type": "Dense", "units": 8})
    with pytest.raises(NetworkFileError, match=r"CAMERA\[2\]: type: Conv2d is not allowed: .*before its Dense"):
        parse_network_file(data)


def test_deepracers_shallow_network_written_as_a_file_builds_the_same_network():
    """The layer table is one: the shallow network as network.json has the same modules, initial weights and outputs."""
    sensors = ("FRONT_FACING_CAMERA", "LIDAR")
    torch.manual_seed(3)
    builtin = ActorCritic(policy_config_from_metadata(metadata("DEEP_CONVOLUTIONAL_NETWORK_SHALLOW", sensors)))
    torch.manual_seed(3)
    own = ActorCritic(policy_config_from_metadata(metadata("MY_SHALLOW", sensors), parse_network_file(SHALLOW_AS_FILE)))
    assert builtin.state_dict().keys() == own.state_dict().keys()
    for key, tensor in builtin.state_dict().items():
        assert torch.equal(tensor, own.state_dict()[key]), key
    observations = batch(own.config)
    with torch.no_grad():
        assert torch.equal(builtin.policy_output(observations), own.policy_output(observations))


def test_batchnorm_tanh_and_dropout_train_and_act_deterministically_when_evaluating():
    config = policy_config_from_metadata(metadata("EXTRA_CONV_BATCHNORM"), parse_network_file(BATCHNORM))
    network = ActorCritic(config)
    kinds = [type(module).__name__ for module in network.policy_tower.embedders["FRONT_FACING_CAMERA"].convs]
    assert kinds == ["Conv2d", "BatchNorm2d", "ReLU", "Conv2d", "BatchNorm2d", "ReLU", "Conv2d", "ReLU"]
    dense = [type(module).__name__ for module in network.policy_tower.embedders["FRONT_FACING_CAMERA"].dense]
    assert dense == ["Linear", "Tanh", "Dropout"]
    middleware = [type(module).__name__ for module in network.policy_tower.middleware]
    assert middleware == ["Linear", "BatchNorm1d", "ReLU", "Linear"]
    observations = batch(config, size=8)
    loss = network.distribution(observations).entropy().mean() + network.value(observations).square().mean()
    loss.backward()  # trains (batch statistics, dropout on)
    assert network.policy_tower.middleware[0].weight.grad is not None
    network.eval()
    one = {name: array[0].numpy() for name, array in observations.items()}
    assert network.act(one, greedy=True) == network.act(one, greedy=True)


@pytest.mark.serial  # asserts a wall-time bound
def test_the_size_check_measures_parameters_and_the_forward_pass(monkeypatch):
    config = policy_config_from_metadata(metadata("EXTRA_CONV_BATCHNORM"), parse_network_file(BATCHNORM))
    findings = network_size_findings(config)
    assert findings.parameters == sum(p.numel() for p in ActorCritic(config).parameters())
    assert 0 < findings.forward_s < network_size.MAX_FORWARD_S and not findings.errors
    monkeypatch.setattr(network_size, "MAX_FORWARD_S", 0.0)
    monkeypatch.setattr(network_size, "MAX_PARAMETERS", 1000)
    errors = network_size_findings(config, "custom/network.json").errors
    assert any(f"{findings.parameters:,} parameters" in error for error in errors)
    assert any("custom/network.json: a policy forward pass takes" in error for error in errors)


def test_model_metadata_and_network_file_must_agree(tmp_path):
    (tmp_path / "network.json").write_text(json.dumps(BATCHNORM))
    with pytest.raises(
        NetworkFileError, match=r"model_metadata.json: neural_network: 'OTHER' does not match .*network"
    ):
        network_for_metadata(tmp_path, metadata("OTHER"))
    with pytest.raises(NetworkFileError, match=r"network.json: input_embedders: no embedder for LIDAR"):
        network_for_metadata(tmp_path, metadata("EXTRA_CONV_BATCHNORM", ("FRONT_FACING_CAMERA", "LIDAR")))
    assert network_for_metadata(tmp_path, metadata("DEEP_CONVOLUTIONAL_NETWORK")) is None
    assert network_for_metadata(tmp_path, metadata("EXTRA_CONV_BATCHNORM")) == parse_network_file(BATCHNORM)
    with pytest.raises(ValueError, match="no network file defines it"):
        policy_config_from_metadata(metadata("EXTRA_CONV_BATCHNORM"))


def test_network_difference_names_the_field():
    wider = _with(("middleware", 0, "units"), 1024)
    ours, theirs = parse_network_file(BATCHNORM).to_dict(), parse_network_file(wider).to_dict()
    assert network_difference(ours, theirs) == "middleware[0].units: 128 vs 1024"
    assert network_difference(ours, ours) is None


def test_a_custom_network_round_trips_through_a_checkpoint_and_refuses_the_frozen_graph(tmp_path):
    config = policy_config_from_metadata(metadata("EXTRA_CONV_BATCHNORM"), parse_network_file(BATCHNORM))
    network = ActorCritic(config)
    network(batch(config, size=8))  # moves the batch-norm running statistics
    store = CheckpointStore(LocalStore(tmp_path), "runs/own")
    name = store.save(0, 0, network, model_metadata=metadata("EXTRA_CONV_BATCHNORM"))
    loaded = store.load_policy(name)
    assert loaded.config == config and not loaded.training
    network.eval()
    observations = batch(config, seed=5)
    with torch.no_grad():
        assert torch.equal(loaded.policy_output(observations), network.policy_output(observations))
    worker = store.load_inference_policy(name)  # the exported ONNX model the workers act with
    one = {key: array[0].numpy() for key, array in observations.items()}
    assert worker.act(one, greedy=True)[0] == network.act(one, greedy=True)[0]
    manifest = json.loads((tmp_path / "runs/own/model" / f"{name}.json").read_text())
    assert manifest["policy_config"]["network"]["name"] == "EXTRA_CONV_BATCHNORM"
    layers = tower_layers(config)[0]["layers"]  # the TensorFlow export knows it: RL Coach's names, batch-norm too
    assert [layer["scope"] for layer in layers] == ["Conv2d_0", "Conv2d_2", "Conv2d_4", "Dense_6"]
    assert layers[0]["batchnorm"]["scope"] == "BatchnormActivationDropout_1_batchnorm"
