"""Training episodes on several envs of one world at once, all their actions from one batched forward pass.

On two cores the policy's forward pass for one frame costs more than the env step itself, and most of it is per call,
not per frame: one call for K frames costs far less than K calls (`python -m benchmarks rollout`, docs/benchmarks.md). So a
rollout worker steps K envs in lockstep: observe all, one `policy.act_batch`, step each. An env whose episode ends
asks for its next episode at once (`next_episode`), so envs never wait for each other between episodes.

Each env has its own random generator, and `act_batch` gives row i the action `act` would give env i alone, so an env
plays the same episodes in a batch as it would alone (tests/rollout/test_batched_rollout.py).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from racer.rollout_worker.episode_runner import EpisodeRecorder
from racer.shared.policy.frame_stack import frame_stacker_for


@dataclass(frozen=True)
class EpisodeTicket:
    """One episode an env is asked to play: its number within the iteration and its e-greedy epsilon."""

    number: int
    epsilon: float = 0.0


class BatchedRollout:
    def __init__(self, envs: Sequence, generators: Sequence[np.random.Generator]):
        if len(envs) != len(generators) or not envs:
            raise ValueError(f"need one generator per env, got {len(envs)} envs and {len(generators)} generators")
        self.envs = tuple(envs)
        self.generators = tuple(generators)

    def play(
        self,
        policy,
        next_episode: Callable[[int], EpisodeTicket | None],
        finished: Callable[[int, EpisodeTicket, EpisodeRecorder], None],
        stop: threading.Event,
        on_step: Callable[[dict, float, dict], None] | None = None,
    ) -> bool:
        """Play until `next_episode(env_index)` has nothing left for any env. `finished(env_index, ticket, recorder)`
        receives each episode as it ends; `on_step` sees env 0's steps (the live viewer's frame tap).

        Returns False when `stop` was set first: episodes still running are abandoned, never half-delivered."""
        slots: list[tuple[EpisodeTicket, EpisodeRecorder] | None] = [None] * len(self.envs)

        def start(index: int) -> None:
            ticket = next_episode(index)
            if ticket is None:
                slots[index] = None
                return
            observation, info = self.envs[index].reset(options={"evaluation": False})
            slots[index] = (ticket, EpisodeRecorder(observation, info, stacker=frame_stacker_for(policy)))

        for index in range(len(self.envs)):
            start(index)
        while True:
            active = [index for index, slot in enumerate(slots) if slot is not None]
            if not active:
                return True
            if stop.is_set():
                return False
            choices = policy.act_batch(
                [slots[index][1].policy_observation for index in active],
                False,
                [self.generators[index] for index in active],
                [slots[index][0].epsilon for index in active],
            )
            ended = False
            for index, (action, log_prob) in zip(active, choices, strict=True):
                ticket, recorder = slots[index]
                result = self.envs[index].step(action)
                if on_step is not None and index == 0:
                    on_step(result[0], float(result[1]), result[4])
                if recorder.record(action, log_prob, result):
                    finished(index, ticket, recorder)
                    ended = True
                    start(index)
            if ended:  # an ended episode may free work for idle envs (next_episode decides)
                for index, slot in enumerate(slots):
                    if slot is None:
                        start(index)
