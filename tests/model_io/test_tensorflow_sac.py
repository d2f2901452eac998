"""SAC models both ways: racer SAC -> TensorFlow checkpoint (RL Coach's policy, Q and V networks) -> racer, racer
SAC -> frozen graph -> racer, TensorFlow restores the checkpoint into the graph it came with and its Q, fed actions
in DeepRacer's units (degrees, m/s), equals racer's Q of the same actions in [-1, 1]; `racer model export` (also
`--for droa`) writes SAC TensorFlow files that validate and import back into a SAC model racer drives.
Every TensorFlow step runs in a process of its own."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import torch

from racer.model_io import FolderDestination, export_model, import_model, validate_location
from racer.model_io.deepracer_import import convert_tf_checkpoints
from racer.model_io.tensorflow.coach_sac_layout import (
    SAC_POLICY_OUTPUT_NODE,
    SAC_Q_NETWORK,
    sac_coach_variables,
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
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.factory import build_network_for_metadata
from racer.shared.policy.networks import ActorCritic
from racer.shared.policy.sac_networks import SACNetworks
from racer.shared.store import LocalStore
from tests.model_io.test_model_sac import sac_store  # noqa: F401 (a fixture)
from tests.model_io.test_tensorflow_round_trip import CONTINUOUS, observations

pytestmark = pytest.mark.slow

SAC_TWO_SENSORS = {
    "action_space": {"steering_angle": {"low": -25, "high": 30}, "speed": {"low": 0.6, "high": 3.1}},
    "action_space_type": "continuous",
    "training_algorithm": "sac",
    "sensor": ["FRONT_FACING_CAMERA", "SECTOR_LIDAR"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_DEEP",
    "version": "5",
}


@pytest.fixture(scope="module")
def sac_export(tmp_path_factory) -> dict:
    metadata = parse_model_metadata(SAC_TWO_SENSORS, "SAC_TWO_SENSORS")
    torch.manual_seed(11)
    network = build_network_for_metadata(metadata).eval()
    assert isinstance(network, SACNetworks)
    folder = tmp_path_factory.mktemp("sac-export")
    files = tensorflow_files([ExportJob(network, "4_Step-400.ckpt", 4, metadata.continuous_action_space)])[0]
    for name, data in files.items():
        (folder / name).write_bytes(data)
    return {"network": network, "metadata": metadata, "folder": folder}


def q_of(network: SACNetworks, batch: dict[str, np.ndarray], actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    with torch.inference_mode():
        features = network.q_features({name: torch.from_numpy(value) for name, value in batch.items()})
        q1, q2 = network.q_values(features, torch.from_numpy(actions))
    return q1.numpy(), q2.numpy()


def test_racer_sac_to_tensorflow_checkpoint_to_racer_restores_policy_q_and_v(sac_export):
    network, metadata = sac_export["network"], sac_export["metadata"]
    imported = network_from_tf_checkpoint(
        sac_export["folder"] / "4_Step-400.ckpt", network.config, metadata.continuous_action_space
    )
    assert isinstance(imported.network, SACNetworks)
    assert imported.value_restored and imported.notes == ()
    original, back = network.state_dict(), imported.network.state_dict()
    assert original.keys() == back.keys()
    for key in original:
        if key.startswith(("q_head.q1.0.", "q_head.q2.0.")):  # rescaled to DeepRacer's action units and back
            torch.testing.assert_close(back[key], original[key], rtol=1e-6, atol=1e-6)
        else:
            assert torch.equal(original[key], back[key]), key
    batch = observations(network.config)
    actions = np.random.default_rng(3).uniform(-1, 1, (len(batch["SECTOR_LIDAR"]), 2)).astype(np.float32)
    for ours, theirs in zip(q_of(network, batch, actions), q_of(imported.network, batch, actions), strict=True):
        np.testing.assert_allclose(theirs, ours, rtol=1e-5, atol=1e-5)
    with torch.inference_mode():
        tensors = {name: torch.from_numpy(value) for name, value in batch.items()}
        np.testing.assert_array_equal(network.policy_output(tensors), imported.network.policy_output(tensors))
        np.testing.assert_array_equal(network.value(tensors), imported.network.value(tensors))
        np.testing.assert_array_equal(imported.network.target_value(tensors), imported.network.value(tensors))


def test_tensorflow_restores_the_sac_checkpoint_and_its_q_reads_deepracer_action_units(sac_export):
    """RL Coach's saver names (policy, q, v networks, no target) with no missing or mismatched variable, and Q1 of
    TensorFlow's graph fed degrees and m/s equals racer's Q1 of the same actions in [-1, 1]."""
    network, space = sac_export["network"], sac_export["metadata"].continuous_action_space
    prefix = sac_export["folder"] / "4_Step-400.ckpt"
    batch = observations(network.config, count=10, seed=4)
    actions = np.random.default_rng(5).uniform(-1, 1, (10, 2)).astype(np.float32)
    low = np.array([space.steering_angle_low_deg, space.speed_low_mps], np.float32)
    high = np.array([space.steering_angle_high_deg, space.speed_high_mps], np.float32)
    deepracer_actions = low + (actions + 1.0) * 0.5 * (high - low)
    feeds = {f"{SAC_Q_NETWORK}/{name}/{name}": value for name, value in batch.items()}
    feeds[f"{SAC_Q_NETWORK}/q_values_head_0/action"] = deepracer_actions
    restore = {
        "meta_path": str(prefix) + ".meta",
        "checkpoint_prefix": str(prefix),
        "inputs": list(feeds),
        "output": f"{SAC_Q_NETWORK}/q_values_head_0/q1_head/q1_output/BiasAdd",
    }
    (listed, _), (result, tensors) = run_tools(  # one TensorFlow process
        [
            ("read_checkpoint", {"checkpoint_prefix": str(prefix), "values": False}, None),
            ("restore_meta", restore, feeds),
        ]
    )
    ours = {variable.name: variable.shape for variable in sac_coach_variables(network.config)}
    assert {name: tuple(item["shape"]) for name, item in listed["variables"].items()} == ours
    assert not any("/target/" in name for name in ours)
    assert result == {"missing": [], "mismatched": [], "restored": True}
    np.testing.assert_allclose(tensors["policy"][:, 0], q_of(network, batch, actions)[0], rtol=1e-4, atol=1e-4)


def test_racer_sac_to_frozen_graph_to_racer_keeps_the_policy_and_starts_fresh_critics(sac_export):
    network = sac_export["network"]
    imported = network_from_frozen_graph(sac_export["folder"] / "model_4.pb", network.config)
    assert isinstance(imported.network, SACNetworks) and not imported.value_restored
    assert any("Q and V networks start fresh" in note for note in imported.notes)
    original, back = network.state_dict(), imported.network.state_dict()
    for key in original:
        if key.startswith(("policy_tower.", "policy_head.hidden.", "policy_head.mean.")):
            assert torch.equal(original[key], back[key]), key
    assert not torch.equal(original["q_head.q1.4.weight"], back["q_head.q1.4.weight"])
    batch = {name: torch.from_numpy(value) for name, value in observations(network.config).items()}
    with torch.inference_mode():
        np.testing.assert_array_equal(network.policy_output(batch), imported.network.policy_output(batch))


def test_the_sac_graph_outputs_deepracers_mean_before_tanh(sac_export):
    """`sac_policy_head_0/policy` is the Gaussian mean before the squash (the SimApp's frozen output); racer drives
    tanh of it, as the SimApp's SAC head does after that node."""
    network = copy.deepcopy(sac_export["network"])
    with torch.no_grad():
        network.policy_head.mean.bias.copy_(torch.tensor([1.7, -2.2]))
    batch = observations(network.config, count=6)
    path = sac_export["folder"] / "wide_mean.pb"
    path.write_bytes(tensorflow_files([ExportJob(network, None, 1)])[0]["model_1.pb"])
    nodes = [f"main_level/agent/policy/online/network_0/{name}/{name}" for name in batch]
    _, outputs = run_tool(
        "run",
        {"models": [{"key": "m", "frozen_path": str(path), "inputs": nodes, "output": SAC_POLICY_OUTPUT_NODE}]},
        {f"m|{node}": batch[name] for node, name in zip(nodes, batch, strict=True)},
    )
    with torch.inference_mode():
        mean, _ = network.policy_distribution({name: torch.from_numpy(value) for name, value in batch.items()})
    graph = outputs["m|tensorflow"]
    np.testing.assert_allclose(graph, mean.numpy(), atol=1e-5)
    assert float(np.abs(graph).max()) > 1.0  # not squashed


def test_a_ppo_graph_is_refused_for_sac_metadata_and_the_other_way(sac_export, tmp_path):
    sac = sac_export["network"]
    ppo_metadata = parse_model_metadata(CONTINUOUS, "CONTINUOUS")
    torch.manual_seed(2)
    ppo = build_network_for_metadata(ppo_metadata).eval()
    assert isinstance(ppo, ActorCritic)
    files = tensorflow_files([ExportJob(ppo, "1_Step-1.ckpt", 1)])[0]
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    with pytest.raises(UnsupportedGraphError, match="training_algorithm is sac"):
        network_from_frozen_graph(tmp_path / "model_1.pb", sac.config)
    with pytest.raises(
        UnsupportedGraphError, match="model_metadata.json says SAC, but the checkpoint is a clipped-PPO"
    ):
        network_from_tf_checkpoint(
            tmp_path / "1_Step-1.ckpt", sac.config, sac_export["metadata"].continuous_action_space
        )
    with pytest.raises(UnsupportedGraphError, match="training_algorithm is clipped_ppo"):
        network_from_frozen_graph(sac_export["folder"] / "model_4.pb", ppo.config)
    with pytest.raises(UnsupportedGraphError, match="this is a SAC model"):
        network_from_tf_checkpoint(sac_export["folder"] / "4_Step-400.ckpt", ppo.config)


@pytest.mark.parametrize("layout", ["racer", "droa"])
def test_a_sac_export_with_tensorflow_files_validates_and_imports_as_sac(sac_store, tmp_path, layout):  # noqa: F811
    """`racer model export` (and `--for droa`) writes SAC TensorFlow files that validate; DRoA's folder imports back
    into a SAC model whose policy and Q are the exported checkpoint's."""
    store, networks = sac_store
    exported = tmp_path / "exported"
    result = export_model(store, "sac", FolderDestination(exported), tensorflow=True, layout=layout)
    assert result.ok, (result.report.problems, result.problems)
    written = sorted(path.name.removesuffix(".index") for path in (exported / "model").glob("*.ckpt.index"))
    assert "1_Step-100.ckpt" in written  # the best checkpoint, which the car bundle's agent/model.pb holds
    for name in written:
        for suffix in (".data-00000-of-00001", ".meta"):
            assert (exported / "model" / (name + suffix)).is_file()
        assert (exported / "model" / f"model_{name.split('_')[0]}.pb").is_file()
    report, source = validate_location(str(exported))
    assert report.ok, [problem.render() for problem in report.problems]
    if layout == "racer":
        return  # racer's own checkpoints travel beside the TensorFlow files: import copies those

    other = LocalStore(tmp_path / "other")
    assert import_model(source, other, "imported").ok
    outcome = convert_tf_checkpoints(other, "imported")
    assert sorted(outcome.written) == written and outcome.notes == ()
    checkpoints = CheckpointStore(other, "imported")
    network = checkpoints.load_policy("1_Step-100.ckpt")
    assert isinstance(network, SACNetworks)
    camera = np.random.default_rng(6).integers(0, 256, (4, 120, 160, 1)).astype(np.float32)
    driver = checkpoints.load_inference_policy("1_Step-100.ckpt")  # what `racer evaluate` drives with
    with torch.inference_mode():
        greedy = networks[1].policy_output({"FRONT_FACING_CAMERA": torch.from_numpy(camera[:1])})[0].numpy()
    frame = {"FRONT_FACING_CAMERA": camera[0].astype(np.uint8)}  # a camera frame as the simulator renders it
    np.testing.assert_allclose(driver.act(frame, greedy=True)[0], greedy, atol=1e-5)
    with torch.inference_mode():
        feeds = {"FRONT_FACING_CAMERA": torch.from_numpy(camera)}
        np.testing.assert_array_equal(network.policy_output(feeds), networks[1].policy_output(feeds))
        actions = torch.tensor([[0.3, -0.5]] * 4)
        ours = networks[1].q_values(networks[1].q_features(feeds), actions)[0]
        torch.testing.assert_close(network.q_values(network.q_features(feeds), actions)[0], ours, rtol=1e-5, atol=1e-5)
