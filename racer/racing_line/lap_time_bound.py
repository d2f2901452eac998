"""The lap-time bound of a car on a track: the fastest lap the car's own limits allow, whoever drives it.

Why: a policy's best lap says little alone; against what the same car could do on the same track it says how much is
left (`python -m benchmarks race-pace` reports the ratio). The model is the textbook quasi-steady point mass on a racing line:

* **The car's limits** come from the car profile and the world (`CarLimits.of_car`), read from the car model, not
  restated: top speed = the largest command (4 m/s) × the tyres' rolling radius / the command radius; lateral
  acceleration = the weaker axle's peak grip × the world's tyre μ × g (each axle saturates at peak grip × μ × its
  static load, and in a steady turn each axle carries its share of the load); drive and brake = the drive force cap /
  the car's mass (racer's tyre model caps both alike and keeps them apart from the lateral force: no friction circle,
  `tyres.py`); curvature ≤ tan(the steering limit) / wheelbase; half a DeepRacer car's width
  (`object_poses.BOT_CAR_SIZE`, the shell) kept inside each border, so the whole car stays on the road.
* **The speed profile** along a line: v² κ ≤ a_lat and the top speed cap each point; a forward pass with the drive
  limit and a backward pass with the brake limit give the fastest speeds (in u = v² each pass is a running minimum).
* **The line**: a periodic cubic spline (scipy) through control points, each offset along the centre line's normal;
  every station kept inside the road shrunk by half the car's width (shapely); the offsets chosen by scipy's SLSQP to
  minimise the lap time, coarse to fine (`CONTROL_SPACINGS_M`). torch's autograd gives the exact gradient of the lap
  time, so an iteration costs one pass. The problem is not convex: the result is the fastest line found, an upper
  estimate of the true optimum by however far the search stopped short.

Everything the model leaves out makes the bound optimistic, as a bound should be: the steering servo's lag and the yaw
inertia (the car turns in at once), the drive's soft approach to top speed, the front tyre's drag in a turn, the 1/15 s
control period, and DeepRacer's off-track rule, which lets the car's centre go beyond the border until no wheel is on
the road (the bound keeps the whole car on it).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.interpolate import CubicSpline
from scipy.optimize import LinearConstraint, minimize

from racer.shared.sim.car import vehicle as car
from racer.shared.sim.car.dynamics import CAR_DYNAMICS, CarDynamics
from racer.shared.sim.car.tyres import GRAVITY_MPS2
from racer.shared.sim.config import STEPS_PER_SECOND
from racer.shared.sim.objects.poses import BOT_CAR_SIZE
from racer.shared.sim.scene.worlds import get_world
from racer.shared.sim.tracks.track import Track

DEFAULT_SPACING_M = 0.05
"""Distance between the stations along the centre line at which the lap time is computed."""
CONTROL_SPACINGS_M: tuple[float, ...] = (0.8, 0.4, 0.2)
"""Distances between the offsets the optimiser chooses, coarse to fine: each stage starts from the line the one before
found. The problem is not convex; solved at one fine spacing from the centre line, it stops in a local minimum that
depends on the spacing (re:Invent 2018 at 0.5, 0.4, 0.3, 0.25 m: 4.30, 4.32, 4.39, 4.35 s), where a coarse line first
places the corners and the finer stages only refine them. A spline through the controls gives every station's offset,
so each variable moves a stretch of line (offsets chosen station by station make curvature, a second difference,
ill-conditioned as 1/spacing⁴)."""
STEERING_PENALTY_S_M2 = 10.0
"""Seconds added per (1/m)² of curvature beyond the steering limit, summed over stations: the optimiser's only
constraint that is not a bound on an offset."""
BORDER_MARGIN_M = 0.005
"""Kept between the car's side and a border at every station beyond half the car's width: the line between stations
may bulge a few millimetres further out than the stations themselves."""
PREPARE_STEP_S = 1.0 / STEPS_PER_SECOND
"""An episode's first step (`prepare`) sends no command, so a standing-start lap loses one camera period."""
STANDING_START_LAPS = 3
"""DeepRacer's evaluation: three laps; driven one after another from a standing start in a continuous run."""


def profile_name(dynamics: CarDynamics) -> str:
    """The car profile's name of `dynamics` (`car_dynamics.CAR_DYNAMICS`), or "custom" for a car of no profile."""
    return next((name for name, known in CAR_DYNAMICS.items() if known == dynamics), "custom")


class LapTimeBoundError(ValueError):
    """The bound cannot be computed for this track and car; the message names the track and why."""


@dataclass(frozen=True)
class CarLimits:
    """What bounds the car's lap: speeds, accelerations, the tightest turn and its half width."""

    top_speed_mps: float
    lateral_accel_mps2: float
    drive_accel_mps2: float
    brake_accel_mps2: float
    max_curvature_per_m: float
    half_width_m: float
    car_profile: str
    """The car profile the limits were read from (`profile_name`)."""
    world: str

    @classmethod
    def of_car(
        cls, dynamics: CarDynamics, world: str = "base", top_command_mps: float = car.MAX_SPEED_MPS
    ) -> CarLimits:
        """The limits of the car with `dynamics` in `world` (its tyre μ) driven at commands up to `top_command_mps`."""
        tyres = dynamics.tyres
        mu = get_world(world).tyre_friction
        drive_accel = tyres.max_drive_force_n / car.TOTAL_MASS_KG
        return cls(
            top_speed_mps=min(top_command_mps, car.MAX_SPEED_MPS) * tyres.rolling_radius_m / car.COMMAND_WHEEL_RADIUS_M,
            lateral_accel_mps2=min(tyres.front_peak_grip, tyres.rear_peak_grip) * mu * GRAVITY_MPS2,
            drive_accel_mps2=drive_accel,
            brake_accel_mps2=drive_accel,
            max_curvature_per_m=math.tan(math.radians(car.MAX_STEERING_DEG)) / car.WHEELBASE_M,
            half_width_m=BOT_CAR_SIZE.width_m / 2.0,
            car_profile=profile_name(dynamics),
            world=world,
        )

    def summary(self) -> dict:
        return {
            "car_profile": self.car_profile,
            "world": self.world,
            "top_speed_mps": round(self.top_speed_mps, 3),
            "lateral_accel_mps2": round(self.lateral_accel_mps2, 3),
            "drive_accel_mps2": round(self.drive_accel_mps2, 3),
            "brake_accel_mps2": round(self.brake_accel_mps2, 3),
            "min_turn_radius_m": round(1.0 / self.max_curvature_per_m, 3),
            "half_width_m": round(self.half_width_m, 4),
        }


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

    @property
    def standing_average_s(self) -> float:
        """The best possible average of 3 consecutive laps from a standing start (DeepRacer's continuous evaluation)."""
        return float(np.mean(self.standing_laps_s))

    def summary(self) -> dict:
        return {
            "track": self.track,
            "flying_lap_s": round(self.lap_time_s, 3),
            "standing_start_laps_s": [round(t, 3) for t in self.standing_laps_s],
            "three_lap_average_s": round(self.standing_average_s, 3),
            "centre_line_lap_s": round(self.centre_line_lap_time_s, 3),
            "line_length_m": round(_closed_length(self.points_m), 3),
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
) -> RacingLine:
    """The fastest line found for a car with `limits` around the loop `track` (a flying lap), and its laps."""
    if not track.is_loop:
        raise LapTimeBoundError(f"track {track.name}: an open route has no lap")
    if not control_spacings_m or not 0 < spacing_m <= min(control_spacings_m):
        raise LapTimeBoundError(f"need 0 < spacing_m <= every control spacing, got {spacing_m}, {control_spacings_m}")
    torch = _torch()
    best = None
    iterations = 0
    with _one_torch_thread():  # a few hundred small tensors: more threads only contend (10x slower on 2 busy cores)
        for control_spacing_m in control_spacings_m:
            model = _LineModel.of_track(track, limits.half_width_m, spacing_m, control_spacing_m)
            start = np.zeros(model.controls) if best is None else model.offsets_of(best[1])
            result = minimize(
                lambda controls, model=model: _objective_and_gradient(model, controls, limits),
                start,
                jac=True,
                method="SLSQP",
                constraints=[LinearConstraint(model.offset_matrix, model.offset_low, model.offset_high)],
                options={"maxiter": 1000, "ftol": 1e-10},
            )
            iterations += int(result.nit)
            with torch.no_grad():
                line = model.line(torch, torch.from_numpy(result.x))
                lap_time_s = float(_flying_lap(torch, *line[1:], limits)[1])
            if best is None or lap_time_s < best[0]:
                best = (lap_time_s, line[0].numpy(), model, result.x)
        _, points, model, controls = best
        with torch.no_grad():
            line = model.line(torch, torch.from_numpy(controls))
            speeds, lap_time_s = _flying_lap(torch, *line[1:], limits)
            centre = model.line(torch, torch.zeros(model.controls, dtype=torch.float64))
            centre_lap_s = _flying_lap(torch, *centre[1:], limits)[1]
            standing = _standing_laps(torch, *line[1:], limits)
    return RacingLine(
        track=track.name,
        limits=limits,
        points_m=points,
        speeds_mps=speeds.numpy(),
        lap_time_s=float(lap_time_s),
        standing_laps_s=standing,
        centre_line_lap_time_s=float(centre_lap_s),
        min_clearance_m=_min_clearance_m(track, points, limits.half_width_m),
        max_curvature_per_m=float(line[1].abs().max()),
        optimiser_iterations=iterations,
    )


def path_speeds(points: np.ndarray, limits: CarLimits) -> tuple[np.ndarray, float]:
    """(fastest speed at each station, flying lap time) of a car with `limits` on the closed polyline `points`
    (N, 2), its curvature taken from each station and its two neighbours."""
    torch = _torch()
    with torch.no_grad():
        path = torch.from_numpy(np.asarray(points, dtype=np.float64))
        speeds, lap = _flying_lap(torch, _three_point_curvatures(torch, path), _lengths(torch, path), limits)
    return speeds.numpy(), float(lap)


def standing_start_laps(points: np.ndarray, limits: CarLimits, laps: int = STANDING_START_LAPS) -> tuple[float, ...]:
    """Lap times of `laps` laps in a row on the closed polyline `points` from rest at station 0 (see `RacingLine`)."""
    torch = _torch()
    with torch.no_grad():
        path = torch.from_numpy(np.asarray(points, dtype=np.float64))
        return _standing_laps(torch, _three_point_curvatures(torch, path), _lengths(torch, path), limits, laps)


# ---- the line and its lap time -----------------------------------------------------------------------------------


def _torch():
    """torch, imported when a bound is computed: the workers' image has no torch, and they never compute one."""
    import torch

    return torch


@contextmanager
def _one_torch_thread() -> Iterator[None]:
    torch = _torch()
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


@dataclass(frozen=True)
class _LineModel:
    """The line as the optimiser sees it: one lateral offset per control point on the centre line; the line is the
    periodic cubic spline through the offset control points, sampled at stations (its curvature is the spline's own,
    so the route's waypoint noise does not reach it); each station's offset along its normal is linear in the controls
    and bounded by the road (`of_track`)."""

    control_points: np.ndarray
    """(M, 2) points on the centre line, evenly spaced from the start line on."""
    control_normals: np.ndarray
    """(M, 2) unit normals there, to the left of the driving direction."""
    values: np.ndarray
    """(K, M) the spline's value at each station per unit control (its first and second derivatives below)."""
    first: np.ndarray
    second: np.ndarray
    offset_matrix: np.ndarray
    """(K, M) each station's offset along its own normal per unit control."""
    offset_low: np.ndarray
    offset_high: np.ndarray

    @property
    def controls(self) -> int:
        return self.control_points.shape[0]

    @classmethod
    def of_track(cls, track: Track, half_width_m: float, spacing_m: float, control_spacing_m: float) -> _LineModel:
        points, normals = _centre_points(track, control_spacing_m)
        count = points.shape[0]
        per_interval = max(1, round(control_spacing_m / spacing_m))
        parameter = np.arange(count * per_interval) / per_interval
        units = CubicSpline(np.arange(count + 1), np.vstack((np.eye(count), np.eye(count)[:1])), bc_type="periodic")
        values, first = units(parameter), units(parameter, 1)
        stations = values @ points  # the zero-offset line: the centre line smoothed through the control points
        tangents = first @ points
        tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
        station_normals = np.column_stack((-tangents[:, 1], tangents[:, 0]))
        low, high = _offset_bounds(track, stations, station_normals, half_width_m)
        return cls(
            control_points=points,
            control_normals=normals,
            values=values,
            first=first,
            second=units(parameter, 2),
            offset_matrix=values * (station_normals @ normals.T),
            offset_low=low,
            offset_high=high,
        )

    def offsets_of(self, points: np.ndarray) -> np.ndarray:
        """The controls that put the line through the closed line `points` at every control point: where each control
        normal crosses it (shapely), the crossing nearest the control point."""
        ring = shapely.LinearRing(points)
        reach = 2.0 * float(np.max(np.abs(np.concatenate((self.offset_low, self.offset_high))))) + 0.1
        ends = np.stack(
            (self.control_points - reach * self.control_normals, self.control_points + reach * self.control_normals),
            axis=1,
        )
        offsets = np.zeros(self.controls)
        for index, crossing in enumerate(shapely.intersection(shapely.linestrings(ends), ring)):
            found = shapely.get_coordinates(crossing)
            if len(found):
                nearest = found[np.argmin(np.linalg.norm(found - self.control_points[index], axis=1))]
                offsets[index] = (nearest - self.control_points[index]) @ self.control_normals[index]
        return offsets

    def line(self, torch, controls):
        """(stations (K, 2), signed curvature (K,), segment lengths to the next station (K,)) for these offsets."""
        knots = torch.from_numpy(self.control_points) + controls[:, None] * torch.from_numpy(self.control_normals)
        points = torch.from_numpy(self.values) @ knots
        first = torch.from_numpy(self.first) @ knots
        second = torch.from_numpy(self.second) @ knots
        speed = torch.linalg.vector_norm(first, dim=1)
        curvature = (first[:, 0] * second[:, 1] - first[:, 1] * second[:, 0]) / speed**3
        return points, curvature, _lengths(torch, points)


def _objective_and_gradient(model: _LineModel, controls: np.ndarray, limits: CarLimits) -> tuple[float, np.ndarray]:
    """The lap time plus the steering penalty, and its gradient with respect to the controls (torch's autograd)."""
    torch = _torch()
    variables = torch.tensor(controls, dtype=torch.float64, requires_grad=True)
    _, curvature, lengths = model.line(torch, variables)
    _, lap = _flying_lap(torch, curvature, lengths, limits)
    excess = torch.clamp(curvature.abs() - limits.max_curvature_per_m, min=0.0)
    objective = lap + STEERING_PENALTY_S_M2 * (excess * excess).sum()
    objective.backward()
    return float(objective.detach()), variables.grad.numpy().copy()


def _ceiling(torch, curvature, limits: CarLimits):
    """u = v² each station allows on its own: the grip in its curvature, the top speed."""
    floor = limits.lateral_accel_mps2 / limits.top_speed_mps**2  # below this curvature the top speed binds
    return limits.lateral_accel_mps2 / torch.clamp(curvature.abs(), min=floor)


def _lengths(torch, points):
    """Each station's distance to the next one of the closed path."""
    return torch.linalg.vector_norm(torch.roll(points, -1, dims=0) - points, dim=1)


def _three_point_curvatures(torch, points):
    """Signed curvature at each station of a closed polyline: the circle through it and its two neighbours."""
    before = points - torch.roll(points, 1, dims=0)
    after = torch.roll(points, -1, dims=0) - points
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    norm = torch.linalg.vector_norm
    return 2.0 * cross / (norm(before, dim=1) * norm(after, dim=1) * norm(before + after, dim=1))


def _forward_pass(torch, ceiling, lengths, accel_mps2: float):
    """u_i = min over j <= i of (ceiling_j + 2 a (s_i - s_j)): the fastest a car accelerating at `accel_mps2` can go
    under every earlier station's ceiling (an open path of len(lengths) + 1 stations)."""
    distance = torch.cat([torch.zeros(1, dtype=lengths.dtype), torch.cumsum(lengths, dim=0)])
    ramp = 2.0 * accel_mps2 * distance
    return ramp + torch.cummin(ceiling - ramp, dim=0).values


def _flying_lap(torch, curvature, lengths, limits: CarLimits):
    """(speeds, lap time) of the periodic speed profile of a closed path. Each pass runs over two laps, so every station
    sees a whole lap of stations before it (drive) and after it (brake); nothing further away can bind."""
    ceiling = _ceiling(torch, curvature, limits)
    n = ceiling.shape[0]
    twice = torch.cat([ceiling, ceiling, ceiling[:1]])
    twice_lengths = torch.cat([lengths, lengths])
    forward = _forward_pass(torch, twice, twice_lengths, limits.drive_accel_mps2)[n : 2 * n]
    backward = _forward_pass(torch, twice.flip(0), twice_lengths.flip(0), limits.brake_accel_mps2).flip(0)[:n]
    speeds = torch.sqrt(torch.minimum(forward, backward))
    return speeds, _segment_times(speeds, torch.roll(speeds, -1), lengths).sum()


def _standing_laps(torch, curvature, lengths, limits: CarLimits, laps: int = STANDING_START_LAPS) -> tuple[float, ...]:
    """`laps` laps in a row from rest at station 0, the first with the prepare step and shorter by the front of the
    car, as DeepRacer counts them; the car drives on after the last line (no braking for it)."""
    ceiling = _ceiling(torch, curvature, limits)
    n = ceiling.shape[0]
    path = torch.cat([ceiling.repeat(laps), ceiling[:1]])
    path[0] = 0.0  # at rest on the start line
    path_lengths = lengths.repeat(laps)
    u = torch.minimum(
        _forward_pass(torch, path, path_lengths, limits.drive_accel_mps2),
        _forward_pass(torch, path.flip(0), path_lengths.flip(0), limits.brake_accel_mps2).flip(0),
    )
    speeds = torch.sqrt(u)
    clock = np.concatenate(([0.0], np.cumsum(_segment_times(speeds[:-1], speeds[1:], path_lengths).numpy())))
    distance = np.concatenate(([0.0], np.cumsum(path_lengths.numpy())))
    lap_m = distance[n]
    # Progress is judged at the front of the car, which starts car.Car.FRONT_OF_CAR_M past the line: each line
    # crossing comes that much before the car's origin has gone round.
    crossings = np.interp(lap_m * np.arange(1, laps + 1) - car.Car.FRONT_OF_CAR_M, distance, clock)
    result = np.diff(np.concatenate(([0.0], crossings)))
    result[0] += PREPARE_STEP_S
    return tuple(float(t) for t in result)


def _segment_times(speed_from, speed_to, lengths):
    """Each segment driven at constant acceleration between its end speeds."""
    return 2.0 * lengths / (speed_from + speed_to)


# ---- the track: stations, how far each may move, and the check ---------------------------------------------------


def _centre_points(track: Track, spacing_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Points evenly spaced along a periodic cubic spline through the centre line (scipy), from the start line on, and
    their unit normals to the left of the driving direction."""
    line = track.center_line
    steps = np.linalg.norm(np.diff(line, axis=0), axis=1)
    keep = np.concatenate(([True], steps > 1e-9))  # repeated waypoints would stall the spline's parameter
    distance = np.concatenate(([0.0], np.cumsum(steps[steps > 1e-9])))
    spline = CubicSpline(distance, line[keep], bc_type="periodic")
    count = max(8, round(distance[-1] / spacing_m))
    along = np.linspace(0.0, distance[-1], count, endpoint=False)
    tangents = spline(along, 1)
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    return spline(along), np.column_stack((-tangents[:, 1], tangents[:, 0]))


def _offset_bounds(
    track: Track, centres: np.ndarray, normals: np.ndarray, half_width_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per station, the offsets along its normal that keep the whole car on the road: the piece of the normal, nearest
    to the station, inside the road shrunk by half the car's width and BORDER_MARGIN_M (shapely)."""
    inside = track.road_polygon.buffer(-(half_width_m + BORDER_MARGIN_M))
    reach = float(np.max(np.linalg.norm(track.inner_border - track.outer_border, axis=1)))
    normal_lines = shapely.linestrings(np.stack((centres - reach * normals, centres + reach * normals), axis=1))
    pieces = shapely.intersection(normal_lines, inside)
    low, high = np.empty(len(centres)), np.empty(len(centres))
    for index, piece in enumerate(pieces):
        parts = [part for part in getattr(piece, "geoms", [piece]) if not part.is_empty and part.length > 0]
        if not parts:
            raise LapTimeBoundError(
                f"track {track.name}: a car {2 * half_width_m:.3f} m wide does not fit on the road (with "
                f"{BORDER_MARGIN_M} m to each border) at ({centres[index][0]:.2f}, {centres[index][1]:.2f}) m"
            )
        centre = shapely.Point(centres[index])
        nearest = min(parts, key=centre.distance)
        offsets = (np.asarray(nearest.coords) - centres[index]) @ normals[index]
        low[index], high[index] = offsets.min(), offsets.max()
    return low, high


def _min_clearance_m(track: Track, points: np.ndarray, half_width_m: float) -> float:
    """How far the car's sides keep from the borders at the closest station, along the whole closed line (shapely):
    negative when the car (or a chord between stations) leaves the road."""
    ring = shapely.LinearRing(points)
    boundary = track.road_polygon.boundary
    if not track.road_polygon.contains(ring):
        return -float(shapely.hausdorff_distance(ring.difference(track.road_polygon), boundary)) - half_width_m
    return float(ring.distance(boundary)) - half_width_m


def _closed_length(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1).sum())
