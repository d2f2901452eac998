"""The fast trainer path learns the same thing as the plain fp32 baseline; `python -m benchmarks ppo` prints one JSON line."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
import torch
from click.testing import CliRunner

from benchmarks.ppo import bench_network, plain_ppo_update, ppo_bench_command, synthetic_episodes
from benchmarks.precision_agreement import update_agreement
from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.trainer.ppo import PPOLearner, PPOSettings
from racer.trainer.precision import Precision
from tests.trainer.ppo_task import play, task_network

pytestmark = pytest.mark.slow  # seconds to minutes each: the full suite runs them, the fast loop does not


def test_fast_path_gives_the_same_learning_result_as_the_plain_baseline():
    hp = Hyperparameters(
        batch_size=32, num_epochs=3, lr=3e-4, beta_entropy=0.01, discount_factor=0.999, loss_type="huber"
    )
    initial = bench_network(num_actions=5, seed=1)
    episodes = synthetic_episodes(200, num_actions=5, seed=1)  # 2 episodes, 6 minibatches per epoch
    fast, plain = copy.deepcopy(initial), copy.deepcopy(initial)
    fast_stats = PPOLearner(fast, hp, PPOSettings(seed=3, precision=Precision.FP32)).update(episodes)
    plain_stats = plain_ppo_update(plain, hp, episodes, seed=3)

    for mine, theirs in zip(fast_stats, plain_stats, strict=True):
        assert mine.surrogate_loss == pytest.approx(theirs["surrogate"], rel=1e-3, abs=1e-5)
        assert mine.kl_divergence == pytest.approx(theirs["kl"], rel=1e-2, abs=1e-6)
        assert mine.entropy == pytest.approx(theirs["entropy"], rel=1e-5)
        assert mine.value_loss == pytest.approx(theirs["value"], rel=1e-4)
    moved = max((fast.state_dict()[k] - initial.state_dict()[k]).abs().max().item() for k in initial.state_dict())
    differ = max((fast.state_dict()[k] - plain.state_dict()[k]).abs().max().item() for k in initial.state_dict())
    assert moved > 1e-3  # 18 Adam steps of lr 3e-4 moved the weights ...
    assert differ < moved * 0.05  # ... and both paths moved them to the same place (measured ratio ~0.006)
    batch = {"FRONT_FACING_CAMERA": torch.from_numpy(episodes[0].observations["FRONT_FACING_CAMERA"][:16])}
    with torch.no_grad():
        torch.testing.assert_close(
            fast.distribution(batch).probs, plain.distribution(batch).probs, rtol=1e-3, atol=1e-5
        )
        torch.testing.assert_close(fast.value(batch), plain.value(batch), rtol=1e-3, atol=1e-4)


def test_bf16_towers_track_the_fp32_baseline():
    """bf16 towers (`--precision bf16`) give the same losses and outputs within bf16 precision on one update.

    Weights are not compared element by element: Adam turns tiny gradient differences in near-zero gradients into
    full-size steps. What must agree is what the update computes and what the network then outputs.
    """
    hp = Hyperparameters(
        batch_size=32, num_epochs=3, lr=3e-4, beta_entropy=0.01, discount_factor=0.999, loss_type="huber"
    )
    initial = bench_network(num_actions=5, seed=1)
    episodes = synthetic_episodes(200, num_actions=5, seed=1)
    fast, plain = copy.deepcopy(initial), copy.deepcopy(initial)
    trainer = PPOLearner(fast, hp, PPOSettings(seed=3, precision=Precision.BF16))
    assert trainer.tower_dtype == torch.bfloat16
    fast_stats = trainer.update(episodes)
    plain_stats = plain_ppo_update(plain, hp, episodes, seed=3)
    for mine, theirs in zip(fast_stats, plain_stats, strict=True):  # measured: within 3 %, 2 %, 3e-4, 0.3 %
        assert mine.surrogate_loss == pytest.approx(theirs["surrogate"], rel=0.1, abs=2e-3)
        assert mine.kl_divergence == pytest.approx(theirs["kl"], rel=0.1)
        assert mine.entropy == pytest.approx(theirs["entropy"], rel=2e-3)
        assert mine.value_loss == pytest.approx(theirs["value"], rel=2e-2)
    assert all(p.dtype == torch.float32 for p in fast.parameters())  # the weights themselves stay fp32
    batch = {"FRONT_FACING_CAMERA": torch.from_numpy(episodes[0].observations["FRONT_FACING_CAMERA"][:16])}
    with torch.no_grad():  # measured: 0.0075 and 0.011
        torch.testing.assert_close(fast.distribution(batch).probs, plain.distribution(batch).probs, rtol=0, atol=0.03)
        torch.testing.assert_close(fast.value(batch), plain.value(batch), rtol=0, atol=0.05)


def test_bench_command_prints_one_json_line():
    result = CliRunner().invoke(
        ppo_bench_command,
        [
            "--transitions",
            "64",
            "--epochs",
            "1",
            "--batch-size",
            "32",
            "--threads",
            "1",
            "--agreement-transitions",
            "64",
        ],
    )
    assert result.exit_code == 0, result.output
    lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
    assert len(lines) == 1
    report = json.loads(lines[0])
    assert report["transitions"] == 64 and report["epochs"] == 1
    assert report["samples_per_s"] > 0 and report["bf16_samples_per_s"] > 0
    assert report["agreement"]["precision"] == "bf16" and report["agreement"]["update_kl"] > 0
    assert report["samples_per_s"] > 0 and report["baseline_samples_per_s"] > 0
    assert report["speedup"] == pytest.approx(report["samples_per_s"] / report["baseline_samples_per_s"], rel=0.01)


@pytest.mark.parametrize("precision", list(Precision), ids=[p.value for p in Precision])
def test_one_update_in_every_offered_precision_moves_the_policy_like_fp32(precision):
    """The guard: a precision the trainer offers must move the policy where fp32 moves it, on a fixed batch of a task
    with a real signal (the bar task). Tolerances: the two updated policies differ by at most 5 % of the update's own
    KL, and no parameter's minibatch gradient differs by more than 25 % (bf16 measured 0.5 % and 11 %)."""
    network = task_network(5, seed=0)
    episodes = play(network, 96, 5, np.random.default_rng(0))
    hp = Hyperparameters(batch_size=32, num_epochs=3, lr=3e-4, beta_entropy=0.01, discount_factor=0.99)
    agreement = update_agreement(network, hp, episodes, precision, seed=3)
    assert agreement.update_kl > 1e-3  # the update itself moved the policy
    assert agreement.kl_share_of_update <= 0.05, agreement.to_dict()
    assert agreement.max_relative_gradient_difference <= 0.25, agreement.gradient_difference_by_parameter
