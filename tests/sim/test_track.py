"""Track geometry against shapely (DeepRacer's own definitions) and route-file validation."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import LinearRing, LineString, Point, Polygon

from racer.shared.sim.tracks.track import Track, TrackError, compute_progress


def _routes(deepracer_data):
    routes = sorted((deepracer_data / "routes").glob("*.npy"))
    assert len(routes) >= 9
    return routes


def _shapely_reference(track: Track):
    line_cls = LinearRing if track.is_loop else LineString
    center = line_cls(track.center_line)
    inner = line_cls(track.inner_border)
    outer = line_cls(track.outer_border)
    return center, inner, outer


def test_projection_matches_shapely_on_every_real_route(deepracer_data):
    rng = np.random.default_rng(7)
    for path in _routes(deepracer_data):
        for track in (Track.load(path), Track.load(path).reversed()):
            center, inner, outer = _shapely_reference(track)
            assert track.length_m == center.length
            lo = track.waypoints.min(axis=0)[:2] - 1.0
            hi = track.waypoints.max(axis=0)[:2] + 1.0
            for x, y in rng.uniform(lo, hi, size=(150, 2)):
                p = Point(x, y)
                assert abs(track.project_normalized(x, y) - center.project(p, normalized=True)) <= 1e-12
                assert abs(track.distance_from_center(x, y) - center.distance(p)) <= 1e-12
                near = center.interpolate(center.project(p))
                near_in = inner.interpolate(inner.project(near))
                near_out = outer.interpolate(outer.project(near))
                assert abs(track.track_width_at(x, y) - near_in.distance(near_out)) <= 1e-9
                d_in, d_out = p.distance(near_in), p.distance(near_out)
                if abs(d_in - d_out) > 1e-9:
                    assert track.is_left_of_center(x, y) == ((d_in < d_out) ^ (not track.is_ccw))


def test_contains_is_strict_polygon_containment(deepracer_data):
    track = Track.load(deepracer_data / "routes" / "reinvent_base.npy")
    polygon = Polygon(track.outer_border, [track.inner_border])
    rng = np.random.default_rng(3)
    inside = 0
    for x, y in rng.uniform(-1, 9, size=(500, 2)):
        expected = polygon.contains(Point(x, y))
        inside += expected
        assert track.contains(x, y) == expected
    assert inside > 20
    # A point exactly on the border is not contained (strict).
    bx, by = track.outer_border[5]
    assert not track.contains(bx, by)


def test_open_track_uses_linestring_and_outer_plus_flipped_inner(deepracer_data):
    track = Track.load(deepracer_data / "routes" / "Straight_track.npy")
    assert not track.is_loop
    assert track.length_m == pytest.approx(LineString(track.center_line).length, abs=1e-12)
    x, y = track.center_line[3]
    assert track.contains(x, y)
    assert track.closest_waypoints(*track.center_line[-1]) == (len(track.center_line) - 1, 0)


def test_is_left_of_center_on_an_open_route_follows_the_simapp(deepracer_data):
    """track_data.py: an open route is counter-clockwise forward (is_ccw = True XOR reverse_dir), so a point on the
    driver's left is left of centre in both directions (the ring orientation of a line that is no ring is not used)."""
    forward = Track.load(deepracer_data / "routes" / "Straight_track.npy")
    assert not forward.is_loop
    for track in (forward, forward.reversed()):
        assert track.is_ccw == (not track.direction_reversed)
        center, inner, outer = _shapely_reference(track)
        for i in range(1, track.num_waypoints - 1, 3):
            (x0, y0), (x1, y1) = track.center_line[i], track.center_line[i + 1]
            heading = np.array([x1 - x0, y1 - y0]) / np.hypot(x1 - x0, y1 - y0)
            left = np.array([-heading[1], heading[0]])
            for side, expected in ((left, True), (-left, False)):
                x, y = track.center_line[i] + 0.5 * heading * np.hypot(x1 - x0, y1 - y0) + 0.1 * side
                assert track.is_left_of_center(x, y) is expected, (track, i, expected)
                assert track.point_geometry(x, y).is_left_of_center is expected
                # The SimApp's own formula with its open-route orientation.
                p = Point(x, y)
                near = center.interpolate(center.project(p))
                d_in = p.distance(inner.interpolate(inner.project(near)))
                d_out = p.distance(outer.interpolate(outer.project(near)))
                assert ((d_in < d_out) ^ track.direction_reversed) is expected


def test_closest_waypoints_bracket_the_projection(deepracer_data):
    track = Track.load(deepracer_data / "routes" / "reinvent_base.npy")
    n = track.num_waypoints
    assert track.closest_waypoints(*track.center_line[0]) == (0, 1)
    mid = (track.center_line[10] + track.center_line[11]) / 2
    assert track.closest_waypoints(*mid) == (10, 11)
    last = track.center_line[n - 2] * 0.3 + track.center_line[n - 1] * 0.7
    assert track.closest_waypoints(*last) == (n - 2, n - 1)
    assert track.closest_waypoint_for_simtrace(*last) == n - 1


def test_reversed_track_flips_rows_direction_and_orientation(deepracer_data):
    track = Track.load(deepracer_data / "routes" / "reinvent_base.npy")
    back = track.reversed()
    assert np.array_equal(back.waypoints, track.waypoints[::-1])
    assert back.is_ccw != track.is_ccw
    assert back.direction_reversed and not track.direction_reversed
    assert back.length_m == pytest.approx(track.length_m, abs=1e-9)
    x, y = track.center_line[20] + 0.1 * (track.inner_border[20] - track.center_line[20])
    assert track.is_left_of_center(x, y) != back.is_left_of_center(x, y)
    assert back.reversed().is_ccw == track.is_ccw


def test_duplicate_consecutive_rows_are_dropped(deepracer_data):
    raw = np.load(deepracer_data / "routes" / "Oval_track.npy")
    track = Track.load(deepracer_data / "routes" / "Oval_track.npy")
    assert track.num_waypoints == len(raw) - 1
    assert track.is_loop


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (np.zeros((5, 4)), "shape"),
        (np.array([[0.0, 0, 0, 1, 0, -1]] * 2 + [[np.nan, 0, 0, 1, 0, -1]]), "NaN"),
        (np.array(["a", "b"]), "shape"),
        (np.array([[0.0, 0, 0, 1, 0, -1], [1.0, 0, 1, 1, 1, -1], [0.0, 0, 0, 1, 0, -1]]), "at least 4"),
    ],
)
def test_malformed_route_files_name_the_file(tmp_path, content, message):
    path = tmp_path / "bad_route.npy"
    np.save(path, content)
    with pytest.raises(TrackError, match=message) as info:
        Track.load(path)
    assert "bad_route.npy" in str(info.value)


def test_unknown_name_and_garbage_file(tmp_path):
    with pytest.raises(TrackError, match="no track named 'nope'"):
        Track.load("nope", tracks_dir=tmp_path)
    garbage = tmp_path / "garbage.npy"
    garbage.write_bytes(b"not numpy at all")
    with pytest.raises(TrackError, match="garbage.npy"):
        Track.load(garbage)


def test_compute_progress_wrap_rules():
    # Plain progress from the start position.
    assert compute_progress(0.30, 0.25, 0.0) == pytest.approx(5.0)
    # Just behind the start line at the start: wraps to ~100 then is pulled back (crossed backwards).
    assert compute_progress(0.24, 0.25, 0.5) == pytest.approx(-1.0)
    # Crossing the line forwards after a lap: capped at 100.
    assert compute_progress(0.26, 0.25, 99.0) == 100
    # Start position beyond 0: passing ndist 1 -> 0 keeps counting.
    assert compute_progress(0.02, 0.95, 6.0) == pytest.approx(7.0)
