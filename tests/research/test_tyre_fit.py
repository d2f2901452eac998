"""The planar twin that fits the car's constants to real simtraces (research/tyre_fit/twin.py): it follows the
MuJoCo car, its fit recovers from wrong constants, and the held-out fit needs files to hold out."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from benchmarks.fidelity.simtrace_replay import CarReplay, load_segments
from research.tyre_fit.study import tyre_fit_command
from research.tyre_fit.twin import CarConstants, SegmentBatch, fit, loss, simulate


@pytest.fixture(scope="module")
def segments(deepracer_data):
    return load_segments([deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"])[:6]


def test_the_planar_twin_follows_the_mujoco_car(deepracer_data, segments):
    """The fit's twin and the MuJoCo car with the same constants end up within a few cm of each other."""
    batch = SegmentBatch.of(segments)
    xs, ys, yaws = simulate(batch, CarConstants())
    replay = CarReplay(deepracer_data / "routes" / "reinvent_base.npy")
    try:
        gaps, yaw_gaps = [], []
        for index, segment in enumerate(segments):
            points, yaw = replay.run(segment)
            k = int(np.argmin(np.abs(segment.times_s[2:] - segment.times_s[2] - 1.0)))
            gaps.append(math.hypot(points[k, 0] - xs[index, k], points[k, 1] - ys[index, k]))
            yaw_gaps.append(abs(math.remainder(yaw[k] - yaws[index, k], 2 * math.pi)))
            # Both move: the gap is small against the distance driven.
            assert math.dist(points[k], points[0]) > 0.5
    finally:
        replay.close()
    assert max(gaps) < 0.04, gaps
    assert math.degrees(max(yaw_gaps)) < 3.0, yaw_gaps


def test_fit_recovers_from_wrong_constants(segments):
    batch = SegmentBatch.of(segments)
    wrong = replace(CarConstants(), yaw_inertia_kgm2=0.08, steering_time_constant_s=0.2)
    fitted = fit(batch, start=wrong, evaluations=80)
    assert loss(batch, fitted) < 0.8 * loss(batch, wrong)
    assert fitted.tyres.min_slip_speed_mps == wrong.tyres.min_slip_speed_mps  # a numerical guard, never fitted


def test_leave_one_file_out_needs_two_files(deepracer_data):
    path = deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"
    route = deepracer_data / "routes" / "reinvent_base.npy"
    result = CliRunner().invoke(
        tyre_fit_command, ["--simtraces", str(path), "--route", str(route), "--fit", "leave-one-file-out"]
    )
    assert result.exit_code != 0
    assert "at least two files" in result.output and path.name in result.output
