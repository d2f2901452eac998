"""Supervision of a local run (`racer train`): keep its redis-server and rollout workers alive, say when they go
down and come back, and stop every process within a fixed time whatever state Redis is in.

A redis-server that dies is started again on the same port and data folder: it loads its append-only file, so
every episode a worker had pushed (XADD answered) is still there; the trainer and the workers reconnect
on their own (RedisLink). A rollout worker that exits with an error is started again with a new seed.
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable, Iterable, Mapping

from racer.local.services import RedisServer
from racer.rollout_worker.cli import EXIT_RUN_CANNOT_GO_ON

QUICK_EXIT_S = 60.0
"""A worker that exits sooner than this after (re)starting has not got going: a startup failure."""
MAX_QUICK_EXITS = 5
"""Startup failures in a row after which a worker is not restarted again: it fails the same way each time (a
model folder missing a file, say), and the run stops with its error instead of restarting it for ever."""

STOP_CHILDREN_BUDGET_S = 18.0
"""Ctrl-C / SIGTERM: how long the trainer and workers get to stop (the trainer's final checkpoint included) before
they are killed; with Redis and MinIO stopped afterwards, everything is gone within 30 s."""


class RunSupervisor:
    """Checked once a second by the `racer train` loop; reports through `say` (one line per change)."""

    def __init__(
        self,
        redis: RedisServer,
        children: Mapping[str, subprocess.Popen],
        restart_worker: Callable[[int], None],
        say: Callable[[str], None],
        num_workers: int,
    ):
        self.redis = redis
        self.children = children
        self.restart_worker = restart_worker
        self.say = say
        self.num_workers = num_workers
        self.redis_down_since: float | None = None
        self._next_redis_attempt = 0.0
        self._redis_retry_s = 1.0
        self._seen_alive: set[int] = set()
        self._down: dict[int, float] = {}
        self._started_at: dict[int, float] = {}
        self._quick_exits: dict[int, int] = {}
        self.fatal_worker: int | None = None
        """A worker that exited with EXIT_RUN_CANNOT_GO_ON: the run stops (it is not restarted)."""

    @property
    def redis_up(self) -> bool:
        return self.redis_down_since is None

    def check_processes(self) -> None:
        self._check_redis()
        for worker_id in range(self.num_workers):
            child = self.children.get(f"worker-{worker_id}")
            if child is None:
                continue
            self._started_at.setdefault(worker_id, time.monotonic())  # a first worker: from when it was first seen
            if child.poll() in (None, 0):
                continue
            if child.returncode == EXIT_RUN_CANNOT_GO_ON:
                self.fatal_worker = worker_id  # restarting it would fail the same way, again and again
                continue
            now = time.monotonic()
            quick = now - self._started_at.get(worker_id, now) < QUICK_EXIT_S
            self._quick_exits[worker_id] = self._quick_exits.get(worker_id, 0) + 1 if quick else 0
            if self._quick_exits[worker_id] >= MAX_QUICK_EXITS:
                self.say(
                    f"worker {worker_id} exited {MAX_QUICK_EXITS} times in a row within {QUICK_EXIT_S:.0f} s of "
                    f"starting (exit status {child.returncode}); not restarting it"
                )
                self.fatal_worker = worker_id
                continue
            self._worker_down(worker_id, f"exit status {child.returncode}; restarting it")
            self.restart_worker(worker_id)
            self._started_at[worker_id] = time.monotonic()

    def check_heartbeats(self, live: Mapping[int, dict]) -> None:
        """Heartbeats (Redis keys with a TTL) tell a stuck or dead worker from a live one."""
        for worker_id in range(self.num_workers):
            if worker_id in live:
                self._seen_alive.add(worker_id)
                if worker_id in self._down:
                    down_s = time.monotonic() - self._down.pop(worker_id)
                    self.say(f"worker {worker_id} is back (down {down_s:.0f} s)")
            elif worker_id in self._seen_alive:
                self._worker_down(worker_id, "no heartbeat")

    def _worker_down(self, worker_id: int, why: str) -> None:
        if worker_id not in self._down:
            self._down[worker_id] = time.monotonic()
            self.say(f"worker {worker_id} is DOWN ({why})")
        elif "restarting" in why:
            self.say(f"worker {worker_id} exited again ({why})")

    def _check_redis(self) -> None:
        if self.redis.running:
            return
        now = time.monotonic()
        if self.redis_down_since is None:
            self.redis_down_since = now
            self.say(
                f"Redis is DOWN (redis-server exited with status {self.redis.exit_status}); restarting it "
                f"from its append-only file"
            )
        if now < self._next_redis_attempt:
            return
        try:
            self.redis.start(timeout_s=10)
        except (RuntimeError, TimeoutError, OSError) as error:
            self._next_redis_attempt = now + self._redis_retry_s
            self._redis_retry_s = min(2 * self._redis_retry_s, 10.0)
            self.say(f"Redis did not start again: {error}; retrying in {self._redis_retry_s:.0f} s")
            return
        self.say(f"Redis is back (down {time.monotonic() - self.redis_down_since:.1f} s)")
        self.redis_down_since = None
        self._redis_retry_s = 1.0


def stop_children(
    children: Mapping[str, subprocess.Popen],
    *,
    trainer: str,
    at_once: bool,
    never_ending: Iterable[str] = (),
    budget_s: float = STOP_CHILDREN_BUDGET_S,
    workers_after_trainer_s: float = 15.0,
) -> None:
    """Stop the run's processes.

    `at_once` (Ctrl-C, SIGTERM): every process gets SIGTERM together and `budget_s` in all; what is left is killed.
    Otherwise (the trainer ended the run) the workers get `workers_after_trainer_s` to finish on the trainer's
    `finished` announcement (worker 0's last evaluation) before SIGTERM. `never_ending` processes (a viewer)
    get SIGTERM at once in both cases.
    """
    deadline = time.monotonic() + budget_s
    for name in never_ending:
        child = children.get(name)
        if child is not None and child.poll() is None:
            child.terminate()
    if at_once:
        for child in children.values():
            if child.poll() is None:
                child.terminate()
    else:
        head = children.get(trainer)
        if head is not None and head.poll() is None:
            head.terminate()
            _wait(head, deadline)
        settle = time.monotonic() + workers_after_trainer_s
        for child in children.values():
            _wait(child, settle)
        for child in children.values():
            if child.poll() is None:
                child.terminate()
        deadline = time.monotonic() + 5
    for child in children.values():
        _wait(child, deadline)
    for child in children.values():
        if child.poll() is None:
            child.kill()
            child.wait()


def _wait(child: subprocess.Popen, deadline: float) -> None:
    try:
        child.wait(max(0.01, deadline - time.monotonic()))
    except subprocess.TimeoutExpired:
        pass
