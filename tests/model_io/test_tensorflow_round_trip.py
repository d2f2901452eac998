"""Models move both ways: racer -> TensorFlow checkpoint -> racer, racer -> frozen graph -> racer, and a graph
TensorFlow wrote from DeepRacer's variable names with weights set here -> racer all compute the same function.
Every TensorFlow step runs in a process of its own (racer.model_io.tensorflow.runner)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from racer.model_io.tensorflow.coach_layout import (
    POLICY_OUTPUT_NODE,
    VALUE_NETWORK,
    coach_tensors_from_racer,
    coach_variables,
    graph_spec,
    input_node,
)
from racer.model_io.tensorflow.convert import (
    ExportJob,
    UnsupportedGraphError,
    network_from_frozen_graph,
    network_from_tf_checkpoint,
    tensorflow_files,
)
from racer.model_io.tensorflow.runner import run_tool, run_tools
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.networks import (
    ActorCritic,
    build_actor_critic,
    policy_config_from_metadata,
)

pytestmark = pytest.mark.slow

DISCRETE = {
    "action_space": [{"steering_angle": angle, "speed": 1.5} for angle in (-30, -10, 0, 10, 30)],
    "sensor": ["FRONT_FACING_CAMERA", "LIDAR"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "version": "5",
}
CONTINUOUS = {
    "action_space": {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 0.5, "high": 2}},
    "action_space_type": "continuous",
    "sensor": ["FRONT_FACING_CAMERA"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_DEEP",
    "version": "5",
}


def observations(config, count: int = 12, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    batch = {}
    for spec in config.inputs:
        if spec.kind == "camera":
            batch[spec.name] = rng.integers(0, 256, (count, *spec.shape)).astype(np.float32)
        else:
            batch[spec.name] = rng.uniform(0.15, 12.0, (count, *spec.shape)).astype(np.float32)
    return batch


def outputs_of(network: ActorCritic, batch: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    with torch.inference_mode():
        tensors = {name: torch.from_numpy(value) for name, value in batch.items()}
        return network.policy_output(tensors).numpy(), network.value(tensors).numpy()


def trained_like(metadata: dict, seed: int) -> ActorCritic:
    torch.manual_seed(seed)
    network = build_actor_critic(parse_model_metadata(metadata, "test"))
    with torch.no_grad():
        network.policy_head.weight.normal_(0.0, 0.05)
        network.policy_head.bias.normal_(0.0, 0.1)
        if network.config.is_continuous:
            network.log_std.copy_(torch.tensor([-0.7, 0.4]))
    return network.eval()


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> dict:
    """Two racer networks (discrete camera+LIDAR shallow; continuous camera deeper) as TensorFlow files."""
    folder = tmp_path_factory.mktemp("tf-export")
    networks = {"discrete": trained_like(DISCRETE, 1), "continuous": trained_like(CONTINUOUS, 2)}
    produced = tensorflow_files([ExportJob(network, "7_Step-700.ckpt", 7) for network in networks.values()])
    paths = {}
    for kind, files in zip(networks, produced, strict=True):
        (folder / kind).mkdir()
        for name, data in files.items():
            (folder / kind / name).write_bytes(data)
        paths[kind] = folder / kind
    return {"networks": networks, "paths": paths}


@pytest.mark.parametrize("kind", ["discrete", "continuous"])
def test_racer_to_tensorflow_checkpoint_to_racer_is_exact(exported, kind):
    network = exported["networks"][kind]
    imported = network_from_tf_checkpoint(exported["paths"][kind] / "7_Step-700.ckpt", network.config)
    assert imported.value_restored and imported.notes == ()
    original, back = network.state_dict(), imported.network.state_dict()
    assert original.keys() == back.keys()
    for key in original:
        assert torch.equal(original[key], back[key]), key
    batch = observations(network.config)
    for ours, theirs in zip(outputs_of(network, batch), outputs_of(imported.network, batch), strict=True):
        np.testing.assert_array_equal(ours, theirs)


@pytest.mark.parametrize("kind", ["discrete", "continuous"])
def test_racer_to_frozen_graph_to_racer_keeps_the_policy_and_starts_a_fresh_value_network(exported, kind):
    network = exported["networks"][kind]
    imported = network_from_frozen_graph(exported["paths"][kind] / "model_7.pb", network.config)
    assert not imported.value_restored
    assert any("value network starts fresh" in note for note in imported.notes)
    original, back = network.state_dict(), imported.network.state_dict()
    for key in original:
        if key.startswith(("policy_tower.", "policy_head.")):
            assert torch.equal(original[key], back[key]), key
    assert not torch.equal(original["value_head.weight"], back["value_head.weight"])
    batch = observations(network.config)
    np.testing.assert_array_equal(outputs_of(network, batch)[0], outputs_of(imported.network, batch)[0])


def test_the_continuous_output_is_deepracers_linear_mean(exported):
    """The frozen graph's `policy` is the dense layer's output itself (tf.identity), not squashed: a mean outside
    [-1, 1] stays outside, and racer's policy output is the same number."""
    network = exported["networks"]["continuous"]
    with torch.no_grad():
        network.policy_head.bias.copy_(torch.tensor([1.7, -2.5]))
    files = tensorflow_files([ExportJob(network, None, 0)])[0]
    path = exported["paths"]["continuous"] / "model_0.pb"
    path.write_bytes(files["model_0.pb"])
    batch = observations(network.config, count=4)
    _, ran = run_tool(
        "run",
        {
            "models": [
                {
                    "key": "c",
                    "frozen_path": str(path),
                    "output": POLICY_OUTPUT_NODE,
                    "inputs": [input_node("FRONT_FACING_CAMERA")],
                }
            ]
        },
        {f"c|{input_node('FRONT_FACING_CAMERA')}": batch["FRONT_FACING_CAMERA"]},
    )
    ours = outputs_of(network, batch)[0]
    assert float(np.abs(ran["c|tensorflow"] - ours).max()) <= 1e-5
    assert ours[:, 0].min() > 1.0 and ours[:, 1].max() < -1.0


def test_a_graph_tensorflow_wrote_from_deepracer_names_imports_into_racer(tmp_path):
    """Weights set here under RL Coach's variable names (not taken from a racer network): TensorFlow builds the
    graph and writes the checkpoint and frozen graph; racer's imports of both compute what TensorFlow computes."""
    config = policy_config_from_metadata(parse_model_metadata(DISCRETE, "test"))
    rng = np.random.default_rng(9)
    weights = {
        variable.name: (rng.normal(0.0, 0.05, variable.shape) if variable.shape else np.asarray(1.0)).astype(np.float32)
        for variable in coach_variables(config)
    }
    request = {
        "key": "w",
        "graph": graph_spec(config),
        "frozen_path": str(tmp_path / "model_3.pb"),
        "checkpoint_prefix": str(tmp_path / "3_Step-30.ckpt"),
    }
    batch = observations(config, seed=4)
    inputs = [input_node(name) for name in batch]
    run = {
        "models": [{"key": "w", "frozen_path": request["frozen_path"], "output": POLICY_OUTPUT_NODE, "inputs": inputs}]
    }
    _, (_, ran) = run_tools(  # one TensorFlow process writes the graph, then runs it
        [
            ("export", {"jobs": [request]}, {f"w|{name}": value for name, value in weights.items()}),
            ("run", run, {f"w|{input_node(name)}": value for name, value in batch.items()}),
        ]
    )
    from_checkpoint = network_from_tf_checkpoint(tmp_path / "3_Step-30.ckpt", config).network
    from_graph = network_from_frozen_graph(tmp_path / "model_3.pb", config).network
    for network in (from_checkpoint, from_graph):
        assert float(np.abs(outputs_of(network, batch)[0] - ran["w|tensorflow"]).max()) <= 1e-5
    back = coach_tensors_from_racer(config, {key: value.numpy() for key, value in from_checkpoint.state_dict().items()})
    for name, value in weights.items():
        np.testing.assert_array_equal(back[name], value.reshape(back[name].shape), err_msg=name)
    assert any(name.startswith(VALUE_NETWORK) for name in back)


def test_a_graph_of_another_network_is_refused_naming_the_variables(exported):
    """model_metadata.json says shallow, the graph is a deeper network: racer names what does not fit."""
    wrong = policy_config_from_metadata(
        parse_model_metadata({**CONTINUOUS, "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW"}, "test")
    )
    with pytest.raises(UnsupportedGraphError) as error:
        network_from_frozen_graph(exported["paths"]["continuous"] / "model_7.pb", wrong)
    message = str(error.value)
    assert "network_1/FRONT_FACING_CAMERA/Conv2d_2/kernel has shape [4, 4, 32, 32]" in message
    assert "unexpected main_level/agent/main/online/network_1/FRONT_FACING_CAMERA/Dense_8/kernel" in message
