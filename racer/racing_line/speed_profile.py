"""The fastest speeds along a line: the textbook quasi-steady point mass.

v² κ ≤ a_lat and the top speed cap each station; a forward pass with the drive limit and a backward pass with the brake
limit give the fastest speeds (in u = v² each pass is a running minimum). The passes are written in torch so the
optimiser gets the exact gradient of the lap time (`optimiser.py`); the same functions, without a gradient, give a
finished line's speeds, station times and laps from rest.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

from racer.racing_line.limits import CarLimits, LapTimeBoundError
from racer.shared.sim.car import vehicle as car
from racer.shared.sim.config import STEPS_PER_SECOND

PREPARE_STEP_S = 1.0 / STEPS_PER_SECOND
"""An episode's first step (`prepare`) sends no command, so a standing-start lap loses one camera period."""
STANDING_START_LAPS = 3
"""DeepRacer's evaluation: three laps; driven one after another from a standing start in a continuous run."""
BRAKING_TOLERANCE = 1e-3
"""A segment brakes at the car's limit when its drop in v² is this close (relative) to the limit's over its length."""
MIN_BRAKING_DROP_MPS = 0.1
"""A slowing that sheds less speed than this is no braking point worth marking (a lift between two bends)."""
SPEED_RISE_MPS = 0.01
"""A segment gaining more speed than this ends a slowing (less: the spline's curvature wobbling in a bend)."""


def torch_module():
    """torch, imported when a line is computed (its autograd gives the lap time's gradient). The worker image has no
    torch: there a line cannot be computed, and what asks for one (racer analyze, the viewer) says so and goes on."""
    try:
        import torch
    except ModuleNotFoundError as error:
        raise LapTimeBoundError(
            "computing the racing line needs torch, which this installation lacks (the worker image has none; "
            "the trainer image and a pip install of racer have it)"
        ) from error
    return torch


@contextmanager
def one_torch_thread() -> Iterator[None]:
    """A few hundred small tensors: more threads only contend (10x slower on 2 busy cores)."""
    torch = torch_module()
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


def path_speeds(points: np.ndarray, limits: CarLimits) -> tuple[np.ndarray, float]:
    """(fastest speed at each station, flying lap time) of a car with `limits` on the closed polyline `points`
    (N, 2), its curvature taken from each station and its two neighbours."""
    torch = torch_module()
    with torch.no_grad():
        path = torch.from_numpy(np.asarray(points, dtype=np.float64))
        speeds, lap = flying_lap(torch, three_point_curvatures(torch, path), lengths_of(torch, path), limits)
    return speeds.numpy(), float(lap)


def standing_start_laps(points: np.ndarray, limits: CarLimits, laps: int = STANDING_START_LAPS) -> tuple[float, ...]:
    """Lap times of `laps` laps in a row on the closed polyline `points` from rest at station 0 (see `RacingLine`)."""
    torch = torch_module()
    with torch.no_grad():
        path = torch.from_numpy(np.asarray(points, dtype=np.float64))
        return standing_laps(torch, three_point_curvatures(torch, path), lengths_of(torch, path), limits, laps)


def ceiling(torch, curvature, limits: CarLimits):
    """u = v² each station allows on its own: the grip in its curvature, the top speed."""
    floor = limits.lateral_accel_mps2 / limits.top_speed_mps**2  # below this curvature the top speed binds
    return limits.lateral_accel_mps2 / torch.clamp(curvature.abs(), min=floor)


def lengths_of(torch, points):
    """Each station's distance to the next one of the closed path."""
    return torch.linalg.vector_norm(torch.roll(points, -1, dims=0) - points, dim=1)


def three_point_curvatures(torch, points):
    """Signed curvature at each station of a closed polyline: the circle through it and its two neighbours."""
    before = points - torch.roll(points, 1, dims=0)
    after = torch.roll(points, -1, dims=0) - points
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    norm = torch.linalg.vector_norm
    return 2.0 * cross / (norm(before, dim=1) * norm(after, dim=1) * norm(before + after, dim=1))


def _forward_pass(torch, ceiling_u, lengths, accel_mps2: float):
    """u_i = min over j <= i of (ceiling_j + 2 a (s_i - s_j)): the fastest a car accelerating at `accel_mps2` can go
    under every earlier station's ceiling (an open path of len(lengths) + 1 stations)."""
    distance = torch.cat([torch.zeros(1, dtype=lengths.dtype), torch.cumsum(lengths, dim=0)])
    ramp = 2.0 * accel_mps2 * distance
    return ramp + torch.cummin(ceiling_u - ramp, dim=0).values


def flying_lap(torch, curvature, lengths, limits: CarLimits):
    """(speeds, lap time) of the periodic speed profile of a closed path. Each pass runs over two laps, so every station
    sees a whole lap of stations before it (drive) and after it (brake); nothing further away can bind."""
    ceiling_u = ceiling(torch, curvature, limits)
    n = ceiling_u.shape[0]
    twice = torch.cat([ceiling_u, ceiling_u, ceiling_u[:1]])
    twice_lengths = torch.cat([lengths, lengths])
    forward = _forward_pass(torch, twice, twice_lengths, limits.drive_accel_mps2)[n : 2 * n]
    backward = _forward_pass(torch, twice.flip(0), twice_lengths.flip(0), limits.brake_accel_mps2).flip(0)[:n]
    speeds = torch.sqrt(torch.minimum(forward, backward))
    return speeds, segment_times(speeds, torch.roll(speeds, -1), lengths).sum()


def standing_laps(torch, curvature, lengths, limits: CarLimits, laps: int = STANDING_START_LAPS) -> tuple[float, ...]:
    """`laps` laps in a row from rest at station 0, the first with the prepare step and shorter by the front of the
    car, as DeepRacer counts them; the car drives on after the last line (no braking for it)."""
    ceiling_u = ceiling(torch, curvature, limits)
    n = ceiling_u.shape[0]
    path = torch.cat([ceiling_u.repeat(laps), ceiling_u[:1]])
    path[0] = 0.0  # at rest on the start line
    path_lengths = lengths.repeat(laps)
    u = torch.minimum(
        _forward_pass(torch, path, path_lengths, limits.drive_accel_mps2),
        _forward_pass(torch, path.flip(0), path_lengths.flip(0), limits.brake_accel_mps2).flip(0),
    )
    speeds = torch.sqrt(u)
    clock = np.concatenate(([0.0], np.cumsum(segment_times(speeds[:-1], speeds[1:], path_lengths).numpy())))
    distance = np.concatenate(([0.0], np.cumsum(path_lengths.numpy())))
    lap_m = distance[n]
    # Progress is judged at the front of the car, which starts car.Car.FRONT_OF_CAR_M past the line: each line
    # crossing comes that much before the car's origin has gone round.
    crossings = np.interp(lap_m * np.arange(1, laps + 1) - car.Car.FRONT_OF_CAR_M, distance, clock)
    result = np.diff(np.concatenate(([0.0], crossings)))
    result[0] += PREPARE_STEP_S
    return tuple(float(t) for t in result)


def segment_times(speed_from, speed_to, lengths):
    """Each segment driven at constant acceleration between its end speeds."""
    return 2.0 * lengths / (speed_from + speed_to)


def braking_starts(speeds_mps: np.ndarray, lengths_m: np.ndarray, brake_accel_mps2: float) -> np.ndarray:
    """Stations of a closed line's flying lap where the car starts to slow for a corner. Along each run of segments
    where the speed does not rise (by more than SPEED_RISE_MPS) and that brakes at the car's limit somewhere (a run that
    only follows a tightening bend is no braking): the start of the slowing that leads into its first braking segment,
    if the run sheds at least MIN_BRAKING_DROP_MPS."""
    u = speeds_mps**2
    after = np.roll(u, -1)
    n = len(u)
    brakes = u - after >= 2.0 * brake_accel_mps2 * lengths_m * (1.0 - BRAKING_TOLERANCE)
    slows = np.roll(speeds_mps, -1) < speeds_mps - SPEED_RISE_MPS / 10.0
    rises = np.roll(speeds_mps, -1) > speeds_mps + SPEED_RISE_MPS
    if not rises.any() or not brakes.any():
        return np.zeros(0, dtype=int)
    starts = []
    first_rise = int(np.flatnonzero(rises)[0])
    segment = first_rise + 1  # walk one lap from just after a rise, so no run is cut by the lap's start
    while segment <= first_rise + n:
        index = segment % n
        if not slows[index]:
            segment += 1
            continue
        end, first_brake = segment, None  # a run: from its first slowing segment to the next rise
        while end <= first_rise + n and not rises[end % n]:
            if first_brake is None and brakes[end % n]:
                first_brake = end
            end += 1
        if first_brake is not None:
            start = first_brake  # back from the first braking segment over the slowing ones just before it
            while start > segment and slows[(start - 1) % n]:
                start -= 1
            if speeds_mps[start % n] - speeds_mps[end % n] >= MIN_BRAKING_DROP_MPS:
                starts.append(start % n)
        segment = end
    return np.asarray(sorted(starts), dtype=int)
