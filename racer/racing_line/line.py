"""The car's fastest line round a track (`racing_line`) and everything a user reads off it (`RacingLine`).

Everything the model leaves out makes the line's laps optimistic, a bound as a bound should be: the steering servo's
lag and the yaw inertia (the car turns in at once), the drive's soft approach to top speed, the front tyre's drag in a
turn, the 1/15 s control period, and DeepRacer's off-track rule, which lets the car's centre go beyond the border until
no wheel is on the road (the line keeps the whole car on it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from racer.racing_line.limits import CarLimits, LapTimeBoundError
from racer.racing_line.optimiser import (
    CONTROL_SPACINGS_M,
    DEFAULT_SPACING_M,
    ProgressCallback,
    optimise_line,
)
from racer.racing_line.speed_profile import (
    braking_starts,
    flying_lap,
    one_torch_thread,
    segment_times,
    standing_laps,
    torch_module,
)
from racer.shared.sim.tracks.track import Track


@dataclass(frozen=True)
class RacingLine:
    """The minimum-time line of one car on one track, and what it gives."""

    track: str
    limits: CarLimits
    points_m: np.ndarray
    """(N, 2) stations of the closed line (the last joins the first), station 0 on the start line."""
    speeds_mps: np.ndarray
    """(N,) the fastest speed at each station on a flying lap."""
    lap_time_s: float
    """A flying lap: the periodic speed profile, the car crossing the line at speed."""
    standing_laps_s: tuple[float, ...]
    """STANDING_START_LAPS consecutive laps from rest at the start line, as DeepRacer times them: the first one with the
    prepare step, and shorter by the front of the car (progress is judged there, and it starts past the line)."""
    centre_line_lap_time_s: float
    """The same car on the centre line: how much the line itself is worth."""
    min_clearance_m: float
    """Closest approach of the car's side (half its width from the line) to a border; negative: outside."""
    max_curvature_per_m: float
    optimiser_iterations: int
    curvatures_per_m: np.ndarray
    """(N,) the line's signed curvature at each station (positive: turning left), the spline's own: the speeds obey
    speed² × |curvature| ≤ the lateral limit."""

    @property
    def standing_average_s(self) -> float:
        """The best possible average of 3 consecutive laps from a standing start (DeepRacer's continuous evaluation)."""
        return float(np.mean(self.standing_laps_s))

    @property
    def segment_lengths_m(self) -> np.ndarray:
        """(N,) each station's distance to the next, the last to station 0."""
        return _closed_lengths(self.points_m)

    @property
    def length_m(self) -> float:
        return float(self.segment_lengths_m.sum())

    @property
    def distances_m(self) -> np.ndarray:
        """(N + 1,) distance along the line from station 0 to each station, and round to station 0 again."""
        return np.concatenate(([0.0], np.cumsum(self.segment_lengths_m)))

    @property
    def times_s(self) -> np.ndarray:
        """(N + 1,) time on a flying lap from station 0 to each station, and round to station 0 again (the lap)."""
        to_next = segment_times(self.speeds_mps, np.roll(self.speeds_mps, -1), self.segment_lengths_m)
        return np.concatenate(([0.0], np.cumsum(to_next)))

    @property
    def braking_indices(self) -> np.ndarray:
        """Stations where the flying lap starts to brake at the car's limit for a corner (`braking_starts`)."""
        return braking_starts(self.speeds_mps, self.segment_lengths_m, self.limits.brake_accel_mps2)

    def summary(self) -> dict:
        return {
            "track": self.track,
            "flying_lap_s": round(self.lap_time_s, 3),
            "standing_start_laps_s": [round(t, 3) for t in self.standing_laps_s],
            "three_lap_average_s": round(self.standing_average_s, 3),
            "centre_line_lap_s": round(self.centre_line_lap_time_s, 3),
            "line_length_m": round(self.length_m, 3),
            "min_speed_mps": round(float(self.speeds_mps.min()), 3),
            "min_clearance_m": round(self.min_clearance_m, 4),
            "max_curvature_per_m": round(self.max_curvature_per_m, 3),
            "optimiser_iterations": self.optimiser_iterations,
            "car": self.limits.summary(),
        }


def racing_line(
    track: Track,
    limits: CarLimits,
    spacing_m: float = DEFAULT_SPACING_M,
    control_spacings_m: tuple[float, ...] = CONTROL_SPACINGS_M,
    on_progress: ProgressCallback | None = None,
) -> RacingLine:
    """The fastest line found for a car with `limits` around the loop `track` (a flying lap), and its laps;
    `on_progress` hears each optimiser iteration and the end of each stage."""
    if not track.is_loop:
        raise LapTimeBoundError(f"track {track.name}: an open route has no lap")
    if not control_spacings_m or not 0 < spacing_m <= min(control_spacings_m):
        raise LapTimeBoundError(
            f"track {track.name}: need 0 < spacing_m <= every control spacing, got {spacing_m}, {control_spacings_m}"
        )
    torch = torch_module()
    with one_torch_thread():
        found = optimise_line(track, limits, spacing_m, control_spacings_m, on_progress)
        model = found.model
        with torch.no_grad():
            points, curvature, lengths = model.line(torch, torch.from_numpy(found.controls))
            speeds, lap_time_s = flying_lap(torch, curvature, lengths, limits)
            centre_model = found.centre_model
            centre = centre_model.line(torch, torch.zeros(centre_model.controls, dtype=torch.float64))
            centre_lap_s = flying_lap(torch, *centre[1:], limits)[1]
            standing = standing_laps(torch, curvature, lengths, limits)
    points_m = points.numpy()
    if not (np.isfinite(float(lap_time_s)) and np.all(np.isfinite(points_m))):
        raise LapTimeBoundError(f"track {track.name}: the line did not converge (its lap time is {float(lap_time_s)})")
    return RacingLine(
        track=track.name,
        limits=limits,
        points_m=points_m,
        speeds_mps=speeds.numpy(),
        lap_time_s=float(lap_time_s),
        standing_laps_s=standing,
        centre_line_lap_time_s=float(centre_lap_s),
        min_clearance_m=_min_clearance_m(track, points_m, limits.half_width_m),
        max_curvature_per_m=float(curvature.abs().max()),
        optimiser_iterations=found.iterations,
        curvatures_per_m=curvature.numpy(),
    )


def _min_clearance_m(track: Track, points: np.ndarray, half_width_m: float) -> float:
    """How far the car's sides keep from the borders at the closest station, along the whole closed line (shapely):
    negative when the car (or a chord between stations) leaves the road."""
    ring = shapely.LinearRing(points)
    boundary = track.road_polygon.boundary
    if not track.road_polygon.contains(ring):
        return -float(shapely.hausdorff_distance(ring.difference(track.road_polygon), boundary)) - half_width_m
    return float(ring.distance(boundary)) - half_width_m


def _closed_lengths(points: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
