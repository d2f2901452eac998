"""SAC's experience replay on the trainer: a ring of transitions sized by a memory budget, not a count.

DeepRacer's trainer keeps RL Coach's `ExperienceReplay` (up to 1,000,000 transitions, uniform sampling). A camera
transition here is 19,200 bytes of uint8 pixels (38,400 stereo) plus action, reward and done, so the capacity is
`memory_budget_bytes // bytes_per_transition` (1 GiB: about 55,000 single-camera transitions, 27,000 stereo) and
the oldest transitions make room for new ones.

The next observation is not stored a second time: transition i's successor is slot i + 1. Episodes arrive whole and
their last transition is terminal (DeepRacer treats every episode end as a game over), so the newest slot never
needs a successor, and a slot's successor is only overwritten after the slot itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from racer.shared.episode import Episode
from racer.shared.policy.frame_stack import stack_episode_frames
from racer.shared.policy.networks import InputSpec

__all__ = ["ReplayBatch", "ReplayBuffer", "bytes_per_transition"]

ACTION_SIZE = 2


def _dtype(spec: InputSpec) -> np.dtype:
    return np.dtype(np.uint8) if spec.kind == "camera" else np.dtype(np.float32)


def bytes_per_transition(inputs: Sequence[InputSpec]) -> int:
    observation = sum(int(np.prod(spec.shape)) * _dtype(spec).itemsize for spec in inputs)
    return observation + ACTION_SIZE * 4 + 4 + 1  # action float32 x2, reward float32, done bool


@dataclass(frozen=True)
class ReplayBatch:
    observations: dict[str, torch.Tensor]
    actions: torch.Tensor
    rewards: torch.Tensor
    dones: torch.Tensor
    """1.0 where the transition ended its episode (no bootstrap from the next state)."""
    next_observations: dict[str, torch.Tensor]

    def to(self, device: torch.device) -> ReplayBatch:
        """The same minibatch on the learner's device (a no-op on the CPU)."""
        return ReplayBatch(
            observations={name: array.to(device) for name, array in self.observations.items()},
            actions=self.actions.to(device),
            rewards=self.rewards.to(device),
            dones=self.dones.to(device),
            next_observations={name: array.to(device) for name, array in self.next_observations.items()},
        )


class ReplayBuffer:
    def __init__(self, inputs: Sequence[InputSpec], memory_budget_bytes: int, stack_size: int = 1):
        """`inputs`: the network's (camera shapes already stacked); `stack_size` > 1: episodes bring single frames,
        stacked here as the workers stacked them (racer.shared.policy.frame_stack)."""
        self.inputs = tuple(inputs)
        self.stack_size = int(stack_size)
        self.capacity = int(memory_budget_bytes // bytes_per_transition(self.inputs))
        if self.capacity < 2:
            raise ValueError(f"a replay memory of {memory_budget_bytes} bytes holds fewer than 2 transitions")
        self._observations = {spec.name: np.zeros((self.capacity, *spec.shape), _dtype(spec)) for spec in self.inputs}
        self._actions = np.zeros((self.capacity, ACTION_SIZE), np.float32)
        self._rewards = np.zeros(self.capacity, np.float32)
        self._dones = np.zeros(self.capacity, np.bool_)
        self._next = 0
        self._size = 0

    def __len__(self) -> int:
        return self._size

    @property
    def nbytes(self) -> int:
        arrays = [*self._observations.values(), self._actions, self._rewards, self._dones]
        return sum(array.nbytes for array in arrays)

    def add_episode(self, episode: Episode) -> None:
        steps = episode.steps
        if steps == 0:
            return
        if steps > self.capacity:
            raise ValueError(f"an episode of {steps} steps does not fit a replay memory of {self.capacity}")
        slots = (self._next + np.arange(steps)) % self.capacity
        for spec in self.inputs:
            frames = episode.observations[spec.name]
            if self.stack_size > 1 and spec.kind == "camera":
                frames = stack_episode_frames(frames, self.stack_size)
            self._observations[spec.name][slots] = frames
        self._actions[slots] = np.asarray(episode.actions, np.float32).reshape(steps, ACTION_SIZE)
        self._rewards[slots] = episode.rewards
        self._dones[slots] = False
        self._dones[slots[-1]] = True
        self._next = int((slots[-1] + 1) % self.capacity)
        self._size = min(self.capacity, self._size + steps)

    def sample(self, batch_size: int, generator: np.random.Generator) -> ReplayBatch:
        """Uniform over the stored transitions (with replacement, as RL Coach's ExperienceReplay.sample)."""
        if self._size == 0:
            raise ValueError("the replay memory is empty")
        oldest = (self._next - self._size) % self.capacity
        slots = (oldest + generator.integers(0, self._size, batch_size)) % self.capacity
        successors = (slots + 1) % self.capacity
        return ReplayBatch(
            observations={name: torch.from_numpy(array[slots]) for name, array in self._observations.items()},
            actions=torch.from_numpy(self._actions[slots]),
            rewards=torch.from_numpy(self._rewards[slots]),
            dones=torch.from_numpy(self._dones[slots].astype(np.float32)),
            next_observations={name: torch.from_numpy(array[successors]) for name, array in self._observations.items()},
        )
