"""How predictable the real heading is: a yardstick for `python -m benchmarks fidelity`'s heading errors.

A linear predictor of each segment's heading change over 1 s from the logged steering commands (times the start
speed) and the logged start yaw rate, fitted by least squares on the other files' segments (leave one file out, so
it never sees the segment it predicts). Its error is what a car model fitted to these logs could hope for; a car
model far above it has the wrong structure, one near it is limited by the logs themselves.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from benchmarks.fidelity.simtrace_replay import Segment

COMMAND_ROWS = 18
"""Commands of rows start-2 .. start+15 (1 s is 14-18 rows of 55-75 ms); shorter segments are zero-padded."""


def _features_and_turn(segment: Segment, horizon_s: float) -> tuple[np.ndarray, float]:
    times = segment.times_s[2:]
    k = int(np.argmin(np.abs(times - times[0] - horizon_s)))
    _, _, _, vx, vy, yaw_rate = segment.start_state()
    steer = np.radians(segment.steer_deg[: 2 + k])[:COMMAND_ROWS]
    steer = np.pad(steer, (0, COMMAND_ROWS - len(steer)))
    features = np.concatenate([steer * math.hypot(vx, vy), [yaw_rate, 1.0]])
    yaw = np.unwrap(segment.yaw_rad)
    return features, float(yaw[2 + k] - yaw[2])


def heading_floor_deg(segments: Sequence[Segment], horizon_s: float = 1.0) -> list[float | None]:
    """Per segment, the leave-one-file-out predictor's absolute heading-change error in degrees (None when its
    file is the only one: nothing to fit on)."""
    if not segments:
        return []
    rows = [_features_and_turn(segment, horizon_s) for segment in segments]
    features = np.stack([f for f, _ in rows])
    turns = np.array([t for _, t in rows])
    sources = np.array([segment.source for segment in segments])
    errors: list[float | None] = [None] * len(segments)
    for source in np.unique(sources):
        held_out = sources == source
        if held_out.all():
            continue
        weights, *_ = np.linalg.lstsq(features[~held_out], turns[~held_out], rcond=None)
        for index in np.flatnonzero(held_out):
            errors[index] = abs(math.degrees(float(features[index] @ weights - turns[index])))
    return errors
