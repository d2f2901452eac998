"""`racer train`'s display says when a worker is down and when it is back (racer/local/supervisor.py), with a real
redis-server for the heartbeats and real child processes."""

from __future__ import annotations

import subprocess
import sys

from racer.local.supervisor import RunSupervisor
from racer.rollout_worker.cli import EXIT_RUN_CANNOT_GO_ON
from racer.shared.redis_connection import RedisLink
from racer.shared.transport.channels import RunChannel


def test_the_display_shows_a_worker_down_and_back(redis_server, redis_settings):
    channel = RunChannel(RedisLink(redis_settings), "display-model")
    crashing = subprocess.Popen([sys.executable, "-c", "raise SystemExit(1)"])
    crashing.wait(30)
    children = {
        "worker-0": crashing,
        "worker-1": subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"]),
    }
    restarted = []

    def restart_worker(worker_id: int) -> None:
        children[f"worker-{worker_id}"] = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
        restarted.append(worker_id)

    lines: list[str] = []
    supervisor = RunSupervisor(redis_server, children, restart_worker, say=lines.append, num_workers=2)
    try:
        channel.beat(1, {"state": "playing"})
        supervisor.check_processes()  # worker 0 exited with an error: down, restarted
        supervisor.check_heartbeats(channel.live_workers())
        assert lines == ["worker 0 is DOWN (exit status 1; restarting it)"]
        assert restarted == [0]

        channel.beat(0, {"state": "playing"})  # the restarted worker's first heartbeat
        supervisor.check_processes()
        supervisor.check_heartbeats(channel.live_workers())
        assert lines[1:] == ["worker 0 is back (down 0 s)"]

        channel.link.do(lambda r: r.delete(channel.key("heartbeat:1")))  # worker 1 stuck: its heartbeat lapses
        supervisor.check_processes()
        supervisor.check_heartbeats(channel.live_workers())
        assert lines[2:] == ["worker 1 is DOWN (no heartbeat)"]
        supervisor.check_heartbeats(channel.live_workers())  # said once, not every second
        channel.beat(1, {"state": "playing"})
        supervisor.check_heartbeats(channel.live_workers())
        assert lines[3:] == ["worker 1 is back (down 0 s)"]
    finally:
        for child in children.values():
            child.kill()
            child.wait()


def test_a_worker_whose_failure_no_restart_mends_stops_the_run_instead_of_restarting(redis_server):
    """Exit status EXIT_RUN_CANNOT_GO_ON (the reward function raised): restarting would fail the same way."""
    failed = subprocess.Popen([sys.executable, "-c", f"raise SystemExit({EXIT_RUN_CANNOT_GO_ON})"])
    failed.wait(30)
    restarted = []
    supervisor = RunSupervisor(redis_server, {"worker-0": failed}, restarted.append, say=print, num_workers=1)
    supervisor.check_processes()
    supervisor.check_processes()
    assert supervisor.fatal_worker == 0 and restarted == []


def test_a_worker_that_keeps_failing_as_it_starts_stops_the_run(redis_server):
    """Five exits in a row within a minute of starting (e.g. a model folder missing model_metadata.json): restarting
    it again would loop for ever, so the run stops with its error."""
    from racer.local.supervisor import MAX_QUICK_EXITS

    def failing() -> subprocess.Popen:
        child = subprocess.Popen([sys.executable, "-c", "raise SystemExit(1)"])
        child.wait(30)
        return child

    children = {"worker-0": failing()}
    restarted = []

    def restart_worker(worker_id: int) -> None:
        children[f"worker-{worker_id}"] = failing()
        restarted.append(worker_id)

    lines: list[str] = []
    supervisor = RunSupervisor(redis_server, children, restart_worker, say=lines.append, num_workers=1)
    for _ in range(MAX_QUICK_EXITS + 2):
        supervisor.check_processes()
    assert supervisor.fatal_worker == 0
    assert len(restarted) == MAX_QUICK_EXITS - 1
    assert "not restarting it" in lines[-1]
