"""One episode as a worker played it: the episode the trainer learns from, plus its simtrace rows and times.

`EpisodeRecorder` collects it step by step from the episode loop (racer.shared.episode_loop), the same way for
training episodes, worker 0's greedy evaluations and the laps of a continuous evaluation run.
"""

from __future__ import annotations

from collections.abc import Mapping
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


class EpisodeRecorder:
    """Collects one episode step by step (observation -> action -> reward, simtrace row) and builds its PlayedEpisode.

    It keeps single camera frames (the observation each action was chosen from); the trainer stacks them as the
    policy did (racer.shared.policy.frame_stack)."""

    def __init__(self, observation: Mapping[str, np.ndarray], start_time_s: float):
        """`observation`: the episode's first; `start_time_s`: the sim clock at its start (the reset, or the
        crossing that closed the lap before)."""
        self.start_time_s = float(start_time_s)
        self._observations: dict[str, list[np.ndarray]] = {name: [] for name in observation}
        self._actions: list = []
        self._log_probs: list[float] = []
        self._rewards: list[float] = []
        self._rows: list[dict] = []
        self._info: dict = {}

    @property
    def steps(self) -> int:
        return len(self._rewards)

    def record(self, step) -> bool:
        """Record one `racer.shared.episode_loop.Step`; True when the episode ended."""
        for name, value in step.observation.items():
            self._observations[name].append(value)
        self._actions.append(step.action)
        self._log_probs.append(step.log_prob)
        self._rewards.append(float(step.reward))
        self._rows.append(step.info["simtrace"])
        self._info = step.info
        return step.done

    def finish(
        self,
        *,
        policy_version: int,
        worker_id: int,
        world: str,
        episode_index: int,
        simtrace_episode: int | None,
        iteration: int = 0,
        episode_number: int = 0,
        info: Mapping[str, float | int | str] | None = None,
    ) -> PlayedEpisode:
        """The episode as played. `iteration` and `episode_number` say which episode of which iteration it is (what
        the trainer reads; evaluation episodes never travel); `info` goes into `Episode.info` (the worker's rates and
        phase times)."""
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
            iteration=iteration,
            episode_number=episode_number,
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
