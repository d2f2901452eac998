"""A learning rate that follows the policy's KL: the step size PPO's clip is meant to keep, kept by the optimiser.

Clipped PPO's clip bounds how far one update may pull each probability, but a fixed Adam learning rate decides how
far the update actually gets: too small and the policy barely moves per iteration (on two CPU cores, where the update
is most of the wall time, that is the learning a run does not get), too large and the clip is what stops it. The rule
below is rsl_rl's `schedule="adaptive"` (leggedrobotics/rsl_rl, `rsl_rl/algorithms/ppo.py`; also rl_games'
`AdaptiveScheduler` and skrl's `KLAdaptiveLR`): before each minibatch's step, with KL the mean KL(old || current)
over the minibatch, the rate is divided by 1.5 when KL > 2 x the target and multiplied by 1.5 when 0 < KL < target / 2,
within [1e-5, 1e-2]. rsl_rl's target is 0.01 (its and Isaac Lab's PPO configurations), the same KL Schulman et al.'s
adaptive-KL PPO aims at (arXiv:1707.06347, section 4, d_targ 0.01).

DeepRacer's trainer has no such rule: it is a preset key (`desired_kl`, rsl_rl's name; null by default), so a run
without it is DeepRacer's fixed-rate update. The adapted rate lives in the optimiser and so in every checkpoint: a
resumed run goes on from it.
"""

from __future__ import annotations

from dataclasses import dataclass

RATE_FACTOR = 1.5
KL_MARGIN = 2.0
MIN_LEARNING_RATE = 1e-5
MAX_LEARNING_RATE = 1e-2


@dataclass(frozen=True)
class KLAdaptiveRate:
    """rsl_rl's adaptive schedule for one target KL."""

    desired_kl: float

    def next_rate(self, learning_rate: float, kl: float) -> float:
        """The rate for the coming step, given the current one and the minibatch's KL(old || current)."""
        if kl > self.desired_kl * KL_MARGIN:
            return max(MIN_LEARNING_RATE, learning_rate / RATE_FACTOR)
        if 0.0 < kl < self.desired_kl / KL_MARGIN:
            return min(MAX_LEARNING_RATE, learning_rate * RATE_FACTOR)
        return learning_rate
