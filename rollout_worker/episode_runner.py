"""Play one episode of the DeepRacer environment with a policy and keep everything the run needs from it.

Used by the rollout workers (training episodes and worker 0's greedy evaluations) so both follow the
same path: observation -> policy.act -> env.step -> (reward, simtrace row).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from racer.shared.episode import Episode
from racer.shared.policy.frame_stack import FrameStacker, frame_stacker_for


@dataclass(frozen=True)
class PlayedEpisode:
    episode: Episode
    simtrace_rows: tuple[dict, ...]
    """DeepRacer simtrace rows (19 columns), one per step."""
    final_status: str
    progress: float
    start_time_s: float
    """Simulation clock at the reset (TrainingMetrics `start_time`); the first row is one step later."""
    end_time_s: float
    lap_time_s: float | None
    """Set when the episode ended with a completed lap."""

    @property
    def steps(self) -> int:
        return self.episode.steps

    @property
    def total_reward(self) -> float:
        return self.episode.total_reward

    @property
    def lap_completed(self) -> bool:
        return self.final_status == "lap_complete"


class EpisodeRecorder:
    """Collects one episode step by step (observation -> action -> reward, simtrace row) and builds its PlayedEpisode.

    Shared by `play_episode` (one env) and `racer.rollout_worker.batched_rollout` (several envs, one batched forward pass), so
    both produce the same episode from the same steps."""

    def __init__(self, observation: dict[str, np.ndarray], reset_info: dict, stacker: FrameStacker | None = None):
        """`stacker` (stack_size > 1, racer.shared.policy.frame_stack.frame_stacker_for): the policy reads
        `policy_observation`, the last N camera frames; the episode keeps single frames (`observation`), which the
        trainer stacks the same way."""
        self.observation = observation
        self._stacker = stacker
        self.policy_observation = observation if stacker is None else stacker.reset(observation)
        self.start_time_s = float(reset_info["start_time_s"])
        self._observations: dict[str, list[np.ndarray]] = {name: [] for name in observation}
        self._actions: list = []
        self._log_probs: list[float] = []
        self._rewards: list[float] = []
        self._rows: list[dict] = []
        self._info: dict = {}

    def record(self, action, log_prob: float, step_result: tuple) -> bool:
        """Record the action taken on `self.observation` and what `env.step` returned; True when the episode ended."""
        for name, value in self.observation.items():
            self._observations[name].append(value)
        self._actions.append(action)
        self._log_probs.append(log_prob)
        observation, reward, terminated, truncated, info = step_result
        self._rewards.append(float(reward))
        self._rows.append(info["simtrace"])
        self._info = info
        self.observation = observation
        self.policy_observation = observation if self._stacker is None else self._stacker.push(observation)
        return bool(terminated or truncated)

    @property
    def steps(self) -> int:
        return len(self._rewards)

    def finish(
        self,
        *,
        policy_version: int,
        worker_id: int,
        world: str,
        episode_index: int,
        simtrace_episode: int | None,
        info: Mapping[str, float | int | str] | None = None,
    ) -> PlayedEpisode:
        """The episode as played; `info` goes into `Episode.info` (the worker's rates and phase times)."""
        rows = self._rows
        if simtrace_episode is not None:
            rows = [{**row, "episode": simtrace_episode} for row in rows]
        last_info = self._info
        actions = self._actions
        discrete = isinstance(actions[0], int | np.integer)
        episode = Episode(
            observations={name: np.stack(values) for name, values in self._observations.items()},
            actions=np.asarray(actions, dtype=np.int64) if discrete else np.stack(actions).astype(np.float32),
            rewards=np.asarray(self._rewards, dtype=np.float32),
            log_probs=np.asarray(self._log_probs, dtype=np.float32),
            policy_version=policy_version,
            worker_id=worker_id,
            world=world,
            episode_index=episode_index,
            final_status=str(last_info.get("episode_status", rows[-1]["episode_status"])),
            progress=float(last_info.get("progress", rows[-1]["progress"])),
            info=dict(info or {}),
        )
        lap_time_s = last_info.get("lap_time_s") if episode.final_status == "lap_complete" else None
        return PlayedEpisode(
            episode=episode,
            simtrace_rows=tuple(rows),
            final_status=episode.final_status,
            progress=episode.progress,
            start_time_s=self.start_time_s,
            end_time_s=float(rows[-1]["tstamp"]),
            lap_time_s=None if lap_time_s is None else float(lap_time_s),
        )


def play_episode(
    env,
    policy,
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
    on_step: Callable[[dict, float, dict], None] | None = None,
    max_steps: int | None = None,
) -> PlayedEpisode:
    """One episode from reset to termination. Evaluation episodes (`greedy=True`) do not advance the start line.

    `simtrace_episode` overrides the simtrace `episode` column (the worker owns that counter so it survives restarts).
    `start_ndist` starts an evaluation episode at that normalised distance along the route; `clear_start` moves it
    off an object as training starts are (the env's `clear_start` reset option).
    `on_step(observation, reward, info)` sees every step (the live viewer's frame tap).
    `max_steps` truncates the episode after that many steps (the env's reset option; None: the env's own cap).
    """
    options = {"evaluation": greedy}
    if start_ndist is not None:
        options["start_ndist"] = start_ndist
    if clear_start:
        options["clear_start"] = True
    if max_steps is not None:
        options["max_steps"] = max_steps
    recorder = EpisodeRecorder(*env.reset(options=options), stacker=frame_stacker_for(policy))
    while True:
        action, log_prob = policy.act(recorder.policy_observation, greedy=greedy, generator=generator, epsilon=epsilon)
        result = env.step(action)
        if on_step is not None:
            on_step(result[0], float(result[1]), result[4])
        if recorder.record(action, log_prob, result):
            break
    return recorder.finish(
        policy_version=policy_version,
        worker_id=worker_id,
        world=world,
        episode_index=episode_index,
        simtrace_episode=simtrace_episode,
    )
