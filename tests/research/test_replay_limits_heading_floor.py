"""The heading yardstick of `python -m benchmarks fidelity` (research/replay_limits): a leave-one-file-out linear predictor on real simtraces."""

from __future__ import annotations

import math

import numpy as np

from benchmarks.fidelity.simtrace_replay import load_segments
from research.replay_limits.heading_floor import heading_floor_deg


def test_one_file_has_nothing_to_fit_on(deepracer_data):
    segments = load_segments([deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"])
    assert segments and heading_floor_deg(segments) == [None] * len(segments)


def test_predictor_fitted_on_other_files_beats_driving_straight(deepracer_data):
    folder = deepracer_data / "simtrace"
    segments = load_segments(
        [
            folder / "drfc1_evaluation_0-iteration.csv",
            folder / "console2022_evaluation_0-iteration.csv",
            folder / "drfc1_training_26-iteration.csv",
        ]
    )
    floor = heading_floor_deg(segments)
    assert all(error is not None and math.isfinite(error) for error in floor)
    straight = []
    for segment in segments:
        k = int(np.argmin(np.abs(segment.times_s[2:] - segment.times_s[2] - 1.0)))
        yaw = np.unwrap(segment.yaw_rad)
        straight.append(abs(math.degrees(yaw[2 + k] - yaw[2])))
    # Real cars turn with their commands: predicting from them must beat predicting no turn at all, by far.
    assert float(np.median(floor)) < 0.5 * float(np.median(straight))
