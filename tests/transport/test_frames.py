"""Live camera frames on a real redis-server: published only while watched, at a capped rate, decodable."""

import cv2
import numpy as np

from racer.shared.redis_connection import RedisLink
from racer.shared.transport.frames import (
    TRAIL_POINTS,
    FrameChannel,
    FrameSettings,
    FrameTap,
    decode_frame,
    encode_frame,
)


class SteppedClock:
    """Wall time advanced by the test, one env step (1/15 s) at a time."""

    def __init__(self):
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


def drive(tap: FrameTap, clock: SteppedClock, steps: int, seed: int = 0, first_step: int = 1) -> list[dict]:
    """Feed `steps` env steps of a car moving along x with a changing camera image; returns the simtrace rows."""
    rng = np.random.default_rng(seed)
    rows = []
    for step in range(first_step, first_step + steps):
        image = rng.integers(0, 255, size=(120, 160, 1), dtype=np.uint8)
        row = {
            "steps": step,
            "X": 0.1 * step,
            "Y": 2.0,
            "yaw": 30.0 + step,
            "progress": step / 3,
            "episode_status": "in_progress",
        }
        tap({"FRONT_FACING_CAMERA": image}, 1.0, {"simtrace": row})
        rows.append(row)
        clock.now_s += 1 / 15
    return rows


def test_nothing_is_published_while_nobody_watches(redis_settings):
    channel = FrameChannel(RedisLink(redis_settings), "run-f")
    clock = SteppedClock()
    tap = FrameTap(channel, worker_id=0, world="base", clock=clock)
    drive(tap, clock, 150)
    assert tap.published == 0
    assert channel.latest(0) is None
    assert not channel.is_watched()


def test_frames_are_capped_and_stop_when_the_viewer_leaves(redis_settings):
    link = RedisLink(redis_settings)
    channel = FrameChannel(link, "run-f")
    clock = SteppedClock()
    tap = FrameTap(
        channel, worker_id=1, world="wood", settings=FrameSettings(max_fps=4.0, watch_check_s=1.0), clock=clock
    )
    channel.mark_watching()
    rows = drive(tap, clock, 150)  # 10 s of env steps at real time
    assert 35 <= tap.published <= 41, tap.published  # about 4 per second, not 15
    frame = channel.latest(1)
    assert frame is not None and frame.worker_id == 1 and frame.world == "wood" and frame.seq == tap.published
    assert frame.step in {row["steps"] for row in rows[-4:]}
    last = next(row for row in rows if row["steps"] == frame.step)
    assert (frame.x_m, frame.y_m, frame.heading_deg) == (last["X"], last["Y"], last["yaw"])
    assert len(frame.trail) == frame.step and frame.trail[-1] == (last["X"], last["Y"])
    assert frame.episode_reward == frame.step
    image = cv2.imdecode(np.frombuffer(frame.jpeg, np.uint8), cv2.IMREAD_UNCHANGED)
    assert image.shape == (120, 160)
    assert link.do(lambda r: r.ttl(channel.key("frame:1"))) > 0  # a dead worker's frame goes away by itself

    # The page closes: its key goes (here: deleted rather than waiting for its TTL); within one watch check
    # the worker stops publishing.
    link.do(lambda r: r.delete(channel.key("watching")))
    published = tap.published
    drive(tap, clock, 150, first_step=151)
    assert tap.published - published <= 4


def test_a_new_episode_starts_a_new_trail_and_long_trails_are_thinned(redis_settings):
    channel = FrameChannel(RedisLink(redis_settings), "run-f")
    clock = SteppedClock()
    tap = FrameTap(channel, worker_id=0, world="base", clock=clock)
    channel.mark_watching()
    drive(tap, clock, 30)
    drive(tap, clock, 1500)  # steps restart at 1: a new episode
    frame = channel.latest(0)
    assert len(frame.trail) <= TRAIL_POINTS + 1
    assert frame.trail[0] == (0.1, 2.0)  # the second episode's first point, not the first episode's
    assert frame.trail[-1] == (frame.x_m, frame.y_m)


def test_frame_round_trip_keeps_every_field(redis_settings):
    channel = FrameChannel(RedisLink(redis_settings), "run-f")
    clock = SteppedClock()
    tap = FrameTap(channel, worker_id=2, world="carpet", clock=clock)
    tap.phase = "evaluation"
    channel.mark_watching()
    drive(tap, clock, 3)
    frame = channel.latest(2)
    assert decode_frame(encode_frame(frame)) == frame
    assert frame.phase == "evaluation" and frame.frame_id.endswith(f"-{frame.seq}")


def test_only_the_workers_on_screen_publish(redis_settings):
    channel = FrameChannel(RedisLink(redis_settings), "run-f")
    clock = SteppedClock()
    taps = {i: FrameTap(channel, worker_id=i, world="base", clock=clock) for i in (0, 1)}
    channel.mark_watching([1])  # the page shows worker 1's panel only
    assert channel.is_watched(1) and not channel.is_watched(0) and not channel.is_watched()
    for step in range(1, 46):  # 3 s at 15 steps/s, both workers
        for tap in taps.values():
            drive(tap, clock, 1, first_step=step)
        clock.now_s -= 1 / 15  # drive() advanced the clock once per tap: one step of wall time for both
    assert taps[0].published == 0 and channel.latest(0) is None
    assert 5 <= taps[1].published <= 7, taps[1].published  # 2 frames/s by default
    channel.mark_watching()  # a page that shows every worker
    assert channel.is_watched(0)
    channel.clear_watching()
    assert not channel.is_watched(0) and not channel.is_watched(1)
