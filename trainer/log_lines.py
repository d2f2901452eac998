"""The trainer's log lines: DeepRacer's `Training>` line per episode and `Policy training>` line per epoch (PPO) or
per iteration (SAC). Existing regex-based tools parse them, so their text is DeepRacer's to the character."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from racer.trainer.ppo import EpochStats
    from racer.trainer.sac import SACStats

__all__ = ["format_policy_training_line", "format_sac_training_line", "format_training_episode_line"]


def format_policy_training_line(stats: EpochStats) -> str:
    """`Policy training> Surrogate loss=-0.0109..., KL divergence=0.0099..., Entropy=2.628..., training epoch=0,
    learning_rate=0.0003` (console 2022 trainer log)."""
    return (
        f"Policy training> Surrogate loss={float(stats.surrogate_loss)}, KL divergence={float(stats.kl_divergence)}, "
        f"Entropy={float(stats.entropy)}, training epoch={stats.epoch}, learning_rate={float(stats.learning_rate)}"
    )


def format_training_episode_line(
    worker: int, episode: int, total_reward: float, steps: int, training_iteration: int
) -> str:
    """`Training> Name=main_level/agent, Worker=0, Episode=20, Total reward=0, Steps=519, Training iteration=0`.

    `episode` and `steps` are the trainer's running totals (episodes received, transitions consumed); the reward is
    rounded to 2 decimals as RL Coach does, and printed without a fraction when it is whole ("0", "12", "3.25").
    """
    reward = round(float(total_reward), 2)
    reward_text = str(int(reward)) if reward.is_integer() else str(reward)
    return (
        f"Training> Name=main_level/agent, Worker={worker}, Episode={episode}, Total reward={reward_text}, "
        f"Steps={steps}, Training iteration={training_iteration}"
    )


def format_sac_training_line(stats: SACStats) -> str:
    """One line per iteration, in the spirit of DeepRacer's `Policy training>` line."""
    return (
        f"Policy training> Policy loss={stats.policy_loss}, Q loss={stats.q_loss}, V loss={stats.value_loss}, "
        f"Entropy={stats.entropy}, Mean Q={stats.mean_q}, training steps={stats.gradient_steps}, "
        f"batch size={stats.minibatch_size}, replay transitions={stats.replay_transitions}, "
        f"learning_rate={stats.learning_rate}"
    )
