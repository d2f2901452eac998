"""A rollout worker: simulates one world, claims and plays episodes of every iteration, pushes them to Redis.

Protocol (see racer.shared.transport.channels for the keys):
1. Join: read the newest `iteration` announcement on the control stream (or wait for the first).
2. For iteration k: load checkpoint k from the store and claim episodes from Redis, one per env as each env becomes
   free: first those of its own DeepRacer share (episodes worker_id, worker_id + W, ...), then, once its own are all
   played, any episode still unclaimed (a slower worker's). Each episode is delivered as soon as it ends; then
   upload the iteration's simtrace and TrainingMetrics. Worker 0 then runs MIN_EVAL_TRIALS greedy episodes and
   updates deepracer_checkpoints.json (best by BEST_MODEL_METRIC).
3. Wait (blocking read, no polling) for the next announcement: a new iteration, a `replay` notice (episodes went
   back to the queue: a worker died holding them; claim them), or `finished`.
The worker steps `envs` envs of its world at once (racer.shared.episode_loop). A heartbeat thread keeps
`heartbeat:<id>` alive so the trainer can tell a dead worker from a slow one.
"""

from __future__ import annotations

import logging
import os
import shutil
import tempfile
import threading
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from racer.rollout_worker.checkpoint_evaluation import evaluate_checkpoint, uses_e_greedy
from racer.rollout_worker.claims import claim_next_episode, load_policy, newer_policy
from racer.rollout_worker.envs import env_generator, spread_env_configs
from racer.rollout_worker.training_log import WorkerLog
from racer.rollout_worker.worker_files import WorkerFiles, load_worker_files, training_env_config
from racer.shared import worker_phases
from racer.shared.config import ServiceSettings
from racer.shared.episode_loop import EpisodeLoop, EpisodeTicket, play_episodes
from racer.shared.played_episode import EpisodeRecorder
from racer.shared.policy.action_selection import e_greedy_epsilon
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.torch_threads import one_torch_thread_if_loaded
from racer.shared.redis_connection import RedisLink, RedisUnavailableError
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.store import open_store
from racer.shared.transport.channels import Announcement, RunChannel
from racer.shared.transport.frames import FrameChannel, FrameTap
from racer.shared.worker_phases import PhaseClock

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
    envs: int = 1
    """Envs of its world the worker steps at once, all actions from one batched forward pass."""


@dataclass
class _WorkerState:
    status: str = "starting"
    iteration: int = -1
    episodes_played: int = 0
    steps_per_s: float = 0.0
    extra: dict = field(default_factory=dict)
    phases: PhaseClock = field(default_factory=PhaseClock)
    """Wall seconds per phase (racer.shared.worker_phases): in the heartbeat and in every delivered episode."""

    def enter(self, status: str, phase: str) -> None:
        """The status the heartbeat shows, and the phase its time counts to."""
        self.status = status
        self.phases.enter(phase)


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
        self.run: WorkerFiles | None = None
        self.envs: list[DeepRacerEnv] = []
        self.policy = None
        self.policy_version = -1
        self.evaluated_version = -1  # the newest checkpoint worker 0 has evaluated
        self.overlapped = False  # an announcement named a checkpoint older than its iteration (`--overlap`)
        self.rngs = [env_generator(options.seed, j) for j in range(max(1, options.envs))]
        self.log: WorkerLog | None = None

    @property
    def env(self) -> DeepRacerEnv | None:
        """Env 0: also the one worker 0 evaluates with."""
        return self.envs[0] if self.envs else None

    @property
    def rng(self) -> np.random.Generator:
        return self.rngs[0]

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
                "phase_s": {phase: round(seconds, 1) for phase, seconds in self.state.phases.totals_s().items()},
            },
        )

    def run_forever(self) -> None:
        one_torch_thread_if_loaded()
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
            for env in self.envs:
                env.close()
            shutil.rmtree(self._workdir, ignore_errors=True)  # the run's files as downloaded; the store keeps them

    def _wait_for_first_announcement(self) -> Announcement:
        self.state.enter("waiting for trainer", worker_phases.WAITING)
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
        self.state.enter("waiting for checkpoint", worker_phases.WAITING)
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
        self.state.enter("building envs", worker_phases.STARTING)
        self.run = load_worker_files(
            self.store,
            self.options.model_prefix,
            self.worker_id,
            self._workdir,
            world_override=self.options.world_override,
            track_override=self.options.track_override,
        )
        worker = self.run.worker
        for j, config in enumerate(spread_env_configs(training_env_config(self.run), len(self.rngs))):
            env = DeepRacerEnv(config)
            env.reset(seed=self.options.seed + 1000 * j)
            self.envs.append(env)
            self._beat()  # building an env holds the GIL for long stretches: the heartbeat thread may not get in
        if announcement.kind == "iteration":  # a fresh process holds nothing: claims of an earlier life go back
            self.channel.release_claims(announcement.iteration, self.worker_id)
        self.log = WorkerLog(self.store, self.run, self.worker_id)
        self.frame_tap = FrameTap(self.frames, self.worker_id, worker.world)
        log.info(
            "worker %d ready: world %s, track %s, model %s, %d envs",
            self.worker_id,
            worker.world,
            worker.track,
            self.options.model_prefix,
            len(self.envs),
        )

    def _load_policy(self, announcement: Announcement) -> None:
        """The announced checkpoint, unless it is the one held or (overlap) older than it."""
        held = self.policy_version
        if held == announcement.policy_version or (self.overlapped and held > announcement.policy_version):
            return
        self.state.enter(f"loading {announcement.checkpoint}", worker_phases.LOADING)
        self.policy = load_policy(self.checkpoints, announcement.checkpoint)
        self.policy_version = announcement.policy_version

    # ---- announcements ---------------------------------------------------------------------------
    def _handle(self, announcement: Announcement) -> None:
        if announcement.kind == "finished":
            log.info("worker %d: training finished", self.worker_id)
            self._stop.set()
            return
        if announcement.kind == "iteration":
            self.state.iteration = announcement.iteration
            self.overlapped |= announcement.policy_version != announcement.iteration
            self._load_policy(announcement)
            if self.worker_id < announcement.num_workers:
                self._play_claimed(announcement)
                self.log.finish_iteration(announcement.iteration, announcement.num_workers)
            if self.worker_id == 0:
                self._evaluate_once(announcement)
        elif announcement.kind == "replay" and announcement.target_worker in (-1, self.worker_id):
            if announcement.iteration != self.state.iteration:
                return  # an old notice; the trainer has moved on
            latest = self.channel.latest_iteration_announcement()
            if latest is None or latest.kind != "iteration" or latest.iteration != announcement.iteration:
                return
            if self.worker_id < latest.num_workers and self._play_claimed(latest):
                self.log.finish_iteration(latest.iteration, latest.num_workers)

    def _play_claimed(self, announcement: Announcement) -> int:
        """Claim and play episodes of the iteration until none is left unclaimed; returns how many were played."""
        iteration, num_workers = announcement.iteration, announcement.num_workers
        hp = self.run.hyperparameters
        world = self.run.worker.world
        own_in_flight: set[int] = set()
        versions: dict[int, int] = {}  # episode number -> the checkpoint it started with
        started = time.monotonic()
        played = {"episodes": 0, "steps": 0}

        def next_episode(_env_index: int) -> EpisodeTicket | None:
            if self._stop.is_set():
                return None
            number = claim_next_episode(self.channel, iteration, self.worker_id, num_workers, own_in_flight)
            if number is None or number in versions:  # in versions: another env plays it (a Redis restart lost the
                return None  # claim and handed it out again); it is played once
            if self.overlapped and (newer := newer_policy(self.channel, self.checkpoints, self.policy_version)):
                self.policy_version, self.policy = newer
                loop.policy = self.policy  # episodes in flight keep their label; each step logs who chose it
            versions[number] = self.policy_version
            if played["episodes"] == 0 and self.state.status != "playing":
                self.state.enter("playing", worker_phases.PLAYING)
                self.frame_tap.phase = "training"
                self._beat()  # at once: a short share can finish between two periodic beats
            epsilon = 0.0
            if self._uses_e_greedy():
                epsilon = e_greedy_epsilon(self.log.training_steps, hp.e_greedy_value, hp.epsilon_steps)
            return EpisodeTicket(number, epsilon)

        def finished(_env_index: int, ticket: EpisodeTicket, recorder: EpisodeRecorder) -> None:
            own_in_flight.discard(ticket.number)
            played["episodes"] += 1
            played["steps"] += recorder.steps
            self.state.episodes_played += 1
            rate = played["steps"] / max(1e-6, time.monotonic() - started)
            self.state.steps_per_s = rate
            counter = self.log.next_training_episode
            episode = recorder.finish(
                policy_version=versions.pop(ticket.number),
                worker_id=self.worker_id,
                world=world,
                episode_index=counter,
                simtrace_episode=counter,
                iteration=iteration,
                episode_number=ticket.number,
                info={
                    "rollout_steps_per_s": round(rate, 1),
                    **worker_phases.episode_info(self.state.phases.totals_s()),
                },
            )
            self.log.record_training_episode(episode, iteration)
            self.channel.deliver_episode(episode.episode)

        loop = EpisodeLoop(self.policy, self.envs, self.rngs, greedy=False)
        while True:
            if not play_episodes(loop, next_episode, finished, self._stop, on_step=self.frame_tap):
                self._hand_back_claims(iteration)
                break
            # Every env is idle, so nothing is held any more; a claim still listed (a command Redis ran but whose
            # answer a Redis restart lost, so the worker never saw it) goes back to the queue and is played now.
            leftover = self.channel.release_claims(iteration, self.worker_id)
            if not leftover:
                break
            log.warning(
                "worker %d: claims %s of iteration %d were never played; playing them",
                self.worker_id,
                leftover,
                iteration,
            )
            own_in_flight.clear()
        if played["episodes"]:
            elapsed_s = time.monotonic() - started
            log.info(
                "worker %d: played %d episodes of iteration %d (%d steps, %.0f steps/s, %d envs)",
                self.worker_id,
                played["episodes"],
                iteration,
                played["steps"],
                played["steps"] / max(elapsed_s, 1e-6),
                len(self.envs),
            )
        return played["episodes"]

    def _hand_back_claims(self, iteration: int) -> None:
        """Stopping mid-episode: the claims go back to the queue at once instead of after the heartbeat lapses."""
        try:
            released = self.channel.release_claims(iteration, self.worker_id)
        except RedisUnavailableError as error:  # the trainer hands them back once the heartbeat lapses
            log.info("worker %d: claims of iteration %d not handed back: %s", self.worker_id, iteration, error)
            return
        if released:
            log.info(
                "worker %d: stopping; episodes %s of iteration %d go back to the queue",
                self.worker_id,
                released,
                iteration,
            )
            try:
                self.channel.request_replay(iteration)  # wakes workers waiting for announcements
            except RedisUnavailableError:
                pass  # the trainer's check for queued episodes nobody claims sends the notice

    def _uses_e_greedy(self) -> bool:
        return uses_e_greedy(self.run.hyperparameters, self.run.model_metadata)

    def _evaluate_once(self, announcement: Announcement) -> None:
        """Evaluate the announced checkpoint under its own number, once (overlap announces k+1 with checkpoint k)."""
        if announcement.policy_version != announcement.iteration:
            if announcement.policy_version <= self.evaluated_version:
                return
            announcement = replace(announcement, iteration=announcement.policy_version)
        self.evaluated_version = max(self.evaluated_version, announcement.iteration)
        self._evaluate(announcement)

    def _evaluate(self, announcement: Announcement) -> None:
        if self.run.worker.min_eval_trials <= 0:
            return
        policy = self.policy  # overlap: the worker may hold a newer checkpoint than the one judged here
        if announcement.iteration != self.policy_version:
            policy = load_policy(self.checkpoints, announcement.checkpoint)
        self.state.enter("evaluating", worker_phases.EVALUATING)
        self.frame_tap.phase = "evaluation"
        results = evaluate_checkpoint(
            self.env,
            policy,
            self.run,
            announcement.iteration,
            self.worker_id,
            self.rng,
            self.frame_tap,
            self._stop,
        )
        if results is not None:
            self.log.record_evaluation(announcement, results, self.checkpoints, self.channel)
