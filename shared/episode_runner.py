"""Play one episode of the DeepRacer environment with a policy and keep everything the run needs from it.

Used by the rollout workers (training episodes and worker 0's greedy evaluations) so both follow the
same path: observation -> policy.act -> env.step -> (reward, simtrace row).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from racer.shared.episode import Episode


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
    on_step: Callable[[dict, float, dict], None] | None = None,
) -> PlayedEpisode:
    """One episode from reset to termination. Evaluation episodes (`greedy=True`) do not advance the start line.

    `simtrace_episode` overrides the simtrace `episode` column (the worker owns that counter so it survives restarts).
    `start_ndist` starts an evaluation episode at that normalised distance along the route.
    `on_step(observation, reward, info)` sees every step (the live viewer's frame tap).
    """
    options = {"evaluation": greedy}
    if start_ndist is not None:
        options["start_ndist"] = start_ndist
    observation, reset_info = env.reset(options=options)
    observations: dict[str, list[np.ndarray]] = {name: [] for name in observation}
    actions: list = []
    log_probs: list[float] = []
    rewards: list[float] = []
    rows: list[dict] = []
    info: dict = {}
    while True:
        action, log_prob = policy.act(observation, greedy=greedy, generator=generator, epsilon=epsilon)
        for name, value in observation.items():
            observations[name].append(value)
        actions.append(action)
        log_probs.append(log_prob)
        observation, reward, terminated, truncated, info = env.step(action)
        rewards.append(float(reward))
        if on_step is not None:
            on_step(observation, float(reward), info)
        row = dict(info["simtrace"])
        if simtrace_episode is not None:
            row["episode"] = simtrace_episode
        rows.append(row)
        if terminated or truncated:
            break
    discrete = isinstance(actions[0], int | np.integer)
    episode = Episode(
        observations={name: np.stack(values) for name, values in observations.items()},
        actions=np.asarray(actions, dtype=np.int64) if discrete else np.stack(actions).astype(np.float32),
        rewards=np.asarray(rewards, dtype=np.float32),
        log_probs=np.asarray(log_probs, dtype=np.float32),
        policy_version=policy_version,
        worker_id=worker_id,
        world=world,
        episode_index=episode_index,
        final_status=str(info.get("episode_status", rows[-1]["episode_status"])),
        progress=float(info.get("progress", rows[-1]["progress"])),
    )
    lap_time_s = info.get("lap_time_s") if episode.final_status == "lap_complete" else None
    return PlayedEpisode(
        episode=episode,
        simtrace_rows=tuple(rows),
        final_status=episode.final_status,
        progress=episode.progress,
        start_time_s=float(reset_info["start_time_s"]),
        end_time_s=float(rows[-1]["tstamp"]),
        lap_time_s=None if lap_time_s is None else float(lap_time_s),
    )
