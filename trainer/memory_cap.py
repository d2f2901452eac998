"""DeepRacer's cap on the transitions one iteration trains on (SimApp `deepracer_memory.py`).

The SimApp's trainer fetches the iteration's episodes in their global order (worker i plays episodes i, i+W, i+2W,
...) and keeps them while the running step count stays within `MAX_MEMORY_STEPS`: 10,000 for the shallow network,
3,000 for the others, or the trainer's `MAX_MEMORY_STEPS` environment variable. The first episode that would pass
the cap and every later one are dropped. So long episodes mean fewer episodes trained, smaller step counts in the
checkpoint names and a different batch size; racer follows it by default (`--max-memory-steps 0` lifts the cap).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from racer.shared.episode import Episode

MAX_MEMORY_STEPS_SHALLOW = 10_000
MAX_MEMORY_STEPS_OTHER = 3_000
SHALLOW_NETWORK = "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW"


def default_max_memory_steps(neural_network: str) -> int:
    return MAX_MEMORY_STEPS_SHALLOW if neural_network == SHALLOW_NETWORK else MAX_MEMORY_STEPS_OTHER


def global_episode_order(by_number: Mapping[int, Episode]) -> list[Episode]:
    """The SimApp's episode order: by episode number within the iteration (worker i's j-th episode is i + j * W)."""
    return [by_number[number] for number in sorted(by_number)]


@dataclass(frozen=True)
class CappedIteration:
    kept: tuple[Episode, ...]
    dropped: tuple[Episode, ...]
    max_steps: int | None

    @property
    def kept_steps(self) -> int:
        return sum(episode.steps for episode in self.kept)

    @property
    def dropped_steps(self) -> int:
        return sum(episode.steps for episode in self.dropped)


def cap_episodes(ordered: Sequence[Episode], max_steps: int | None) -> CappedIteration:
    """Keep the episodes while the running step count is within `max_steps` (None or 0: keep all).

    One difference: when the very first episode is longer than the cap it is kept alone (the SimApp would train on
    nothing, and an iteration without data cannot update the policy)."""
    if not max_steps:
        return CappedIteration(tuple(ordered), (), None)
    total = 0
    for index, episode in enumerate(ordered):
        total += episode.steps
        if total > max_steps:
            cut = max(index, 1)
            return CappedIteration(tuple(ordered[:cut]), tuple(ordered[cut:]), max_steps)
    return CappedIteration(tuple(ordered), (), max_steps)
