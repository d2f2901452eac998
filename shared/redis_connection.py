"""Connecting to Redis with bounded retries: a clear error instead of a hang."""

from __future__ import annotations

import logging
import threading
import time

import redis
from redis.backoff import NoBackoff
from redis.retry import Retry

from racer.shared.config import RedisSettings

log = logging.getLogger(__name__)


class RedisUnavailableError(ConnectionError):
    """Redis could not be reached within the configured time budget."""


OPERATION_SOCKET_TIMEOUT_S = 7.0
"""Socket timeout of the returned client: longer than any blocking stream read the run makes (at most 5 s), short
enough that a hung server (stopped, not dead) cannot hold a stopping process past its 30 s."""

STOPPING_BUDGET_S = 2.0
"""Once a process is stopping, how long it still tries to reach Redis (to announce `finished`, acknowledge) before
it gives up: stopping never waits for Redis."""


class _Budget:
    """A retry deadline that shrinks to `STOPPING_BUDGET_S` once `stop` is set, and a sleep that `stop` wakes."""

    def __init__(self, budget_s: float, stop: threading.Event | None):
        self.deadline = time.monotonic() + budget_s
        self.stop = stop
        self.stopping = False

    def remaining_s(self) -> float:
        if self.stop is not None and self.stop.is_set() and not self.stopping:
            self.stopping = True
            self.deadline = min(self.deadline, time.monotonic() + STOPPING_BUDGET_S)
        return self.deadline - time.monotonic()

    def sleep(self, seconds: float) -> None:
        if self.stop is None or self.stop.is_set():
            time.sleep(max(0.0, min(seconds, self.remaining_s())))
        else:
            self.stop.wait(seconds)  # a stop wakes it: the budget shrinks at once

    def why(self) -> str:
        return " (the process is stopping)" if self.stopping else ""


def connect_redis(
    settings: RedisSettings,
    *,
    first_backoff_s: float = 0.1,
    max_backoff_s: float = 2.0,
    stop: threading.Event | None = None,
    operation_timeout_s: float = OPERATION_SOCKET_TIMEOUT_S,
) -> redis.Redis:
    """Return a client once the server answered PING, retrying with exponential backoff until `connect_timeout_s`
    is spent, or `STOPPING_BUDGET_S` after `stop` is set (a stopping process must not wait for Redis).

    The PING goes through a probe client whose socket timeouts fit in the remaining budget, so a host that accepts
    connections but never answers fails within the budget too. The returned client keeps longer socket timeouts
    and health checks, so a later restart of the server shows up as `redis.ConnectionError` that callers can retry
    (see `RedisLink`).
    """
    budget = _Budget(settings.connect_timeout_s, stop)
    backoff_s = first_backoff_s
    attempts = 0
    while True:
        attempts += 1
        budget_s = max(0.1, min(2.0, budget.remaining_s()))
        probe = redis.Redis.from_url(
            settings.url,
            socket_connect_timeout=budget_s,
            socket_timeout=budget_s,
            retry_on_timeout=False,
            retry=_no_retry(),
        )
        try:
            probe.ping()
        except (redis.ConnectionError, redis.TimeoutError) as error:
            remaining_s = budget.remaining_s()
            if remaining_s <= 0:
                raise RedisUnavailableError(
                    f"cannot reach Redis at {settings.url} after {attempts} attempts{budget.why()} "
                    f"in {settings.connect_timeout_s:.0f} s: {error}. Is redis-server running (RACER_REDIS_URL)?"
                ) from error
            log.info("Redis at %s not reachable yet (%s); retrying in %.1f s", settings.url, error, backoff_s)
            budget.sleep(min(backoff_s, remaining_s))
            backoff_s = min(backoff_s * 2, max_backoff_s)
            continue
        finally:
            probe.close()
        return redis.Redis.from_url(
            settings.url,
            socket_connect_timeout=min(2.0, settings.connect_timeout_s),
            socket_timeout=operation_timeout_s,
            health_check_interval=15,
            retry_on_timeout=False,
            retry=_no_retry(),
        )


def _no_retry() -> Retry:
    """redis-py's own retries (10, by default, around every command) would hide a dead server from `RedisLink`
    for seconds at a time, out of reach of a stop request: the link does all retrying."""
    return Retry(NoBackoff(), 0)


class RedisLink:
    """A Redis client that survives server restarts: operations are retried after reconnecting.

    `do(operation)` runs `operation(client)`; on a connection error it reconnects with backoff for
    up to `reconnect_budget_s` and runs the operation again, so use it only for operations that are
    safe to repeat (reads, XADD of a message the reader de-duplicates, SET, XACK). A write refused
    because Redis is full (maxmemory, noeviction) is retried the same way.

    `stop` is the owner's stop event (SIGTERM, Ctrl-C, a time limit): once it is set, retries end within
    `STOPPING_BUDGET_S` with `RedisUnavailableError` and backoff sleeps wake at once, so stopping never
    depends on the state Redis is in.
    """

    def __init__(
        self,
        settings: RedisSettings,
        reconnect_budget_s: float = 300.0,
        stop: threading.Event | None = None,
        operation_timeout_s: float = OPERATION_SOCKET_TIMEOUT_S,
    ):
        self.settings = settings
        self.reconnect_budget_s = reconnect_budget_s
        self.stop = stop
        self.operation_timeout_s = operation_timeout_s
        self._client = connect_redis(settings, stop=stop, operation_timeout_s=operation_timeout_s)

    @property
    def client(self) -> redis.Redis:
        return self._client

    def do(self, operation):
        if self.stop is not None and self.stop.is_set() and self.operation_timeout_s > STOPPING_BUDGET_S:
            # Stopping: a hung server may hold each command only this long.
            self.operation_timeout_s = STOPPING_BUDGET_S
            self._client.close()
            self._client = redis.Redis.from_url(
                self.settings.url,
                socket_connect_timeout=STOPPING_BUDGET_S,
                socket_timeout=STOPPING_BUDGET_S,
                retry=_no_retry(),
            )
        budget = _Budget(self.reconnect_budget_s, self.stop)
        full_wait_s = 0.5
        while True:
            try:
                return operation(self._client)
            except redis.exceptions.OutOfMemoryError as error:
                # redis.conf refuses writes at maxmemory (noeviction) rather than drop episodes: wait for the
                # trainer to consume and acknowledge what is queued.
                if budget.remaining_s() <= 0:
                    raise RedisUnavailableError(
                        f"Redis at {self.settings.url} stayed full (maxmemory){budget.why()} for "
                        f"{self.reconnect_budget_s:.0f} s: {error}. Is the trainer consuming episodes? Raise "
                        f"maxmemory in redis.conf for larger iterations"
                    ) from error
                log.warning(
                    "Redis is full (maxmemory); retrying in %.1f s while the trainer consumes episodes", full_wait_s
                )
                budget.sleep(full_wait_s)
                full_wait_s = min(2 * full_wait_s, 10.0)
            except (redis.ConnectionError, redis.TimeoutError) as error:
                remaining_s = budget.remaining_s()
                if remaining_s <= 0:
                    raise RedisUnavailableError(
                        f"lost Redis at {self.settings.url} and could not reconnect{budget.why()} within "
                        f"{self.reconnect_budget_s:.0f} s: {error}"
                    ) from error
                log.warning("Redis connection lost (%s); reconnecting to %s", error, self.settings.url)
                self._client.close()
                self._client = connect_redis(
                    RedisSettings(url=self.settings.url, connect_timeout_s=max(0.5, remaining_s)),
                    stop=self.stop,
                    operation_timeout_s=self.operation_timeout_s,
                )

    def close(self) -> None:
        self._client.close()
