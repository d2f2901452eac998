"""The trainer's half of the Redis protocol (racer.shared.transport.channels): announce an iteration, then collect its
episodes from the episode stream, with the reconciliation that keeps a run going when workers or Redis fail.

What `Collector.collect` does with each episode it reads: episodes of an older policy are dropped (clipped PPO is
strictly on-policy; the learner may keep a late episode, as SAC keeps those of checkpoint k-1 in its replay memory), a
second copy of an episode number is dropped, and the claims of a worker with no heartbeat go back to the queue for a
live worker. Episodes that are nowhere in Redis (a restarted Redis lost them) are queued again, and an announcement
Redis lost is made again.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from racer.shared.transport.channels import ReceivedEpisode, RunChannel
from racer.shared.user_errors import RunCannotGoOnError
from racer.trainer.learner import Learner

__all__ = ["CollectTimes", "Collector", "StopRequested"]

log = logging.getLogger(__name__)


class StopRequested(Exception):
    """SIGTERM / Ctrl-C / a stop condition: finish cleanly."""


@dataclass(frozen=True)
class CollectTimes:
    """How long the trainer waits while collecting (TrainerOptions holds one)."""

    episodes_timeout_s: float = 3600.0
    """Longest wait for the episodes of one iteration before giving up with an error."""
    dead_worker_grace_s: float = 20.0
    """How long into an iteration the claims of a worker without a heartbeat may wait before they go back to the
    queue."""
    announcement_check_s: float = 30.0
    """While collecting, how often to check that Redis still holds this iteration's announcement (a restarted
    Redis may have lost the newest writes); a lost one is announced again."""


class Collector:
    """Announces iterations and collects their episodes for one trainer (consumer `consumer` of group `trainer`)."""

    def __init__(
        self,
        channel: RunChannel,
        consumer: str,
        num_workers: int,
        episodes_per_iteration: int,
        learner: Learner,
        latest_checkpoint: Callable[[], str | None],
        stop_event: threading.Event,
        times: CollectTimes = CollectTimes(),
        overlap: bool = False,
    ):
        self.channel = channel
        self.consumer = consumer
        self.num_workers = num_workers
        self.episodes_per_iteration = episodes_per_iteration
        self.learner = learner
        self.latest_checkpoint = latest_checkpoint
        """The newest saved checkpoint's name (what a lost announcement is announced with again)."""
        self.stop_event = stop_event
        self.times = times
        self.overlap = overlap
        """An overlapped run: iteration k+1 is queued while k trains, so its episodes may be of policy k (one
        behind); an episode of k+1 read while collecting k is kept for k+1."""
        self.announced: dict[int, tuple[str, int]] = {}
        """Iteration -> (checkpoint, its number) as announced (what a lost announcement is announced with again)."""
        self.early: list[ReceivedEpisode] = []
        """Episodes of the next iteration read while collecting this one (overlap only), not yet acknowledged."""

    def collect(self, iteration: int) -> dict[int, ReceivedEpisode]:
        """The iteration's E episodes, by episode number. Workers claim them from Redis lists (see
        racer.shared.transport.channels); the claims of a worker whose heartbeat lapsed go back to the queue, and a
        live worker plays them."""
        num_workers = self.num_workers
        expected = set(range(self.episodes_per_iteration))
        got: dict[int, ReceivedEpisode] = {}
        waiting_since = time.monotonic()
        next_notice = waiting_since + 60
        next_announcement_check = waiting_since + self.times.announcement_check_s
        next_reconcile = waiting_since + self.times.dead_worker_grace_s
        last_queued: set[int] = set()

        oldest_policy = iteration - 1 if self.overlap else iteration

        def consider(received: ReceivedEpisode) -> None:
            episode = received.episode
            if self.overlap and episode.iteration == iteration + 1:
                self.early.append(received)  # queued ahead; collected with its own iteration
            elif episode.iteration < iteration and self.learner.take_late_episode(episode, iteration):
                self.channel.ack(received.stream_id)
            elif self.overlap and episode.iteration == iteration and episode.policy_version < oldest_policy:
                log.info(
                    "dropping episode %d of iteration %d: its policy %d is more than one version behind; queueing "
                    "it again",
                    episode.episode_number,
                    iteration,
                    episode.policy_version,
                )
                self.channel.ack(received.stream_id)
                if episode.episode_number in expected and episode.episode_number not in got:
                    self.channel.requeue(iteration, [episode.episode_number], num_workers)
                    self.channel.request_replay(iteration)
            elif episode.iteration != iteration or not oldest_policy <= episode.policy_version <= iteration:
                log.info(
                    "dropping a stale episode (iteration %d, policy %d) while training iteration %d",
                    episode.iteration,
                    episode.policy_version,
                    iteration,
                )
                self.channel.ack(received.stream_id)
            elif episode.episode_number in got or episode.episode_number not in expected:
                log.info(
                    "dropping a duplicate of episode %d of iteration %d from worker %d",
                    episode.episode_number,
                    iteration,
                    episode.worker_id,
                )
                self.channel.ack(received.stream_id)
            else:
                got[episode.episode_number] = received
                self.channel.mark_received(iteration, episode.episode_number)

        def read_all_now() -> None:
            while received := self.channel.read_episodes(self.consumer, block_s=0.001):
                for item in received:
                    consider(item)

        early, self.early = self.early, []
        seen: set[str] = set()  # an early episode is also among the pending ones
        for received in early + self.channel.read_episodes(self.consumer, 0, pending=True):
            if received.stream_id not in seen:
                seen.add(received.stream_id)
                consider(received)
        while expected - got.keys():
            if self.stop_event.is_set():
                raise StopRequested()
            fatal = self.channel.fatal()
            if fatal is not None:  # as the SimApp's RewardFunctionError ends its job: no training on what is left
                raise RunCannotGoOnError(f"{fatal['source']}: {fatal['message']}")
            for received in self.channel.read_episodes(self.consumer, block_s=2.0):
                consider(received)
            missing = sorted(expected - got.keys())
            if not missing:
                break
            now = time.monotonic()
            live = self.channel.live_workers()
            if now - waiting_since > self.times.dead_worker_grace_s:
                for worker_id in range(num_workers):
                    if worker_id in live:
                        continue
                    released = self.channel.release_claims(iteration, worker_id)
                    if released:
                        log.warning(
                            "worker %d has no heartbeat: its episodes %s of iteration %d go back to the queue and "
                            "a live worker replays it",
                            worker_id,
                            released,
                            iteration,
                        )
                        self.channel.request_replay(iteration)
            if now > next_reconcile:
                next_reconcile = now + 10.0
                queued, claimed = self.channel.queued_and_claimed(iteration, num_workers)
                read_all_now()  # anything delivered before the snapshot is in the stream now
                held = queued.union(*claimed.values())
                lost = sorted(expected - got.keys() - held)
                if lost:
                    log.warning(
                        "episodes %s of iteration %d are nowhere in Redis; queueing them again", lost, iteration
                    )
                    self.channel.requeue(iteration, lost, num_workers)
                    self.channel.request_replay(iteration)
                elif queued and queued == last_queued:  # nobody claimed for 10 s: wake workers that wait
                    self.channel.request_replay(iteration)
                last_queued = queued
            if now > next_announcement_check:
                next_announcement_check = now + self.times.announcement_check_s
                self.announce_again_if_lost(iteration)
            if now > next_notice:
                log.info(
                    "iteration %d: waiting for episodes %s (live workers %s)",
                    iteration,
                    missing,
                    sorted(live),
                )
                next_notice = now + 60
            if now - waiting_since > self.times.episodes_timeout_s:
                raise TimeoutError(
                    f"iteration {iteration}: episodes {missing} did not arrive within "
                    f"{self.times.episodes_timeout_s:.0f} s (live workers: {sorted(live) or 'none'}); "
                    f"are the rollout workers running against {self.channel.key('episodes')}?"
                )
        return got

    def announce_again_if_lost(self, iteration: int) -> None:
        """Workers learn of an iteration only from the control stream: if Redis lost the announcement (restarted
        before its append-only file had it), nobody would ever play the iteration."""
        latest = self.channel.latest_iteration_announcement()
        if latest is not None and latest.kind == "iteration" and latest.iteration == iteration:
            return
        log.warning(
            "the announcement of iteration %d is no longer in Redis (restarted without it?); announcing it again",
            iteration,
        )
        checkpoint, policy_version = self.announced.get(iteration, (self.latest_checkpoint(), iteration))
        self.announce(iteration, checkpoint, policy_version)

    def announce(self, iteration: int, checkpoint: str, policy_version: int | None = None) -> None:
        """Queue the iteration's episodes (once), then tell the workers to play them with `checkpoint` (number
        `policy_version`; None: `iteration`, DeepRacer's strict alternation)."""
        episodes = self.episodes_per_iteration
        version = iteration if policy_version is None else policy_version
        self.announced = {iteration: (checkpoint, version)}
        self.channel.open_episodes(iteration, episodes, self.num_workers)
        self.channel.announce_iteration(iteration, checkpoint, episodes, self.num_workers, version)
