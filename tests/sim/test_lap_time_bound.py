"""The lap-time bound (racer.racing_line) against answers worked out by hand: a ring road, whose fastest
line hugs the inner border at the grip's or the top speed's limit; a stadium's speed profile with its drive and brake
phases; a standing start; and a real track, where the line must beat the centre line and keep the car on the road."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import shapely
from scipy.optimize import LinearConstraint, minimize

from racer.racing_line import (
    PREPARE_STEP_S,
    CarLimits,
    LapTimeBoundError,
    optimiser,
    path_speeds,
    racing_line,
    standing_start_laps,
)
from racer.racing_line.augmented import AugmentedLagrangianSettings, augmented_lagrangian
from racer.racing_line.optimiser import BORDER_MARGIN_M, LineModel
from racer.racing_line.speed_profile import flying_lap, torch_module
from racer.shared.sim.car.dynamics import CAR_DYNAMICS, DEFAULT_CAR_PROFILE
from racer.shared.sim.car.vehicle import Car
from racer.shared.sim.scene.worlds import get_world
from racer.shared.sim.tracks.track import Track

LIMITS = CarLimits(
    top_speed_mps=4.0,
    lateral_accel_mps2=4.9,
    drive_accel_mps2=3.0,
    brake_accel_mps2=3.0,
    max_curvature_per_m=3.5,
    half_width_m=0.1,
    car_profile="test",
    world="base",
)


def ring_track(radius_m: float, width_m: float, points: int = 240) -> Track:
    angles = np.linspace(0.0, 2.0 * math.pi, points + 1)
    angles[-1] = 0.0  # the first row repeated: a loop
    circle = np.column_stack((np.cos(angles), np.sin(angles)))
    rows = np.hstack((radius_m * circle, (radius_m - width_m / 2) * circle, (radius_m + width_m / 2) * circle))
    return Track("ring", rows)


def circle(radius_m: float, points: int) -> np.ndarray:
    angles = np.linspace(0.0, 2.0 * math.pi, points, endpoint=False)
    return radius_m * np.column_stack((np.cos(angles), np.sin(angles)))


def stadium(straight_m: float, radius_m: float, step_m: float) -> np.ndarray:
    """Anticlockwise: the right half circle, the top straight, the left half circle, the bottom straight."""
    arc = np.linspace(-math.pi / 2, math.pi / 2, round(math.pi * radius_m / step_m), endpoint=False)
    along = np.linspace(straight_m / 2, -straight_m / 2, round(straight_m / step_m), endpoint=False)
    bend = radius_m * np.column_stack((np.cos(arc), np.sin(arc)))
    top = np.column_stack((along, np.full_like(along, radius_m)))
    return np.vstack((bend + [straight_m / 2, 0], top, -bend - [straight_m / 2, 0], -top))


@pytest.mark.parametrize("slsqp_max_size", [optimiser.SLSQP_MAX_SIZE, 0], ids=["slsqp", "augmented"])
@pytest.mark.parametrize("top_speed_mps", [4.0, 1.2])
def test_on_a_ring_the_line_hugs_the_inner_border_at_the_limit(top_speed_mps, slsqp_max_size, monkeypatch):
    """Lap time on a circle of radius r is 2πr / min(v_top, √(a r)): the smallest r the road allows wins, whether grip
    (4 m/s) or the top speed (1.2 m/s) binds; by either solver."""
    monkeypatch.setattr(optimiser, "SLSQP_MAX_SIZE", slsqp_max_size)
    limits = dataclasses.replace(LIMITS, top_speed_mps=top_speed_mps)
    radius_m, width_m = 1.5, 0.76
    line = racing_line(ring_track(radius_m, width_m), limits, control_spacings_m=(0.4,))
    inner_radius_m = radius_m - width_m / 2 + limits.half_width_m + BORDER_MARGIN_M
    speed = min(top_speed_mps, math.sqrt(limits.lateral_accel_mps2 * inner_radius_m))
    assert line.lap_time_s == pytest.approx(2 * math.pi * inner_radius_m / speed, rel=5e-3)
    assert np.linalg.norm(line.points_m, axis=1) == pytest.approx(inner_radius_m, abs=5e-3)
    assert line.centre_line_lap_time_s > line.lap_time_s
    assert line.min_clearance_m >= 0.0


def test_a_stadium_has_drive_and_brake_phases_on_its_straights():
    """Two 3 m straights between half circles of 0.5 m: the car leaves each bend at √(a_lat r), accelerates for half the
    straight and brakes for the other half (equal limits), peaking at √(v_c² + a S)."""
    straight_m, radius_m, step_m = 3.0, 0.5, 0.002
    speeds, lap_s = path_speeds(stadium(straight_m, radius_m, step_m), LIMITS)
    corner = math.sqrt(LIMITS.lateral_accel_mps2 * radius_m)
    peak = math.sqrt(corner**2 + LIMITS.drive_accel_mps2 * straight_m)
    assert peak < LIMITS.top_speed_mps  # the straight is too short for the top speed
    expected = 2 * (math.pi * radius_m / corner + 2 * (peak - corner) / LIMITS.drive_accel_mps2)
    assert lap_s == pytest.approx(expected, rel=1e-2)
    assert speeds.max() == pytest.approx(peak, rel=1e-2)
    assert speeds.min() == pytest.approx(corner, rel=1e-2)


def test_a_standing_start_costs_the_drive_up_to_speed_and_the_prepare_step_less_the_front_of_the_car():
    limits = dataclasses.replace(LIMITS, top_speed_mps=1.5, lateral_accel_mps2=50.0)
    radius_m = 2.0
    laps = standing_start_laps(circle(radius_m, 2000), limits)
    length_m = 2 * math.pi * radius_m
    speed, accel = limits.top_speed_mps, limits.drive_accel_mps2
    front_m = Car.FRONT_OF_CAR_M  # progress is judged there: the first lap is that much shorter
    first = speed / accel + (length_m - front_m - speed**2 / (2 * accel)) / speed + PREPARE_STEP_S
    assert laps[0] == pytest.approx(first, rel=1e-3)
    assert laps[1:] == pytest.approx((length_m / speed, length_m / speed), rel=1e-3)


def test_the_limits_are_read_from_the_car_profile_and_the_world():
    dynamics = CAR_DYNAMICS[DEFAULT_CAR_PROFILE]
    base = CarLimits.of_car(dynamics, world="base")
    assert base.car_profile == DEFAULT_CAR_PROFILE
    carpet = CarLimits.of_car(dynamics, world="carpet")
    mu_ratio = get_world("carpet").tyre_friction / get_world("base").tyre_friction
    assert carpet.lateral_accel_mps2 == pytest.approx(base.lateral_accel_mps2 * mu_ratio)
    grippier = dataclasses.replace(
        dynamics, tyres=dataclasses.replace(dynamics.tyres, front_peak_grip=2 * dynamics.tyres.front_peak_grip)
    )
    stronger = dataclasses.replace(
        dynamics, tyres=dataclasses.replace(dynamics.tyres, max_drive_force_n=2 * dynamics.tyres.max_drive_force_n)
    )
    assert CarLimits.of_car(grippier).lateral_accel_mps2 >= base.lateral_accel_mps2  # the weaker axle still binds
    assert CarLimits.of_car(grippier).car_profile == "custom"
    assert CarLimits.of_car(stronger).drive_accel_mps2 == pytest.approx(2 * base.drive_accel_mps2)
    assert CarLimits.of_car(dynamics, top_command_mps=2.0).top_speed_mps == pytest.approx(base.top_speed_mps / 2)


def test_on_a_real_track_the_line_beats_the_centre_line_and_keeps_the_car_on_the_road():
    track = Track.load("racer_oval")
    limits = CarLimits.of_car(CAR_DYNAMICS[DEFAULT_CAR_PROFILE])
    line = racing_line(track, limits, control_spacings_m=(0.8, 0.4))
    assert line.lap_time_s < line.centre_line_lap_time_s
    assert line.min_clearance_m >= 0.0
    assert line.lap_time_s >= line.summary()["line_length_m"] / limits.top_speed_mps
    assert line.standing_laps_s[0] > line.standing_laps_s[1] == pytest.approx(line.lap_time_s, rel=1e-6)
    assert track.road_polygon.contains(shapely.LinearRing(line.points_m))


def test_an_open_route_or_a_car_too_wide_is_refused_by_name():
    straight = np.zeros((20, 6))
    straight[:, 0] = straight[:, 2] = straight[:, 4] = np.linspace(0, 5, 20)
    straight[:, 1], straight[:, 3], straight[:, 5] = 0.0, 0.4, -0.4
    with pytest.raises(LapTimeBoundError, match="open route"):
        racing_line(Track("straight", straight), LIMITS)
    with pytest.raises(LapTimeBoundError, match="ring: a car 0.800 m wide does not fit"):
        racing_line(ring_track(1.5, 0.76), dataclasses.replace(LIMITS, half_width_m=0.4))


def test_a_finer_stage_starts_from_the_very_line_the_coarser_one_found():
    """Refined to twice the controls, the model at zero offsets is the coarse line (its stations coincide), so no
    stage throws away what the one before found."""
    track = Track.load("racer_oval")
    coarse = LineModel.of_track(track, LIMITS.half_width_m, 0.05, 0.8)
    controls = np.linspace(-0.05, 0.05, coarse.controls)
    fine = coarse.refined(track, controls, LIMITS.half_width_m, 2 * coarse.controls, 8)
    torch = torch_module()
    with torch.no_grad():
        old = coarse.line(torch, torch.from_numpy(controls))[0].numpy()
        new = fine.line(torch, torch.zeros(fine.controls, dtype=torch.float64))[0].numpy()
    assert fine.controls == 2 * coarse.controls and new.shape == old.shape
    assert np.abs(new - old).max() < 1e-9


def test_the_augmented_lagrangian_finds_a_convex_problems_optimum_inside_every_bound():
    """Nearest point to `target` in a box of rows that binds several of them: the optimum is unique, so SLSQP's and
    the augmented Lagrangian's must agree, and no row may end outside its bounds."""
    rng = np.random.default_rng(0)
    matrix = rng.normal(size=(60, 12))
    low, high = -np.ones(60), np.ones(60)
    target = 3.0 * rng.normal(size=12)
    settings = AugmentedLagrangianSettings(ftol_s=1e-12)
    found = augmented_lagrangian(
        lambda x: (float((x - target) @ (x - target)), 2.0 * (x - target)), np.zeros(12), matrix, low, high, settings
    )
    reference = minimize(
        lambda x: float((x - target) @ (x - target)),
        np.zeros(12),
        jac=lambda x: 2.0 * (x - target),
        method="SLSQP",
        constraints=[LinearConstraint(matrix, low, high)],
        options={"ftol": 1e-12, "maxiter": 500},
    )
    assert found.worst_violation_m <= 0.0
    assert np.all(matrix @ found.controls <= high) and np.all(matrix @ found.controls >= low)
    assert (np.abs(matrix @ reference.x) > 1 - 1e-6).sum() >= 2  # the bounds bind: a constrained problem
    assert found.controls == pytest.approx(reference.x, abs=2 * settings.feasibility_m)


def test_the_augmented_lagrangian_keeps_every_station_on_the_road_and_matches_slsqps_lap(monkeypatch):
    """racer_oval's first stage (17 controls, 544 rows) both ways from the centre line: every station inside its bounds,
    the lap within 0.1 % of SLSQP's (measured 0.001 % apart: the problem is not convex, the two may stop at different minima)."""
    track = Track.load("racer_oval")
    limits = CarLimits.of_car(CAR_DYNAMICS[DEFAULT_CAR_PROFILE])
    laps = {}
    for name, size in (("slsqp", 10**12), ("augmented", 0)):
        monkeypatch.setattr(optimiser, "SLSQP_MAX_SIZE", size)
        found = optimiser.optimise_line(track, limits, 0.05, (0.8,))
        offsets = found.model.offset_matrix @ found.controls
        slack_m = 1e-12 if name == "slsqp" else 0.0  # SLSQP lands on a bound to the last bit (4e-16 m out, AVX2 EPYC)
        low, high = found.model.offset_low - slack_m, found.model.offset_high + slack_m
        assert np.all(offsets >= low) and np.all(offsets <= high), name
        line = found.model.line(torch_module(), torch_module().from_numpy(found.controls))
        laps[name] = float(flying_lap(torch_module(), *line[1:], limits)[1])
    assert laps["augmented"] == pytest.approx(laps["slsqp"], rel=1e-3)
