"""Generalised advantage estimation as DeepRacer computes it (deepracer-simapp v5.3.3, RL Coach's `clipped_ppo_agent.py`
vendored in `bundle/rl_coach/`).

`compute_gae(rewards, values, episode_ends, discount, gae_lambda) -> (advantages, value_targets)` works on the
transitions of several episodes laid end to end. `episode_ends[t]` is True for the last transition of an episode:
every DeepRacer episode ends in a terminal for GAE purposes (off track, crash, lap complete *and* time-out), so the
value after it is 0 and nothing leaks from one episode into the next.

    delta_t = r_t + discount * V(s_{t+1}) * (1 - end_t) - V(s_t)
    A_t     = delta_t + discount * gae_lambda * (1 - end_t) * A_{t+1}
    target_t = A_t + V(s_t)          (estimate_state_value_using_gae = True)

Advantages are returned raw; the PPO update standardises them over the whole iteration.
"""

from __future__ import annotations

import numpy as np

__all__ = ["GAE_LAMBDA", "compute_gae", "episode_ends_from_lengths"]

GAE_LAMBDA = 0.95
"""Hard-wired in DeepRacer's clipped-PPO preset (not a hyperparameter)."""


def compute_gae(
    rewards: np.ndarray,
    values: np.ndarray,
    episode_ends: np.ndarray,
    discount: float,
    gae_lambda: float = GAE_LAMBDA,
) -> tuple[np.ndarray, np.ndarray]:
    """Advantages and value targets, float64 arrays shaped like `rewards`. The last transition must end an episode."""
    rewards = np.asarray(rewards, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    ends = np.asarray(episode_ends, dtype=bool)
    if not (rewards.shape == values.shape == ends.shape) or rewards.ndim != 1:
        raise ValueError(
            f"rewards {rewards.shape}, values {values.shape} and episode_ends {ends.shape} must be equal 1-D"
        )
    if rewards.size and not ends[-1]:
        raise ValueError("the last transition must end an episode (DeepRacer bootstraps 0 after every episode)")
    advantages = np.zeros_like(rewards)
    next_value = 0.0
    next_advantage = 0.0
    for t in range(rewards.size - 1, -1, -1):
        if ends[t]:
            next_value = 0.0
            next_advantage = 0.0
        delta = rewards[t] + discount * next_value - values[t]
        advantages[t] = delta + discount * gae_lambda * next_advantage
        next_value = values[t]
        next_advantage = advantages[t]
    return advantages, advantages + values


def episode_ends_from_lengths(lengths: list[int]) -> np.ndarray:
    """[3, 2] -> [F, F, T, F, T]: the `episode_ends` mask of episodes laid end to end."""
    ends = np.zeros(sum(lengths), dtype=bool)
    ends[np.cumsum(lengths)[np.asarray(lengths) > 0] - 1] = True
    return ends
