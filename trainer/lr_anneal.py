"""A learning rate that falls to zero as the run reaches its limit: the last checkpoints settle instead of moving.

With a fixed rate the policy moves as far in the run's last iteration as in its first, so the last checkpoint is
one more draw from a policy still on its way; on two cores a 20-minute race-pace run's last checkpoint often drove
no 3 laps without a reset where an earlier one had. PPO's authors annealed the Adam step size linearly from its
value to 0 over the training budget (Schulman et al., arXiv:1707.06347, Table 5, Atari: "2.5e-4 x alpha, alpha
linearly annealed from 1 to 0"), and CleanRL's PPO does so by default (vwxyzjn/cleanrl `cleanrl/ppo.py`,
`anneal_lr = True`: lr x (1 - (iteration - 1) / iterations)). racer's budget is the run's own limit: the share of it
used is the larger of the time used of `--max-minutes` and the episodes played of the episode limit, whichever
stops the run sooner, so the rate reaches 0 where the run stops.

DeepRacer's trainer has no such rule: it is a preset key (`anneal_lr`, CleanRL's name; false by default). A time
limit makes the rate depend on how fast the machine trains, so a run with it under `--max-minutes` is not
reproducible bit for bit (one limited by episodes is).
"""

from __future__ import annotations

from racer.shared.run_progress import StopCondition


def share_of_run_used(condition: StopCondition, elapsed_s: float, episodes: int) -> float:
    """0..1: the larger share used of the two limits (`elapsed_s` of the trainer's clock, `episodes` played)."""
    by_episodes = episodes / max(1, condition.max_episodes)
    by_time = 0.0 if condition.max_minutes is None else elapsed_s / (60.0 * condition.max_minutes)
    return min(1.0, max(0.0, by_episodes, by_time))


def annealed_rate(base_lr: float, share_used: float) -> float:
    """hyperparameters.json's `lr` scaled by the share of the run still to go."""
    return base_lr * (1.0 - min(1.0, max(0.0, share_used)))
