"""`racer track line`: the car's fastest line as users get it (line.csv, line.npy, line.json, line.png), kept in racer's
cache by route, direction, car and world, and errors that name the track."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from racer.racing_line import CarLimits, LapTimeBoundError, racing_line
from racer.racing_line.cache import LineCache, cached_racing_line, line_key
from racer.racing_line.export import COLUMNS
from racer.shared.config import line_cache
from racer.shared.sim.car.dynamics import CAR_DYNAMICS
from racer.shared.sim.tracks.track import Track
from racer.track.cli import track_group

FILES = ("line.csv", "line.npy", "line.json", "line.png")


def ring_route(path, radius_m: float, width_m: float, points: int = 120):
    """A ring road's route file (counter-clockwise, the first row repeated last)."""
    angles = np.linspace(0.0, 2.0 * math.pi, points + 1)
    angles[-1] = 0.0
    circle = np.column_stack((np.cos(angles), np.sin(angles)))
    np.save(path, np.hstack((radius_m * circle, (radius_m - width_m / 2) * circle, (radius_m + width_m / 2) * circle)))
    return path


@pytest.fixture(scope="module")
def oval_line(tmp_path_factory):
    """racer_oval's line, computed once by the command, and the second run's output (from the cache)."""
    out = tmp_path_factory.mktemp("oval")
    first = CliRunner().invoke(track_group, ["line", "racer_oval", "--out", str(out)])
    assert first.exit_code == 0, first.output
    second = CliRunner().invoke(track_group, ["line", "racer_oval", "--out", str(out)])
    assert second.exit_code == 0, second.output
    return out, first.output, second.output


def test_the_files_hold_the_line_its_speeds_times_and_distances(oval_line):
    out, first, _ = oval_line
    assert all((out / name).stat().st_size > 0 for name in FILES)
    assert (out / "line.png").stat().st_size > 20_000
    header = (out / "line.csv").read_text().splitlines()[0]
    assert header.split(",") == list(COLUMNS) == ["x", "y", "speed_mps", "time_s", "curvature_per_m", "distance_m"]
    table = np.load(out / "line.npy")
    assert np.allclose(np.loadtxt(out / "line.csv", delimiter=",", skiprows=1), table, atol=1e-5)
    facts = json.loads((out / "line.json").read_text())
    x, y, speed, time_s, curvature, distance = table.T
    assert np.all(np.diff(time_s) > 0) and time_s[0] == 0.0
    assert time_s[-1] == pytest.approx(facts["flying_lap_s"], abs=1e-3)
    assert distance[-1] == pytest.approx(facts["line_length_m"], abs=1e-3)
    assert (x[0], y[0]) == (x[-1], y[-1])  # a loop: the first station repeated, as in a route file
    assert facts["lowest_speed_mps"] - 1e-3 <= speed.min() <= speed.max() <= facts["top_speed_mps"] + 1e-3
    limits = facts["car"]
    assert np.all(speed**2 * np.abs(curvature) <= limits["lateral_accel_mps2"] * (1 + 1e-6))
    assert facts["flying_lap_s"] < facts["three_lap_average_s"] < facts["centre_line_lap_s"]
    assert len(facts["standing_start_laps_s"]) == 3
    assert facts["braking_points"], "an oval brakes for each end"
    for point in facts["braking_points"]:
        later = table[np.searchsorted(distance, point["distance_m"]) + 5]
        assert later[2] < point["speed_mps"]  # the speed falls after each braking point
    assert {k: facts[k] for k in ("track", "direction", "generation", "car_profile", "world")} == {
        "track": "racer_oval",
        "direction": "counter-clockwise",
        "generation": "simapp6",
        "car_profile": "simapp6-fit",
        "world": "base",
    }
    assert len(facts["route_sha256"]) == 64
    assert "stage 3/3" in first and "computed in" in first


def test_the_second_run_reads_the_cache(oval_line):
    out, first, second = oval_line
    assert "from the cache" in second and "stage 1/3" not in second
    assert first.splitlines()[-5].split(":", 1)[1] == second.splitlines()[-5].split(":", 1)[1]  # the same laps


def test_the_cache_is_keyed_by_world_and_a_corrupt_entry_is_computed_again(tmp_path):
    track = Track.load(ring_route(tmp_path / "ring.npy", 1.5, 0.76))
    dynamics = CAR_DYNAMICS["simapp6-fit"]
    limits = CarLimits.of_car(dynamics, world="base")
    key = line_key(track, dynamics, limits, control_spacings_m=(0.8,))
    cache = LineCache(tmp_path / "lines")
    computed = cached_racing_line(track, key, cache)
    assert not computed.from_cache and computed.path.is_file()
    again = cached_racing_line(track, key, cache)
    assert again.from_cache and again.line.lap_time_s == computed.line.lap_time_s
    assert np.array_equal(again.line.points_m, computed.line.points_m)
    carpet = line_key(track, dynamics, CarLimits.of_car(dynamics, world="carpet"), control_spacings_m=(0.8,))
    assert carpet.digest != key.digest and cache.load(track.name, carpet).line is None
    wider = dataclasses.replace(dynamics, yaw_inertia_kgm2=2 * dynamics.yaw_inertia_kgm2)
    assert line_key(track, wider, limits, control_spacings_m=(0.8,)).digest != key.digest
    computed.path.write_bytes(b"not a cache entry")
    broken = cache.load(track.name, key)
    assert broken.line is None and str(computed.path) in broken.problem
    redone = cached_racing_line(track, key, cache)
    assert not redone.from_cache and redone.problem is not None
    assert redone.line.lap_time_s == pytest.approx(computed.line.lap_time_s)
    assert cache.load(track.name, key).line is not None


def test_the_cache_lives_beside_the_fetched_routes(tmp_path):
    assert line_cache({"RACER_CACHE_HOME": str(tmp_path)}) == (tmp_path / "lines").resolve()


def test_a_road_too_narrow_for_the_car_stops_with_the_track_named(tmp_path):
    narrow = ring_route(tmp_path / "narrow_ring.npy", 1.5, 0.15)
    result = CliRunner().invoke(track_group, ["line", str(narrow), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1
    assert "track narrow_ring: a car 0.196 m wide does not fit on the road" in result.output
    assert not (tmp_path / "out").exists()


def test_a_direction_the_track_does_not_offer_is_a_usage_error(tmp_path):
    result = CliRunner().invoke(track_group, ["line", "racer_oval", "--direction", "sideways", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "--direction" in result.output


def test_racing_line_names_the_track_when_the_line_cannot_be_found(tmp_path):
    track = Track.load(ring_route(tmp_path / "ring.npy", 1.5, 0.76))
    with pytest.raises(LapTimeBoundError, match="track ring: need 0 < spacing_m"):
        racing_line(track, CarLimits.of_car(CAR_DYNAMICS["simapp6-fit"]), spacing_m=1.0)
