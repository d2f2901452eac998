"""The trainer process: iteration after iteration, collect every worker's share, update the policy (clipped PPO or
SAC, as model_metadata.json says: racer.trainer.algorithms), publish a checkpoint.

One iteration k, top to bottom:
1. announce checkpoint k on the control stream (it is already complete in the store);
2. collect the iteration's E episodes (numbers 0..E-1, queued in Redis; workers claim them one by one, their own
   DeepRacer share first, then whatever is left) from the episode stream (consumer group `trainer`): episodes of an
   older policy are dropped (PPO is strictly on-policy; SAC keeps a late batch of checkpoint k-1 in its replay
   memory without counting it, and drops older ones), a second copy of an episode number is dropped, and the
   claims of a worker with no heartbeat go back to the queue for a live worker (racer.trainer.collector);
3. print DeepRacer's `Training>` line per episode, run the learner's update, print `Policy training>` lines;
4. save checkpoint k+1 to the store (files first, then `.coach_checkpoint`), then acknowledge the batches.
A trainer killed at any point restarts from the newest checkpoint: unacknowledged batches are read again.
"""

from __future__ import annotations

import json
import logging
import signal
import threading
import time
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from racer.shared import model_layout
from racer.shared.config import ServiceSettings
from racer.shared.deepracer.hyperparameters import Hyperparameters, hyperparameters_to_json_bytes
from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.deepracer.training_params import training_params_to_yaml
from racer.shared.episode import Episode
from racer.shared.model_layout import ModelLayout
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.network_file import NETWORK_FILE, NetworkFile
from racer.shared.redis_connection import RedisLink, RedisUnavailableError
from racer.shared.sim.car_dynamics import DEFAULT_CAR_PROFILE
from racer.shared.store import ObjectNotFoundError, open_store
from racer.shared.transport.channels import ReceivedBatch, RunChannel
from racer.shared.worker_settings import WorkerSettings
from racer.trainer.algorithms import LearnerOptions, build_learner
from racer.trainer.collector import Collector, CollectTimes, StopRequested
from racer.trainer.learner import UpdateAbandoned
from racer.trainer.log_lines import format_training_episode_line
from racer.trainer.memory_cap import cap_episodes, default_max_memory_steps, global_episode_order
from racer.trainer.precision import DEFAULT_PRECISION, Precision
from racer.trainer.preflight import PreflightReport, check_clone_source, preflight
from racer.trainer.preset import PRESET_FILE, Preset

log = logging.getLogger(__name__)


STOP_UPDATE_GRACE_S = 10.0
"""A stop that arrives during the PPO update lets it run this much longer (then save the checkpoint); a longer
update is abandoned, the newest saved checkpoint stays the final one, so every process is gone within 30 s."""


@dataclass(frozen=True)
class TrainerOptions:
    model_prefix: str
    custom_files: Path
    num_workers: int
    track: str
    worlds: tuple[str, ...]
    max_episodes: int | None = None
    """Training episodes to consume before stopping (default: hyperparameters' term_cond_max_episodes)."""
    max_minutes: float | None = None
    seed: int = 0
    pretrained_prefix: str | None = None
    pretrained_checkpoint: str = "last"
    domain_randomization: bool = False
    """Default ENABLE_DOMAIN_RANDOMIZATION of every worker (workers.json may override it per worker)."""
    car_randomization: bool = False
    """Default RACER_CAR_RANDOMIZATION of every worker."""
    dynamics_randomization: bool = False
    """Default RACER_DYNAMICS_RANDOMIZATION of every worker."""
    car_profile: str = DEFAULT_CAR_PROFILE
    """Default RACER_CAR_PROFILE of every worker (`car_dynamics.CAR_DYNAMICS`; workers.json may override it)."""
    race_params: tuple[tuple[str, str], ...] = ()
    """RACE_TYPE and obstacle / bot-car training_params keys for every worker (workers.json may override them)."""
    share_timeout_s: float = 3600.0
    """Longest wait for the episodes of one iteration before giving up with an error."""
    dead_worker_grace_s: float = 20.0
    """How long a share may have no live worker before it is re-assigned."""
    max_memory_steps: int | None = None
    """Transitions one iteration trains on (DeepRacer's MAX_MEMORY_STEPS): None = DeepRacer's cap for the network
    (10,000 shallow, 3,000 others), 0 = no cap."""
    announcement_check_s: float = 30.0
    """While collecting, how often to check that Redis still holds this iteration's announcement (a restarted
    Redis may have lost the newest writes); a lost one is announced again."""
    sac_replay_memory_mb: float = 1024.0
    """SAC: memory budget of the replay ring on the trainer (its capacity in transitions follows from it)."""
    sac_updates_per_transition: float = 1.0
    """SAC: gradient steps per transition received (DeepRacer: 1)."""
    precision: Precision = DEFAULT_PRECISION
    """What the towers compute in during updates (racer.trainer.precision); written into every checkpoint."""
    preflight: PreflightReport | None = None
    """The custom files as `racer trainer` checked them; None: the trainer runs the preflight itself."""


def _world_steps_per_s(episodes: list[Episode]) -> float:
    """Experience rate of one world: the rates its workers measured while playing their shares, added up."""
    by_worker = {e.worker_id: float(e.info.get("rollout_steps_per_s", 0.0)) for e in episodes}
    return round(sum(by_worker.values()), 1)


class Trainer:
    def __init__(self, settings: ServiceSettings, options: TrainerOptions):
        self.options = options
        self.store = open_store(settings.store)
        self.layout = ModelLayout(options.model_prefix)
        self.stop_event = threading.Event()
        """Set by SIGTERM / Ctrl-C or the wall-time limit; it also cuts Redis retries short (see RedisLink)."""
        self.channel = RunChannel(RedisLink(settings.redis, stop=self.stop_event), options.model_prefix)
        self.checkpoints = CheckpointStore(self.store, options.model_prefix)
        self.consumer = "trainer-0"
        self.started = time.monotonic()
        self.episodes_consumed = 0
        self.env_steps = 0
        self.iteration = 0
        """The newest saved checkpoint's number: the iteration being collected."""
        self.network_file: NetworkFile | None = None
        """network.json of the custom files when model_metadata.json names it."""
        self.preset: Preset | None = None
        """preset.json of the custom files, when there is one."""

    # ---- set-up ----------------------------------------------------------------------------------
    def _read_custom_files(self) -> tuple[ModelMetadata, Hyperparameters, bytes, list[WorkerSettings]]:
        folder = self.options.custom_files
        report = self.options.preflight or preflight(
            folder,
            self.options.num_workers,
            self.options.track,
            self.options.worlds,
            domain_randomization=self.options.domain_randomization,
            car_randomization=self.options.car_randomization,
            race_params=self.options.race_params,
            car_profile=self.options.car_profile,
            dynamics_randomization=self.options.dynamics_randomization,
        )
        for warning in report.warnings:
            log.warning(warning)
        self.network_file, self.preset = report.network, report.preset
        return (
            report.model_metadata,
            report.hyperparameters,
            (folder / "reward_function.py").read_bytes(),
            list(report.workers),
        )

    def _upload_run_files(
        self,
        metadata_bytes: bytes,
        hyperparameters: Hyperparameters,
        metadata: ModelMetadata,
        reward_bytes: bytes,
        workers: list[WorkerSettings],
    ) -> None:
        self.store.put_bytes(self.layout.model_metadata, metadata_bytes)
        if self.network_file is not None:  # beside model_metadata.json, verbatim: evaluation and clones read it
            self.store.put_bytes(self.layout.network, (self.options.custom_files / NETWORK_FILE).read_bytes())
        if self.preset is not None:  # beside the hyperparameters, verbatim
            self.store.put_bytes(self.layout.preset, (self.options.custom_files / PRESET_FILE).read_bytes())
        self.store.put_bytes(
            self.layout.hyperparameters, hyperparameters_to_json_bytes(hyperparameters, metadata.training_algorithm)
        )
        self.store.put_bytes(self.layout.reward_function, reward_bytes)
        params = [w.to_training_params(self.options.model_prefix, len(workers)) for w in workers]
        for worker_id, worker_params in enumerate(params):
            if worker_id == 0 or worker_params != params[0]:
                self.store.put_bytes(
                    self.layout.training_params(worker_id), training_params_to_yaml(worker_params).encode()
                )
        self.store.put_bytes(self.layout.ip_done, b"done")

    def setup(self) -> int:
        """Upload the run's files, restore or create the newest checkpoint; returns its number."""
        torch.manual_seed(self.options.seed)
        metadata, hyperparameters, reward_bytes, workers = self._read_custom_files()
        self.metadata, self.hyperparameters = metadata, hyperparameters
        self.learner = build_learner(
            metadata,
            hyperparameters,
            LearnerOptions(
                seed=self.options.seed,
                precision=self.options.precision,
                sac_replay_memory_mb=self.options.sac_replay_memory_mb,
                sac_updates_per_transition=self.options.sac_updates_per_transition,
                network=self.network_file,
                preset=self.preset,
            ),
        )
        self.network = self.learner.network
        self.collector = Collector(
            self.channel,
            self.consumer,
            self.options.num_workers,
            hyperparameters.num_episodes_between_training,
            self.learner,
            self.checkpoints.latest_name,
            self.stop_event,
            CollectTimes(
                share_timeout_s=self.options.share_timeout_s,
                dead_worker_grace_s=self.options.dead_worker_grace_s,
                announcement_check_s=self.options.announcement_check_s,
            ),
        )
        latest = self.checkpoints.latest_name()
        if latest is not None:
            iteration, self.env_steps = self.checkpoints.restore(latest, self.network, self.learner.optimizer)
            log.info("resuming %s from checkpoint %s", self.options.model_prefix, latest)
            self.store.delete(self.layout.finished)  # training goes on: the model is not finished any more
            self.episodes_consumed = iteration * hyperparameters.num_episodes_between_training
        else:
            if self.options.pretrained_prefix:
                self._clone_from_pretrained()  # checked first: a refused clone leaves nothing behind
            self.channel.delete_run_keys()
            metadata_bytes = (self.options.custom_files / "model_metadata.json").read_bytes()
            self._upload_run_files(metadata_bytes, hyperparameters, metadata, reward_bytes, workers)
            iteration = 0
            self._save(iteration)
            self.store.put_bytes(self.layout.ready, b"")
        self.iteration = iteration  # what a stop while Redis is gone finishes at
        self.channel.ensure_trainer_group()
        return iteration

    def _clone_from_pretrained(self) -> None:
        """Start from another model's weights. Action values may change; the number of actions may not."""
        source_prefix = self.options.pretrained_prefix
        check_clone_source(
            self.store,
            source_prefix,
            self.metadata,
            str(self.options.custom_files / "model_metadata.json"),
            self.network_file,
        )
        source = CheckpointStore(self.store, source_prefix)
        name = source.select(self.options.pretrained_checkpoint)
        source.restore(name, self.network)  # weights only: a clone starts a fresh optimiser
        print(f"Cloned weights from {source_prefix}/model/{name}", flush=True)

    def _save(self, iteration: int) -> str:
        name = self.checkpoints.save(
            iteration,
            self.env_steps,
            self.network,
            self.learner.optimizer,
            self.metadata,
            self.hyperparameters,
            extra={"trainer_precision": self.options.precision.value}
            | ({"preset": self.preset.to_dict()} if self.preset is not None else {}),
        )
        print(f"Checkpoint> Saving in path=['{self.layout.key(model_layout.MODEL_DIR, name)}']", flush=True)
        return name

    # ---- one iteration -----------------------------------------------------------------------------
    def collect(self, iteration: int) -> dict[int, ReceivedBatch]:
        """The iteration's E episodes, by episode number (racer.trainer.collector)."""
        return self.collector.collect(iteration)

    def _announce(self, iteration: int, checkpoint: str) -> None:
        self.collector.announce(iteration, checkpoint)

    def _memory_cap(self) -> int | None:
        if self.options.max_memory_steps is not None:
            return self.options.max_memory_steps
        return default_max_memory_steps(self.metadata.neural_network)

    def train_iteration(self, iteration: int, batches: dict[int, ReceivedBatch], rollout_wall_s: float) -> dict:
        shares = {share: received.batch.episodes for share, received in batches.items()}
        capped = cap_episodes(global_episode_order(shares, self.options.num_workers), self._memory_cap())
        episodes = list(capped.kept)
        if capped.dropped:
            log.info(
                "iteration %d: training on the first %d episodes (%d steps); %d later episodes (%d steps) are "
                "beyond the MAX_MEMORY_STEPS cap of %d steps, as in DeepRacer",
                iteration,
                len(episodes),
                capped.kept_steps,
                len(capped.dropped),
                capped.dropped_steps,
                capped.max_steps,
            )
        for episode in episodes:
            self.episodes_consumed += 1
            self.env_steps += episode.steps
            print(
                format_training_episode_line(
                    episode.worker_id, self.episodes_consumed, episode.total_reward, self.env_steps, iteration
                ),
                flush=True,
            )
        self.episodes_consumed += len(capped.dropped)  # played, so they count towards the episode limit
        stop_seen: list[float] = []

        def abandon() -> bool:
            if not self.stop_event.is_set():
                return False
            stop_seen[:] = stop_seen or [time.monotonic()]
            return time.monotonic() - stop_seen[0] > STOP_UPDATE_GRACE_S

        update_started = time.monotonic()
        try:
            all_stats = self.learner.update(episodes, abandon=abandon)
        except UpdateAbandoned:
            log.warning(
                "stopping: abandoned the update of iteration %d after %.0f s; the final checkpoint is %s",
                iteration,
                STOP_UPDATE_GRACE_S,
                self.checkpoints.latest_name(),
            )
            raise StopRequested() from None
        for line in self.learner.training_lines(all_stats):
            print(line, flush=True)
        update_s = time.monotonic() - update_started
        summary = self._summary(iteration, episodes, rollout_wall_s)
        summary.update(
            episodes_dropped=len(capped.dropped),
            steps_dropped=capped.dropped_steps,
            rollout_s=round(rollout_wall_s, 3),
            update_s=round(update_s, 3),
        )
        return summary

    def _summary(self, iteration: int, episodes: list[Episode], rollout_wall_s: float) -> dict:
        by_world = defaultdict(list)
        for episode in episodes:
            by_world[episode.world].append(episode)
        steps = sum(e.steps for e in episodes)
        return {
            "iteration": iteration,
            "episodes": len(episodes),
            "env_steps_total": self.env_steps,
            "mean_reward": float(np.mean([e.total_reward for e in episodes])),
            "mean_progress": float(np.mean([e.progress for e in episodes])),
            "completion_rate": float(np.mean([e.final_status == "lap_complete" for e in episodes])),
            "experience_steps_per_s": steps / max(rollout_wall_s, 1e-6),
            "elapsed_s": time.monotonic() - self.started,
            "worlds": {
                world: {
                    "episodes": len(items),
                    "mean_reward": float(np.mean([e.total_reward for e in items])),
                    "mean_progress": float(np.mean([e.progress for e in items])),
                    "completion_rate": float(np.mean([e.final_status == "lap_complete" for e in items])),
                    "steps_per_s": _world_steps_per_s(items),
                }
                for world, items in by_world.items()
            },
        }

    def _record_summary(self, summary: dict) -> None:
        key = self.layout.iterations_log  # the store first: it is the record, the stream only feeds displays
        try:
            existing = self.store.get_bytes(key)
        except ObjectNotFoundError:
            existing = b""
        self.store.put_bytes(key, existing + json.dumps(summary).encode() + b"\n")
        self.channel.publish("iterations", summary)

    def _should_stop(self) -> bool:
        max_episodes = self.options.max_episodes or self.hyperparameters.term_cond_max_episodes
        if self.episodes_consumed >= max_episodes:
            log.info("stopping: %d training episodes reached (limit %d)", self.episodes_consumed, max_episodes)
            return True
        if self.options.max_minutes is not None and time.monotonic() - self.started > 60 * self.options.max_minutes:
            log.info("stopping: wall-time limit of %.1f minutes reached", self.options.max_minutes)
            return True
        return self.stop_event.is_set()

    def run(self) -> None:
        """Iterate until a stop condition or signal, then write `.finished` and tell the workers.

        A failure (an exception) writes neither: the run stays resumable, and a restarted trainer continues from
        the newest checkpoint with the workers still waiting for it.
        """
        time_limit = self._start_time_limit()  # before setup: its last step waits for Redis too
        stopped_cleanly = False
        try:
            try:
                self.iteration = self.setup()
                self._iterate_until_stopped()
            except RedisUnavailableError as error:
                if not self.stop_event.is_set() or self.checkpoints.latest_name() is None:
                    raise
                # Stopping with Redis gone: the newest checkpoint is complete in the store; batches not
                # acknowledged are of an older policy by now and a resumed trainer drops them.
                log.warning("stopping without Redis: %s", error)
            stopped_cleanly = True
        finally:
            if time_limit is not None:
                time_limit.cancel()
            if not stopped_cleanly:
                print(
                    f"Trainer failed during iteration {self.iteration}; the run is not finished: restart the trainer "
                    f"to resume from {self.checkpoints.latest_name()}",
                    flush=True,
                )
        iteration = self.iteration
        self.store.put_bytes(self.layout.finished, b"")
        try:
            self.channel.announce_finished(iteration)
        except RedisUnavailableError as error:
            log.warning(
                "could not tell the workers that training finished (%s); they stop on their own signal or time-out",
                error,
            )
        print(
            f"Training finished at checkpoint {iteration} ({self.episodes_consumed} episodes, {self.env_steps} steps)",
            flush=True,
        )

    def _iterate_until_stopped(self) -> None:
        while True:
            try:
                self._iterate(self.iteration)
            except StopRequested:
                return
            if self._should_stop():
                return

    def _iterate(self, iteration: int) -> None:
        """Announce, collect, train and save one iteration (`self.iteration` moves on once its checkpoint is
        saved)."""
        self.collector.announce(iteration, self.checkpoints.latest_name())
        announced = time.monotonic()
        batches = self.collect(iteration)
        summary = self.train_iteration(iteration, batches, time.monotonic() - announced)
        self._save(iteration + 1)
        self.iteration = iteration + 1
        self._record_summary(summary)
        self.channel.ack(*[b.stream_id for b in batches.values()])
        self.channel.forget_iteration(iteration, self.options.num_workers)

    def _start_time_limit(self) -> threading.Timer | None:
        """`max_minutes` as a timer on the stop event: honoured while the trainer waits for episodes or for Redis,
        not only between iterations."""
        if self.options.max_minutes is None:
            return None

        def time_is_up() -> None:
            log.info("stopping: wall-time limit of %.1f minutes reached", self.options.max_minutes)
            self.stop_event.set()

        delay_s = max(0.0, 60 * self.options.max_minutes - (time.monotonic() - self.started))
        timer = threading.Timer(delay_s, time_is_up)
        timer.daemon = True
        timer.start()
        return timer


def run_trainer(settings: ServiceSettings, options: TrainerOptions) -> None:
    trainer = Trainer(settings, options)

    def request_stop(signum, frame):
        log.info("signal %d: finishing the current step, then writing .finished", signum)
        trainer.stop_event.set()

    signal.signal(signal.SIGTERM, request_stop)
    signal.signal(signal.SIGINT, request_stop)
    trainer.run()
