"""Your own network (network.json) and stacked frames reach DeepRacer's frozen graph: RL Coach's names for every layer
(batch-norm's running statistics included), the camera placeholder with C * N channels, stereo decided by the sensor
and never by the channel count; and the graph imports back into racer computing the same function."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

from racer.model_io.deepracer_import import import_frozen_graphs
from racer.model_io.destinations import FolderDestination
from racer.model_io.import_export import export_model
from racer.model_io.sources import FolderSource
from racer.model_io.tensorflow.coach_layout import coach_tensors_from_racer, coach_variables, input_node, tower_layers
from racer.model_io.tensorflow.convert import UnsupportedGraphError, output_node
from racer.model_io.tensorflow.runner import run_tool, tensorflow_available
from racer.shared.deepracer.hyperparameters import parse_hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.model_layout import ModelLayout
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.network_file import parse_network_file
from racer.shared.policy.networks import ActorCritic, policy_config_from_metadata
from racer.shared.store import LocalStore
from tests.model_io.model_io_builders import real_files
from tests.model_io.tf_proof_examples import EXAMPLE_NETWORKS
from tests.policy.test_network_file import ACTIONS, BATCHNORM


def config_for(network: str, sensors: tuple[str, ...], stack_size: int, network_file: dict | None = None):
    metadata = parse_model_metadata(
        {"action_space": ACTIONS, "sensor": list(sensors), "neural_network": network, "version": "5"}, "test"
    )
    parsed = parse_network_file(network_file) if network_file else None
    return policy_config_from_metadata(metadata, parsed, stack_size)


def racer_arrays(network: ActorCritic) -> dict[str, np.ndarray]:
    return {key: value.detach().numpy() for key, value in network.state_dict().items()}


@pytest.mark.parametrize(
    ("sensor", "stack_size", "kernel", "convs"),
    [
        ("FRONT_FACING_CAMERA", 2, [5, 5, 2, 32], 4),  # two mono frames: 2 channels, still the camera's layers
        ("STEREO_CAMERAS", 1, [3, 3, 2, 32], 5),  # one stereo pair: 2 channels, the stereo layers
        ("STEREO_CAMERAS", 2, [3, 3, 4, 32], 5),
    ],
)
def test_stereo_is_the_sensor_not_the_channel_count(sensor, stack_size, kernel, convs):
    """DEEP_CONVOLUTIONAL_NETWORK gives the front camera 5x5 convolutions and stereo 3x3 ones: a two-frame mono
    stack has stereo's channel count and must keep the camera's layers."""
    config = config_for("DEEP_CONVOLUTIONAL_NETWORK", (sensor,), stack_size)
    embedder = tower_layers(config)[0]
    assert embedder["shape"] == [120, 160, 2 * stack_size if sensor == "STEREO_CAMERAS" else stack_size]
    assert embedder["layers"][0]["kernel"] == kernel
    assert sum(layer["type"] == "conv" for layer in embedder["layers"]) == convs
    coach_tensors_from_racer(config, racer_arrays(ActorCritic(config)))  # every shape agrees with racer's network


def test_every_racer_tensor_of_a_custom_network_has_its_coach_variable():
    """Kernels, biases and batch-norm's gamma, beta, moving mean and variance of both towers, and nothing twice
    (num_batches_tracked only counts training steps: no function of it)."""
    config = config_for("EXTRA_CONV_BATCHNORM", ("FRONT_FACING_CAMERA",), 2, BATCHNORM)
    keys = [variable.racer_key for variable in coach_variables(config) if variable.racer_key is not None]
    state = ActorCritic(config).state_dict()
    assert sorted(keys) == sorted(key for key in state if not key.endswith("num_batches_tracked"))
    names = {variable.name for variable in coach_variables(config)}
    camera = "main_level/agent/main/online/network_1/FRONT_FACING_CAMERA"
    assert f"{camera}/BatchnormActivationDropout_3_batchnorm/moving_variance" in names
    assert f"{camera}/Dense_6/kernel" in names


def trained_like(config, seed: int) -> ActorCritic:
    """Weights and batch-norm statistics far from their initial values, so a dropped or misplaced batch-norm shows."""
    torch.manual_seed(seed)
    network = ActorCritic(config)
    with torch.no_grad():
        network.policy_head.weight.normal_(0.0, 0.05)
        for module in network.modules():
            if isinstance(module, torch.nn.BatchNorm1d | torch.nn.BatchNorm2d):
                module.running_mean.uniform_(-0.5, 0.5)
                module.running_var.uniform_(0.3, 3.0)
                module.weight.uniform_(0.5, 1.5)
                module.bias.uniform_(-0.3, 0.3)
    return network.eval()


@pytest.mark.slow
@pytest.mark.skipif(not tensorflow_available(), reason="needs the TensorFlow extra")
def test_a_custom_stacked_model_exports_and_imports_back_computing_the_same(tmp_path):
    """racer -> `racer model export` (frozen graph) -> TensorFlow equals racer; the graph folder -> `racer model
    import` (network.json and stack_size read from the folder) -> racer equals racer; without the stack_size the
    import says what is missing. Four TensorFlow processes."""
    network_file = {
        **BATCHNORM,
        "input_embedders": {
            **BATCHNORM["input_embedders"],
            "LIDAR": [{"type": "Dense", "units": 32, "batchnorm": True, "activation": "tanh"}],
        },
    }
    metadata = parse_model_metadata(
        {"action_space": ACTIONS, "sensor": ["FRONT_FACING_CAMERA", "LIDAR"], "neural_network": BATCHNORM["name"]},
        "test",
    )
    config = policy_config_from_metadata(metadata, parse_network_file(network_file), 2)
    network = trained_like(config, seed=3)
    store = LocalStore(tmp_path / "store")
    layout = ModelLayout("own")
    checkpoints = CheckpointStore(store, "own")
    checkpoints.put_model_metadata(metadata)
    hyperparameters, _ = parse_hyperparameters(
        {**json.loads(real_files().hyperparameters), "stack_size": 2}, "hyperparameters.json"
    )
    checkpoints.put_hyperparameters(hyperparameters)
    store.put_bytes(layout.network, json.dumps(network_file).encode())
    store.put_bytes("own/reward_function.py", real_files().reward_function)
    store.put_bytes("own/training_params.yaml", real_files().training_params)
    checkpoints.save(0, 100, network, model_metadata=metadata)

    exported = tmp_path / "exported"
    result = export_model(store, "own", FolderDestination(exported), tensorflow=True)
    assert result.ok, (result.report.problems, result.problems)
    assert json.loads((exported / "model" / "network.json").read_text()) == network_file

    rng = np.random.default_rng(4)
    batch = {
        "FRONT_FACING_CAMERA": rng.integers(0, 256, (6, 120, 160, 2)).astype(np.float32),
        "LIDAR": rng.uniform(0.15, 12.0, (6, 64)).astype(np.float32),
    }
    with torch.inference_mode():
        expected = network.policy_output({name: torch.from_numpy(value) for name, value in batch.items()}).numpy()
    nodes = {name: input_node(name) for name in batch}
    model = {"key": "own", "frozen_path": str(exported / "model" / "model_0.pb"), "output": output_node(config)}
    _, outputs = run_tool(
        "run",
        {"models": [{**model, "inputs": list(nodes.values())}]},
        {f"own|{nodes[name]}": value for name, value in batch.items()},
    )
    assert np.abs(outputs["own|tensorflow"] - expected).max() <= 1e-5

    graph_only = tmp_path / "graph-only"  # what the importer takes: metadata, network file, hyperparameters, graph
    for key in ("model/model_metadata.json", "model/network.json", "ip/hyperparameters.json", "model/model_0.pb"):
        (graph_only / key).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(exported / key, graph_only / key)
    other = LocalStore(tmp_path / "other")
    outcome = import_frozen_graphs(FolderSource(graph_only), ("model/model_0.pb",), other, "back")
    imported = CheckpointStore(other, "back").load_policy(outcome.written[0])
    assert imported.config == config
    assert other.get_bytes(ModelLayout("back").network) == (graph_only / "model" / "network.json").read_bytes()
    with torch.inference_mode():
        back = imported.policy_output({name: torch.from_numpy(value) for name, value in batch.items()}).numpy()
    np.testing.assert_array_equal(back, expected)

    (graph_only / "ip" / "hyperparameters.json").unlink()  # the car's tarball says nothing of the stack either
    with pytest.raises(UnsupportedGraphError, match=r"racer needs \[-1, 120, 160, 1\] \(stack_size 1\); a graph of"):
        import_frozen_graphs(FolderSource(graph_only), ("model/model_0.pb",), LocalStore(tmp_path / "third"), "x")


def test_the_proof_examples_are_the_documented_network_files():
    """The examples' proof (tf_proof_examples.py) proves the network files docs/custom-networks.md shows, not others."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "custom-networks.md").read_text()
    documented = {}
    for block in re.findall(r"```json\n(.*?)```", text, flags=re.S):
        data = json.loads(block)
        if isinstance(data, dict) and "input_embedders" in data:
            documented[data["name"]] = data
    assert documented == EXAMPLE_NETWORKS


@pytest.mark.slow
@pytest.mark.timeout(2400)
@pytest.mark.skipif(not tensorflow_available(), reason="needs the TensorFlow extra")
def test_the_examples_compute_the_same_function_in_every_runtime(deepracer_data):
    """The documented networks and a two-frame stack (6 models) on DeepRacer's 92 Gazebo frames: TensorFlow, OpenVINO
    and LiteRT at fp32 within 1e-5 of racer; at fp16 the same greedy action on 99 % of the frames and within 1e-3 or
    two fp16 steps at the output's size. Batch-norm carries the frames' own running statistics, so a dropped or
    misplaced one shows."""
    from tests.model_io.tf_proof import RUNTIMES, prove_examples

    figures = prove_examples(())
    assert figures["models"] == 6
    for runtime in RUNTIMES:
        assert figures[runtime]["min_same_greedy_action"] >= 0.99, figures
    assert figures["goals_met"], figures
