"""Worker 0's in-training evaluation: MIN_EVAL_TRIALS greedy episodes of each new checkpoint, or with
RACER_EVAL_CONTINUOUS as many consecutive laps of one run (deepracer_checkpoints.json and the best checkpoint follow from
them, racer.rollout_worker.training_log), and the exploration rule they share with training episodes."""

from __future__ import annotations

import logging
import threading

import numpy as np

from racer.rollout_worker.worker_files import WorkerFiles
from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.episode_loop import EpisodeLoop, EpisodeTicket, play_episode, play_episodes
from racer.shared.played_episode import EpisodeRecorder, PlayedEpisode
from racer.shared.policy.action_selection import E_GREEDY_EVALUATION_EPSILON
from racer.shared.sim.env import DeepRacerEnv

log = logging.getLogger(__name__)


def uses_e_greedy(hyperparameters: Hyperparameters, metadata: ModelMetadata) -> bool:
    """RL Coach's e-greedy applies to discrete action spaces only (continuous ones keep Gaussian sampling)."""
    return hyperparameters.exploration_type.lower().strip() == "e-greedy" and not metadata.continuous_action_space


def evaluation_epsilon(hyperparameters: Hyperparameters, metadata: ModelMetadata) -> float:
    """ε of worker 0's in-training evaluation episodes: RL Coach keeps its evaluation ε (0.05) under e-greedy."""
    return E_GREEDY_EVALUATION_EPSILON if uses_e_greedy(hyperparameters, metadata) else 0.0


def evaluate_checkpoint(
    env: DeepRacerEnv,
    policy,
    run: WorkerFiles,
    iteration: int,
    worker_id: int,
    generator: np.random.Generator,
    on_step,
    stop: threading.Event,
) -> list | None:
    """The run's MIN_EVAL_TRIALS greedy episodes of checkpoint `iteration` (spread over the lap when
    RACER_EVAL_SPREAD_STARTS, each at most RACER_EVAL_MAX_STEPS steps when set), or its consecutive laps with
    RACER_EVAL_CONTINUOUS (`play_consecutive_laps`); None when `stop` is set before they are all played."""
    trials = run.worker.min_eval_trials
    epsilon = evaluation_epsilon(run.hyperparameters, run.model_metadata)
    if run.worker.eval_continuous:
        laps = play_consecutive_laps(
            env,
            policy,
            laps=trials,
            generator=generator,
            epsilon=epsilon,
            policy_version=iteration,
            worker_id=worker_id,
            world=run.worker.world,
            on_step=on_step,
            stop=stop,
            max_steps=run.worker.eval_max_steps or None,
        )
        if laps is not None:
            log.info(
                "worker %d: evaluation of checkpoint %d, %d consecutive laps: %s",
                worker_id,
                iteration,
                len(laps),
                ", ".join(
                    f"{lap.final_status} {lap.progress:.1f}% {lap.end_time_s - lap.start_time_s:.2f} s" for lap in laps
                ),
            )
        return laps
    results = []
    first_start = env.start_ndist
    for trial in range(trials):
        if stop.is_set():
            return None
        start = (first_start + trial / trials) % 1.0 if run.worker.eval_spread_starts else None
        results.append(
            play_episode(
                env,
                policy,
                greedy=True,
                generator=generator,
                epsilon=epsilon,
                policy_version=iteration,
                worker_id=worker_id,
                world=run.worker.world,
                episode_index=trial,
                start_ndist=start,
                clear_start=start is not None,
                on_step=on_step,
                max_steps=run.worker.eval_max_steps or None,
            )
        )
        log.info(
            "worker %d: evaluation trial %d of checkpoint %d from %.3f of the lap: %s, progress %.1f%%",
            worker_id,
            trial,
            iteration,
            first_start if start is None else start,
            results[-1].final_status,
            results[-1].progress,
        )
    return results


def play_consecutive_laps(
    env: DeepRacerEnv,
    policy,
    *,
    laps: int,
    generator: np.random.Generator,
    epsilon: float,
    policy_version: int,
    worker_id: int,
    world: str,
    on_step,
    stop: threading.Event,
    max_steps: int | None = None,
) -> list[PlayedEpisode] | None:
    """Up to `laps` greedy laps in one evaluation run, as DeepRacer's continuous evaluation: from the start line
    (START_POSITION_OFFSET, where DeepRacer's evaluation job starts, not where the training round robin has got to, so
    every checkpoint drives the same laps), each crossing closes a lap (one PlayedEpisode, its lap time from the
    crossing before) and the car drives on at speed; a reset rule or the step cap ends the run with the lap it was in.
    None when `stop` is set between laps. The policy's frame stack runs on across the line, as the car does."""
    options: dict = {"evaluation": True, "start_ndist": env.config.start_position_offset % 1.0}
    if max_steps is not None:
        options["max_steps"] = max_steps
    played: list[PlayedEpisode] = []
    stopped = False

    def next_lap(_index: int) -> EpisodeTicket | None:
        nonlocal stopped
        if not played:
            return EpisodeTicket(0, epsilon, options)
        last = played[-1]
        if not last.lap_completed or len(played) == laps:
            return None
        if stop.is_set():
            stopped = True
            return None
        env.continue_after_lap(last.end_time_s, renew_reset_budget=False)
        return EpisodeTicket(len(played), epsilon, carry_on_from_s=last.end_time_s)

    def finished(_index: int, ticket: EpisodeTicket, recorder: EpisodeRecorder) -> None:
        played.append(
            recorder.finish(
                policy_version=policy_version,
                worker_id=worker_id,
                world=world,
                episode_index=ticket.number,
                simtrace_episode=None,
            )
        )

    play_episodes(EpisodeLoop(policy, [env], [generator], greedy=True), next_lap, finished, on_step=on_step)
    return None if stopped else played
