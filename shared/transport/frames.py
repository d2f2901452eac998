"""Live camera frames for the viewer, through Redis, and only while somebody watches.

Keys (under the run's `racer:<run>:` prefix, next to those of channels.py):

| key | type | written by | meaning |
|---|---|---|---|
| `watching` | string with TTL | viewer | present while a page shows every worker; all workers publish frames |
| `watching:<worker>` | string with TTL | viewer | present while a page shows that worker's panel; it publishes frames |
| `frame:<worker>` | string with TTL | workers | the newest frame of that worker: msgpack (below), never pickle |

A frame is a msgpack map: `worker_id`, `world`, `session` (changes when the worker restarts), `seq`, `time`
(Unix s), `jpeg` (the camera observation the network sees, JPEG), `x_m`, `y_m`, `heading_deg`, `trail` (the
episode's path so far, at most TRAIL_POINTS [x, y] pairs), `step`, `progress`, `episode_reward`, `status`,
`phase` (`training` or `evaluation`).

Cost on the rollout: one EXISTS per `watch_check_s` of wall time while nobody watches; while watched, one JPEG
encode (160x120 grey) and one SET per published frame, at most `max_fps` per second. A page asks for the workers
whose panels are on screen only, so a scrolled-away or hidden panel costs its worker nothing.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import cv2
import msgpack
import numpy as np

from racer.shared.redis_connection import RedisLink

WATCHING_TTL_S = 5
"""The viewer renews its `watching` keys on every page poll (twice a second); a closed page stops the frames within
this."""
FRAME_TTL_S = 30
"""A frame outlives its worker by this much at most: the heartbeat, not the frame, says whether a worker is up."""
TRAIL_POINTS = 250
JPEG_QUALITY = 85


@dataclass(frozen=True)
class FrameSettings:
    max_fps: float = 2.0
    """Frames per second and worker, at most, while somebody watches (the page polls twice a second: more frames
    would be made and never shown)."""
    watch_check_s: float = 1.0
    """How often (wall time) a worker asks Redis whether somebody watches."""


@dataclass(frozen=True)
class Frame:
    worker_id: int
    world: str
    session: str
    seq: int
    time: float
    jpeg: bytes
    x_m: float
    y_m: float
    heading_deg: float
    trail: tuple[tuple[float, float], ...]
    step: int
    progress: float
    episode_reward: float
    status: str
    phase: str

    @property
    def frame_id(self) -> str:
        """Changes with every new frame, also across a worker restart (seq starts again there)."""
        return f"{self.session}-{self.seq}"


def encode_frame(frame: Frame) -> bytes:
    return msgpack.packb(
        {
            "worker_id": frame.worker_id,
            "world": frame.world,
            "session": frame.session,
            "seq": frame.seq,
            "time": frame.time,
            "jpeg": frame.jpeg,
            "x_m": frame.x_m,
            "y_m": frame.y_m,
            "heading_deg": frame.heading_deg,
            "trail": [list(p) for p in frame.trail],
            "step": frame.step,
            "progress": frame.progress,
            "episode_reward": frame.episode_reward,
            "status": frame.status,
            "phase": frame.phase,
        },
        use_bin_type=True,
    )


def decode_frame(data: bytes) -> Frame:
    raw = msgpack.unpackb(data, raw=False)
    return Frame(
        worker_id=int(raw["worker_id"]),
        world=str(raw["world"]),
        session=str(raw["session"]),
        seq=int(raw["seq"]),
        time=float(raw["time"]),
        jpeg=bytes(raw["jpeg"]),
        x_m=float(raw["x_m"]),
        y_m=float(raw["y_m"]),
        heading_deg=float(raw["heading_deg"]),
        trail=tuple((float(x), float(y)) for x, y in raw["trail"]),
        step=int(raw["step"]),
        progress=float(raw["progress"]),
        episode_reward=float(raw["episode_reward"]),
        status=str(raw["status"]),
        phase=str(raw["phase"]),
    )


class FrameChannel:
    """The frame keys of one run (workers publish, the viewer reads and says that it watches)."""

    def __init__(self, link: RedisLink, run_id: str):
        self.link = link
        self.prefix = f"racer:{run_id}:"

    def key(self, name: str) -> str:
        return self.prefix + name

    def _watching_key(self, worker_id: int | None) -> str:
        return self.key("watching" if worker_id is None else f"watching:{worker_id}")

    def mark_watching(self, worker_ids: Iterable[int] | None = None) -> None:
        """Somebody watches these workers (None: all of them) for the next WATCHING_TTL_S seconds."""
        keys = [self._watching_key(None)] if worker_ids is None else [self._watching_key(i) for i in worker_ids]
        if not keys:
            return

        def renew(r) -> None:
            with r.pipeline(transaction=False) as pipe:
                for key in keys:
                    pipe.set(key, b"1", ex=WATCHING_TTL_S)
                pipe.execute()

        self.link.do(renew)

    def clear_watching(self) -> None:
        """Nobody watches any worker any more (as if every key had expired)."""
        self.link.do(lambda r: r.delete(self.key("watching"), *r.scan_iter(match=self.key("watching:*"))))

    def is_watched(self, worker_id: int | None = None) -> bool:
        """Whether somebody watches all workers or, given a worker, that one (one EXISTS either way)."""
        keys = [self._watching_key(None)] + ([] if worker_id is None else [self._watching_key(worker_id)])
        return bool(self.link.do(lambda r: r.exists(*keys)))

    def publish(self, frame: Frame) -> None:
        payload = encode_frame(frame)
        self.link.do(lambda r: r.set(self.key(f"frame:{frame.worker_id}"), payload, ex=FRAME_TTL_S))

    def latest(self, worker_id: int) -> Frame | None:
        raw = self.link.do(lambda r: r.get(self.key(f"frame:{worker_id}")))
        return None if raw is None else decode_frame(raw)

    def latest_of(self, worker_ids: list[int]) -> dict[int, Frame]:
        """The newest frame of each of these workers that has one, in one round trip."""
        if not worker_ids:
            return {}
        raws = self.link.do(lambda r: r.mget([self.key(f"frame:{i}") for i in worker_ids]))
        return {i: decode_frame(raw) for i, raw in zip(worker_ids, raws, strict=True) if raw is not None}


def camera_image(observation: dict[str, np.ndarray]) -> np.ndarray | None:
    """The (H, W) grey camera image of an observation (left eye of a stereo pair), None without a camera."""
    for value in observation.values():
        if value.ndim == 3 and value.dtype == np.uint8:
            return value[:, :, 0]
    return None


def jpeg_bytes(image: np.ndarray) -> bytes:
    ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
    if not ok:
        raise ValueError(f"OpenCV could not encode a {image.shape} {image.dtype} image as JPEG")
    return encoded.tobytes()


def _thin(points: list[tuple[float, float]], limit: int) -> tuple[tuple[float, float], ...]:
    if len(points) <= limit:
        return tuple(points)
    stride = -(-len(points) // limit)
    kept = points[::stride]
    if kept[-1] != points[-1]:
        kept.append(points[-1])
    return tuple(kept)


class FrameTap:
    """Called by the episode loop after every step; publishes a frame now and then, only while watched."""

    def __init__(
        self,
        channel: FrameChannel,
        worker_id: int,
        world: str,
        settings: FrameSettings = FrameSettings(),
        clock: Callable[[], float] = time.monotonic,
    ):
        self.channel = channel
        self.worker_id = worker_id
        self.world = world
        self.settings = settings
        self.clock = clock
        self.session = f"{os.getpid()}.{int(time.time() * 1000) % 10**9}"
        self.phase = "training"
        self.seq = 0
        self.published = 0
        self._watched = False
        self._next_watch_check = float("-inf")
        self._next_frame = float("-inf")
        self._trail: list[tuple[float, float]] = []
        self._episode_reward = 0.0

    def __call__(self, observation: dict[str, np.ndarray], reward: float, info: dict) -> None:
        row = info["simtrace"]
        if row["steps"] <= 1:
            self._trail.clear()
            self._episode_reward = 0.0
        self._trail.append((row["X"], row["Y"]))
        self._episode_reward += reward
        now = self.clock()
        if now >= self._next_watch_check:
            self._next_watch_check = now + self.settings.watch_check_s
            self._watched = self.channel.is_watched(self.worker_id)
        if not self._watched or now < self._next_frame:
            return
        self._next_frame = now + 1.0 / self.settings.max_fps
        image = camera_image(observation)
        self.seq += 1
        self.channel.publish(
            Frame(
                worker_id=self.worker_id,
                world=self.world,
                session=self.session,
                seq=self.seq,
                time=time.time(),
                jpeg=b"" if image is None else jpeg_bytes(image),
                x_m=float(row["X"]),
                y_m=float(row["Y"]),
                heading_deg=float(row["yaw"]),
                trail=_thin(self._trail, TRAIL_POINTS),
                step=int(row["steps"]),
                progress=float(row["progress"]),
                episode_reward=self._episode_reward,
                status=str(row["episode_status"]),
                phase=self.phase,
            )
        )
        self.published += 1
