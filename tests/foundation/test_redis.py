"""Redis round trip against a real server, restart, and a bounded failure when unreachable."""

from __future__ import annotations

import time

import pytest
import redis

from racer.local.services import free_port
from racer.shared.config import RedisSettings
from racer.shared.redis_connection import RedisLink, RedisUnavailableError, connect_redis


def test_round_trip(redis_settings):
    client = connect_redis(redis_settings)
    client.set("racer:test", b"\x00\x01payload")
    assert client.get("racer:test") == b"\x00\x01payload"
    client.xadd("racer:stream", {"field": b"value"})
    assert client.xlen("racer:stream") == 1


def test_project_config_is_applied(redis_settings):
    client = connect_redis(redis_settings)
    assert client.config_get("protected-mode")["protected-mode"] == "no"
    assert client.config_get("maxmemory-policy")["maxmemory-policy"] == "noeviction"
    assert client.config_get("bind")["bind"] == "127.0.0.1"


def test_data_survives_restart(redis_server, redis_settings):
    client = connect_redis(redis_settings)
    client.xadd("racer:stream", {"n": 1})
    client.execute_command("BGREWRITEAOF")
    time.sleep(0.5)
    redis_server.restart()
    client = connect_redis(redis_settings)
    assert client.xlen("racer:stream") == 1


@pytest.mark.serial  # asserts a wall-time bound
def test_unreachable_redis_fails_within_budget():
    settings = RedisSettings(url=f"redis://127.0.0.1:{free_port()}/0", connect_timeout_s=1.5)
    started = time.monotonic()
    with pytest.raises(RedisUnavailableError, match="cannot reach Redis"):
        connect_redis(settings)
    assert time.monotonic() - started < 5


@pytest.mark.serial  # asserts a wall-time bound
def test_a_host_that_never_answers_fails_within_budget():
    """A listener that accepts connections (kernel backlog) but never replies: not a hang, the budget holds."""
    import socket

    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen(8)
        port = silent.getsockname()[1]
        settings = RedisSettings(url=f"redis://127.0.0.1:{port}/0", connect_timeout_s=1.5)
        started = time.monotonic()
        with pytest.raises(RedisUnavailableError, match=f"cannot reach Redis at redis://127.0.0.1:{port}/0"):
            connect_redis(settings)
        assert time.monotonic() - started < 5


def test_waits_for_a_server_that_starts_late(redis_server):
    import concurrent.futures

    redis_server.stop()
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        connecting = pool.submit(connect_redis, RedisSettings(url=redis_server.url, connect_timeout_s=10))
        time.sleep(0.7)
        assert not connecting.done()
        # Started from the main thread: PR_SET_PDEATHSIG is tied to the thread that spawns the child.
        redis_server.start()
        assert connecting.result(timeout=15).ping()


@pytest.mark.serial  # asserts a wall-time bound
def test_a_write_refused_by_a_full_redis_waits_until_there_is_room(redis_server):
    """redis.conf refuses writes at maxmemory rather than evict episodes; the link waits instead of failing."""
    import threading

    link = RedisLink(RedisSettings(url=redis_server.url, connect_timeout_s=5))
    admin = connect_redis(RedisSettings(url=redis_server.url, connect_timeout_s=5))
    admin.config_set("maxmemory", "1")  # every write is now refused with OOM
    with pytest.raises(redis.exceptions.OutOfMemoryError):
        admin.set("probe", "x")
    threading.Timer(1.5, lambda: admin.config_set("maxmemory", "0")).start()  # the trainer catches up
    started = time.monotonic()
    assert link.do(lambda client: client.xadd("episodes", {"batch": b"x" * 1000})) is not None
    assert time.monotonic() - started >= 1.0
    assert admin.xlen("episodes") == 1


@pytest.mark.parametrize("server_class", ["RedisServer", "MinioServer"])
def test_servers_die_with_a_test_process_that_is_killed(tmp_path, server_class):
    """A test (or run) killed with SIGKILL cannot clean up; the kernel kills its servers (PR_SET_PDEATHSIG)."""
    import os
    import signal
    import subprocess
    import sys

    script = (
        "import sys, time\n"
        f"from racer.local.services import {server_class}\n"
        f"server = {server_class}(__import__('pathlib').Path({str(tmp_path / 'data')!r}))\n"
        "server.start(timeout_s=60)\n"
        "print(server.pid, flush=True)\n"
        "time.sleep(600)\n"
    )
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    server_pid = int(parent.stdout.readline())
    os.kill(server_pid, 0)  # running
    parent.send_signal(signal.SIGKILL)
    parent.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and _alive(server_pid):
        time.sleep(0.1)
    assert not _alive(server_pid), f"{server_class} (pid {server_pid}) outlived its killed parent"


def _alive(pid: int) -> bool:
    """Running or sleeping; a zombie (killed, waiting for whoever adopted it to reap it) counts as dead."""
    from pathlib import Path

    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except FileNotFoundError:
        return False
    state = next(line for line in status.splitlines() if line.startswith("State:"))
    return "zombie" not in state


@pytest.mark.serial  # asserts a wall-time bound
def test_a_stop_request_ends_the_retries_for_a_dead_server(redis_server):
    """Stopping never waits for Redis: the link's 300 s reconnect budget shrinks to STOPPING_BUDGET_S once its
    stop event is set, and its backoff sleeps wake at once."""
    import threading

    from racer.shared.redis_connection import STOPPING_BUDGET_S

    stop = threading.Event()
    link = RedisLink(RedisSettings(url=redis_server.url, connect_timeout_s=5), reconnect_budget_s=300, stop=stop)
    assert link.do(lambda client: client.ping())
    redis_server.kill()
    threading.Timer(1.0, stop.set).start()
    started = time.monotonic()
    with pytest.raises(RedisUnavailableError, match="the process is stopping"):
        link.do(lambda client: client.ping())
    assert 1.0 <= time.monotonic() - started < 1.0 + STOPPING_BUDGET_S + 1.0


@pytest.mark.serial  # asserts a wall-time bound
def test_a_dead_server_is_seen_at_once_not_after_silent_client_retries(redis_server):
    """redis-py retries every command itself by default (10 times with backoff); the link's clients do not, so a
    dead server reaches RedisLink's retry loop (and its stop checks) at once."""
    client = connect_redis(RedisSettings(url=redis_server.url, connect_timeout_s=5))
    redis_server.kill()
    started = time.monotonic()
    with pytest.raises(redis.ConnectionError):
        client.ping()
    assert time.monotonic() - started < 0.5
