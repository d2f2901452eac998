"""A camera frame as a worker publishes it, for tests that need one on the run's Redis without a worker."""

from __future__ import annotations

import time

import numpy as np

from racer.shared.transport.frames import Frame, FrameChannel, jpeg_bytes


def publish_frame(frames: FrameChannel, worker_id: int, seq: int, shade: int) -> Frame:
    image = np.full((120, 160), shade, dtype=np.uint8)
    frame = Frame(
        worker_id=worker_id,
        world="carpet",
        session="s1",
        seq=seq,
        time=time.time(),
        jpeg=jpeg_bytes(image),
        x_m=1.5,
        y_m=-0.5,
        heading_deg=45.0,
        trail=((1.0, -0.5), (1.5, -0.5)),
        step=seq,
        progress=12.0,
        episode_reward=3.0,
        status="in_progress",
        phase="training",
    )
    frames.publish(frame)
    return frame
