"""The one episode loop: training episodes, worker 0's in-training evaluation and `racer evaluate` all drive it.

A step is the same everywhere: the policy chooses from what it sees (the last N camera frames when the model stacks
frames), the env steps, and the loop hands back a `Step`. What differs is left to the caller: greedy or sampled
actions, one env or several, what is recorded (an `EpisodeRecorder` for the trainer and TrainingMetrics, the
evaluation driver's simtrace and video observers), and when an episode or lap ends and how the next starts.

On two cores the policy's forward pass for one frame costs more than the env step itself, and most of it is per call,
not per frame: one call for K frames costs far less than K calls (`python -m benchmarks rollout`, docs/benchmarks.md).
So a rollout worker steps K envs in lockstep: one `act_batch` for all of them. Each env has its own random generator,
and `act_batch` gives row i the action `act` would give env i alone, so an env plays the same episodes in a batch as it
would alone (tests/rollout/test_batched_rollout.py). One env asks the policy's `act`.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from racer.shared.played_episode import EpisodeRecorder, PlayedEpisode
from racer.shared.policy.frame_stack import frame_stacker_for
from racer.shared.policy.protocol import Policy

StepTap = Callable[[dict, float, dict], None]
"""`(observation, reward, info)` of each step of env 0: the live viewer's frame tap."""


@dataclass(frozen=True)
class Step:
    """One env step: the observation the action was chosen from, the action, and what `env.step` answered."""

    observation: Mapping[str, np.ndarray]
    """Single frames, as the episode keeps them (the policy may have read a stack of them)."""
    action: Any
    log_prob: float
    next_observation: dict[str, np.ndarray]
    reward: float
    terminated: bool
    truncated: bool
    info: dict

    @property
    def done(self) -> bool:
        return self.terminated or self.truncated


class EpisodeLoop:
    """One policy driving `envs` in lockstep, greedy or sampling, each env with its own generator and frame stack."""

    def __init__(self, policy: Policy, envs: Sequence, generators: Sequence[np.random.Generator], *, greedy: bool):
        if len(envs) != len(generators) or not envs:
            raise ValueError(f"need one generator per env, got {len(envs)} envs and {len(generators)} generators")
        self.policy = policy
        self.envs = tuple(envs)
        self.generators = tuple(generators)
        self.greedy = greedy
        self._stackers = [frame_stacker_for(policy) for _ in self.envs]
        self._observations: list[dict | None] = [None] * len(self.envs)
        self._policy_observations: list[dict | None] = [None] * len(self.envs)

    def reset(self, index: int, options: Mapping[str, Any], seed: int | None = None) -> tuple[dict, dict]:
        """Reset env `index` (its frame stack too) and return the env's (observation, info)."""
        env = self.envs[index]
        if seed is None:
            observation, info = env.reset(options=dict(options))
        else:
            observation, info = env.reset(seed=seed, options=dict(options))
        stacker = self._stackers[index]
        self._observations[index] = observation
        self._policy_observations[index] = observation if stacker is None else stacker.reset(observation)
        return observation, info

    def observation(self, index: int) -> dict:
        """The observation env `index`'s next action is chosen from."""
        observation = self._observations[index]
        if observation is None:
            raise RuntimeError(f"env {index} was never reset")
        return observation

    def step(self, indices: Sequence[int], epsilons: Sequence[float]) -> list[Step]:
        """One action for each env in `indices` (one forward pass), then step each; `epsilons`: their e-greedy ε."""
        if any(self._observations[index] is None for index in indices):
            raise RuntimeError("an env must be reset before it steps")
        if len(indices) == 1:
            (index,), (epsilon,) = indices, epsilons
            choices = [
                self.policy.act(
                    self._policy_observations[index],
                    greedy=self.greedy,
                    generator=self.generators[index],
                    epsilon=epsilon,
                )
            ]
        else:
            choices = self.policy.act_batch(
                [self._policy_observations[index] for index in indices],
                self.greedy,
                [self.generators[index] for index in indices],
                list(epsilons),
            )
        steps = []
        for index, (action, log_prob) in zip(indices, choices, strict=True):
            next_observation, reward, terminated, truncated, info = self.envs[index].step(action)
            steps.append(
                Step(
                    observation=self._observations[index],
                    action=action,
                    log_prob=log_prob,
                    next_observation=next_observation,
                    reward=float(reward),
                    terminated=bool(terminated),
                    truncated=bool(truncated),
                    info=info,
                )
            )
            stacker = self._stackers[index]
            self._observations[index] = next_observation
            self._policy_observations[index] = next_observation if stacker is None else stacker.push(next_observation)
        return steps


@dataclass(frozen=True)
class EpisodeTicket:
    """One episode an env is asked to play: its number, its e-greedy ε and how it starts."""

    number: int
    """The episode's number within the iteration (training), or its trial or lap."""
    epsilon: float = 0.0
    reset_options: Mapping[str, Any] | None = None
    """The env's reset options; None: a training start (`{"evaluation": False}`)."""
    carry_on_from_s: float | None = None
    """Set: no reset, the car drives on (the env was told `continue_after_lap`) and the episode's clock starts at
    this sim time (the crossing that closed the lap before); the frame stack runs on across the line, as the car does."""


def play_episodes(
    loop: EpisodeLoop,
    next_episode: Callable[[int], EpisodeTicket | None],
    finished: Callable[[int, EpisodeTicket, EpisodeRecorder], None],
    stop: threading.Event | None = None,
    on_step: StepTap | None = None,
) -> bool:
    """Play until `next_episode(env_index)` has nothing left for any env. An env whose episode ends asks for its next
    at once, so envs never wait for each other between episodes. `finished(env_index, ticket, recorder)` receives
    each episode as it ends; `on_step` sees env 0's steps.

    Returns False when `stop` was set first: episodes still running are abandoned, never half-delivered."""
    slots: list[tuple[EpisodeTicket, EpisodeRecorder] | None] = [None] * len(loop.envs)

    def start(index: int) -> None:
        ticket = next_episode(index)
        if ticket is None:
            slots[index] = None
        elif ticket.carry_on_from_s is None:
            options = {"evaluation": False} if ticket.reset_options is None else ticket.reset_options
            observation, info = loop.reset(index, options)
            slots[index] = (ticket, EpisodeRecorder(observation, info["start_time_s"]))
        else:
            slots[index] = (ticket, EpisodeRecorder(loop.observation(index), ticket.carry_on_from_s))

    for index in range(len(loop.envs)):
        start(index)
    while True:
        active = [index for index, slot in enumerate(slots) if slot is not None]
        if not active:
            return True
        if stop is not None and stop.is_set():
            return False
        steps = loop.step(active, [slots[index][0].epsilon for index in active])
        ended = False
        for index, step in zip(active, steps, strict=True):
            ticket, recorder = slots[index]
            if on_step is not None and index == 0:
                on_step(step.next_observation, step.reward, step.info)
            if recorder.record(step):
                finished(index, ticket, recorder)
                ended = True
                start(index)
        if ended:  # an ended episode may free work for idle envs (next_episode decides)
            for index, slot in enumerate(slots):
                if slot is None:
                    start(index)


def play_episode(
    env,
    policy: Policy,
    *,
    greedy: bool,
    generator: np.random.Generator,
    policy_version: int,
    worker_id: int,
    world: str,
    episode_index: int,
    epsilon: float = 0.0,
    simtrace_episode: int | None = None,
    start_ndist: float | None = None,
    clear_start: bool = False,
    on_step: StepTap | None = None,
    max_steps: int | None = None,
) -> PlayedEpisode:
    """One episode of one env from reset to its end. Evaluation episodes (`greedy=True`) do not advance the start line.

    `simtrace_episode` overrides the simtrace `episode` column (the worker owns that counter so it survives restarts).
    `start_ndist` starts an evaluation episode at that normalised distance along the route; `clear_start` moves it
    off an object as training starts are (the env's `clear_start` reset option).
    `max_steps` truncates the episode after that many steps (the env's reset option; None: the env's own cap).
    """
    options: dict[str, Any] = {"evaluation": greedy}
    if start_ndist is not None:
        options["start_ndist"] = start_ndist
    if clear_start:
        options["clear_start"] = True
    if max_steps is not None:
        options["max_steps"] = max_steps
    tickets = iter([EpisodeTicket(episode_index, epsilon, options)])
    played: list[PlayedEpisode] = []

    def finished(_index: int, _ticket: EpisodeTicket, recorder: EpisodeRecorder) -> None:
        played.append(
            recorder.finish(
                policy_version=policy_version,
                worker_id=worker_id,
                world=world,
                episode_index=episode_index,
                simtrace_episode=simtrace_episode,
            )
        )

    loop = EpisodeLoop(policy, [env], [generator], greedy=greedy)
    play_episodes(loop, lambda _index: next(tickets, None), finished, on_step=on_step)
    return played[0]
