"""The line as the optimiser sees it, and the search for the fastest one.

A periodic cubic spline (scipy) through control points, each offset along the centre line's normal; every station kept
inside the road shrunk by half the car's width (shapely); the offsets chosen to minimise the lap time, coarse to fine
(`CONTROL_SPACINGS_M`), each stage's controls on the line the stage before found: by scipy's SLSQP where its QP is
small, by an augmented Lagrangian (`augmented.py`) where SLSQP would take minutes (`SLSQP_MAX_SIZE`). torch's autograd
gives the exact gradient of the lap time, so an iteration costs one pass. The problem is not convex: the result is the
fastest line found, an upper estimate of the true optimum by however far the search stopped short.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.interpolate import CubicSpline
from scipy.optimize import LinearConstraint, minimize

from racer.racing_line.augmented import AugmentedLagrangianSettings, augmented_lagrangian
from racer.racing_line.limits import CarLimits, LapTimeBoundError
from racer.racing_line.speed_profile import flying_lap, lengths_of, torch_module
from racer.shared.sim.tracks.track import Track

DEFAULT_SPACING_M = 0.05
"""Distance between the stations along the centre line at which the lap time is computed."""
CONTROL_SPACINGS_M: tuple[float, ...] = (0.8, 0.4, 0.2)
"""Distances between the offsets the optimiser chooses, coarse to fine: each stage's controls sit on the line the one
before found (`LineModel.refined`), so it starts from that very line. The problem is not convex; solved at one fine spacing from the centre line, it stops in a local minimum that
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
MAX_ITERATIONS = 1000
"""Per stage: SLSQP's cap."""
FTOL_S = 1e-6
"""SLSQP stops when an iteration gains less lap time than this. At 1e-10 the search crept on for hundreds of
iterations to gain under a millisecond; at 1e-6 it takes half the time and the laps differ by at most 0.6 ms
(measured on the stages as they were before each refined its predecessor's line: re:Invent 2018 4.8821 -> 4.8822 s
flying, racer_oval 3.5280 -> 3.5286 s)."""
SLSQP_MAX_SIZE = 500_000
"""A stage whose controls × constraint rows (two per station) exceed this is solved by the augmented Lagrangian, the
rest by SLSQP. SLSQP's iteration grows with both (penbay_pro, 89 m, at 112, 223 and 446 controls with ~3,570 rows:
0.05, 0.15 and 0.53 s, later iterations more; the line took 213 s, against 57 s with the finer two here), the
augmented Lagrangian's is one gradient (12 ms at 446 controls) whatever the rows. Where SLSQP is quick it keeps the
stage: it is the reference the published bounds come from, and on racer_oval it found a line 0.01 % faster (3.5236 s
against 3.5240 s with the augmented Lagrangian on every stage). With stations 0.05 m apart a stage's size is
40 L² / its control spacing for a line L metres long: every stage of a track up to 50 m stays with SLSQP (the two
that judge the recipe are 17.7 and 33.3 m), and penbay_pro's first (0.8 m, 278 iterations in 11 s)."""
AUGMENTED_LAGRANGIAN = AugmentedLagrangianSettings(ftol_s=FTOL_S)


@dataclass(frozen=True)
class OptimiserProgress:
    """Where the search is: stage `stage` of `stages` (1-based), its iteration, the lap time of its latest line."""

    stage: int
    stages: int
    control_spacing_m: float
    iteration: int
    lap_time_s: float
    stage_done: bool


ProgressCallback = Callable[[OptimiserProgress], None]


@dataclass(frozen=True)
class LineModel:
    """One lateral offset per control point on a reference line (the centre line, or the line a coarser stage found);
    the line is the periodic cubic spline through the offset control points, sampled at stations (its curvature is the
    spline's own, so the route's waypoint noise does not reach it); each station's offset along its normal is linear in
    the controls and bounded by the road."""

    control_points: np.ndarray
    """(M, 2) points on the reference line, evenly spaced in its spline's parameter from the start line on."""
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
    def of_track(cls, track: Track, half_width_m: float, spacing_m: float, control_spacing_m: float) -> LineModel:
        """Controls on the centre line, `control_spacing_m` apart."""
        points, normals = _centre_points(track, control_spacing_m)
        return cls.on_reference(track, points, normals, half_width_m, _per_interval(spacing_m, control_spacing_m))

    def refined(self, track: Track, controls: np.ndarray, half_width_m: float, count: int, per_interval: int):
        """`count` controls on the line `controls` give: the periodic spline through this line's knots, sampled evenly
        in its parameter. With `count` a multiple of this model's, the new knots hold the old ones, so at zero controls
        the new line is this very line (a cubic spline is one on any refinement of its knots)."""
        knots = self.control_points + controls[:, None] * self.control_normals
        spline = CubicSpline(np.arange(self.controls + 1), np.vstack((knots, knots[:1])), bc_type="periodic")
        parameter = np.arange(count) * self.controls / count
        tangents = spline(parameter, 1)
        tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
        normals = np.column_stack((-tangents[:, 1], tangents[:, 0]))
        return LineModel.on_reference(track, spline(parameter), normals, half_width_m, per_interval)

    @classmethod
    def on_reference(
        cls, track: Track, points: np.ndarray, normals: np.ndarray, half_width_m: float, per_interval: int
    ) -> LineModel:
        """The model of controls at `points` moving along `normals`, `per_interval` stations between two of them."""
        count = points.shape[0]
        per_interval = max(1, per_interval)
        parameter = np.arange(count * per_interval) / per_interval
        units = CubicSpline(np.arange(count + 1), np.vstack((np.eye(count), np.eye(count)[:1])), bc_type="periodic")
        values, first = units(parameter), units(parameter, 1)
        stations = values @ points  # the zero-offset line: the reference smoothed through the control points
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

    def line(self, torch, controls):
        """(stations (K, 2), signed curvature (K,), segment lengths to the next station (K,)) for these offsets."""
        knots = torch.from_numpy(self.control_points) + controls[:, None] * torch.from_numpy(self.control_normals)
        points = torch.from_numpy(self.values) @ knots
        first = torch.from_numpy(self.first) @ knots
        second = torch.from_numpy(self.second) @ knots
        speed = torch.linalg.vector_norm(first, dim=1)
        curvature = (first[:, 0] * second[:, 1] - first[:, 1] * second[:, 0]) / speed**3
        return points, curvature, lengths_of(torch, points)


@dataclass(frozen=True)
class OptimisedLine:
    """The fastest stage's model and controls, the iterations all stages took, and the centre line's model at the
    fastest stage's control spacing (the line at zero offsets, to say what the line is worth)."""

    model: LineModel
    controls: np.ndarray
    iterations: int
    centre_model: LineModel


def optimise_line(
    track: Track,
    limits: CarLimits,
    spacing_m: float,
    control_spacings_m: tuple[float, ...],
    on_progress: ProgressCallback | None = None,
) -> OptimisedLine:
    """Run the stages coarse to fine, each from the line the one before found; the fastest stage's line wins. The
    caller holds torch to one thread (`speed_profile.one_torch_thread`)."""
    torch = torch_module()
    best: tuple[float, LineModel, np.ndarray, float] | None = None
    previous: tuple[LineModel, np.ndarray, float] | None = None
    iterations = 0
    stages = len(control_spacings_m)
    for stage, control_spacing_m in enumerate(control_spacings_m, start=1):
        if previous is None:
            model = LineModel.of_track(track, limits.half_width_m, spacing_m, control_spacing_m)
        else:
            last, controls, last_spacing_m = previous
            count = max(8, round(last.controls * last_spacing_m / control_spacing_m))
            per_interval = _per_interval(spacing_m, control_spacing_m)
            model = last.refined(track, controls, limits.half_width_m, count, per_interval)
        watch = _StageWatch(model, limits, stage, stages, control_spacing_m, on_progress)
        controls, message = _solve_stage(model, np.zeros(model.controls), watch)
        if not np.all(np.isfinite(controls)):
            raise LapTimeBoundError(
                f"track {track.name}: the line did not converge at control spacing {control_spacing_m} m "
                f"(stage {stage}/{stages}: {message})"
            )
        iterations += watch.iterations
        with torch.no_grad():
            line = model.line(torch, torch.from_numpy(controls))
            lap_time_s = float(flying_lap(torch, *line[1:], limits)[1])
        if on_progress is not None:
            on_progress(OptimiserProgress(stage, stages, control_spacing_m, watch.iterations, lap_time_s, True))
        if best is None or lap_time_s < best[0]:
            best = (lap_time_s, model, controls, control_spacing_m)
        previous = (model, controls, control_spacing_m)
    assert best is not None  # control_spacings_m is not empty: racing_line checks
    centre = LineModel.of_track(track, limits.half_width_m, spacing_m, best[3])
    return OptimisedLine(model=best[1], controls=best[2], iterations=iterations, centre_model=centre)


def _solve_stage(model: LineModel, start: np.ndarray, watch: _StageWatch) -> tuple[np.ndarray, str]:
    """(controls, the solver's message): the controls, every station's offset kept inside the road (a linear
    constraint per station), by SLSQP or, for a large stage, the augmented Lagrangian (`SLSQP_MAX_SIZE`)."""
    if model.controls * 2 * model.offset_matrix.shape[0] > SLSQP_MAX_SIZE:
        found = augmented_lagrangian(
            watch.objective,
            start,
            model.offset_matrix,
            model.offset_low,
            model.offset_high,
            AUGMENTED_LAGRANGIAN,
            watch.iteration_done,
        )
        if found.worst_violation_m > 0.0:
            return np.full_like(start, np.nan), f"augmented Lagrangian: a station {found.worst_violation_m} m outside"
        return found.controls, f"augmented Lagrangian: {found.message}"
    result = minimize(
        watch.objective,
        start,
        jac=True,
        method="SLSQP",
        constraints=[LinearConstraint(model.offset_matrix, model.offset_low, model.offset_high)],
        options={"maxiter": MAX_ITERATIONS, "ftol": FTOL_S},
        callback=watch.iteration_done,
    )
    return result.x, result.message


class _StageWatch:
    """One stage's objective for SLSQP, which remembers the latest lap time to report after each iteration."""

    def __init__(
        self,
        model: LineModel,
        limits: CarLimits,
        stage: int,
        stages: int,
        control_spacing_m: float,
        on_progress: ProgressCallback | None,
    ) -> None:
        self.model, self.limits, self.on_progress = model, limits, on_progress
        self.stage, self.stages, self.control_spacing_m = stage, stages, control_spacing_m
        self.iterations = 0
        self.lap_time_s = float("nan")

    def objective(self, controls: np.ndarray) -> tuple[float, np.ndarray]:
        value, gradient, self.lap_time_s = _objective_and_gradient(self.model, controls, self.limits)
        return value, gradient

    def iteration_done(self, _controls: np.ndarray) -> None:
        self.iterations += 1
        if self.on_progress is not None:
            self.on_progress(
                OptimiserProgress(
                    self.stage, self.stages, self.control_spacing_m, self.iterations, self.lap_time_s, False
                )
            )


def _objective_and_gradient(
    model: LineModel, controls: np.ndarray, limits: CarLimits
) -> tuple[float, np.ndarray, float]:
    """The lap time plus the steering penalty, its gradient with respect to the controls (torch's autograd), and the
    lap time alone."""
    torch = torch_module()
    variables = torch.tensor(controls, dtype=torch.float64, requires_grad=True)
    _, curvature, lengths = model.line(torch, variables)
    _, lap = flying_lap(torch, curvature, lengths, limits)
    excess = torch.clamp(curvature.abs() - limits.max_curvature_per_m, min=0.0)
    objective = lap + STEERING_PENALTY_S_M2 * (excess * excess).sum()
    objective.backward()
    return float(objective.detach()), variables.grad.numpy().copy(), float(lap.detach())


def _per_interval(spacing_m: float, control_spacing_m: float) -> int:
    """Stations between two controls."""
    return max(1, round(control_spacing_m / spacing_m))


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
