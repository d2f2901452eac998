"""Connecting to Redis with bounded retries: a clear error instead of a hang."""

from __future__ import annotations

import logging
import time

import redis

from racer.shared.config import RedisSettings

log = logging.getLogger(__name__)


class RedisUnavailableError(ConnectionError):
    """Redis could not be reached within the configured time budget."""


OPERATION_SOCKET_TIMEOUT_S = 30.0
"""Socket timeout of the returned client: longer than any blocking stream read the run makes (at most 5 s)."""


def connect_redis(settings: RedisSettings, *, first_backoff_s: float = 0.1, max_backoff_s: float = 2.0) -> redis.Redis:
    """Return a client once the server answered PING, retrying with exponential backoff until `connect_timeout_s`
    is spent.

    The PING goes through a probe client whose socket timeouts fit in the remaining budget, so a host that accepts
    connections but never answers fails within the budget too. The returned client keeps longer socket timeouts
    and health checks, so a later restart of the server shows up as `redis.ConnectionError` that callers can retry
    (see `RedisLink`).
    """
    deadline = time.monotonic() + settings.connect_timeout_s
    backoff_s = first_backoff_s
    attempts = 0
    while True:
        attempts += 1
        budget_s = max(0.1, min(2.0, deadline - time.monotonic()))
        probe = redis.Redis.from_url(settings.url, socket_connect_timeout=budget_s, socket_timeout=budget_s,
                                     retry_on_timeout=False)
        try:
            probe.ping()
        except (redis.ConnectionError, redis.TimeoutError) as error:
            remaining_s = deadline - time.monotonic()
            if remaining_s <= 0:
                raise RedisUnavailableError(
                    f"cannot reach Redis at {settings.url} after {attempts} attempts "
                    f"in {settings.connect_timeout_s:.0f} s: {error}. Is redis-server running (RACER_REDIS_URL)?"
                ) from error
            log.info("Redis at %s not reachable yet (%s); retrying in %.1f s", settings.url, error, backoff_s)
            time.sleep(min(backoff_s, remaining_s))
            backoff_s = min(backoff_s * 2, max_backoff_s)
            continue
        finally:
            probe.close()
        return redis.Redis.from_url(
            settings.url,
            socket_connect_timeout=min(2.0, settings.connect_timeout_s),
            socket_timeout=OPERATION_SOCKET_TIMEOUT_S,
            health_check_interval=15,
            retry_on_timeout=False,
        )


class RedisLink:
    """A Redis client that survives server restarts: operations are retried after reconnecting.

    `do(operation)` runs `operation(client)`; on a connection error it reconnects with backoff for
    up to `reconnect_budget_s` and runs the operation again, so use it only for operations that are
    safe to repeat (reads, XADD of a message the reader de-duplicates, SET, XACK). A write refused
    because Redis is full (maxmemory, noeviction) is retried the same way.
    """

    def __init__(self, settings: RedisSettings, reconnect_budget_s: float = 300.0):
        self.settings = settings
        self.reconnect_budget_s = reconnect_budget_s
        self._client = connect_redis(settings)

    @property
    def client(self) -> redis.Redis:
        return self._client

    def do(self, operation):
        deadline = time.monotonic() + self.reconnect_budget_s
        full_wait_s = 0.5
        while True:
            try:
                return operation(self._client)
            except redis.exceptions.OutOfMemoryError as error:
                # redis.conf refuses writes at maxmemory (noeviction) rather than drop episodes: wait for the
                # trainer to consume and acknowledge what is queued.
                if time.monotonic() > deadline:
                    raise RedisUnavailableError(
                        f"Redis at {self.settings.url} stayed full (maxmemory) for {self.reconnect_budget_s:.0f} s: "
                        f"{error}. Is the trainer consuming episodes? Raise maxmemory in redis.conf for larger "
                        f"iterations") from error
                log.warning("Redis is full (maxmemory); retrying in %.1f s while the trainer consumes episodes",
                            full_wait_s)
                time.sleep(full_wait_s)
                full_wait_s = min(2 * full_wait_s, 10.0)
            except (redis.ConnectionError, redis.TimeoutError) as error:
                if time.monotonic() > deadline:
                    raise RedisUnavailableError(
                        f"lost Redis at {self.settings.url} and could not reconnect within "
                        f"{self.reconnect_budget_s:.0f} s: {error}"
                    ) from error
                log.warning("Redis connection lost (%s); reconnecting to %s", error, self.settings.url)
                self._client.close()
                remaining_s = max(1.0, deadline - time.monotonic())
                self._client = connect_redis(
                    RedisSettings(url=self.settings.url, connect_timeout_s=min(remaining_s, self.reconnect_budget_s))
                )

    def close(self) -> None:
        self._client.close()
