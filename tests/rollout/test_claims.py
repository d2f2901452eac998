"""The rollout worker's claim protocol against a real redis-server (racer.rollout_worker.claims.claim_next_episode on
racer.shared.transport.channels): a worker claims its own DeepRacer share first, a finished worker helps a slower
one only after its own episodes are played, and the claims of a worker whose heartbeat lapsed go back to the queue."""

from __future__ import annotations

import threading
import time

import pytest

from racer.rollout_worker.claims import claim_next_episode
from racer.shared.redis_connection import RedisLink
from racer.shared.transport.channels import RunChannel
from racer.trainer.collector import Collector, CollectTimes

ITERATION = 0
WORKERS = 2
EPISODES = 6  # worker 0's share: 0, 2, 4; worker 1's: 1, 3, 5 (the SimApp's split)


@pytest.fixture
def channel(redis_settings) -> RunChannel:
    channel = RunChannel(RedisLink(redis_settings), "claims")
    assert channel.open_episodes(ITERATION, EPISODES, WORKERS)
    return channel


def lapse_heartbeat(channel: RunChannel, worker_id: int) -> None:
    """What HEARTBEAT_TTL_S does to a dead worker's key, in 50 ms instead of 15 s."""
    channel.link.client.pexpire(channel.key(f"heartbeat:{worker_id}"), 50)
    deadline = time.monotonic() + 5
    while worker_id in channel.live_workers() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert worker_id not in channel.live_workers()


def deliver(channel: RunChannel, worker_id: int, number: int, episode_factory) -> None:
    channel.deliver_episode(
        episode_factory(
            5,
            worker_id,
            worker_id=worker_id,
            world="base",
            policy_version=ITERATION,
            iteration=ITERATION,
            episode_number=number,
        )
    )


def test_a_worker_claims_its_own_share_first_in_order(channel):
    in_flight: set[int] = set()
    claims = [claim_next_episode(channel, ITERATION, 0, WORKERS, in_flight) for _ in range(3)]
    assert claims == [0, 2, 4] and in_flight == {0, 2, 4}
    queued, claimed = channel.queued_and_claimed(ITERATION, WORKERS)
    assert queued == {1, 3, 5} and claimed == {0: {0, 2, 4}, 1: set()}
    assert channel.open_episodes(ITERATION, EPISODES, WORKERS) is False  # queued once, also when announced again


def test_a_finished_worker_claims_a_slower_ones_episodes_only_after_its_own(channel, episode_factory):
    channel.beat(1, {"state": "playing"})  # worker 1 is alive and slow: it has claimed nothing yet
    in_flight: set[int] = set()
    for _ in range(3):
        claim_next_episode(channel, ITERATION, 0, WORKERS, in_flight)
    # Its own episodes are claimed but still being played: it does not take another worker's.
    assert claim_next_episode(channel, ITERATION, 0, WORKERS, in_flight) is None
    assert channel.queued_and_claimed(ITERATION, WORKERS)[0] == {1, 3, 5}
    for number in sorted(in_flight):
        deliver(channel, 0, number, episode_factory)
    in_flight.clear()  # what the worker's `finished` callback does per delivered episode
    assert channel.queued_and_claimed(ITERATION, WORKERS)[1][0] == set()  # delivered: no longer claimed
    # Now it helps, from the back of worker 1's queue; the last queued episode stays worker 1's own.
    helped = [claim_next_episode(channel, ITERATION, 0, WORKERS, in_flight) for _ in range(3)]
    assert helped == [5, 3, None] and in_flight == set()
    assert claim_next_episode(channel, ITERATION, 1, WORKERS, set()) == 1


def test_a_lapsed_heartbeat_returns_the_claims_to_the_queue_for_a_live_worker(channel):
    channel.beat(1, {"state": "playing"})
    slow: set[int] = set()
    assert [claim_next_episode(channel, ITERATION, 1, WORKERS, slow) for _ in range(2)] == [1, 3]
    lapse_heartbeat(channel, 1)
    # The trainer's reconciliation (racer.trainer.collector): claims of a worker with no heartbeat go back, in order.
    assert sorted(channel.release_claims(ITERATION, 1)) == [1, 3]
    queued, claimed = channel.queued_and_claimed(ITERATION, WORKERS)
    assert queued == set(range(EPISODES)) and claimed[1] == set()
    # A live worker plays its own share, then all of the dead worker's (no episode is kept for a dead worker).
    done: set[int] = set()
    own = [claim_next_episode(channel, ITERATION, 0, WORKERS, done) for _ in range(3)]
    done.clear()
    others = [claim_next_episode(channel, ITERATION, 0, WORKERS, done) for _ in range(4)]
    assert own == [0, 2, 4] and others == [5, 3, 1, None]


class _OnPolicyLearner:
    def take_late_episode(self, episode, iteration):
        return False


def test_the_trainer_collects_an_iteration_whose_worker_died_holding_a_claim(channel, episode_factory):
    """Both halves: worker 1 dies holding episode 1; the collector hands it back and wakes the workers; worker 0,
    done with its own share, plays it (and the rest of worker 1's share)."""
    channel.ensure_trainer_group()
    channel.beat(0, {"state": "playing"})
    channel.beat(1, {"state": "playing"})
    assert claim_next_episode(channel, ITERATION, 1, WORKERS, set()) == 1
    lapse_heartbeat(channel, 1)
    collector = Collector(
        channel,
        "trainer-0",
        WORKERS,
        EPISODES,
        _OnPolicyLearner(),
        lambda: "checkpoint-0",
        threading.Event(),
        CollectTimes(episodes_timeout_s=60.0, dead_worker_grace_s=0.0, announcement_check_s=3600.0),
    )
    stop = threading.Event()

    def worker_0() -> None:
        in_flight: set[int] = set()
        while not stop.is_set():
            channel.beat(0, {"state": "playing"})
            number = claim_next_episode(channel, ITERATION, 0, WORKERS, in_flight)
            if number is None:
                time.sleep(0.05)  # the real worker waits for the trainer's `replay` notice
                continue
            deliver(channel, 0, number, episode_factory)
            in_flight.discard(number)

    playing = threading.Thread(target=worker_0, daemon=True)
    playing.start()
    try:
        got = collector.collect(ITERATION)
    finally:
        stop.set()
        playing.join(timeout=10)
    assert sorted(got) == list(range(EPISODES))
    assert {received.episode.worker_id for received in got.values()} == {0}
    replays = [a for a in channel.next_announcements("0", block_s=0) if a.kind == "replay"]
    assert replays, "the collector wakes waiting workers when it hands claims back"
