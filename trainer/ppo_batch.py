"""The data side of DeepRacer's clipped PPO update (racer.trainer.ppo): one iteration's episodes as one batch of
tensors, DeepRacer's minibatch size and the per-epoch shuffle (split from ppo.py to keep each module short)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from racer.shared.episode import Episode
from racer.shared.policy.frame_stack import stack_episode_observations
from racer.shared.policy.networks import ActionDistribution, CategoricalPolicy, GaussianPolicy
from racer.shared.policy.policy_config import PolicyConfig
from racer.trainer.gae import episode_ends_from_lengths

__all__ = [
    "TrainingBatch",
    "cat_distributions",
    "make_training_batch",
    "minibatch_size_for",
    "old_log_probs",
    "shuffled_minibatches",
    "slice_distribution",
]


@dataclass(frozen=True)
class TrainingBatch:
    """One iteration's transitions, end to end, as tensors (observations keep the episodes' dtypes and layout)."""

    observations: dict[str, torch.Tensor]
    actions: torch.Tensor
    rewards: torch.Tensor
    episode_ends: torch.Tensor
    behind: torch.Tensor | None = None
    """bool (N,): the transition's episode was played by an older checkpoint than the network's (an overlapped run);
    None when every episode is the network's own."""
    behaviour_log_probs: torch.Tensor | None = None
    """float32 (N,): log-probability of each action under the policy that played it (set with `behind`)."""

    @property
    def size(self) -> int:
        return int(self.rewards.shape[0])

    def to(self, device: torch.device) -> TrainingBatch:
        """Observations and actions on the learner's device; rewards and episode ends stay on the CPU, where the GAE
        runs (a no-op on the CPU)."""
        return TrainingBatch(
            observations={name: array.to(device) for name, array in self.observations.items()},
            actions=self.actions.to(device),
            rewards=self.rewards,
            episode_ends=self.episode_ends,
            behind=None if self.behind is None else self.behind.to(device),
            behaviour_log_probs=None if self.behaviour_log_probs is None else self.behaviour_log_probs.to(device),
        )

    def select(self, indices: torch.Tensor) -> dict[str, torch.Tensor]:
        return {name: array[indices] for name, array in self.observations.items()}


def make_training_batch(
    episodes: Sequence[Episode],
    input_names: Sequence[str],
    config: PolicyConfig | None = None,
    policy_version: int | None = None,
) -> TrainingBatch:
    """Concatenate episodes (in the order given) into one batch with the sensors the network reads. With a `config`
    whose stack_size > 1 each episode's camera frames are stacked first (racer.shared.policy.frame_stack), as the
    workers stacked them for the policy. `policy_version`: the network's checkpoint number; the transitions of
    episodes played by an older one are marked `behind`, with the log-probabilities they were played with."""
    for episode in episodes:
        missing = [name for name in input_names if name not in episode.observations]
        if missing:
            raise ValueError(
                f"episode {episode.episode_index} of worker {episode.worker_id} lacks observations {missing}"
            )
    if config is not None and config.stack_size > 1:
        per_episode = [stack_episode_observations(episode.observations, config, input_names) for episode in episodes]
    else:
        per_episode = [episode.observations for episode in episodes]
    observations = {
        name: torch.from_numpy(np.concatenate([episode_observations[name] for episode_observations in per_episode]))
        for name in input_names
    }
    behind = behaviour_log_probs = None
    if policy_version is not None and any(episode.policy_version < policy_version for episode in episodes):
        behind = torch.from_numpy(
            np.concatenate([np.full(episode.steps, episode.policy_version < policy_version) for episode in episodes])
        )
        behaviour_log_probs = torch.from_numpy(
            np.concatenate([episode.log_probs for episode in episodes]).astype(np.float32)
        )
    return TrainingBatch(
        observations=observations,
        actions=torch.from_numpy(np.concatenate([episode.actions for episode in episodes])),
        rewards=torch.from_numpy(np.concatenate([episode.rewards for episode in episodes]).astype(np.float32)),
        episode_ends=torch.from_numpy(episode_ends_from_lengths([episode.steps for episode in episodes])),
        behind=behind,
        behaviour_log_probs=behaviour_log_probs,
    )


def old_log_probs(batch: TrainingBatch, indices: torch.Tensor, recomputed: torch.Tensor) -> torch.Tensor:
    """log pi_old(a|s) of a minibatch for the clipped ratio: the frozen network's (`recomputed`, DeepRacer's old
    policy) for the network's own episodes, the stored log-probabilities for an episode of an older checkpoint, so
    its ratio is taken against the policy that played it (importance sampling, as in PPO's own derivation)."""
    if batch.behind is None:
        return recomputed
    return torch.where(batch.behind[indices], batch.behaviour_log_probs[indices], recomputed)


def minibatch_size_for(transitions: int, batch_size: int) -> int:
    """DeepRacer's training_worker: a rollout with <= batch_size steps trains on 2^floor(log2(steps))."""
    if transitions <= 0:
        return 0
    if transitions <= batch_size:
        return 2 ** int(math.floor(math.log2(transitions)))
    return batch_size


def shuffled_minibatches(transitions: int, minibatch_size: int, generator: torch.Generator) -> list[torch.Tensor]:
    """One epoch: a random permutation cut into floor(N / size) minibatches, the remainder dropped."""
    permutation = torch.randperm(transitions, generator=generator)
    count = transitions // minibatch_size
    return [permutation[i * minibatch_size : (i + 1) * minibatch_size] for i in range(count)]


def slice_distribution(distribution: ActionDistribution, indices: torch.Tensor) -> ActionDistribution:
    if isinstance(distribution, CategoricalPolicy):
        return CategoricalPolicy(distribution.probs[indices])
    return GaussianPolicy(distribution.mean[indices], distribution.log_std)


def cat_distributions(parts: list[ActionDistribution]) -> ActionDistribution:
    if isinstance(parts[0], CategoricalPolicy):
        return CategoricalPolicy(torch.cat([part.probs for part in parts]))
    return GaussianPolicy(torch.cat([part.mean for part in parts]), parts[0].log_std)
