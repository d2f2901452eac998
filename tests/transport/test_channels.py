"""RunChannel against a real redis-server: delivery once, pending redelivery, restart survival."""

import threading
import time

import numpy as np
import pytest

from racer.shared.redis_connection import RedisLink
from racer.shared.transport.channels import RunChannel, share_sizes


@pytest.fixture
def episode(episode_factory):
    def make(iteration: int, number: int):
        return episode_factory(
            5,
            number,
            worker_id=number,
            world="base",
            policy_version=iteration,
            iteration=iteration,
            episode_number=number,
        )

    return make


def test_share_sizes_follow_deepracer_split():
    assert share_sizes(20, 4) == [5, 5, 5, 5]
    assert share_sizes(10, 4) == [3, 3, 2, 2]
    assert share_sizes(3, 4) == [1, 1, 1, 0]
    assert sum(share_sizes(37, 5)) == 37


def test_episodes_are_consumed_once_and_redelivered_if_unacked(redis_settings, episode):
    channel = RunChannel(RedisLink(redis_settings), "run-a")
    channel.ensure_trainer_group()
    channel.push_episode(episode(0, 0))
    channel.push_episode(episode(0, 1))
    first = channel.read_episodes("trainer-0", block_s=1)
    assert sorted(e.episode.episode_number for e in first) == [0, 1]
    assert channel.read_episodes("trainer-0", block_s=0.2) == []  # consumed once
    # A restarted trainer sees what it read but never acknowledged.
    pending = channel.read_episodes("trainer-0", block_s=0, pending=True)
    assert sorted(e.episode.episode_number for e in pending) == [0, 1]
    channel.ack(*[e.stream_id for e in pending])
    assert channel.read_episodes("trainer-0", block_s=0, pending=True) == []


@pytest.mark.serial  # asserts a wall-time bound
def test_blocking_announcement_wait_wakes_on_publish(redis_settings):
    channel = RunChannel(RedisLink(redis_settings), "run-b")
    threading.Timer(0.3, channel.announce_iteration, args=(4, "4_Step-100.ckpt", 20, 4)).start()
    started = time.monotonic()
    announcements = channel.next_announcements("0", block_s=5)
    assert time.monotonic() - started < 3
    assert announcements[0].kind == "iteration" and announcements[0].checkpoint == "4_Step-100.ckpt"
    assert channel.latest_iteration_announcement().iteration == 4


def test_run_survives_redis_restart(redis_server, redis_settings, episode):
    channel = RunChannel(RedisLink(redis_settings, reconnect_budget_s=30), "run-c")
    channel.ensure_trainer_group()
    channel.push_episode(episode(1, 0))
    channel.link.client.execute_command("BGREWRITEAOF")
    time.sleep(0.5)
    redis_server.restart()
    channel.push_episode(episode(1, 1))  # reconnects transparently
    numbers = sorted(e.episode.episode_number for e in channel.read_episodes("trainer-0", block_s=1))
    assert numbers == [0, 1]
    np.testing.assert_array_equal(
        channel.read_episodes("trainer-0", 0, pending=True)[0].episode.rewards, episode(1, 0).rewards
    )


def test_heartbeats_expire(redis_settings):
    channel = RunChannel(RedisLink(redis_settings), "run-d")
    channel.beat(2, {"state": "playing"})
    assert channel.live_workers()[2]["state"] == "playing"
    channel.link.client.pexpire(channel.key("heartbeat:2"), 50)
    time.sleep(0.2)
    assert 2 not in channel.live_workers()


def test_a_fresh_run_wipes_its_keys_but_not_the_workers_heartbeats(redis_settings, episode):
    channel = RunChannel(RedisLink(redis_settings), "run-e")
    channel.beat(0, {"state": "starting"})
    channel.push_episode(episode(0, 0))
    assert channel.link.client.exists(channel.key("episodes"))
    channel.delete_run_keys()
    assert not channel.link.client.exists(channel.key("episodes"))
    assert channel.live_workers()[0]["state"] == "starting"
