"""The trainer process: iteration after iteration, collect every worker's share, update the policy (clipped PPO or
SAC, as model_metadata.json says: racer.trainer.algorithms), publish a checkpoint.

One iteration k, top to bottom:
1. announce checkpoint k on the control stream (it is already complete in the store);
2. collect the iteration's E episodes (numbers 0..E-1, queued in Redis; workers claim them one by one, their own
   DeepRacer share first, then whatever is left) from the episode stream (consumer group `trainer`): episodes of an
   older policy are dropped (PPO is strictly on-policy; SAC keeps a late episode of checkpoint k-1 in its replay
   memory without counting it, and drops older ones), a second copy of an episode number is dropped, and the
   claims of a worker with no heartbeat go back to the queue for a live worker (racer.trainer.collector);
3. print DeepRacer's `Training>` line per episode, run the learner's update, print `Policy training>` lines;
4. save checkpoint k+1 to the store (files first, then `.coach_checkpoint`): all the workers wait for;
5. after announcing k+1, while the workers play: record iteration k's summary (racer.trainer.iteration_summary),
   acknowledge its episodes, apply the checkpoints' retention (and at the end of the run, before `.finished`).
A trainer killed at any point restarts from the newest checkpoint: unacknowledged episodes are read again. The time
of each part is in every summary's `trainer_parts_s` (racer.trainer.iteration_parts).

Under `--overlap` (RunOptions.overlap) step 2 ends by queueing iteration k+1 and announcing it with checkpoint k, so
the workers play on during the update; checkpoint k+1 is published for them to take up between episodes, and
iteration k+1 trains on episodes of k (one behind, against their own log_probs) or k+1 (racer.trainer.collector).

Before the first iteration the run's custom files are checked and published (racer.trainer.run_files); a signal
or the wall-time limit stops the loop (racer.trainer.stopping). Which checkpoint is the best is not decided here:
rollout worker 0 evaluates each one it is announced and writes deepracer_checkpoints.json
(racer.rollout_worker.checkpoint_evaluation), since the evaluation drives an env.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import torch

from racer.shared import model_layout
from racer.shared.config import ServiceSettings
from racer.shared.model_layout import ModelLayout
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.network_file import NetworkFile
from racer.shared.redis_connection import RedisLink, RedisUnavailableError
from racer.shared.run_progress import RunPace, StopCondition
from racer.shared.run_settings import RunOptions
from racer.shared.store import open_store
from racer.shared.transport.channels import ReceivedEpisode, RunChannel
from racer.trainer.algorithms import LearnerOptions, build_learner
from racer.trainer.collector import Collector, CollectTimes, StopRequested
from racer.trainer.device import describe_device
from racer.trainer.iteration_finish import FinishingIteration, save_checkpoint
from racer.trainer.iteration_parts import ANNOUNCEMENTS, SUMMARIES, IterationParts
from racer.trainer.iteration_summary import iteration_summary, overlap_summary, update_summary
from racer.trainer.learner import UpdateAbandoned
from racer.trainer.log_lines import format_training_episode_line
from racer.trainer.lr_anneal import annealed_rate, share_of_run_used
from racer.trainer.memory_cap import cap_episodes, default_max_memory_steps, global_episode_order
from racer.trainer.precision import DEFAULT_PRECISION, Precision
from racer.trainer.preflight import PreflightReport, check_clone_source
from racer.trainer.preset import Preset
from racer.trainer.run_files import MODEL_METADATA_FILE, publish_run_files, read_run_files
from racer.trainer.stopping import STOP_UPDATE_GRACE_S, start_time_limit, stop_on_signals, update_abandoner

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TrainerOptions:
    model_prefix: str
    custom_files: Path
    run: RunOptions
    """Every worker's settings before custom_files/workers.json (track, worlds, car, challenge)."""
    max_episodes: int | None = None
    """Training episodes to consume before stopping (default: hyperparameters' term_cond_max_episodes)."""
    max_minutes: float | None = None
    seed: int = 0
    pretrained_prefix: str | None = None
    pretrained_checkpoint: str = "last"
    collect_times: CollectTimes = CollectTimes()
    """How long collecting waits: for an iteration's episodes, on a share with no live worker, between checks of the
    announcement (racer.trainer.collector)."""
    max_memory_steps: int | None = None
    """Transitions one iteration trains on (DeepRacer's MAX_MEMORY_STEPS): None = DeepRacer's cap for the network
    (10,000 shallow, 3,000 others), 0 = no cap."""
    sac_replay_memory_mb: float = 1024.0
    """SAC: memory budget of the replay ring on the trainer (its capacity in transitions follows from it)."""
    sac_updates_per_transition: float | None = None
    """SAC: gradient steps per transition received (`--sac-updates-per-transition`); None: the preset's
    `updates_per_transition`, else DeepRacer's 1."""
    precision: Precision = DEFAULT_PRECISION
    """What the towers compute in during updates (racer.trainer.precision); written into every checkpoint."""
    device: str = "cpu"
    """The torch device of the networks and updates (racer.trainer.device resolves `--device`)."""
    preflight: PreflightReport | None = None
    """The custom files as `racer trainer` checked them; None: the trainer runs the preflight itself."""


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
        self.queued_ahead: int | None = None
        """Overlap: the iteration announced before the update of the one before it (not announced again)."""
        self.network_file: NetworkFile | None = None
        """network.json of the custom files when model_metadata.json names it."""
        self.preset: Preset | None = None
        """preset.json of the custom files, when there is one."""
        self.parts = IterationParts()
        self.finishing: FinishingIteration | None = None
        """The last iteration, its records written once the next one is announced."""

    # ---- set-up ----------------------------------------------------------------------------------
    def setup(self) -> int:
        """Upload the run's files, restore or create the newest checkpoint; returns its number."""
        torch.manual_seed(self.options.seed)
        options = self.options
        files = read_run_files(options.custom_files, options.run, report=options.preflight)
        self.network_file, self.preset = files.network, files.preset
        metadata, hyperparameters = files.model_metadata, files.hyperparameters
        self.metadata, self.hyperparameters = metadata, hyperparameters
        self.pace = RunPace(
            StopCondition(self._max_episodes(), options.max_minutes, hyperparameters.num_episodes_between_training)
        )
        self.learner = build_learner(
            metadata,
            hyperparameters,
            LearnerOptions(
                seed=self.options.seed,
                precision=self.options.precision,
                device=str(self.options.device),
                sac_replay_memory_mb=self.options.sac_replay_memory_mb,
                sac_updates_per_transition=self.options.sac_updates_per_transition,
                network=self.network_file,
                preset=self.preset,
            ),
        )
        self.network = self.learner.network
        log.info("Training on %s", describe_device(torch.device(self.options.device)))
        self.collector = Collector(
            self.channel,
            self.consumer,
            self.options.run.num_workers,
            hyperparameters.num_episodes_between_training,
            self.learner,
            self.checkpoints.latest_name,
            self.stop_event,
            self.options.collect_times,
            overlap=self.options.run.overlap,
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
            publish_run_files(self.store, self.layout, self.options.model_prefix, files)
            iteration = 0
            self._save(iteration)
            self.checkpoints.apply_retention()
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
            str(self.options.custom_files / MODEL_METADATA_FILE),
            self.network_file,
            self.hyperparameters.stack_size,
        )
        source = CheckpointStore(self.store, source_prefix)
        name = source.select(self.options.pretrained_checkpoint)
        source.restore(name, self.network)  # weights only: a clone starts a fresh optimiser
        print(f"Cloned weights from {source_prefix}/model/{name}", flush=True)

    def _save(self, iteration: int) -> str:
        """Publish checkpoint `iteration`; its retention is left to the caller (_finish_previous)."""
        name = save_checkpoint(
            self.checkpoints,
            self.parts,
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
    def collect(self, iteration: int) -> dict[int, ReceivedEpisode]:
        """The iteration's E episodes, by episode number (racer.trainer.collector)."""
        return self.collector.collect(iteration)

    def _announce(self, iteration: int, checkpoint: str) -> None:
        self.collector.announce(iteration, checkpoint)

    def _memory_cap(self) -> int | None:
        if self.options.max_memory_steps is not None:
            return self.options.max_memory_steps
        return default_max_memory_steps(self.metadata.neural_network)

    def train_iteration(self, iteration: int, received: dict[int, ReceivedEpisode], rollout_wall_s: float) -> dict:
        by_number = {number: item.episode for number, item in received.items()}
        capped = cap_episodes(global_episode_order(by_number), self._memory_cap())
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
        if self.preset is not None and self.preset.anneal_lr:  # by the share used before this iteration, as CleanRL
            used = share_of_run_used(self.pace.condition, time.monotonic() - self.started, self.episodes_consumed)
            self.learner.learning_rate = annealed_rate(self.hyperparameters.lr, used)
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
        update_started = time.monotonic()
        try:
            all_stats = self.learner.update(
                episodes, abandon=update_abandoner(self.stop_event), env_steps=self.env_steps, policy_version=iteration
            )
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
        with self.parts.timed(SUMMARIES):
            summary = iteration_summary(
                iteration, episodes, self.env_steps, rollout_wall_s, elapsed_s=time.monotonic() - self.started
            )
            summary.update(
                episodes_dropped=len(capped.dropped),
                steps_dropped=capped.dropped_steps,
                rollout_s=round(rollout_wall_s, 3),
                update_s=round(update_s, 3),
                learning_rate=self.learner.learning_rate,  # after the update: a preset's desired_kl or anneal_lr moves it
                **update_summary(all_stats),
            )
            if self.options.run.overlap:
                summary.update(overlap_summary(iteration, episodes))
        summary["trainer_parts_s"] = self.parts.totals()  # up to elapsed_s
        return summary

    def _queue_ahead(self) -> bool:
        """Overlap, and the next iteration will be trained (not past the episode limit)."""
        episodes = self.hyperparameters.num_episodes_between_training
        return self.options.run.overlap and self.episodes_consumed + episodes < self._max_episodes()

    def _max_episodes(self) -> int:
        return self.options.max_episodes or self.hyperparameters.term_cond_max_episodes

    def _should_stop(self) -> bool:
        max_episodes = self._max_episodes()
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
        # The time limit starts before setup: its last step waits for Redis too.
        time_limit = start_time_limit(self.stop_event, self.options.max_minutes, self.started)
        stopped_cleanly = False
        try:
            try:
                self.iteration = self.setup()
                self._iterate_until_stopped()
                self._finish_previous()
            except RedisUnavailableError as error:
                if not self.stop_event.is_set() or self.checkpoints.latest_name() is None:
                    raise
                self._finish_previous(redis=False)
                # Stopping with Redis gone: the newest checkpoint is complete in the store; episodes not
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
        saved); the one before is finished while this one's episodes come in."""
        if self.queued_ahead != iteration:
            with self.parts.timed(ANNOUNCEMENTS):
                self.collector.announce(iteration, self.checkpoints.latest_name())
        announced = time.monotonic()
        with self.parts.collecting():
            self._finish_previous()
            received = self.collect(iteration)
        with self.parts.timed(ANNOUNCEMENTS):
            if self._queue_ahead():  # the workers play k+1 with checkpoint k while k trains
                self.collector.announce(iteration + 1, self.checkpoints.latest_name(), policy_version=iteration)
                self.queued_ahead = iteration + 1
            elif self.queued_ahead == iteration:  # the last one: its own checkpoint, for worker 0 to judge as strict
                self.collector.announce(iteration, self.checkpoints.latest_name())
        summary = self.train_iteration(iteration, received, time.monotonic() - announced)
        checkpoint = self._save(iteration + 1)
        if self.options.run.overlap:  # the workers take it up at their next episode
            with self.parts.timed(ANNOUNCEMENTS):
                self.channel.publish_newest_checkpoint(iteration + 1, checkpoint)
        self.iteration = iteration + 1
        summary["progress"] = self.pace.after_iteration(
            iteration, time.monotonic() - self.started, self.episodes_consumed
        ).to_dict()
        self.finishing = FinishingIteration(summary, tuple(item.stream_id for item in received.values()), iteration)

    def _finish_previous(self, redis: bool = True) -> None:
        """What no worker waits for, done after the next announcement (or before `.finished`; `redis`: False when a
        stop found Redis gone): the iteration's log line and retention, then its summary and acks in Redis."""
        finishing, self.finishing = self.finishing, None
        if finishing is not None:
            finishing.finish_in_store(self.store, self.layout, self.checkpoints, self.parts)
            if redis:
                finishing.finish_in_redis(self.channel, self.parts, self.options.run.num_workers)


def run_trainer(settings: ServiceSettings, options: TrainerOptions) -> None:
    trainer = Trainer(settings, options)
    stop_on_signals(trainer.stop_event)
    trainer.run()
