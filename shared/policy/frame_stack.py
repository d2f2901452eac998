"""Frame stacking (hyperparameters.json `stack_size` > 1): a camera input of the policy is the last N frames.

Semantics follow RL Coach's `ObservationStackingFilter` (rl_coach/filters/observation/observation_stacking_filter.py):
the first observation of an episode fills the whole stack (it is repeated N times), every later one pushes the
oldest out. RL Coach stacks a (120, 160) grey frame on a new last axis (`np.stack(..., axis=-1)`), giving
(120, 160, N) with the newest frame last; racer's frames already carry a channel axis (120, 160, C), so frames are
concatenated on that axis, oldest first: for C = 1 that is RL Coach's layout exactly. STEREO_CAMERAS (C = 2) gives
(120, 160, 2N), frame by frame (left, right of the oldest, ..., left, right of the newest).

Only camera inputs are stacked; LIDAR vectors are passed through unstacked. Episodes on the wire keep single frames
(racer.shared.transport.codec): the workers stack for the policy (`FrameStacker`), the trainer rebuilds the same stacks
from an episode's frames (`stack_episode_frames`), since every episode is complete from its reset.

numpy only: the rollout and evaluation workers import this module and carry no torch.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping, Sequence

import numpy as np

__all__ = ["FrameStacker", "frame_stacker_for", "stack_episode_frames", "stack_episode_observations"]


def _stacked_names(config) -> tuple[str, ...]:
    return tuple(spec.name for spec in config.inputs if spec.kind == "camera")


def stack_episode_frames(frames: np.ndarray, stack_size: int) -> np.ndarray:
    """An episode's single frames (T, H, W, C), from its reset on -> the policy's inputs (T, H, W, C * stack_size):
    row t is frames t-N+1 .. t on the channel axis, oldest first, frame 0 standing in for the steps before it."""
    frames = np.asarray(frames)
    if stack_size == 1:
        return frames
    steps = frames.shape[0]
    if steps == 0:
        return np.zeros((0, *frames.shape[1:-1], frames.shape[-1] * stack_size), frames.dtype)
    offsets = np.arange(stack_size) - (stack_size - 1)  # -(N-1) .. 0
    indices = np.clip(np.arange(steps)[:, None] + offsets[None, :], 0, None)  # (T, N)
    gathered = frames[indices]  # (T, N, H, W, C)
    return np.ascontiguousarray(np.moveaxis(gathered, 1, -2).reshape(*frames.shape[:-1], -1))


def stack_episode_observations(
    observations: Mapping[str, np.ndarray], config, names: Sequence[str] | None = None
) -> dict[str, np.ndarray]:
    """`stack_episode_frames` on an episode's camera observations (the others as they are) for `config.stack_size`."""
    stack_size = int(getattr(config, "stack_size", 1))
    stacked = set(_stacked_names(config))
    wanted = names if names is not None else list(observations)
    return {
        name: stack_episode_frames(observations[name], stack_size) if name in stacked else observations[name]
        for name in wanted
    }


class FrameStacker:
    """One env's stacks: `reset(observation)` at an episode's first observation, `push(observation)` at every later
    one; both return the observation the policy reads (camera inputs stacked, the rest unchanged)."""

    def __init__(self, stack_size: int, names: Sequence[str]):
        if int(stack_size) < 1:
            raise ValueError(f"stack_size must be at least 1, got {stack_size}")
        self.stack_size = int(stack_size)
        self.names = tuple(names)
        self._stacks: dict[str, deque] = {}

    def reset(self, observation: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        self._stacks = {
            name: deque([observation[name]] * self.stack_size, maxlen=self.stack_size)
            for name in self.names
            if name in observation
        }
        return self._current(observation)

    def push(self, observation: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        if not self._stacks:
            return self.reset(observation)
        for name, stack in self._stacks.items():
            stack.append(observation[name])
        return self._current(observation)

    def _current(self, observation: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        current = dict(observation)
        for name, stack in self._stacks.items():
            current[name] = np.concatenate(list(stack), axis=-1)
        return current


def frame_stacker_for(policy) -> FrameStacker | None:
    """The stacker a policy (OnnxPolicy, ActorCritic, ... anything with a PolicyConfig `config`) needs, or None when
    it reads single frames (stack_size 1: observations go to it untouched, as before stacking existed)."""
    config = getattr(policy, "config", None)
    stack_size = int(getattr(config, "stack_size", 1)) if config is not None else 1
    if stack_size == 1:
        return None
    return FrameStacker(stack_size, _stacked_names(config))
