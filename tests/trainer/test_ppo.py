"""The clipped-PPO update: first-minibatch invariants, losses, NaN rollback, log lines, and learning a tiny task."""

from __future__ import annotations

import logging
import math
import re
from dataclasses import replace

import numpy as np
import pytest
import torch

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.trainer.learner import UpdateAbandoned
from racer.trainer.log_lines import format_policy_training_line, format_training_episode_line
from racer.trainer.nan_guard import first_non_finite_parameter
from racer.trainer.ppo import (
    EpochStats,
    PPOLearner,
    PPOSettings,
    minibatch_size_for,
    shuffled_minibatches,
)
from racer.trainer.precision import Precision
from tests.trainer.ppo_task import greedy_accuracy, play, random_episodes, task_network

HP = Hyperparameters(batch_size=32, num_epochs=2, lr=3e-4, beta_entropy=0.01, discount_factor=0.99, loss_type="huber")


def weights(network) -> dict[str, torch.Tensor]:
    return {name: value.detach().clone() for name, value in network.state_dict().items()}


def test_minibatch_size_and_shuffling_follow_deepracer():
    assert minibatch_size_for(1000, 64) == 64
    assert minibatch_size_for(64, 64) == 64
    assert minibatch_size_for(63, 64) == 32  # <= batch_size: largest power of two that fits
    assert minibatch_size_for(5, 64) == 4
    assert minibatch_size_for(0, 64) == 0
    generator = torch.Generator().manual_seed(0)
    minibatches = shuffled_minibatches(100, 32, generator)
    assert [len(m) for m in minibatches] == [32, 32, 32]  # remainder of 4 dropped
    assert len(torch.cat(minibatches).unique()) == 96
    assert not torch.equal(torch.cat(minibatches), torch.arange(96))  # shuffled


def test_first_minibatch_has_ratio_one_and_nothing_clipped():
    network = task_network(3)
    rng = np.random.default_rng(0)
    episodes = random_episodes(network, [10, 12, 10], rng)  # 32 transitions = exactly one minibatch
    learner = PPOLearner(network, replace(HP, num_epochs=1), PPOSettings(seed=0))
    (stats,) = learner.update(episodes)
    # The stats of a single-minibatch epoch are measured before its step: new policy == old policy.
    assert stats.minibatches == 1
    assert stats.clip_fraction == 0.0
    assert abs(stats.kl_divergence) < 1e-6
    assert abs(stats.surrogate_loss) < 1e-5  # -mean(1 * A) with standardised advantages


def test_one_update_changes_the_weights_and_keeps_losses_finite():
    network = task_network(3)
    before = weights(network)
    learner = PPOLearner(network, HP, PPOSettings(seed=1))
    stats = learner.update(random_episodes(network, [30, 20, 50], np.random.default_rng(1)))
    assert [s.epoch for s in stats] == [0, 1]
    assert all(s.minibatches == 3 for s in stats)  # 100 transitions // 32
    for s in stats:
        for field in ("surrogate_loss", "kl_divergence", "entropy", "value_loss", "clip_fraction", "gradient_norm"):
            assert math.isfinite(getattr(s, field)), field
        assert s.learning_rate == pytest.approx(3e-4)
    after = network.state_dict()
    changed = [name for name in before if not torch.equal(before[name], after[name])]
    assert any(name.startswith("policy_") for name in changed) and any(name.startswith("value_") for name in changed)
    assert stats[1].kl_divergence > 0.0 and learner.nan_rollbacks == 0


def test_a_stopping_trainer_abandons_the_update_between_minibatches():
    """`abandon()` is asked before each minibatch; the trainer uses it to stop within 30 s of a signal."""
    network = task_network(3)
    learner = PPOLearner(network, HP, PPOSettings(seed=1))
    asked = []

    def abandon() -> bool:
        asked.append(True)
        return len(asked) > 4  # after four of the six minibatches (2 epochs x 3)

    with pytest.raises(UpdateAbandoned):
        learner.update(random_episodes(network, [30, 20, 50], np.random.default_rng(1)), abandon=abandon)
    assert len(asked) == 5
    assert (
        len(learner.update(random_episodes(network, [30, 20, 50], np.random.default_rng(1)), abandon=lambda: False))
        == 2
    )


@pytest.mark.parametrize(
    ("loss_type", "expected"), [("huber", lambda e: np.abs(e) - 0.5), ("mean squared error", np.square)]
)
def test_value_loss_type(loss_type, expected):
    network = task_network(3)
    with torch.no_grad():  # V(s) = 10 everywhere
        network.value_head.weight.zero_()
        network.value_head.bias.fill_(10.0)
    rng = np.random.default_rng(2)
    episodes = random_episodes(network, [1] * 32, rng)  # one-step episodes: value target = reward
    rewards = np.array([e.rewards[0] for e in episodes], dtype=np.float64)
    learner = PPOLearner(network, replace(HP, num_epochs=1, loss_type=loss_type), PPOSettings(seed=0))
    (stats,) = learner.update(episodes)
    assert stats.value_loss == pytest.approx(float(np.mean(expected(10.0 - rewards))), rel=1e-4)


def test_entropy_bonus_pushes_towards_higher_entropy():
    entropies = {}
    for beta in (0.0, 1.0):
        network = task_network(5, seed=3)
        with torch.no_grad():  # a confident policy, far from maximum entropy
            network.policy_head.bias.copy_(torch.tensor([4.0, 0.0, 0.0, 0.0, 0.0]))
        episodes = random_episodes(network, [40, 24], np.random.default_rng(3))
        observations = {k: torch.from_numpy(v) for k, v in episodes[0].observations.items()}
        with torch.no_grad():
            before = network.distribution(observations).entropy().mean().item()
        PPOLearner(network, replace(HP, beta_entropy=beta, num_epochs=3), PPOSettings(seed=0)).update(episodes)
        with torch.no_grad():
            entropies[beta] = network.distribution(observations).entropy().mean().item()
    assert before < 0.5
    assert entropies[1.0] > before + 0.1
    assert entropies[1.0] > entropies[0.0] + 0.1


def test_continuous_policy_update():
    network = task_network(continuous=True)
    learner = PPOLearner(network, HP, PPOSettings(seed=0))
    stats = learner.update(random_episodes(network, [40, 30], np.random.default_rng(4)))
    assert len(stats) == 2 and all(math.isfinite(s.surrogate_loss) and math.isfinite(s.entropy) for s in stats)
    assert not torch.equal(network.log_std.detach(), torch.zeros(2))


def test_same_seed_same_result():
    results = []
    for _ in range(2):
        network = task_network(3, seed=5)
        learner = PPOLearner(network, HP, PPOSettings(seed=7))
        stats = learner.update(random_episodes(network, [40, 30], np.random.default_rng(5)))
        results.append((stats, weights(network)))
    assert results[0][0] == results[1][0]
    assert all(torch.equal(results[0][1][name], results[1][1][name]) for name in results[0][1])


def test_nan_gradient_rolls_back_halves_learning_rate_and_keeps_training(caplog):
    network = task_network(3)
    learner = PPOLearner(network, HP, PPOSettings(seed=0))
    episodes = random_episodes(network, [50, 50], np.random.default_rng(6))
    learner.update(episodes)  # a good update first: its result is the last good state
    good = weights(network)

    parameter = network.policy_head.weight
    injected = []

    def poison_once(grad):
        if injected:
            return grad
        injected.append(True)
        return grad * float("nan")

    handle = parameter.register_hook(poison_once)
    with caplog.at_level(logging.WARNING, logger="racer.trainer.ppo"):
        stats = learner.update(episodes)
    handle.remove()

    assert injected and learner.nan_rollbacks == 1
    assert learner.learning_rate == pytest.approx(1.5e-4)
    assert "NaN guard: gradient at epoch 0, minibatch 0 is nan" in caplog.text
    assert "rolled back" in caplog.text and "halved the learning rate 0.0003 -> 0.00015" in caplog.text
    # The retry trained normally from the rolled-back weights, at the new rate.
    assert len(stats) == 2 and all(s.learning_rate == pytest.approx(1.5e-4) for s in stats)
    assert all(torch.isfinite(value).all() for value in network.state_dict().values())
    assert any(not torch.equal(good[name], value) for name, value in network.state_dict().items())


def test_persistent_nan_skips_the_iteration_and_the_next_one_trains(caplog):
    network = task_network(3)
    learner = PPOLearner(network, HP, PPOSettings(seed=0, max_nan_retries=2))
    episodes = random_episodes(network, [40, 40], np.random.default_rng(7))
    before = weights(network)
    handle = network.value_head.bias.register_hook(lambda grad: grad * float("inf"))
    with caplog.at_level(logging.WARNING, logger="racer.trainer.ppo"):
        assert learner.update(episodes) == []
    handle.remove()
    assert learner.nan_rollbacks == 3 and learner.learning_rate == pytest.approx(3e-4 / 8)
    assert "skipped this iteration's 80 transitions" in caplog.text
    assert all(torch.equal(before[name], value) for name, value in network.state_dict().items())
    stats = learner.update(episodes)  # training goes on
    assert len(stats) == 2 and all(math.isfinite(s.surrogate_loss) for s in stats)


def test_nan_weights_from_outside_are_rolled_back(caplog):
    network = task_network(3)
    learner = PPOLearner(network, HP, PPOSettings(seed=0))
    episodes = random_episodes(network, [40, 40], np.random.default_rng(8))
    before = weights(network)
    with torch.no_grad():
        network.value_tower.middleware[0].weight[0, 0] = float("nan")
    with caplog.at_level(logging.WARNING, logger="racer.trainer.ppo"):
        stats = learner.update(episodes)
    assert "weights were not finite at the start of the update" in caplog.text
    assert len(stats) == 2 and learner.nan_rollbacks == 1
    assert torch.isfinite(network.value_tower.middleware[0].weight).all()
    assert not torch.equal(before["value_head.weight"], network.value_head.weight)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_first_non_finite_parameter_names_the_weight_and_is_not_fooled_by_an_overflowing_norm(bad):
    network = task_network(3)
    assert first_non_finite_parameter(network) is None
    with torch.no_grad():
        network.policy_head.weight.fill_(1e30)  # finite, but the sum of squares overflows float32
    assert not math.isfinite(float(torch.nn.utils.get_total_norm(list(network.parameters()))))
    assert first_non_finite_parameter(network) is None
    with torch.no_grad():
        network.value_tower.middleware[0].weight[1, 2] = bad
    assert first_non_finite_parameter(network) == "value_tower.middleware.0.weight"


def test_episodes_with_non_finite_values_are_dropped(caplog):
    network = task_network(3)
    learner = PPOLearner(network, replace(HP, num_epochs=1), PPOSettings(seed=0))
    good, bad = random_episodes(network, [64, 10], np.random.default_rng(9))
    bad.rewards[3] = np.nan
    with caplog.at_level(logging.WARNING, logger="racer.trainer.ppo"):
        (stats,) = learner.update([good, bad])
    assert "dropped episode 1 of worker 0" in caplog.text
    assert stats.minibatches == 2 and math.isfinite(stats.value_loss)  # 64 good transitions only
    assert learner.update([bad]) == []


def test_log_lines_match_the_real_console_log(deepracer_data):
    lines = (deepracer_data / "logs" / "console2022_training_sagemaker.log").read_text().splitlines()
    policy_line = next(line for line in lines if line.startswith("Policy training>"))
    numbers = re.findall(r"=([-\d.e]+)", policy_line)
    stats = EpochStats(
        epoch=int(numbers[3]),
        surrogate_loss=float(numbers[0]),
        kl_divergence=float(numbers[1]),
        entropy=float(numbers[2]),
        value_loss=0.5,
        clip_fraction=0.1,
        learning_rate=float(numbers[4]),
        minibatches=8,
        gradient_norm=1.0,
    )
    assert format_policy_training_line(stats) == policy_line

    episode_line = next(line for line in lines if line.startswith("Training> ") and "Episode=20," in line)
    fields = dict(re.findall(r"(Worker|Episode|Total reward|Steps|Training iteration)=([-\d.]+)", episode_line))
    assert (
        format_training_episode_line(
            int(fields["Worker"]),
            int(fields["Episode"]),
            float(fields["Total reward"]),
            int(fields["Steps"]),
            int(fields["Training iteration"]),
        )
        == episode_line
    )
    assert "Total reward=12.35," in format_training_episode_line(1, 3, 12.3456, 100, 2)
    assert "Total reward=-3," in format_training_episode_line(1, 3, -3.0, 100, 2)


@pytest.mark.parametrize("precision", list(Precision), ids=[p.value for p in Precision])
def test_ppo_learns_the_bar_task_within_a_fixed_budget(precision):
    """Five actions, the right one shown as a bright bar: > 95 % greedy accuracy within 8 iterations of 96 episodes."""
    num_actions = 5
    network = task_network(num_actions, seed=0)
    hp = Hyperparameters(
        batch_size=32, num_epochs=3, lr=3e-4, beta_entropy=0.01, discount_factor=0.99, loss_type="huber"
    )
    learner = PPOLearner(network, hp, PPOSettings(seed=0, precision=precision))
    rng = np.random.default_rng(0)
    start_accuracy = greedy_accuracy(network, num_actions, rng)
    accuracies = []
    for _ in range(8):
        learner.update(play(network, 96, num_actions, rng))
        accuracies.append(greedy_accuracy(network, num_actions, rng))
        if accuracies[-1] > 0.95:
            break
    assert start_accuracy < 0.5
    assert accuracies[-1] > 0.95, accuracies
