"""What the trainer's loop asks of a learning algorithm (clipped PPO, SAC), and what every learner shares.

The loop (racer.trainer.training_loop) never asks which algorithm it drives: it calls `Learner.update` with the
iteration's episodes, prints `Learner.training_lines`, offers a late episode with `Learner.take_late_episode`, and saves
`Learner.network` with `Learner.optimizer`. racer.trainer.algorithms builds the learner model_metadata.json asks for.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np
import torch

if TYPE_CHECKING:
    from torch import nn

    from racer.shared.episode import Episode

__all__ = ["ADAM_BETAS", "ADAM_EPSILON", "Learner", "UpdateAbandoned", "adam", "seed_or_fresh"]

ADAM_EPSILON = 1e-5
ADAM_BETAS = (0.9, 0.999)
"""DeepRacer's Adam (RL Coach's defaults for clipped PPO and SAC)."""


class UpdateAbandoned(Exception):
    """`update(abandon=...)` said stop: the network holds a partial update and must not be saved."""


class Learner(Protocol):
    """One algorithm's update over the trainer's network (PPOLearner and SACLearner implement it)."""

    @property
    def network(self) -> nn.Module:
        """The weights checkpoints save and restore."""
        ...

    @property
    def optimizer(self) -> torch.optim.Optimizer: ...

    @property
    def tower_dtype(self) -> torch.dtype | None:
        """What the towers compute in during updates (None: fp32)."""
        ...

    @property
    def learning_rate(self) -> float: ...

    @property
    def nan_rollbacks(self) -> int:
        """How many times an update was rolled back because of a non-finite number."""
        ...

    def update(
        self,
        episodes: Sequence[Episode],
        abandon: Callable[[], bool] | None = None,
        env_steps: int | None = None,
        policy_version: int | None = None,
    ) -> Sequence[object]:
        """Learn from one iteration's episodes; returns the update's statistics ([] when nothing was trained).
        `abandon()` is asked between steps; True raises `UpdateAbandoned`. `env_steps`: the run's environment steps
        trained on, these episodes' included (the clock of a schedule, e.g. PPO's clip range). `policy_version`: the network's checkpoint number (episodes of an older one
        came from an overlapped run)."""
        ...

    def training_lines(self, stats: Sequence[object]) -> list[str]:
        """The `Policy training>` log lines of an update's statistics."""
        ...

    def take_late_episode(self, episode: Episode, iteration: int) -> bool:
        """Offered an episode played for an older iteration while collecting `iteration`: True when the learner
        keeps it (the collector then acknowledges it), False when it is dropped as stale."""
        ...


def adam(parameters: Iterable[nn.Parameter], learning_rate: float, betas=ADAM_BETAS, eps=ADAM_EPSILON):
    """Every learner's optimiser: one fused Adam (same arithmetic as the textbook loop), no gradient clipping."""
    return torch.optim.Adam(parameters, lr=learning_rate, betas=betas, eps=eps, fused=True)


def seed_or_fresh(seed: int | None) -> int:
    """The seed a learner's random numbers start from: the one given, or a fresh one."""
    return seed if seed is not None else int(np.random.SeedSequence().generate_state(1)[0])
