"""Re-derive `progress` and `closest_waypoint` of real DeepRacer simtraces from their X, Y
(the geometry of deepracer-simapp v5.3.3 `bundle/markov/track_geom/`)."""

from __future__ import annotations

import csv

import pytest

from racer.shared.sim.tracks.track import Track, compute_progress

ROUND_ROBIN_ADVANCE = 0.05


def _simtraces(deepracer_data):
    folder = deepracer_data / "simtrace"
    files = sorted(folder.glob("console2022_*.csv")) + sorted(folder.glob("drfc1_*.csv"))
    assert len(files) >= 7, f"expected the console2022_* and drfc1_* simtraces in {folder}"
    return files


def _start_ndist(episode: int, training: bool) -> float:
    """Training episode e of a single worker starts at 0.05*e (accumulated as DeepRacer does); evaluation at 0."""
    start = 0.0
    if training:
        for _ in range(episode):
            start = (start + ROUND_ROBIN_ADVANCE) % 1.0
    return start


def test_progress_and_closest_waypoint_match_real_simtraces(deepracer_data):
    track = Track.load(deepracer_data / "routes" / "reinvent_base.npy")
    checked_rows = 0
    for path in _simtraces(deepracer_data):
        training = "training" in path.name
        with path.open(newline="") as handle:
            rows = list(csv.DictReader(handle))
        assert rows, path
        max_error = 0.0
        mismatches = 0
        prev_progress = 0.0
        start_ndist = 0.0
        for row in rows:
            if row["steps"] == "1.0":
                prev_progress = 0.0
                start_ndist = _start_ndist(int(row["episode"]), training)
            x, y = float(row["X"]), float(row["Y"])
            progress = compute_progress(track.project_normalized(x, y), start_ndist, prev_progress)
            max_error = max(max_error, abs(progress - float(row["progress"])))
            if track.closest_waypoint_for_simtrace(x, y) != int(row["closest_waypoint"]):
                mismatches += 1
            assert track.length_m == pytest.approx(float(row["track_len"]), abs=1e-12)
            prev_progress = 0.0 if progress == 100 else progress
            checked_rows += 1
        assert max_error <= 1e-9, f"{path.name}: max progress error {max_error}"
        assert mismatches == 0, f"{path.name}: {mismatches} closest_waypoint mismatches"
    assert checked_rows > 9000


def test_point_geometry_matches_simtrace_too(deepracer_data):
    """The env's single-pass `point_geometry` gives the same values as the individual methods."""
    track = Track.load(deepracer_data / "routes" / "reinvent_base.npy")
    path = deepracer_data / "simtrace" / "console2022_training_0-iteration.csv"
    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    for row in rows[:300]:
        x, y = float(row["X"]), float(row["Y"])
        geometry = track.point_geometry(x, y)
        assert geometry.ndist == track.project_normalized(x, y)
        assert geometry.closest_waypoint_for_simtrace == int(row["closest_waypoint"])
        assert geometry.closest_waypoints == track.closest_waypoints(x, y)
        assert geometry.distance_from_center_m == pytest.approx(track.distance_from_center(x, y), abs=1e-12)
        assert geometry.track_width_m == pytest.approx(track.track_width_at(x, y), abs=1e-12)
        assert geometry.is_left_of_center == track.is_left_of_center(x, y)


def test_wheel_geometry_reproduces_all_wheels_on_track_and_off_track(deepracer_data):
    """Wheel centres placed from X, Y, yaw with the car's geometry (flat car) give DeepRacer's on-track flags."""
    import math

    import numpy as np

    from racer.shared.sim.car import vehicle as car

    track = Track.load(deepracer_data / "routes" / "reinvent_base.npy")
    local = np.array(
        [
            [car.REAR_AXLE_X_M, car.REAR_HALF_TRACK_M],
            [car.FRONT_AXLE_X_M, car.FRONT_HALF_TRACK_M],
            [car.REAR_AXLE_X_M, -car.REAR_HALF_TRACK_M],
            [car.FRONT_AXLE_X_M, -car.FRONT_HALF_TRACK_M],
        ]
    )
    rows_checked = mismatches = off_track_rows = 0
    for path in _simtraces(deepracer_data):
        with path.open(newline="") as handle:
            for row in csv.DictReader(handle):
                yaw = math.radians(float(row["yaw"]))
                cos, sin = math.cos(yaw), math.sin(yaw)
                origin_x = float(row["X"]) - 0.14 * cos
                origin_y = float(row["Y"]) - 0.14 * sin
                inside = track.contains_points(
                    origin_x + local[:, 0] * cos - local[:, 1] * sin, origin_y + local[:, 0] * sin + local[:, 1] * cos
                )
                rows_checked += 1
                mismatches += bool(inside.all()) != (row["all_wheels_on_track"] == "True")
                if row["episode_status"] == "off_track":
                    off_track_rows += 1
                    assert not inside.any(), (path.name, row["episode"], row["steps"])
                elif row["episode_status"] == "in_progress":
                    assert inside.any(), (path.name, row["episode"], row["steps"])
    assert off_track_rows > 50
    assert mismatches <= rows_checked // 1000, f"{mismatches} all_wheels_on_track mismatches in {rows_checked} rows"


def test_reset_rules_reproduce_real_episode_statuses(deepracer_data):
    """Replaying real rows through the rule counters gives DeepRacer's status on every RUN row (training
    files and the console evaluation; DRfC's continuous evaluation reports intermediate laps as in_progress)."""
    import math

    import numpy as np

    from racer.shared.sim.car import vehicle as car
    from racer.shared.sim.episode import reset_rules as rules

    track = Track.load(deepracer_data / "routes" / "reinvent_base.npy")
    local = np.array(
        [
            [car.REAR_AXLE_X_M, car.REAR_HALF_TRACK_M],
            [car.FRONT_AXLE_X_M, car.FRONT_HALF_TRACK_M],
            [car.REAR_AXLE_X_M, -car.REAR_HALF_TRACK_M],
            [car.FRONT_AXLE_X_M, -car.FRONT_HALF_TRACK_M],
        ]
    )
    seen = set()
    for path in _simtraces(deepracer_data):
        if path.name.startswith("drfc1_evaluation"):
            continue
        counters = rules.RuleCounters(rules.RuleLimits())
        prev_progress = 0.0
        with path.open(newline="") as handle:
            for row in csv.DictReader(handle):
                yaw = math.radians(float(row["yaw"]))
                cos, sin = math.cos(yaw), math.sin(yaw)
                origin = (float(row["X"]) - 0.14 * cos, float(row["Y"]) - 0.14 * sin)
                progress = float(row["progress"])
                if row["episode_status"] == "prepare":
                    counters.clear(origin)
                    prev_progress = progress
                    continue
                inside = track.contains_points(
                    origin[0] + local[:, 0] * cos - local[:, 1] * sin, origin[1] + local[:, 0] * sin + local[:, 1] * cos
                )
                status = counters.judge(
                    progress=progress, prev_progress=prev_progress, origin=origin, any_wheel_on_track=bool(inside.any())
                )
                assert status == row["episode_status"], (path.name, row["episode"], row["steps"])
                seen.add(status)
                prev_progress = 0.0 if progress == 100 else progress
    assert seen == {"in_progress", "off_track", "lap_complete"}
