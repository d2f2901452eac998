"""One finished episode, as a rollout worker hands it to the trainer.

This is the one unit that travels env -> Redis -> trainer: one stream entry per episode, which says which episode
of which iteration it is. Arrays share a leading time axis of length `steps` (every transition, including
DeepRacer's zero-reward `prepare` step). The transport encodes it without pickle (`racer.shared.transport.codec`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Episode:
    observations: dict[str, np.ndarray]
    """Sensor name -> array (steps, ...): cameras uint8 (steps, 120, 160, C), lidar float32 (steps, n)."""
    actions: np.ndarray
    """Discrete: int64 (steps,) action indices. Continuous: float32 (steps, 2) in the network's [-1, 1] space."""
    rewards: np.ndarray
    """float32 (steps,): reward of each transition (0 for prepare and pause steps)."""
    log_probs: np.ndarray
    """float32 (steps,): log-probability of the action under the policy that chose it."""
    policy_version: int
    """Checkpoint number of the policy that played this episode."""
    worker_id: int
    world: str
    iteration: int = 0
    """The training iteration the episode was played for (the trainer drops it when it is not the one it collects,
    unless its learner keeps late episodes)."""
    episode_number: int = 0
    """Its number within the iteration, 0..E-1 (worker i of W owns i, i+W, ...): what the trainer counts, orders
    and drops second copies by."""
    episode_index: int = 0
    """Worker-local training-episode counter (DeepRacer's simtrace `episode`)."""
    final_status: str = ""
    """DeepRacer episode_status of the last step, e.g. `off_track`, `lap_complete`."""
    progress: float = 0.0
    """Progress (%) reached at the end of the episode."""
    info: dict[str, float | int | str] = field(default_factory=dict)

    @property
    def steps(self) -> int:
        return int(self.rewards.shape[0])

    @property
    def total_reward(self) -> float:
        return float(self.rewards.sum(dtype=np.float64))

    def validate(self) -> None:
        """Raise ValueError if the arrays disagree on length or dtype (checked before sending and after receiving)."""
        steps = self.steps
        if self.rewards.ndim != 1:
            raise ValueError(f"episode rewards must be 1-D, got shape {self.rewards.shape}")
        for name, array in self.observations.items():
            if array.shape[0] != steps:
                raise ValueError(f"observation {name!r} has {array.shape[0]} steps, rewards have {steps}")
        for name, array in (("actions", self.actions), ("log_probs", self.log_probs)):
            if array.shape[0] != steps:
                raise ValueError(f"{name} has {array.shape[0]} steps, rewards have {steps}")
        if not np.all(np.isfinite(self.rewards)):
            raise ValueError("episode rewards contain NaN or infinity")
