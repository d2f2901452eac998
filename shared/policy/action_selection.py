"""DeepRacer's action selection in numpy alone: what the rollout and evaluation workers run, so their image carries
no torch (ONNX Runtime computes the network's output; this module turns it into an action and its log-probability).

- `select_discrete_action(probs, greedy, rng, epsilon)`: argmax, `choice(actions, p=probs)` or e-greedy over one row
  of action probabilities; `sample_categorical` is its draw.
- `select_gaussian_action(mean, log_std, greedy, rng)`: clipped PPO's continuous head, `mean + std * N(0, 1)` (or the
  mean), with the diagonal Gaussian's log-probability.
- `select_squashed_gaussian_action(deterministic, mean, log_std, greedy, rng)` and `squashed_gaussian_log_prob`: SAC's
  a = tanh(mean + std * N(0, 1)), the same formula as `racer.shared.policy.sac_networks.squashed_gaussian_log_prob`
  (torch, for the trainer's gradients).
- `e_greedy_epsilon`, `E_GREEDY_EVALUATION_EPSILON`: DeepRacer's e-greedy schedule.

The torch side (`racer.shared.policy.networks.select_action`, `ActorCritic.act`) calls these same functions, so a
seeded generator gives the same actions through either path (tests/policy/test_action_selection.py compares them).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "E_GREEDY_EVALUATION_EPSILON",
    "LOG_STD_MAX",
    "LOG_STD_MIN",
    "SQUASH_EPSILON",
    "e_greedy_epsilon",
    "gaussian_log_prob",
    "sample_categorical",
    "select_discrete_action",
    "select_gaussian_action",
    "select_squashed_gaussian_action",
    "squashed_gaussian_log_prob",
]

LOG_STD_MIN = -20.0
LOG_STD_MAX = 3.0
"""Clipped PPO's continuous head: the state-independent log-std is clipped to [-20, 3] where it is used."""
SQUASH_EPSILON = float(np.finfo(np.float32).eps)
"""RL Coach's `eps` in SAC's tanh correction log(1 - a^2 + eps) (float32's machine epsilon, as torch's finfo)."""
_HALF_LOG_2PI = 0.5 * math.log(2 * math.pi)


def select_discrete_action(
    probs: np.ndarray, greedy: bool, rng: np.random.Generator, epsilon: float = 0.0
) -> tuple[int, float]:
    """DeepRacer's action choice for one row of action probabilities (float64). Returns (action, log-probability).

    epsilon > 0 (`e-greedy` exploration): a uniformly random action with probability epsilon, else the argmax;
    greedy: the argmax; otherwise a draw from the probabilities (renormalised for the draw only, as the floor of
    1e-8 leaves them summing to slightly more than 1)."""
    if epsilon > 0.0:
        action = int(rng.integers(len(probs))) if rng.random() < epsilon else int(probs.argmax())
    elif greedy:
        action = int(probs.argmax())
    else:
        action = sample_categorical(probs / probs.sum(), rng)
    return action, float(np.log(probs[action]))


def sample_categorical(p: np.ndarray, rng: np.random.Generator) -> int:
    """`int(rng.choice(len(p), p=p))` for probabilities that sum to 1: the same draw from the same generator state,
    without `choice`'s argument checks, which took most of a rollout step's action choice (tests hold the two equal)."""
    cdf = p.cumsum()
    cdf /= cdf[-1]
    return int(cdf.searchsorted(rng.random(), side="right"))


def gaussian_log_prob(action: np.ndarray, mean: np.ndarray, log_std: np.ndarray) -> float:
    """log N(action; mean, exp(log_std)) of a diagonal Gaussian, summed over the action's dimensions."""
    z = (action - mean) / np.exp(log_std)
    return float(np.sum(-0.5 * z**2 - log_std - _HALF_LOG_2PI))


def select_gaussian_action(
    mean: np.ndarray, log_std: np.ndarray, greedy: bool, rng: np.random.Generator, epsilon: float = 0.0
) -> tuple[np.ndarray, float]:
    """Clipped PPO's continuous action for one row: `mean` (float64, (2,): DeepRacer's linear head output) and the
    clipped `log_std` (float64, (2,)). greedy: the mean; otherwise `mean + std * N(0, 1)`, not clipped (the environment
    clips to [-1, 1] when it scales the action, as DeepRacer's does). Returns (float32 action, log-probability)."""
    if epsilon > 0.0:
        raise ValueError("e-greedy exploration is for discrete action spaces; continuous policies sample a Gaussian")
    action = mean if greedy else mean + np.exp(log_std) * rng.standard_normal(mean.shape)
    return action.astype(np.float32), gaussian_log_prob(action, mean, log_std)


def squashed_gaussian_log_prob(raw: np.ndarray, action: np.ndarray, mean: np.ndarray, log_std: np.ndarray) -> float:
    """log pi(a|s) of a = tanh(raw), raw ~ N(mean, exp(log_std)), for one row: the Gaussian density minus
    sum log(1 - a^2 + eps), the correction clipped to [1e-10, 1] as in DeepRacer's head."""
    z = (raw - mean) * np.exp(-log_std)
    gaussian = np.sum(-0.5 * np.square(z) - log_std - _HALF_LOG_2PI)
    correction = np.sum(np.log(np.clip(1.0 - np.square(action) + SQUASH_EPSILON, 1e-10, 1.0)))
    return float(gaussian - correction)


def select_squashed_gaussian_action(
    deterministic: np.ndarray,
    mean: np.ndarray,
    log_std: np.ndarray,
    greedy: bool,
    rng: np.random.Generator,
    epsilon: float = 0.0,
) -> tuple[np.ndarray, float]:
    """SAC's action for one row (float64 arrays of shape (2,)). greedy: `deterministic` (tanh(mean), what evaluation
    and the car drive), log-probability 0; otherwise a = tanh(mean + exp(log_std) * N(0, 1)) and its log-probability."""
    if epsilon > 0.0:
        raise ValueError("e-greedy exploration is for discrete action spaces; SAC samples its squashed Gaussian")
    if greedy:
        return deterministic.astype(np.float32), 0.0
    raw = mean + np.exp(log_std) * rng.standard_normal(mean.shape)
    action = np.tanh(raw)
    return action.astype(np.float32), squashed_gaussian_log_prob(raw, action, mean, log_std)


E_GREEDY_EVALUATION_EPSILON = 0.05
"""RL Coach's `EGreedyParameters.evaluation_epsilon`: with `e-greedy` exploration the in-training evaluation episodes
(TEST phase) still take a random action with this probability; DeepRacer does not change it."""


def e_greedy_epsilon(env_step: int, final_epsilon: float, decay_steps: int) -> float:
    """DeepRacer's e-greedy schedule, `LinearSchedule(1.0, e_greedy_value, epsilon_steps)`, at `env_step`."""
    if decay_steps <= 0:
        return final_epsilon
    fraction = min(1.0, max(0, env_step) / decay_steps)
    return 1.0 + fraction * (final_epsilon - 1.0)
