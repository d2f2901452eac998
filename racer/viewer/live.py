"""The live half of the viewer: workers' heartbeats and camera frames from Redis, with short time budgets.

A web request never waits long for Redis: the link gives up after `budget_s` and the page shows "Redis
unreachable" until the next poll gets through (the connection is made again then).
"""

from __future__ import annotations

import base64
import threading
import time
from dataclasses import dataclass

import redis

from racer.shared.config import RedisSettings
from racer.shared.redis_connection import RedisLink, RedisUnavailableError
from racer.shared.transport.channels import RunChannel
from racer.shared.transport.frames import Frame, FrameChannel


@dataclass(frozen=True)
class LiveSnapshot:
    redis_error: str | None
    workers: dict[int, dict]
    """Heartbeat status of each live worker."""
    frames: dict[int, Frame]
    finished: bool


class LiveRun:
    def __init__(self, settings: RedisSettings, model_prefix: str, budget_s: float = 1.0):
        self.settings = RedisSettings(url=settings.url, connect_timeout_s=budget_s)
        self.model_prefix = model_prefix
        self.budget_s = budget_s
        self._link: RedisLink | None = None
        self._lock = threading.Lock()

    def _channels(self) -> tuple[RunChannel, FrameChannel]:
        with self._lock:
            if self._link is None:
                self._link = RedisLink(self.settings, reconnect_budget_s=self.budget_s)
            return RunChannel(self._link, self.model_prefix), FrameChannel(self._link, self.model_prefix)

    def _forget_link(self) -> None:
        with self._lock:
            if self._link is not None:
                self._link.close()
            self._link = None

    def snapshot(self, worker_ids: list[int], watching: bool, watched_ids: list[int] | None = None) -> LiveSnapshot:
        """Heartbeats and newest frames; `watching` renews the keys that make workers publish frames: of the
        workers in `watched_ids` (the panels on screen), of all workers when it is None."""
        try:
            run, frames = self._channels()
            if watching:
                frames.mark_watching(watched_ids)
            workers = run.live_workers()
            latest = frames.latest_of(sorted(set(worker_ids) | set(workers)))
            announcement = run.latest_iteration_announcement()
        except (RedisUnavailableError, redis.RedisError) as error:
            self._forget_link()
            return LiveSnapshot(redis_error=str(error), workers={}, frames={}, finished=False)
        finished = announcement is not None and announcement.kind == "finished"
        return LiveSnapshot(redis_error=None, workers=workers, frames=latest, finished=finished)

    def frame(self, worker_id: int) -> Frame | None:
        try:
            _run, frames = self._channels()
            return frames.latest(worker_id)
        except (RedisUnavailableError, redis.RedisError):
            self._forget_link()
            return None

    @staticmethod
    def frame_summary(frame: Frame, with_jpeg: bool = False) -> dict:
        """The frame as JSON; `with_jpeg` adds the image (base64): one poll brings everything a panel on screen
        draws, instead of one more request per frame and worker."""
        summary = {
            "id": frame.frame_id,
            "has_image": bool(frame.jpeg),
            "age_s": round(max(0.0, time.time() - frame.time), 1),
            "x_m": frame.x_m,
            "y_m": frame.y_m,
            "heading_deg": frame.heading_deg,
            "trail": [list(p) for p in frame.trail],
            "step": frame.step,
            "progress": round(frame.progress, 1),
            "episode_reward": round(frame.episode_reward, 2),
            "status": frame.status,
            "phase": frame.phase,
        }
        if with_jpeg and frame.jpeg:
            summary["jpeg_base64"] = base64.b64encode(frame.jpeg).decode("ascii")
        return summary
