"""RL Coach's SAC variable layout without TensorFlow: the names racer writes, the Q rescaling to DeepRacer's action
units and back, and the ROS 2 SimApp's Keras numbering of the heads' unnamed Dense layers read as the same model."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from racer.model_io.tensorflow.coach_layout import CoachMismatchError
from racer.model_io.tensorflow.coach_sac_layout import (
    SAC_Q_NETWORK,
    sac_coach_tensors_from_racer,
    sac_coach_variables,
    sac_racer_state_from_coach,
)
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.factory import build_network_for_metadata

METADATA = parse_model_metadata(
    {
        "action_space": {"steering_angle": {"low": -20, "high": 30}, "speed": {"low": 0.8, "high": 2.6}},
        "action_space_type": "continuous",
        "training_algorithm": "sac",
        "sensor": ["FRONT_FACING_CAMERA", "LIDAR"],
        "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_DEEP",
        "version": "5",
    },
    "METADATA",
)
# The ROS 2 SimApp's Keras layers: the policy head makes dense and dense_1, then each Q head two more.
KERAS_NAMES = {
    "q1_head/dense/": "q1_head/dense_2/",
    "q1_head/dense_1/": "q1_head/dense_3/",
    "q2_head/dense/": "q2_head/dense_4/",
    "q2_head/dense_1/": "q2_head/dense_5/",
}


@pytest.fixture(scope="module")
def network():
    torch.manual_seed(4)
    return build_network_for_metadata(METADATA).eval()


def state_of(network) -> dict[str, np.ndarray]:
    return {key: value.numpy() for key, value in network.state_dict().items()}


def test_the_checkpoint_holds_policy_q_and_v_but_not_the_target(network):
    names = [variable.name for variable in sac_coach_variables(network.config)]
    assert len(names) == len(set(names))
    assert {name.split("/")[2] for name in names} == {"policy", "q", "v"}
    assert not any("/target/" in name for name in names)
    assert f"{SAC_Q_NETWORK}/q_values_head_0/q1_head/q1_output/kernel" in names
    assert not any(name.startswith(f"{SAC_Q_NETWORK}/middleware_fc_embedder/") for name in names)  # Q: no middleware


def test_q_in_deepracer_units_computes_racers_q_and_converts_back(network):
    tensors = sac_coach_tensors_from_racer(network.config, state_of(network), METADATA.continuous_action_space)
    kernel = tensors[f"{SAC_Q_NETWORK}/q_values_head_0/q1_head/dense/kernel"]
    bias = tensors[f"{SAC_Q_NETWORK}/q_values_head_0/q1_head/dense/bias"]
    features = np.random.default_rng(0).normal(size=(5, kernel.shape[0] - 2))
    racer_actions = np.random.default_rng(1).uniform(-1, 1, (5, 2))
    deepracer_actions = np.array([[-20, 0.8]]) + (racer_actions + 1) / 2 * np.array([[50, 1.8]])
    layer = network.q_head.q1[0]
    ours = np.concatenate([features, racer_actions], 1) @ layer.weight.detach().numpy().T.astype(np.float64)
    ours += layer.bias.detach().numpy()
    theirs = np.concatenate([features, deepracer_actions], 1) @ kernel.astype(np.float64) + bias
    np.testing.assert_allclose(theirs, ours, rtol=1e-5, atol=1e-5)
    assert not np.allclose(kernel[-2:], layer.weight.detach().numpy().T[-2:])  # really rescaled

    back = sac_racer_state_from_coach(network.config, tensors, True, METADATA.continuous_action_space)
    for key, value in back.items():
        np.testing.assert_allclose(value, state_of(network)[key], rtol=1e-6, atol=1e-6, err_msg=key)


def test_keras_numbered_head_layers_read_as_the_same_model(network):
    tensors = sac_coach_tensors_from_racer(network.config, state_of(network), METADATA.continuous_action_space)
    keras = {}
    for name, value in tensors.items():
        for old, new in KERAS_NAMES.items():
            if old in name:
                name = name.replace(old, new)
                break
        keras[name] = value
    assert f"{SAC_Q_NETWORK}/q_values_head_0/q2_head/dense_5/kernel" in keras
    back = sac_racer_state_from_coach(network.config, keras, True, METADATA.continuous_action_space)
    plain = sac_racer_state_from_coach(network.config, tensors, True, METADATA.continuous_action_space)
    assert back.keys() == plain.keys()
    for key in plain:
        np.testing.assert_array_equal(back[key], plain[key], err_msg=key)


def test_a_missing_or_foreign_variable_is_named(network):
    tensors = sac_coach_tensors_from_racer(network.config, state_of(network), METADATA.continuous_action_space)
    del tensors[f"{SAC_Q_NETWORK}/q_values_head_0/q2_head/q2_output/bias"]
    tensors[f"{SAC_Q_NETWORK}/q_values_head_0/q2_head/BatchNorm/gamma"] = np.ones(256, np.float32)
    with pytest.raises(CoachMismatchError, match=r"missing .*q2_output/bias.*unexpected .*BatchNorm/gamma"):
        sac_racer_state_from_coach(network.config, tensors, True, METADATA.continuous_action_space)
