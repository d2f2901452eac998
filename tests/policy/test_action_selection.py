"""The workers' numpy action selection (racer.shared.policy.action_selection) chooses what the torch path chooses:
the same actions bit for bit from the same seeded generator, and log-probabilities equal to the trainer's torch
formulas to ~1e-6, over many draws; and it runs in a process where torch cannot be imported."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest
import torch

from racer.shared.policy.action_selection import (
    select_discrete_action,
    select_gaussian_action,
    select_squashed_gaussian_action,
    squashed_gaussian_log_prob,
)
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.factory import build_network
from racer.shared.policy.networks import CategoricalPolicy, GaussianPolicy, select_action
from racer.shared.policy.policy_config import InputSpec, PolicyConfig
from racer.shared.policy.sac_networks import squashed_gaussian_log_prob as torch_squashed_gaussian_log_prob
from racer.shared.store import LocalStore

DRAWS = 2000


def _torch_gaussian(mean32: np.ndarray, log_std: torch.Tensor, greedy: bool, rng: np.random.Generator):
    """The continuous PPO choice through torch: a GaussianPolicy through `select_action`, with the log-probability
    the trainer computes (GaussianPolicy.log_prob, torch)."""
    distribution = GaussianPolicy(mean=torch.from_numpy(mean32[None]), log_std=log_std)
    action, _ = select_action(distribution, greedy, rng)
    mean64 = GaussianPolicy(mean=distribution.mean.double(), log_std=log_std.double())
    return action, float(mean64.log_prob(torch.from_numpy(action.astype(np.float64))[None])[0])


def _reference_squashed(deterministic, mean, log_std, greedy: bool, rng: np.random.Generator):
    """The SAC choice by reference: numpy sampling, the log-probability by sac_networks' torch formula."""
    if greedy:
        return deterministic.astype(np.float32), 0.0
    raw = mean + np.exp(log_std) * rng.standard_normal(mean.shape)
    action = np.tanh(raw)
    log_prob = torch_squashed_gaussian_log_prob(*(torch.from_numpy(a) for a in (raw, action, mean, log_std)))
    return action.astype(np.float32), float(log_prob)


def test_discrete_actions_equal_the_torch_distributions_over_many_draws():
    source = np.random.default_rng(0)
    for draw in range(DRAWS):
        logits = torch.from_numpy(source.normal(0.0, 2.0, (1, 7)).astype(np.float32))
        probs = torch.softmax(logits, dim=1).clamp_min(1e-8)
        greedy, epsilon = bool(draw % 3 == 0), (0.3 if draw % 5 == 0 else 0.0)
        seed = int(source.integers(1 << 31))
        expected = select_action(CategoricalPolicy(probs=probs), greedy, np.random.default_rng(seed), epsilon)
        actual = select_discrete_action(probs[0].double().numpy(), greedy, np.random.default_rng(seed), epsilon)
        assert actual[0] == expected[0]
        torch_log_prob = float(CategoricalPolicy(probs=probs.double()).log_prob(torch.tensor([actual[0]]))[0])
        assert actual[1] == pytest.approx(torch_log_prob, abs=1e-6)


def test_continuous_ppo_actions_equal_the_torch_path_bit_for_bit_over_many_draws():
    source = np.random.default_rng(1)
    for draw in range(DRAWS):
        mean32 = source.normal(0.0, 0.5, 2).astype(np.float32)
        log_std = torch.from_numpy(source.uniform(-2.0, 0.5, 2).astype(np.float32))
        greedy = draw % 4 == 0
        seed = int(source.integers(1 << 31))
        expected = _torch_gaussian(mean32, log_std, greedy, np.random.default_rng(seed))
        actual = select_gaussian_action(
            mean32.astype(np.float64), log_std.numpy().astype(np.float64), greedy, np.random.default_rng(seed)
        )
        assert actual[0].dtype == np.float32 and actual[0].tobytes() == expected[0].tobytes()
        assert actual[1] == pytest.approx(expected[1], abs=1e-6)


def test_sac_actions_equal_the_torch_path_bit_for_bit_over_many_draws():
    source = np.random.default_rng(2)
    for draw in range(DRAWS):
        mean = source.normal(0.0, 1.0, 2)
        log_std = source.uniform(-3.0, 1.0, 2)
        deterministic = np.tanh(mean)
        greedy = draw % 4 == 0
        seed = int(source.integers(1 << 31))
        expected = _reference_squashed(deterministic, mean, log_std, greedy, np.random.default_rng(seed))
        actual = select_squashed_gaussian_action(deterministic, mean, log_std, greedy, np.random.default_rng(seed))
        assert actual[0].tobytes() == expected[0].tobytes()
        assert actual[1] == pytest.approx(expected[1], abs=1e-6)


def test_the_squashed_log_prob_equals_the_trainers_near_the_box_edge():
    """Actions at +-1 (tanh saturated) hit the [1e-10, 1] clip of the correction: both formulas clip alike."""
    raw = np.array([9.0, -12.0])
    mean, log_std = np.array([8.0, -11.0]), np.array([0.2, -0.1])
    action = np.tanh(raw)
    expected = float(torch_squashed_gaussian_log_prob(*(torch.from_numpy(a) for a in (raw, action, mean, log_std))))
    assert squashed_gaussian_log_prob(raw, action, mean, log_std) == pytest.approx(expected, rel=1e-9)
    assert math.isfinite(expected)


def _config(action_space_type: str, algorithm: str, num_actions: int) -> PolicyConfig:
    return PolicyConfig(
        neural_network="DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
        inputs=(InputSpec("LIDAR", "vector", (64,)),),
        action_space_type=action_space_type,
        num_actions=num_actions,
        training_algorithm=algorithm,
    )


CONFIGS = {
    "discrete": _config("discrete", "clipped_ppo", 5),
    "continuous-ppo": _config("continuous", "clipped_ppo", 2),
    "sac": _config("continuous", "sac", 2),
}

# Runs in a child process where importing torch (or safetensors' torch API) fails, as in the worker image: it loads
# each saved checkpoint's inference policy and acts with seeded generators, and prints what it chose.
_ACT_WITHOUT_TORCH = """
import json, sys
import numpy as np

class NoTorch:
    def find_spec(self, name, path=None, target=None):
        if name == "torch" or name.startswith("torch.") or name == "safetensors.torch":
            raise ImportError(f"{name} is not installed here (the worker image has no torch)")

sys.meta_path.insert(0, NoTorch())
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.store import LocalStore

root, names = sys.argv[1], sys.argv[2:]
lidar = np.random.default_rng(7).uniform(0.15, 1.0, (8, 64)).astype(np.float32)
chosen = {}
for name in names:
    policy = CheckpointStore(LocalStore(root), name).load_inference_policy()
    rows = []
    for i, greedy in enumerate([True, False] * 4):
        action, log_prob = policy.act({"LIDAR": lidar[i]}, greedy, np.random.default_rng(100 + i))
        rows.append([np.asarray(action).tolist(), log_prob])
    chosen[name] = rows
assert "torch" not in sys.modules
print(json.dumps(chosen))
"""


def test_checkpoints_act_in_a_process_without_torch_as_they_do_with_it(tmp_path):
    torch.manual_seed(0)
    for name, config in CONFIGS.items():
        network = build_network(config)
        if name == "continuous-ppo":
            with torch.no_grad():
                network.log_std.copy_(torch.tensor([-0.7, -1.1]))
        CheckpointStore(LocalStore(tmp_path), name).save(0, 0, network)
    result = subprocess.run(
        [sys.executable, "-c", _ACT_WITHOUT_TORCH, str(tmp_path), *CONFIGS],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    without_torch = json.loads(result.stdout)

    lidar = np.random.default_rng(7).uniform(0.15, 1.0, (8, 64)).astype(np.float32)
    for name in CONFIGS:
        policy = CheckpointStore(LocalStore(tmp_path), name).load_inference_policy()
        for i, greedy in enumerate([True, False] * 4):
            output_rows = policy._outputs([{"LIDAR": lidar[i]}]) if name == "sac" else None
            rng = np.random.default_rng(100 + i)
            if name == "discrete":
                probs = torch.from_numpy(policy.policy_outputs([{"LIDAR": lidar[i]}]))
                expected = select_action(CategoricalPolicy(probs=probs), greedy, rng)
            elif name == "continuous-ppo":
                mean32 = policy.policy_outputs([{"LIDAR": lidar[i]}])[0]
                log_std = torch.tensor([-0.7, -1.1])
                expected = _torch_gaussian(mean32, log_std, greedy, rng)
            else:
                deterministic, mean, log_std = (output[0].astype(np.float64) for output in output_rows)
                expected = _reference_squashed(deterministic, mean, log_std, greedy, rng)
            action, log_prob = without_torch[name][i]
            assert np.array_equal(np.asarray(action, np.float32), np.asarray(expected[0], np.float32)), (name, i)
            assert log_prob == pytest.approx(expected[1], abs=1e-6), (name, i)
