"""Where a lap loses time against the racing line: its rows projected onto the line by distance, the lap's clock and
the line's compared over each track section and each corner.

* **Distance**: each row's X, Y (the front of the car, where progress is judged) is projected onto the closed line
  (shapely); the distance is unwrapped near the row's progress, held from going back (a put-back car waits where it
  was) and kept in [0, line length].
* **The lap's clock**: its start (its last row's time less the lap time, so DeepRacer's lap time counts whole) at
  distance 0, each row's time at its distance, its last row (the step that crossed the line) at the line's length.
  A stretch's time is the clock's difference between its ends, interpolated between rows, so the stretches of a lap
  that cover the line add up to the lap time and their losses to the lap time less the line's flying lap. The first
  stretch carries the standing start; the car starts with its front already past the line.
* **The line's clock**: its stations driven at its speed profile at constant acceleration between them, as
  racer.racing_line times them; it adds up to the line's flying lap.
* **Corners**: stretches of the line whose curvature exceeds `corner_curvature_per_m`, where the grip holds the car
  noticeably below its top speed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
import shapely

from racer.racing_line import CarLimits, RacingLine
from racer.shared.sim.config import STEPS_PER_SECOND
from racer.shared.sim.tracks.track import Track


def corner_curvature_per_m(limits: CarLimits) -> float:
    """a_lat / (v_top - a_drive / 15 Hz)²: the curvature from which the car's lateral grip (v² κ ≤ a_lat) holds it
    slower than its top speed by more than it can gain in one control period.

    At a_lat / v_top² itself the grip starts to bind, but only just: bending up to it costs no time, so the line's
    straights lie on that curvature wherever the optimiser found it free, and it would make corners of them. One
    control period's acceleration is the smallest change of speed a policy acts in; a stretch of line that slows the
    car by less is a straight to it."""
    slower_mps = limits.top_speed_mps - limits.drive_accel_mps2 / STEPS_PER_SECOND
    return limits.lateral_accel_mps2 / slower_mps**2


@dataclass(frozen=True)
class LineStations:
    """The line by distance from the start line: each station's distance, the line's clock and speed there (N + 1
    values, the last closing the loop at the line's length) and its curvature (N)."""

    line: RacingLine
    distance_m: np.ndarray
    time_s: np.ndarray
    speed_mps: np.ndarray
    curvature_per_m: np.ndarray
    ring: shapely.LineString

    @classmethod
    def of(cls, line: RacingLine) -> LineStations:
        points = np.asarray(line.points_m, dtype=float)
        closed = np.vstack((points, points[:1]))
        lengths = np.linalg.norm(np.diff(closed, axis=0), axis=1)
        speeds = np.append(line.speeds_mps, line.speeds_mps[0])
        segment_s = 2.0 * lengths / (speeds[:-1] + speeds[1:])
        return cls(
            line=line,
            distance_m=np.concatenate(([0.0], np.cumsum(lengths))),
            time_s=np.concatenate(([0.0], np.cumsum(segment_s))),
            speed_mps=speeds,
            curvature_per_m=_three_point_curvature(points),
            ring=shapely.LineString(closed),
        )

    @property
    def length_m(self) -> float:
        return float(self.distance_m[-1])

    def time_at(self, distance_m: np.ndarray | float) -> np.ndarray:
        return np.interp(distance_m, self.distance_m, self.time_s)

    def speed_at(self, distance_m: np.ndarray | float) -> np.ndarray:
        return np.interp(distance_m, self.distance_m, self.speed_mps)

    def project(self, xy: np.ndarray) -> np.ndarray:
        """Distance along the line of the nearest point to each (x, y), in [0, length)."""
        distance = shapely.line_locate_point(self.ring, shapely.points(np.asarray(xy, dtype=float)))
        return np.mod(distance, self.length_m)


def _three_point_curvature(points: np.ndarray) -> np.ndarray:
    """Signed curvature at each station of a closed polyline: the circle through it and its two neighbours."""
    before = points - np.roll(points, 1, axis=0)
    after = np.roll(points, -1, axis=0) - points
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    norms = np.linalg.norm(before, axis=1) * np.linalg.norm(after, axis=1) * np.linalg.norm(before + after, axis=1)
    return 2.0 * cross / norms


@dataclass(frozen=True)
class Stretch:
    """A piece of the line: a track section or a corner, from `start_m` to `end_m` along it (end < start: it
    runs over the start line)."""

    kind: str
    name: str
    start_m: float
    end_m: float
    description: str


def corners(stations: LineStations, threshold_per_m: float) -> list[Stretch]:
    """The line's corners: each run of stations whose |curvature| exceeds the threshold (one that runs over the
    start line is one corner), numbered from the start line, with its tightest radius, slowest speed and side."""
    bent = np.abs(stations.curvature_per_m) > threshold_per_m
    count = len(bent)
    if not bent.any():
        return []
    if bent.all():
        runs = [(0, count)]
    else:
        first_straight = int(np.argmin(bent))  # walk from a straight station so no run is cut at station 0
        order = (np.arange(count) + first_straight) % count
        runs, begin = [], None
        for position, station in enumerate(order):
            if bent[station] and begin is None:
                begin = position
            if not bent[station] and begin is not None:
                runs.append((begin + first_straight, position + first_straight))
                begin = None
        if begin is not None:
            runs.append((begin + first_straight, count + first_straight))
    found = []
    for begin, end in runs:
        stations_in = np.arange(begin, end) % count
        start_m = float(stations.distance_m[begin % count])
        end_m = float(stations.distance_m[(end - 1) % count + 1])
        peak = float(np.max(np.abs(stations.curvature_per_m[stations_in])))
        side = "left" if stations.curvature_per_m[stations_in].sum() > 0 else "right"
        slowest = float(np.min(stations.speed_mps[stations_in]))
        found.append((start_m, end_m, f"{side}, radius {1.0 / peak:.2f} m, line slowest {slowest:.2f} m/s"))
    found.sort()
    return [Stretch("corner", f"C{n}", start, end, text) for n, (start, end, text) in enumerate(found, start=1)]


def sections(track: Track, stations: LineStations, count: int) -> list[Stretch]:
    """The report's track sections (equal lengths of centre line from waypoint 0, track_sections) on the line: each
    boundary's centre-line point projected onto it; the first starts at the start line, the last ends there."""
    centre = track.center_line
    along = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(centre, axis=0), axis=1))))
    wanted = np.arange(count + 1) / count * along[-1]
    points = np.column_stack((np.interp(wanted, along, centre[:, 0]), np.interp(wanted, along, centre[:, 1])))
    bounds = _unwrap(stations.project(points), wanted / along[-1] * stations.length_m, stations.length_m)
    bounds[0], bounds[-1] = 0.0, stations.length_m
    bounds = np.maximum.accumulate(np.clip(bounds, 0.0, stations.length_m))
    waypoint = np.searchsorted(along, wanted)
    return [
        Stretch(
            "section", str(n + 1), float(bounds[n]), float(bounds[n + 1]), f"waypoints {waypoint[n]}-{waypoint[n + 1]}"
        )
        for n in range(count)
    ]


def _unwrap(distance_m: np.ndarray, expected_m: np.ndarray, length_m: float) -> np.ndarray:
    """Each distance moved by whole laps to the one nearest its expected value."""
    return distance_m + length_m * np.round((expected_m - distance_m) / length_m)


@dataclass(frozen=True)
class LapClock:
    """One lap by distance along the line: where each of its rows was, when, and how fast it went there."""

    distance_m: np.ndarray
    """Non-decreasing, from 0 (the lap's start) to the line's length (its last row)."""
    time_s: np.ndarray
    """From 0 at the lap's start to the lap time at its last row."""
    xy_m: np.ndarray
    """Each point's X, Y (the start: the lap's first row's)."""
    speed_mps: np.ndarray
    """Each point's speed (the simtrace's distance per step time; NaN at the start)."""

    @property
    def lap_time_s(self) -> float:
        return float(self.time_s[-1])

    def time_at(self, distance_m: np.ndarray | float) -> np.ndarray:
        return np.interp(distance_m, self.distance_m, self.time_s)


def lap_clock(rows: pd.DataFrame, stations: LineStations, lap_time_s: float) -> LapClock:
    """The clock of one complete lap from its simtrace rows (racer.analysis.loading columns), timed `lap_time_s`."""
    driving = rows[rows["episode_status"] != "pause"]
    xy = driving[["X", "Y"]].to_numpy(dtype=float)
    length = stations.length_m
    expected = np.clip(driving["progress"].to_numpy(dtype=float), 0.0, 100.0) / 100.0 * length
    distance = np.maximum.accumulate(_unwrap(stations.project(xy), expected, length))
    distance = np.clip(distance, 0.0, length)
    end_s = float(driving["tstamp"].iloc[-1])
    time = driving["tstamp"].to_numpy(dtype=float) - (end_s - lap_time_s)
    distance[-1], time[-1] = length, lap_time_s  # the step that crossed the line ends the lap
    return LapClock(
        distance_m=np.concatenate(([0.0], distance)),
        time_s=np.concatenate(([0.0], np.maximum(time, 0.0))),
        xy_m=np.vstack((xy[:1], xy)),
        speed_mps=np.concatenate(([np.nan], driving["speed_mps"].to_numpy(dtype=float))),
    )


def stretch_times(clock: LapClock, stations: LineStations, stretch: Stretch) -> tuple[float, float]:
    """(the lap's time, the line's time) over the stretch; one that runs over the start line is the lap's end and
    its start joined (a lap's clock restarts at the line)."""
    if stretch.end_m >= stretch.start_m:
        lap = clock.time_at(stretch.end_m) - clock.time_at(stretch.start_m)
        line = stations.time_at(stretch.end_m) - stations.time_at(stretch.start_m)
    else:
        length = stations.length_m
        lap = clock.lap_time_s - clock.time_at(stretch.start_m) + clock.time_at(stretch.end_m)
        line = stations.time_at(length) - stations.time_at(stretch.start_m) + stations.time_at(stretch.end_m)
    return float(lap), float(line)


def losses(clock: LapClock, stations: LineStations, stretches: list[Stretch]) -> pd.DataFrame:
    """One row per stretch: where it is on the line, the lap's time there, the line's, the loss (lap - line)."""
    rows = []
    for stretch in stretches:
        lap_s, line_s = stretch_times(clock, stations, stretch)
        rows.append(
            {
                "kind": stretch.kind,
                "stretch": stretch.name,
                "where": stretch.description,
                "start_m": stretch.start_m,
                "end_m": stretch.end_m,
                "lap_s": lap_s,
                "line_s": line_s,
                "loss_s": lap_s - line_s,
            }
        )
    return pd.DataFrame(rows)


def loss_per_metre(clock: LapClock, stations: LineStations) -> np.ndarray:
    """Between each pair of the lap's points: the time lost to the line there per metre of line (s/m; negative:
    faster than the line there), NaN where the lap did not move along the line."""
    moved = np.diff(clock.distance_m)
    lost = np.diff(clock.time_s) - np.diff(stations.time_at(clock.distance_m))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(moved > 1e-6, lost / moved, np.nan)
