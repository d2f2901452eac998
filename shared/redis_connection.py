"""Connecting to Redis with bounded retries: a clear error instead of a hang."""

from __future__ import annotations

import logging
import time

import redis

from racer.shared.config import RedisSettings

log = logging.getLogger(__name__)


class RedisUnavailableError(ConnectionError):
    """Redis could not be reached within the configured time budget."""


def connect_redis(settings: RedisSettings, *, first_backoff_s: float = 0.1, max_backoff_s: float = 2.0) -> redis.Redis:
    """Return a client that answered PING, retrying with exponential backoff until `connect_timeout_s` is spent.

    The client itself keeps short socket timeouts and health checks, so a later restart of the
    server shows up as `redis.ConnectionError` that callers can retry (see `retry_on_disconnect`).
    """
    deadline = time.monotonic() + settings.connect_timeout_s
    backoff_s = first_backoff_s
    attempts = 0
    while True:
        attempts += 1
        client = redis.Redis.from_url(
            settings.url,
            socket_connect_timeout=min(2.0, settings.connect_timeout_s),
            socket_timeout=30.0,
            health_check_interval=15,
            retry_on_timeout=False,
        )
        try:
            client.ping()
            return client
        except (redis.ConnectionError, redis.TimeoutError) as error:
            client.close()
            remaining_s = deadline - time.monotonic()
            if remaining_s <= 0:
                raise RedisUnavailableError(
                    f"cannot reach Redis at {settings.url} after {attempts} attempts "
                    f"in {settings.connect_timeout_s:.0f} s: {error}. Is redis-server running (RACER_REDIS_URL)?"
                ) from error
            log.info("Redis at %s not reachable yet (%s); retrying in %.1f s", settings.url, error, backoff_s)
            time.sleep(min(backoff_s, remaining_s))
            backoff_s = min(backoff_s * 2, max_backoff_s)
