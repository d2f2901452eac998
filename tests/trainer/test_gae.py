"""GAE against hand-computed values, including an episode boundary in the middle of the batch."""

from __future__ import annotations

import numpy as np
import pytest

from racer.trainer.gae import compute_gae, episode_ends_from_lengths


def test_single_step_episode_is_reward_minus_value():
    advantages, targets = compute_gae(np.array([2.0]), np.array([0.5]), np.array([True]), discount=0.9, gae_lambda=0.95)
    assert advantages.tolist() == [1.5]  # bootstrap 0 after the last transition
    assert targets.tolist() == [2.0]


def test_hand_computed_with_a_terminal_in_the_middle():
    # Episode A: 3 steps, episode B: 2 steps, laid end to end.
    rewards = np.array([1.0, 0.0, 2.0, 1.0, 1.0])
    values = np.array([0.5, 1.0, 1.5, 2.0, 0.5])
    ends = np.array([False, False, True, False, True])
    g, lam = 0.9, 0.5
    # Episode A, backwards (value after step 2 is 0, not V of episode B's first state):
    d2 = 2.0 + g * 0.0 - 1.5  # 0.5
    d1 = 0.0 + g * 1.5 - 1.0  # 0.35
    d0 = 1.0 + g * 1.0 - 0.5  # 1.4
    a2 = d2
    a1 = d1 + g * lam * a2  # 0.35 + 0.225 = 0.575
    a0 = d0 + g * lam * a1  # 1.4 + 0.25875 = 1.65875
    # Episode B:
    d4 = 1.0 - 0.5  # 0.5
    d3 = 1.0 + g * 0.5 - 2.0  # -0.55
    a4 = d4
    a3 = d3 + g * lam * a4  # -0.55 + 0.225 = -0.325
    advantages, targets = compute_gae(rewards, values, ends, discount=g, gae_lambda=lam)
    np.testing.assert_allclose(advantages, [a0, a1, a2, a3, a4], rtol=1e-12)
    np.testing.assert_allclose(targets, np.array([a0, a1, a2, a3, a4]) + values, rtol=1e-12)
    assert advantages[2] == pytest.approx(0.5)  # not r + g*V(s_next of episode B) - V


def test_lambda_one_gives_discounted_returns_and_lambda_zero_gives_td_errors():
    rewards = np.array([1.0, 2.0, 3.0, 4.0])
    values = np.array([0.3, -0.2, 0.7, 0.1])
    ends = episode_ends_from_lengths([2, 2])
    _, targets = compute_gae(rewards, values, ends, discount=0.5, gae_lambda=1.0)
    np.testing.assert_allclose(targets, [1.0 + 0.5 * 2.0, 2.0, 3.0 + 0.5 * 4.0, 4.0])  # Monte-Carlo returns
    advantages, _ = compute_gae(rewards, values, ends, discount=0.5, gae_lambda=0.0)
    np.testing.assert_allclose(advantages, [1.0 + 0.5 * -0.2 - 0.3, 2.0 - -0.2, 3.0 + 0.5 * 0.1 - 0.7, 4.0 - 0.1])


def test_episode_ends_from_lengths():
    assert episode_ends_from_lengths([3, 2]).tolist() == [False, False, True, False, True]
    assert episode_ends_from_lengths([1, 1, 1]).tolist() == [True, True, True]


def test_rejects_unterminated_or_mismatched_input():
    with pytest.raises(ValueError, match="last transition"):
        compute_gae(np.ones(2), np.ones(2), np.array([True, False]), 0.9)
    with pytest.raises(ValueError, match="equal"):
        compute_gae(np.ones(2), np.ones(3), np.array([False, True]), 0.9)
