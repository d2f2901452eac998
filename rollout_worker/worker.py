"""A rollout worker: simulates one world, plays its share of every iteration, pushes the episodes to Redis.

Protocol (see racer.shared.transport.channels for the keys):
1. Join: read the newest `iteration` announcement on the control stream (or wait for the first).
2. For iteration k: load checkpoint k from the store, play share `worker_id` (DeepRacer's split of
   num_episodes_between_training) unless the trainer already holds it, push it as one batch, upload the
   iteration's simtrace and TrainingMetrics. Worker 0 then runs MIN_EVAL_TRIALS greedy episodes and
   updates deepracer_checkpoints.json (best by BEST_MODEL_METRIC).
3. Wait (blocking read, no polling) for the next announcement: a new iteration, a `replay` request
   addressed to this worker (another worker died: play its share too), or `finished`.
A heartbeat thread keeps `heartbeat:<id>` alive so the trainer can tell a dead worker from a slow one.
"""

from __future__ import annotations

import logging
import os
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from racer.rollout_worker.run_files import RunFiles, load_run_files
from racer.rollout_worker.training_log import WorkerLog
from racer.shared.config import ServiceSettings
from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.episode_runner import PlayedEpisode, play_episode
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.networks import E_GREEDY_EVALUATION_EPSILON, e_greedy_epsilon
from racer.shared.redis_connection import RedisLink, RedisUnavailableError
from racer.shared.sim.env import DeepRacerEnv, EnvConfig
from racer.shared.store import open_store
from racer.shared.transport.channels import Announcement, RunChannel, share_sizes
from racer.shared.transport.codec import EpisodeBatch
from racer.shared.transport.frames import FrameChannel, FrameTap

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RolloutOptions:
    model_prefix: str
    worker_id: int
    seed: int = 0
    wait_timeout_s: float = 3600.0
    """Longest wait for the trainer's next checkpoint before giving up with an error."""
    world_override: str | None = None
    track_override: str | None = None


@dataclass
class _WorkerState:
    status: str = "starting"
    iteration: int = -1
    episodes_played: int = 0
    steps_per_s: float = 0.0
    extra: dict = field(default_factory=dict)


def uses_e_greedy(hyperparameters: Hyperparameters, metadata: ModelMetadata) -> bool:
    """RL Coach's e-greedy applies to discrete action spaces only (continuous ones keep Gaussian sampling)."""
    return hyperparameters.exploration_type.lower().strip() == "e-greedy" and not metadata.continuous_action_space


def evaluation_epsilon(hyperparameters: Hyperparameters, metadata: ModelMetadata) -> float:
    """ε of worker 0's in-training evaluation episodes: RL Coach keeps its evaluation ε (0.05) under e-greedy."""
    return E_GREEDY_EVALUATION_EPSILON if uses_e_greedy(hyperparameters, metadata) else 0.0


def training_env_config(run: RunFiles) -> EnvConfig:
    """The env of a training worker: its training_params (DeepRacer's keys) applied to DeepRacer's defaults."""
    worker = run.worker
    return EnvConfig(
        track=worker.track,
        world=worker.world,
        model_metadata=run.model_metadata,
        reward_function_path=run.reward_function_path,
        reverse_dir=worker.reverse_dir,
        alternate_driving_direction=worker.alternate_driving_direction,
        change_start_position=worker.change_start_position,
        round_robin_advance_dist=worker.round_robin_advance_dist,
        start_position_offset=worker.start_position_offset,
        number_of_resets=worker.number_of_resets,
        off_track_penalty_s=worker.off_track_penalty_s,
        collision_penalty_s=worker.collision_penalty_s,
        number_of_reverse_counts=worker.number_of_reverse_counts,
        domain_randomization=worker.domain_randomization,
        car_randomization=worker.car_randomization,
        simapp_dir=Path(worker.simapp_dir) if worker.simapp_dir else None,
        race=worker.race,
    )


class RolloutWorker:
    def __init__(self, settings: ServiceSettings, options: RolloutOptions):
        self.options = options
        self.worker_id = options.worker_id
        self.store = open_store(settings.store)
        self._stop = threading.Event()  # also cuts Redis retries short: stopping never waits for Redis
        link = RedisLink(settings.redis, stop=self._stop)
        self.channel = RunChannel(link, options.model_prefix)
        self.frames = FrameChannel(link, options.model_prefix)
        self.frame_tap: FrameTap | None = None
        self.checkpoints = CheckpointStore(self.store, options.model_prefix)
        self.state = _WorkerState()
        self._workdir = Path(tempfile.mkdtemp(prefix=f"racer-worker{self.worker_id}-"))
        self.run: RunFiles | None = None
        self.env: DeepRacerEnv | None = None
        self.policy = None
        self.policy_version = -1
        self.rng = np.random.default_rng(options.seed)
        self.log: WorkerLog | None = None

    # ---- lifecycle -------------------------------------------------------------------------------
    def stop(self) -> None:
        self._stop.set()

    def _heartbeat_loop(self) -> None:
        while not self._stop.wait(3.0):
            try:
                self._beat()
            except RedisUnavailableError as error:  # beat again once Redis is back; the run goes on
                log.warning("worker %d: heartbeat not sent: %s", self.worker_id, error)

    def _beat(self) -> None:
        world = self.run.worker.world if self.run else self.options.world_override or "?"
        self.channel.beat(
            self.worker_id,
            {
                "state": self.state.status,
                "iteration": self.state.iteration,
                "episodes": self.state.episodes_played,
                "world": world,
                "steps_per_s": round(self.state.steps_per_s, 1),
                "pid": os.getpid(),
            },
        )

    def run_forever(self) -> None:
        torch.set_num_threads(1)
        self._beat()
        threading.Thread(target=self._heartbeat_loop, name="heartbeat", daemon=True).start()
        try:
            announcement = self._wait_for_first_announcement()
            self._prepare(announcement)
            last_id = announcement.stream_id
            self._handle(announcement)
            while not self._stop.is_set():
                if announcement.kind == "finished":
                    break
                announcements = self._wait_for_announcements(last_id)
                for announcement in announcements:
                    last_id = announcement.stream_id
                    self._handle(announcement)
                    if announcement.kind == "finished":
                        break
        except RedisUnavailableError as error:
            if not self._stop.is_set():
                raise
            log.info("worker %d: stopped while Redis was unreachable (%s)", self.worker_id, error)
        finally:
            self._stop.set()
            if self.env is not None:
                self.env.close()

    def _wait_for_first_announcement(self) -> Announcement:
        self.state.status = "waiting for trainer"
        deadline = time.monotonic() + self.options.wait_timeout_s
        while not self._stop.is_set():
            announcement = self.channel.latest_iteration_announcement()
            if announcement is not None:
                return announcement
            if time.monotonic() > deadline:
                raise TimeoutError(
                    f"worker {self.worker_id}: no trainer announced a checkpoint on "
                    f"{self.channel.key('control')} within {self.options.wait_timeout_s:.0f} s"
                )
            self.channel.next_announcements("$", block_s=5.0)
        raise InterruptedError("stopped before the trainer started")

    def _wait_for_announcements(self, after_id: str) -> list[Announcement]:
        self.state.status = "waiting for checkpoint"
        started = time.monotonic()
        next_notice = started + 60
        while not self._stop.is_set():
            announcements = self.channel.next_announcements(after_id, block_s=5.0)
            if announcements:
                return announcements
            now = time.monotonic()
            if now > started + self.options.wait_timeout_s:
                raise TimeoutError(
                    f"worker {self.worker_id}: waited {self.options.wait_timeout_s:.0f} s for checkpoint "
                    f"{self.state.iteration + 1} from the trainer on {self.channel.key('control')}; is the trainer alive?"
                )
            if now > next_notice:
                log.info(
                    "worker %d: still waiting for checkpoint %d from the trainer (%.0f s)",
                    self.worker_id,
                    self.state.iteration + 1,
                    now - started,
                )
                next_notice = now + 60
        return []

    # ---- set-up ----------------------------------------------------------------------------------
    def _prepare(self, announcement: Announcement) -> None:
        self.run = load_run_files(
            self.store,
            self.options.model_prefix,
            self.worker_id,
            self._workdir,
            world_override=self.options.world_override,
            track_override=self.options.track_override,
        )
        worker = self.run.worker
        self.env = DeepRacerEnv(training_env_config(self.run))
        self.env.reset(seed=self.options.seed)
        self.log = WorkerLog(self.store, self.run, self.worker_id)
        self.frame_tap = FrameTap(self.frames, self.worker_id, worker.world)
        log.info(
            "worker %d ready: world %s, track %s, model %s",
            self.worker_id,
            worker.world,
            worker.track,
            self.options.model_prefix,
        )

    def _load_policy(self, announcement: Announcement) -> None:
        if self.policy_version == announcement.iteration:
            return
        self.state.status = f"loading {announcement.checkpoint}"
        self.policy = self.checkpoints.load_inference_policy(announcement.checkpoint)
        self.policy.eval()
        self.policy_version = announcement.iteration

    # ---- announcements ---------------------------------------------------------------------------
    def _handle(self, announcement: Announcement) -> None:
        if announcement.kind == "finished":
            log.info("worker %d: training finished", self.worker_id)
            self._stop.set()
            return
        if announcement.kind == "iteration":
            self.state.iteration = announcement.iteration
            self._load_policy(announcement)
            if self.worker_id < announcement.num_workers:
                self._play_share(announcement, share=self.worker_id)
                self.log.finish_iteration(announcement.iteration, announcement.num_workers)
            if self.worker_id == 0:
                self._evaluate(announcement)
        elif announcement.kind == "replay" and announcement.target_worker == self.worker_id:
            if announcement.iteration != self.policy_version:
                return  # an old request; the trainer has moved on
            log.info(
                "worker %d: replaying share %d of iteration %d for a dead worker",
                self.worker_id,
                announcement.share,
                announcement.iteration,
            )
            latest = self.channel.latest_iteration_announcement()
            self._play_share(latest, share=announcement.share)
            self.log.finish_iteration(announcement.iteration, latest.num_workers)

    def _play_share(self, announcement: Announcement, share: int) -> None:
        if share in self.channel.received_shares(announcement.iteration):
            log.info(
                "worker %d: share %d of iteration %d already delivered", self.worker_id, share, announcement.iteration
            )
            return
        count = share_sizes(announcement.episodes_per_iteration, announcement.num_workers)[share]
        if count == 0:
            return
        self.state.status = "playing"
        self.frame_tap.phase = "training"
        self._beat()  # at once: a short share can finish between two periodic beats
        hp = self.run.hyperparameters
        played: list[PlayedEpisode] = []
        started = time.monotonic()
        steps = 0
        for _ in range(count):
            if self._stop.is_set():
                return  # nothing half-sent: the batch goes out whole or not at all
            episode_counter = self.log.next_training_episode
            epsilon = 0.0
            if self._uses_e_greedy():
                epsilon = e_greedy_epsilon(self.log.training_steps, hp.e_greedy_value, hp.epsilon_steps)
            episode = play_episode(
                self.env,
                self.policy,
                greedy=False,
                generator=self.rng,
                epsilon=epsilon,
                policy_version=announcement.iteration,
                worker_id=self.worker_id,
                world=self.run.worker.world,
                episode_index=episode_counter,
                simtrace_episode=episode_counter,
                on_step=self.frame_tap,
            )
            played.append(episode)
            steps += episode.steps
            self.state.episodes_played += 1
            self.state.steps_per_s = steps / max(1e-6, time.monotonic() - started)
            self.log.record_training_episode(episode, announcement.iteration)
        elapsed_s = time.monotonic() - started
        batch = EpisodeBatch(
            iteration=announcement.iteration,
            share=share,
            worker_id=self.worker_id,
            world=self.run.worker.world,
            policy_version=announcement.iteration,
            episodes=tuple(p.episode for p in played),
        )
        for p in played:
            p.episode.info.update(rollout_steps_per_s=round(steps / max(elapsed_s, 1e-6), 1))
        self.channel.push_batch(batch)
        log.info(
            "worker %d: pushed share %d of iteration %d (%d episodes, %d steps, %.0f steps/s)",
            self.worker_id,
            share,
            announcement.iteration,
            len(played),
            steps,
            steps / max(elapsed_s, 1e-6),
        )

    def _uses_e_greedy(self) -> bool:
        return uses_e_greedy(self.run.hyperparameters, self.run.model_metadata)

    def _evaluate(self, announcement: Announcement) -> None:
        trials = self.run.worker.min_eval_trials
        if trials <= 0:
            return
        self.state.status = "evaluating"
        epsilon = evaluation_epsilon(self.run.hyperparameters, self.run.model_metadata)
        self.frame_tap.phase = "evaluation"
        results = []
        first_start = self.env.start_ndist
        for trial in range(trials):
            if self._stop.is_set():
                return
            start = (first_start + trial / trials) % 1.0 if self.run.worker.eval_spread_starts else None
            results.append(
                play_episode(
                    self.env,
                    self.policy,
                    greedy=True,
                    generator=self.rng,
                    epsilon=epsilon,
                    policy_version=announcement.iteration,
                    worker_id=self.worker_id,
                    world=self.run.worker.world,
                    episode_index=trial,
                    start_ndist=start,
                    on_step=self.frame_tap,
                )
            )
            log.info(
                "worker %d: evaluation trial %d of checkpoint %d from %.3f of the lap: %s, progress %.1f%%",
                self.worker_id,
                trial,
                announcement.iteration,
                first_start if start is None else start,
                results[-1].final_status,
                results[-1].progress,
            )
        self.log.record_evaluation(announcement, results, self.checkpoints, self.channel)
