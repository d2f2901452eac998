"""What the racing line asks of the car, station by station and step by step: ground speed, commanded speed, lateral
acceleration and the steering that holds it.

The line is the lap-time bound's (`racer.racing_line`); its speeds are not. The bound drives a point mass at the
tyres' peak grip, which racer's tanh tyre reaches only at an infinite slip angle, and it turns in at once. The recipe
holds the line at a lateral acceleration its tyres reach at a finite slip with grip left to steer with (`HELD_SLIP`),
asks for each speed a drive response ahead of where it is needed (`command_lead_s`), and steers with the slip the
tyres need (`steady_steering_deg`): a car with a soft front axle needs more steering than the wheelbase alone gives.
docs/racing.md says why each rule is what it is.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from racer.racing_line import CarLimits, RacingLine, path_speeds, standing_start_laps
from racer.shared.sim.car import vehicle as car
from racer.shared.sim.car.dynamics import CarDynamics
from racer.shared.sim.car.tyres import GRAVITY_MPS2
from racer.shared.sim.config import STEPS_PER_SECOND
from racer.shared.sim.scene.worlds import get_world

STEP_S = 1.0 / STEPS_PER_SECOND
"""DeepRacer's control period: one action per camera frame."""
HELD_SLIP = 1.0
"""The weaker axle's slip at the held lateral acceleration, in units of its linear region's end (peak force /
cornering stiffness): racer's tyre gives tanh(1) = 76 % of its peak there. Beyond it the force barely answers the
steering (its slope, sech², is 0.42 of the cornering stiffness at 1 and 0.07 at 2): the margin is what the car has
left to start and stop its yaw, which the bound leaves out (the servo's lag, the yaw inertia)."""
FRONT_SHARE = -car.REAR_AXLE_X_M / car.WHEELBASE_M
"""The front axle's share of the weight: the chassis' centre of mass is at its origin (`vehicle.car_mjcf`)."""


@dataclass(frozen=True)
class LineNeeds:
    """The line's stations (the bound's points) with what the recipe asks at each."""

    track: str
    points_m: np.ndarray
    """(N, 2) the bound's closed line, station 0 on the start line."""
    speeds_mps: np.ndarray
    """(N,) ground speed on a flying lap at the held lateral acceleration."""
    commands_mps: np.ndarray
    """(N,) the speed to command at each station: the slowest held speed within `command_lead_s` ahead, in
    command units (÷ the car's rolling ratio)."""
    lateral_accel_mps2: np.ndarray
    """(N,) signed (left +) v² κ at the held speed."""
    steering_deg: np.ndarray
    """(N,) the steady steering of that turn at that speed (`steady_steering_deg`), clipped to the car's lock."""
    times_s: np.ndarray
    """(N,) when a flying lap at the held speeds passes each station."""
    lap_s: float
    """A flying lap at the held speeds."""
    standing_lap_s: float
    """The first lap from rest at the held speeds (DeepRacer's timing, `standing_start_laps`)."""
    held: CarLimits
    """The bound's limits with the held lateral acceleration."""
    rolling_ratio: float
    """Ground speed per commanded m/s (the tyres' rolling radius / the command radius)."""
    command_lead_s: float
    over_lock_stations: int
    """Stations whose steady steering is beyond the lock (clipped there)."""


def held_limits(limits: CarLimits) -> CarLimits:
    """The bound's limits with the lateral acceleration the recipe holds the line at (`HELD_SLIP`)."""
    return dataclasses.replace(limits, lateral_accel_mps2=math.tanh(HELD_SLIP) * limits.lateral_accel_mps2)


def drive_time_constant_s(dynamics: CarDynamics) -> float:
    """How long the drive takes to answer a new speed command (mass / drive stiffness: a first-order lag)."""
    return car.TOTAL_MASS_KG / dynamics.tyres.drive_stiffness_n_per_mps


def command_lead_s(dynamics: CarDynamics) -> float:
    """How far ahead a speed is commanded: one control period (an action drives from the next frame on) plus the
    drive's time constant."""
    return STEP_S + drive_time_constant_s(dynamics)


def steady_steering_deg(
    curvature_per_m: np.ndarray, speed_mps: np.ndarray, dynamics: CarDynamics, world: str
) -> np.ndarray:
    """The steering of a steady turn of this curvature at this ground speed on racer's tyres: the wheelbase's angle
    plus the front axle's slip less the rear's, each axle's slip the one whose tanh force carries its share of the
    mass times v² κ (each axle's peak is grip × μ × its share of the weight)."""
    tyres = dynamics.tyres
    mu_g = get_world(world).tyre_friction * GRAVITY_MPS2
    accel = np.abs(speed_mps**2 * curvature_per_m)
    slip = np.zeros_like(accel)
    for share, grip, stiffness, sign in (
        (FRONT_SHARE, tyres.front_peak_grip, tyres.front_cornering_stiffness_n_per_rad, 1.0),
        (1.0 - FRONT_SHARE, tyres.rear_peak_grip, tyres.rear_cornering_stiffness_n_per_rad, -1.0),
    ):
        peak_n = grip * mu_g * car.TOTAL_MASS_KG * share
        ratio = np.minimum(accel / (grip * mu_g), math.tanh(HELD_SLIP))  # the held speeds keep every axle within
        slip += sign * peak_n / stiffness * np.arctanh(ratio)
    angle = np.arctan(car.WHEELBASE_M * np.abs(curvature_per_m)) + slip
    return np.sign(curvature_per_m) * np.degrees(angle)


def line_curvatures(points_m: np.ndarray) -> np.ndarray:
    """Signed curvature (left +) at each station of a closed polyline: the circle through it and its neighbours."""
    before = points_m - np.roll(points_m, 1, axis=0)
    after = np.roll(points_m, -1, axis=0) - points_m
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    norms = np.linalg.norm(before, axis=1) * np.linalg.norm(after, axis=1) * np.linalg.norm(before + after, axis=1)
    return 2.0 * cross / norms


def line_needs(line: RacingLine, dynamics: CarDynamics) -> LineNeeds:
    """The needs of `line` (the bound of the car with `dynamics` in `line.limits.world`)."""
    held = held_limits(line.limits)
    points = line.points_m
    speeds, lap_s = path_speeds(points, held)
    curvature = line_curvatures(points)
    lengths = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    segment_s = 2.0 * lengths / (speeds + np.roll(speeds, -1))
    times = np.concatenate(([0.0], np.cumsum(segment_s)[:-1]))
    lead_s = command_lead_s(dynamics)
    rolling_ratio = line.limits.top_speed_mps / car.MAX_SPEED_MPS  # the bound's top speed is the 4 m/s command's
    steering = steady_steering_deg(curvature, speeds, dynamics, line.limits.world)
    over_lock = int(np.count_nonzero(np.abs(steering) > car.MAX_STEERING_DEG))
    return LineNeeds(
        track=line.track,
        points_m=points,
        speeds_mps=speeds,
        commands_mps=np.minimum(_slowest_ahead(speeds, times, lap_s, lead_s) / rolling_ratio, car.MAX_SPEED_MPS),
        lateral_accel_mps2=speeds**2 * curvature,
        steering_deg=np.clip(steering, -car.MAX_STEERING_DEG, car.MAX_STEERING_DEG),
        times_s=times,
        lap_s=lap_s,
        standing_lap_s=standing_start_laps(points, held)[0],
        held=held,
        rolling_ratio=rolling_ratio,
        command_lead_s=lead_s,
        over_lock_stations=over_lock,
    )


def _slowest_ahead(speeds: np.ndarray, times: np.ndarray, lap_s: float, lead_s: float) -> np.ndarray:
    """Each station's slowest speed over the stations a flying lap reaches within `lead_s` after it."""
    n = len(speeds)
    twice_t = np.concatenate((times, times + lap_s))
    twice_v = np.concatenate((speeds, speeds))
    ends = np.searchsorted(twice_t, times + lead_s, side="right")
    return np.array([twice_v[i : max(i + 1, ends[i])].min() for i in range(n)])


def step_samples(needs: LineNeeds) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(commanded speed, signed lateral acceleration, steering) once per control step of a flying lap: what the
    policy must be able to choose, each need weighted by the time the line spends on it."""
    steps = np.arange(0.0, needs.lap_s, STEP_S)
    closed_t = np.append(needs.times_s, needs.lap_s)

    def at(values: np.ndarray) -> np.ndarray:
        return np.interp(steps, closed_t, np.append(values, values[0]))

    return at(needs.commands_mps), at(needs.lateral_accel_mps2), at(needs.steering_deg)
