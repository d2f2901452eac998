"""`python -m benchmarks fidelity`: the open-loop replay of real simtraces (the accuracy figures are a benchmark, in the README)."""

from __future__ import annotations

import json
import math

import click
import numpy as np
import pytest
from click.testing import CliRunner

from benchmarks.fidelity.simtrace_replay import (
    HORIZONS_S,
    CarReplay,
    fidelity_bench_command,
    files_on_route,
    load_segments,
    replay_files,
    segment_errors,
)


def test_segments_follow_the_simapps_timing(deepracer_data):
    path = deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"
    segments = load_segments([path])
    assert len(segments) >= 5
    for segment in segments:
        span = segment.times_s[-1] - segment.times_s[2]
        assert 2.0 <= span < 2.1  # from the start pose to the last compared pose: 2 s of logged steps
        assert np.all(np.diff(segment.times_s) > 0.02)
        assert 0.0 <= segment.start_speed_mps < 3.0


def test_rows_are_replayed_for_the_nominal_step(deepracer_data):
    segment = load_segments([deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"])[0]
    assert np.diff(segment.replay_times_s) == pytest.approx(np.full(len(segment.times_s) - 1, 1 / 15))
    assert segment.replay_times_s[0] == segment.times_s[0]
    assert not np.allclose(np.diff(segment.times_s), 1 / 15, atol=1e-3)  # the logged steps jitter


def test_the_replay_starts_on_the_logged_pose_and_stays_near_it(deepracer_data):
    path = deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"
    segments = load_segments([path])
    replay = CarReplay(deepracer_data / "routes" / "reinvent_base.npy")
    try:
        first_errors, one_second = [], []
        for segment in segments:
            points, yaws = replay.run(segment)
            assert len(points) == len(segment.times_s) - 2
            first_errors.append(math.hypot(*(points[0] - segment.model_xy[2])))
            k = int(np.argmin(np.abs(segment.times_s[2:] - segment.times_s[2] - 1.0)))
            one_second.append(math.hypot(*(points[k] - segment.model_xy[2 + k])))
    finally:
        replay.close()
    assert max(first_errors) < 2e-3
    # README: 8-10 cm medians per band with the tyre model (this file: ≈ 10 cm; the sphere-tyre car missed by 24 cm).
    assert float(np.median(one_second)) < 0.13


def test_error_split_adds_up_and_says_which_way(deepracer_data):
    path = deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"
    segment = load_segments([path])[0]
    replay = CarReplay(deepracer_data / "routes" / "reinvent_base.npy")
    try:
        points, yaws = replay.run(segment)
    finally:
        replay.close()
    error = segment_errors(segment, points, yaws)
    for horizon in HORIZONS_S:
        assert math.isclose(
            math.hypot(error.along_track_m[horizon], error.cross_track_m[horizon]),
            error.position_m[horizon],
            rel_tol=1e-9,
            abs_tol=1e-12,
        )
    # A prediction that stands still at the start pose is behind the real car and has turned less than it.
    k = int(np.argmin(np.abs(segment.times_s[2:] - segment.times_s[2] - 1.0)))
    logged_turn = abs(math.degrees(np.unwrap(segment.yaw_rad)[2 + k] - segment.yaw_rad[2]))
    still = segment_errors(
        segment, np.repeat(segment.model_xy[2:3], len(points), axis=0), np.full(len(yaws), segment.yaw_rad[2])
    )
    assert still.along_track_m[1.0] < -0.3
    assert math.isclose(still.turn_deg[1.0], -logged_turn, abs_tol=1e-9)


def test_bench_prints_one_json_line_with_every_band(deepracer_data):
    result = CliRunner().invoke(
        fidelity_bench_command,
        [
            "--simtraces",
            str(deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"),
            "--route",
            str(deepracer_data / "routes" / "reinvent_base.npy"),
        ],
    )
    assert result.exit_code == 0, result.output
    numbers = json.loads(result.stdout.strip().splitlines()[-1])
    assert numbers["files"] == 1 and numbers["segments"] >= 5
    assert len(numbers["bands"]) == 4
    populated = [band for band in numbers["bands"].values() if band["segments"]]
    assert populated
    for band in populated:
        for key in (
            "position_m_1s_median",
            "position_m_1s_p90",
            "heading_deg_2s_median",
            "heading_deg_2s_p90",
            "cross_track_m_1s_median_abs",
        ):
            assert math.isfinite(band[key]) and band[key] >= 0
        assert band["position_m_1s_median"] <= band["position_m_1s_p90"]
        assert abs(band["along_track_m_1s_median"]) <= band["position_m_1s_p90"]
        assert math.isfinite(band["turn_deg_2s_median"])
    assert isinstance(numbers["goal_median_position_1s_le_0_05_m"], bool)
    assert numbers["car"] == "simtrace-fit"


def test_files_of_another_track_are_left_out_and_named(deepracer_data, capsys):
    """The test data's simtraces include DeepRacer on AWS runs on Spain_track: replayed on re:Invent 2018's floor they
    would compare nothing, so the bench keeps only the files whose logged track length is the route's."""
    folder, route = deepracer_data / "simtrace", deepracer_data / "routes" / "reinvent_base.npy"
    kept = replay_files(folder, route)
    assert kept and all(path.name.startswith(("console2022_", "drfc")) for path in kept)
    assert "droa2026_spain_evaluation_0-iteration.csv" in capsys.readouterr().err
    spain = folder / "droa2026_spain_evaluation_0-iteration.csv"
    assert files_on_route([spain, kept[0]], route) == ([kept[0]], [spain])
    with pytest.raises(click.ClickException, match="was driven on"):
        replay_files(spain, route)


def test_a_generation_replays_its_own_car_and_car_replaces_it(deepracer_data, monkeypatch):
    """`--generation simapp6` replays the simapp6 car; `--car` beside it wins; neither: the simtrace fit."""
    from benchmarks.fidelity import simtrace_replay

    replayed = []
    monkeypatch.setattr(simtrace_replay, "run_fidelity", lambda files, route, progress, car: replayed.append(car) or {})
    base = ["--simtraces", str(deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv")]
    base += ["--route", str(deepracer_data / "routes" / "reinvent_base.npy")]
    for extra in (["--generation", "simapp6"], ["--generation", "simapp6", "--car", "gazebo"], []):
        result = CliRunner().invoke(fidelity_bench_command, [*base, *extra])
        assert result.exit_code == 0, result.output
    assert replayed == ["simapp6-fit", "gazebo", "simtrace-fit"]
