"""How the trainer is told to stop: SIGTERM / Ctrl-C and the wall-time limit set one stop event, and an update
under way when it is set gets a short grace before it is abandoned.

The loop (racer.trainer.training_loop) checks the event between iterations; the collector and the Redis retries
(racer.shared.redis_connection.RedisLink) watch it while they wait.
"""

from __future__ import annotations

import logging
import signal
import threading
import time
from collections.abc import Callable

log = logging.getLogger(__name__)

STOP_UPDATE_GRACE_S = 10.0
"""A stop that arrives during the PPO update lets it run this much longer (then save the checkpoint); a longer
update is abandoned, the newest saved checkpoint stays the final one, so every process is gone within 30 s."""


def stop_on_signals(stop_event: threading.Event) -> None:
    """SIGTERM and SIGINT set the stop event: the trainer finishes its current step, then writes `.finished`."""

    def request_stop(signum, frame):
        log.info("signal %d: finishing the current step, then writing .finished", signum)
        stop_event.set()

    signal.signal(signal.SIGTERM, request_stop)
    signal.signal(signal.SIGINT, request_stop)


def start_time_limit(stop_event: threading.Event, max_minutes: float | None, started: float) -> threading.Timer | None:
    """`max_minutes` (counted from the monotonic time `started`) as a timer on the stop event: honoured while the
    trainer waits for episodes or for Redis, not only between iterations. None without a limit."""
    if max_minutes is None:
        return None

    def time_is_up() -> None:
        log.info("stopping: wall-time limit of %.1f minutes reached", max_minutes)
        stop_event.set()

    delay_s = max(0.0, 60 * max_minutes - (time.monotonic() - started))
    timer = threading.Timer(delay_s, time_is_up)
    timer.daemon = True
    timer.start()
    return timer


def update_abandoner(stop_event: threading.Event, grace_s: float = STOP_UPDATE_GRACE_S) -> Callable[[], bool]:
    """The `abandon` callback of one learner update: true once the stop event has been set for over `grace_s`."""
    stop_seen: list[float] = []

    def abandon() -> bool:
        if not stop_event.is_set():
            return False
        stop_seen[:] = stop_seen or [time.monotonic()]
        return time.monotonic() - stop_seen[0] > grace_s

    return abandon
