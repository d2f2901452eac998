"""Clipped PPO on an overlapped run's episodes: an episode played by the checkpoint before the network's has its ratio
taken against the log-probabilities it was played with, and the clip applies to it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.trainer.ppo import PPOLearner, PPOSettings, make_training_batch
from racer.trainer.ppo_batch import old_log_probs
from tests.trainer.ppo_task import random_episodes, task_network

HP = Hyperparameters(batch_size=32, num_epochs=1, lr=3e-4, beta_entropy=0.01, discount_factor=0.99, loss_type="huber")
STORED_LOG_PROB = -3.0
"""Far from what a 3-action network gives any action (about log 1/3): the policy changed since it played."""


def episodes_with_one_behind(network):
    """Three episodes (10 + 12 + 10 = 32 transitions, one minibatch) for network version 1; the middle one was
    played by checkpoint 0."""
    episodes = random_episodes(network, [10, 12, 10], np.random.default_rng(0))
    episodes = [replace(episode, policy_version=1) for episode in episodes]
    episodes[1] = replace(episodes[1], policy_version=0, log_probs=np.full(12, STORED_LOG_PROB, dtype=np.float32))
    return episodes


def test_an_episode_one_version_behind_is_compared_with_its_own_log_probs():
    network = task_network(3)
    episodes = episodes_with_one_behind(network)
    batch = make_training_batch(episodes, network.input_names, network.config, policy_version=1)
    assert batch.behind.tolist() == [False] * 10 + [True] * 12 + [False] * 10
    recomputed = torch.full((32,), -1.1)
    old = old_log_probs(batch, torch.arange(32), recomputed)
    assert old[10:22].tolist() == [STORED_LOG_PROB] * 12
    assert old[:10].tolist() == pytest.approx([-1.1] * 10) and old[22:].tolist() == pytest.approx([-1.1] * 10)
    # The network's own episodes only (a strict run): nothing is marked, DeepRacer's recomputed old policy stays.
    strict = make_training_batch([episodes[0], episodes[2]], network.input_names, network.config, policy_version=1)
    assert strict.behind is None and strict.behaviour_log_probs is None


def test_the_clip_applies_to_the_ratio_of_an_episode_one_version_behind():
    on_policy = task_network(3)
    episodes = episodes_with_one_behind(on_policy)
    (same,) = PPOLearner(task_network(3), HP, PPOSettings(seed=0)).update(
        [replace(episode, policy_version=1) for episode in episodes], policy_version=1
    )
    (mixed,) = PPOLearner(task_network(3), HP, PPOSettings(seed=0)).update(episodes, policy_version=1)
    # One minibatch, measured before its step: the network's own transitions have ratio 1 exactly; the 12 of the
    # episode one behind have ratio exp(log pi - (-3)) ~ 6.7, all beyond 1 + 0.2.
    assert same.clip_fraction == 0.0
    assert mixed.clip_fraction == pytest.approx(12 / 32)
    assert mixed.surrogate_loss != pytest.approx(same.surrogate_loss)


def test_a_strict_runs_update_is_the_same_with_or_without_the_network_version():
    """A strict run's episodes are all the network's own: the update, numbers and weights, is DeepRacer's as before."""
    results = []
    for policy_version in (None, 1):
        network = task_network(3)
        episodes = [replace(episode, policy_version=1) for episode in episodes_with_one_behind(network)]
        stats = PPOLearner(network, replace(HP, num_epochs=2), PPOSettings(seed=3)).update(
            episodes, policy_version=policy_version
        )
        results.append((stats, {name: value.clone() for name, value in network.state_dict().items()}))
    (stats_a, weights_a), (stats_b, weights_b) = results
    assert stats_a == stats_b
    assert all(torch.equal(weights_a[name], weights_b[name]) for name in weights_a)
