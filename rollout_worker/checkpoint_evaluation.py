"""Worker 0's in-training evaluation: MIN_EVAL_TRIALS greedy episodes of each new checkpoint (deepracer_checkpoints.json
and the best checkpoint follow from them, racer.rollout_worker.training_log), and the exploration rule they share with
training episodes."""

from __future__ import annotations

import logging
import threading

import numpy as np

from racer.rollout_worker.episode_runner import play_episode
from racer.rollout_worker.worker_files import WorkerFiles
from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import ModelMetadata
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
    RACER_EVAL_SPREAD_STARTS, each at most RACER_EVAL_MAX_STEPS steps when set); None when `stop` is set before
    they are all played."""
    trials = run.worker.min_eval_trials
    epsilon = evaluation_epsilon(run.hyperparameters, run.model_metadata)
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
