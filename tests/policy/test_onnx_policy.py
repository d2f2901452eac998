"""The ONNX inference policy the workers act with chooses exactly what the PyTorch network would."""

import numpy as np
import pytest
import torch

from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.networks import build_actor_critic
from racer.shared.store import LocalStore

DISCRETE = {
    "action_space": [{"steering_angle": a, "speed": 1.0} for a in (-30, -15, 0, 15, 30)],
    "sensor": ["FRONT_FACING_CAMERA", "LIDAR"],
    "version": "5",
}
CONTINUOUS = {
    "action_space": {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 0.5, "high": 2.0}},
    "action_space_type": "continuous",
    "sensor": ["FRONT_FACING_CAMERA"],
    "version": "5",
}


@pytest.mark.parametrize("metadata_json", [DISCRETE, CONTINUOUS], ids=["discrete+lidar", "continuous"])
def test_same_actions_and_log_probs_as_the_network(tmp_path, metadata_json):
    torch.manual_seed(0)
    metadata = parse_model_metadata(metadata_json)
    network = build_actor_critic(metadata)
    if metadata.is_continuous:
        with torch.no_grad():
            network.log_std.fill_(-0.7)  # a trained std, so the sampling path is really exercised
    checkpoints = CheckpointStore(LocalStore(tmp_path), "m")
    name = checkpoints.save(0, 0, network, model_metadata=metadata)
    torch_policy = checkpoints.load_policy(name)
    onnx_policy = checkpoints.load_inference_policy(name)
    rng = np.random.default_rng(1)
    for _ in range(5):
        observation = {"FRONT_FACING_CAMERA": rng.integers(0, 255, (120, 160, 1), dtype=np.uint8)}
        if "LIDAR" in metadata.sensors:
            observation["LIDAR"] = rng.uniform(0.15, 1.0, 64).astype(np.float32)
        for greedy in (True, False):
            seed = int(rng.integers(1 << 30))
            expected = torch_policy.act(observation, greedy, np.random.default_rng(seed))
            actual = onnx_policy.act(observation, greedy, np.random.default_rng(seed))
            np.testing.assert_allclose(np.asarray(actual[0]), np.asarray(expected[0]), atol=1e-5)
            assert actual[1] == pytest.approx(expected[1], abs=1e-4)


def test_wrong_observation_shape_is_a_clear_error(tmp_path):
    metadata = parse_model_metadata(DISCRETE)
    checkpoints = CheckpointStore(LocalStore(tmp_path), "m")
    name = checkpoints.save(0, 0, build_actor_critic(metadata), model_metadata=metadata)
    policy = checkpoints.load_inference_policy(name)
    with pytest.raises(ValueError, match="FRONT_FACING_CAMERA.*expects"):
        policy.act({"FRONT_FACING_CAMERA": np.zeros((60, 80, 1), np.uint8), "LIDAR": np.zeros(64, np.float32)}, True)


@pytest.mark.parametrize("metadata_json", [DISCRETE, CONTINUOUS], ids=["discrete+lidar", "continuous"])
def test_a_batched_call_gives_each_row_what_a_call_alone_gives(tmp_path, metadata_json):
    """Workers pick the actions of several envs with one forward pass; an env must act as it would alone."""
    torch.manual_seed(0)
    metadata = parse_model_metadata(metadata_json)
    checkpoints = CheckpointStore(LocalStore(tmp_path), "m")
    name = checkpoints.save(0, 0, build_actor_critic(metadata), model_metadata=metadata)
    policy = checkpoints.load_inference_policy(name)
    rng = np.random.default_rng(2)
    observations = []
    for _ in range(5):
        observation = {"FRONT_FACING_CAMERA": rng.integers(0, 255, (120, 160, 1), dtype=np.uint8)}
        if "LIDAR" in metadata.sensors:
            observation["LIDAR"] = rng.uniform(0.15, 1.0, 64).astype(np.float32)
        observations.append(observation)
    outputs = policy.policy_outputs(observations)
    assert outputs.shape[0] == 5
    for row, observation in zip(outputs, observations, strict=True):
        np.testing.assert_array_equal(row, policy.policy_output(observation))
    batched = policy.act_batch(observations, False, [np.random.default_rng(i) for i in range(5)], [0.0] * 5)
    alone = [policy.act(o, False, np.random.default_rng(i)) for i, o in enumerate(observations)]
    for (action, log_prob), (expected_action, expected_log_prob) in zip(batched, alone, strict=True):
        np.testing.assert_array_equal(np.asarray(action), np.asarray(expected_action))
        assert log_prob == expected_log_prob
